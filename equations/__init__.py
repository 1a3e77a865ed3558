"""Hand-derived equations of motion, one module per system, numpy only (no engine imports).

A system is `models/<name>.xml` + `equations/<name>.py`; the harness pairs them by file stem.
A module needs only `parameters(model)` and its dynamics in one form; everything else has a default
(shapes: `q`, `v`, `tau` are `(..., n)`; functions broadcast over leading axes):

    parameters(model) -> Params        REQUIRED: a dataclass of the numbers the derivation uses, read
                                       from the compiled model (a Mapping: validate/model/modelview.py);
                                       the probes move each number it reads (validate/handwritten/reads.py)
    DESCRIPTION: str                   optional: one paragraph (default: the docstring's first paragraph)
    COORDINATES: tuple[str, ...]       optional: the generalized coordinates, in order (default: the
                                       model's joints, in the model's order; a free joint `root` is six:
                                       root_tx, root_ty, root_tz slides along the body's axes, then
                                       root_rz, root_ry, root_rx hinges, intrinsic Z-Y-X angles; a ball
                                       joint the three hinges: validate/model/floating.py)
    JOINTS: tuple[str, ...]            optional: the model joint that measures each coordinate, same sign
                                       and zero (default: COORDINATES where they name joints, else the
                                       model's joints)
    JOINT_MAP: (n, n) matrix           optional: q = JOINT_MAP @ (joint angles) where a coordinate is not
                                       one joint's angle (absolute angles of a chain of relative hinges)
    BODIES: tuple[str, ...]            optional: model bodies whose positions and orientations are compared
                                       (default: those body_positions() names; none: poses not checked)
    assumptions(p) -> dict             optional: what the derivation assumes of the compiled model, key ->
                                       value (NaN entries: a component it does not depend on). Stating
                                       every key makes the probes move the Params fields and build the
                                       model from them; stating some (the relations its formulas bake in:
                                       a uniform rod's inertia m l^2 / 12) keeps those while the numbers
                                       parameters() reads move; stating none, they move alone
    The physics a scene uses (gravity, joint damping, actuators) is read from the model.
    the dynamics, in ONE of five forms (validate/handwritten/forms.py derives the rest from it; the first
    of a, b, c, d, e a module defines is the one it is written in):
      (a) mass_matrix(p, q) -> (..., n, n) and bias(p, q, v) -> (..., n), C(q, v) v + G(q)
      (b) residual(p, q, v, a, tau) -> (..., n)  M a + bias - passive - tau, the implicit equations
      (c) qacc(p, q, v, tau) -> (..., n)          the explicit accelerations M^-1 (tau + passive - bias)
          In (b) and (c), a last parameter named `u` instead of `tau` takes the actuators' controls, in
          the model's actuator order (tau = B u through each actuator's gear on its joint): inputs on
          the actuated coordinates only, as published equations have them. Explicit accelerations with
          u give M^-1 B, not M: they are judged in accelerations (validate/verdict/verdict.py)
      (d) kinetic_energy and potential_energy only (below): M, G and C v are differentiated from them
      (e) hamiltonian(p, q, pm) -> (...)  H = pm^T M^-1(q) pm / 2 + V(q), pm = M v the generalized
                                       momenta (..., n): M^-1 = d2H/dpm2 and V = H(q, 0), traced with
                                       sympy, give the energies and so form (d) (validate/systems/
                                       hamiltonian.py); H not quadratic in pm is an error
    passive(p, q, v) -> (..., n)       generalized joint friction forces (viscous damping); optional in
                                       forms (a), (d), (e) (zero if absent), found from (b) and (c) as the
                                       part of the equations odd in v
    kinetic_energy(p, q, v) -> (...)   optional (except in form d): what a module leaves out of these
    potential_energy(p, q) -> (...)    four is listed as "not checked (not provided)", never failed;
                                       V is zero at the world origin's height: V = -sum m g . x_com, as
                                       MuJoCo and Pinocchio count it
    body_positions(p, q) -> {body: (..., 3)}   optional: centres of mass in the world frame
    body_rotations(p, q) -> {body: (..., 3, 3)} optional: body frames in the world frame
    VARIANTS: tuple[variant, ...]      optional (default none): every printed form of the notes
                                       (Implicit, Explicit, DerivationStep of lagrange_xval.forms)
    PRINTED_FORMS_ASSUME: (...)        optional: equalities the printed forms assume, each a mapping
                                       {Params field: k} with k * field equal across it (one m for
                                       m1 and m2: {"m1": 1, "m2": 1}); their probes keep them
    INITIAL_STATE: (q0, v0)            optional: the start of the trajectories and of the perturbation
                                       experiment (the notes' simulation, where they have one)
    NOTES_EXPERIMENT: str              optional: where the notes run INITIAL_STATE ("section 1, Figs 3-4");
                                       without it the report says nothing of the notes' experiment
    NOTES_SEPARATION: float            optional: when the notes say the two starts stop resembling each other (s)
    SAME_SYSTEM_AS: str                optional: another system that is the same physical chain in other
                                       coordinates (the harness checks that the two map onto each other)
    NUMBERS_ONLY: str                  optional: why the dynamics compute on numbers only (a Matlab function
                                       run by Octave): the stages that integrate them as expressions (the
                                       Taylor reference, chaos, the notes' experiments) are "not run" with it

(f) Equations as text, with no Python: a TOML file `<name>.toml` of T, V and optional friction
forces as expressions in the person's own symbols, each symbol bound to a model key
(`mc = "body/cart/mass"`, `g = "-gravity[2]"`, `lc = "body/pole/com[2]"`), read against its model
by `System.from_files(model, "x.toml")` or `run --model X --equations x.toml` and checked as form
(d); the coordinates are the model's joints unless named (validate/handwritten/textform.py).

The equations of motion are M(q) a + bias(q, v) = tau + passive(q, v), with tau the generalized
force of the inputs (motors where the MJCF has actuators, otherwise an applied joint torque); forms
(b) and (c) named with `tau` take it on every coordinate, actuated or not, and with `u` the actuators'
controls. The dynamics are traced with symbolic values for the fast path, the Taylor reference and
form (d): write them with numpy arithmetic and elementary functions (np.sin, np.cos, np.sqrt, ...;
np.abs, np.sign, np.where, np.minimum, np.maximum; `@`, np.einsum and np.cross work), not
np.linalg. A module given as a file runs in a worker process of its own, within one time limit for its
import and all its calls (30 s by default; validate/handwritten/worker.py); it may not end the process (sys.exit,
os._exit) nor print to stdout, and whatever it raises is its own failure, named.
"""

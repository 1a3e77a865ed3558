"""Drake as a source: a MultibodyPlant in continuous mode (time_step = 0) built by Drake's own parser
from the same text the other engines read (its MJCF parser for an MJCF, its URDF parser for a URDF).

Drake's quantities, in the harness's convention:

    M        CalcMassMatrix (the actuators' reflected inertia included: Drake's form of armature)
    bias     CalcBiasTerm - CalcGravityGeneralizedForces (Drake's tau_g is the generalized force of
             gravity, on the right-hand side: G = -tau_g)
    passive  the generalized forces of Drake's force elements (CalcForceElementsContribution): joint
             damping as Drake applies it in continuous mode
    qacc     the plant's generalized-acceleration output port, tau on the applied-generalized-force port
    tau_inv  CalcInverseDynamics with the force elements' forces (gravity, damping) as applied forces
    T, V     CalcKineticEnergy, CalcPotentialEnergy (V = -sum m g . x_com over every body, those welded
             to the world too, zero at the world origin; V is compared up to a constant, see
             results.schema.SCALED_DEFINITION)

Coordinates are mapped by joint name (a joint's `position_start`), never by position. What Drake reads
differently from MuJoCo, and what is done about it, is listed in `alignments` (never silent):
Drake's MJCF parser ignores `<option><flag>` (so a disabled damper or gravity is set from the model),
`stiffness`, `springref` and `frictionloss`; it gives a joint's armature only through a motor on it
(reflected inertia), so a joint with armature and no motor gets a motor-less rotor inertia here; URDF
says no gravity (set from the model); Drake enforces no joint limits in continuous mode.
"""

from __future__ import annotations

import importlib.util
import logging
from collections.abc import Callable
from typing import Any, TypedDict

import numpy as np

from ..core.arrays import Floats
from ..core.errors import HarnessError
from ..model.modelview import names
from ..systems import System
from .base import Kinematics
from .drakeparse import abort_line, likely_cause

INSTALL = "pip install 'lagrange-xval[drake]' (requirements.lock pins drake)"
RTOL = 1e-12  # a value Drake read equals the model's when within this fraction of its size


def unavailable() -> str:
    """Why Drake cannot be a source here ("" when pydrake is importable)."""
    if importlib.util.find_spec("pydrake") is None:
        return f"pydrake is not installed ({INSTALL})"
    return ""


class _Collect(logging.Handler):
    """Drake's parser warnings, collected instead of printed: each becomes an alignment line."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage().split("warning: ", 1)[-1].strip()
        if text not in self.lines:
            self.lines.append(text)


def parse(system: System) -> tuple[Any, list[str]]:
    """Drake's (unfinalized) plant of the system's model and the parser's warnings. Raises
    HarnessError naming the first line of Drake's error when its parser refuses the model."""
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    from ..model.urdf import without_geometry

    plant = MultibodyPlant(time_step=0.0)
    text, kind = (without_geometry(system.urdf_text()), "urdf") if system.reads_urdf else (system.mjcf_xml(), "xml")
    named = [] if system.reads_urdf else _named(text, system.name)
    text = named[0] if named else text
    text, dropped = _unconstrained(text, system.reads_urdf)
    if died := abort_line(text, kind):  # Drake's parser would end the process (sources/drakeparse.py)
        raise HarnessError(f"{system.mjcf.name}: Drake cannot read it: {died}; {likely_cause(died)}")
    log, handler = logging.getLogger("drake"), _Collect()
    log.addHandler(handler)
    propagate, log.propagate = log.propagate, False
    try:
        Parser(plant).AddModelsFromString(text, kind)
    except Exception as exc:  # RuntimeError with Drake's diagnostic
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        fmt = "URDF" if system.reads_urdf else "MJCF"
        raise HarnessError(f"{system.mjcf.name}: Drake's {fmt} parser cannot read it: {first}") from None
    finally:
        log.removeHandler(handler)
        log.propagate = propagate
    warnings = [f"its {'URDF' if system.reads_urdf else 'MJCF'} parser: {w}" for w in handler.lines]
    return plant, named[1:] + dropped + warnings


def _unconstrained(text: str, urdf: bool) -> tuple[str, list[str]]:
    """The model without its coupling constraints (a URDF joint's <mimic>, an MJCF's <equality>): the
    harness leaves constraints out of every comparison (model/scope.py), and Drake's continuous-mode
    plant refuses them outright."""
    import xml.etree.ElementTree as ET

    tag = "mimic" if urdf else "equality"
    if tag not in text:
        return text, []
    root = ET.fromstring(text)
    parents = root.iter("joint") if urdf else [root]
    found = [(parent, child) for parent in parents for child in parent.findall(tag)]
    for parent, child in found:
        parent.remove(child)
    removed = len(found)
    if not removed:
        return text, []
    what = "<mimic> coupling(s)" if urdf else "<equality> section(s)"
    line = f"{removed} {what} removed before Drake reads the model (constraints are left out of every comparison)"
    return ET.tostring(root, encoding="unicode"), [line]


def _weld_root(system: System, plant: Any) -> list[str]:
    """A URDF's root link welded to the world: Drake's URDF parser would make it a free body, where
    MuJoCo and Pinocchio fix it (the harness compares fixed-base chains)."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(system.urdf_text())
    children = {c.get("link") for j in root.findall("joint") for c in j.findall("child")}
    # a link named "world" is Drake's world already (URDF's convention for a fixed base)
    roots = [link.get("name", "") for link in root.findall("link") if link.get("name") not in children | {"world"}]
    for name in roots:
        plant.WeldFrames(plant.world_frame(), plant.GetBodyByName(name).body_frame())
    return [f"URDF root link '{name}' welded to the world (Drake's URDF parser would let it float)" for name in roots]


def _named(mjcf: str, name: str) -> list[str]:
    """[the MJCF with a model name, the alignment line] where its <mujoco> has none (Drake's parser
    requires one; MuJoCo and Pinocchio do not), else []."""
    import re

    root = re.search(r"<mujoco\b[^>]*>", mjcf)
    if root is None or re.search(r"\bmodel\s*=", root.group(0)):
        return []
    tag = root.group(0)[:-1].rstrip("/") + f' model="{name}"' + ("/>" if root.group(0).endswith("/>") else ">")
    line = f"the MJCF's <mujoco> has no model name, which Drake's parser requires: given '{name}'"
    return [mjcf[: root.start()] + tag + mjcf[root.end() :], line]


def _align(system: System, plant: Any) -> list[str]:
    """Sets what Drake read differently from the model the others see; one line per change."""
    out = _weld_root(system, plant) if system.reads_urdf else []
    gravity = np.array(system.view["gravity"], dtype=float)
    drake_gravity = np.array(plant.gravity_field().gravity_vector())
    if system.reads_urdf:  # URDF states none: MuJoCo's default, copied into Pinocchio, is copied here too
        plant.mutable_gravity_field().set_gravity_vector(gravity)
        out.append(f"URDF states no gravity: Drake's set to the model's {gravity.tolist()} m/s^2 (MuJoCo's default)")
    elif not np.allclose(drake_gravity, gravity, rtol=RTOL, atol=0.0):
        plant.mutable_gravity_field().set_gravity_vector(gravity)
        out.append(f"Drake's gravity {drake_gravity.tolist()} set to MuJoCo's {gravity.tolist()} m/s^2")
    motors = {plant.get_joint_actuator(a).joint().name(): a for a in plant.GetJointActuatorIndices()}
    for j in system.joints:
        joint = plant.GetJointByName(j)
        want = float(system.view[f"joint/{j}/damping"])
        read = float(joint.default_damping())
        if abs(read - want) > RTOL * max(abs(want), abs(read)):
            joint.set_default_damping(want)
            out.append(f"joint '{j}': Drake read damping {read:g}, set to the {want:g} the model's dynamics see")
        armature = float(system.view[f"joint/{j}/armature"])
        if armature and j not in motors:
            motor = plant.AddJointActuator(f"armature of {j}", joint)
            motor.set_default_rotor_inertia(armature)
            motor.set_default_gear_ratio(1.0)
            out.append(
                f"joint '{j}': armature {armature:g} given to Drake as the rotor inertia of a motor (Drake adds "
                "armature only through a motor's reflected inertia)"
            )
        out += _spring(system, plant, j)
    out.append("joint limits not enforced: Drake's continuous-mode plant has none (MuJoCo's are disabled)")
    return out


def _spring(system: System, plant: Any, j: str) -> list[str]:
    """A joint's stiffness, which Drake's MJCF parser does not read, as Drake's own spring on the joint
    (a force element: in the passive forces, the dynamics and the potential energy)."""
    from pydrake.multibody.tree import PrismaticSpring, RevoluteSpring

    stiffness = float(system.view[f"joint/{j}/stiffness"])
    if not stiffness:
        return []
    key = f"joint/{j}/springref"
    ref = float(system.view[key]) if key in system.view else 0.0
    joint = plant.GetJointByName(j)
    kind = RevoluteSpring if system.view[f"joint/{j}/type"] == "hinge" else PrismaticSpring
    plant.AddForceElement(kind(joint, ref, stiffness))
    return [
        f"joint '{j}': stiffness {stiffness:g} (springref {ref:g}), which Drake's parser does not read, "
        "given as a spring"
    ]


def parsed_values(system: System, plant: Any) -> dict[str, tuple[float, float]]:
    """Each compared joint's damping and armature (a motor's reflected inertia) as Drake's parser read them."""
    motors = {plant.get_joint_actuator(a).joint().name(): a for a in plant.GetJointActuatorIndices()}
    out = {}
    for j in system.joints:
        if not plant.HasJointNamed(j):
            raise HarnessError(f"Drake's model of {system.mjcf.name} has no joint '{j}'.")
        motor = plant.get_joint_actuator(motors[j]) if j in motors else None
        armature = 0.0 if motor is None else float(motor.default_reflected_inertia())
        out[j] = (float(plant.GetJointByName(j).default_damping()), armature)
    return out


def _several_hinges(system: System) -> None:
    """Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo (and Pinocchio and
    the model's derived equations, which agree): on a body with a ball joint's three hinges, M differs by
    90% (measured with 1.51.1). Such a model is read without Drake, saying why."""
    if system.reads_urdf:
        return
    hinges: dict[str, list[str]] = {}
    for j in system.model_joints:
        if system.view[f"joint/{j}/type"] == "hinge":
            hinges.setdefault(str(system.view[f"joint/{j}/body"]), []).append(j)
    several = {b: js for b, js in hinges.items() if len(js) > 1}
    if several:
        body, joints = next(iter(several.items()))
        raise HarnessError(
            f"Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo (body '{body}': "
            f"{', '.join(joints)}; a free or ball joint is three such hinges), so it is not a reader of this model"
        )


def build_plant(system: System) -> tuple[Any, list[str], dict[str, tuple[float, float]]]:
    """Drake's finalized plant of the system, what was aligned (parser warnings first), and each joint's
    damping and armature as read before the alignment."""
    _several_hinges(system)
    plant, warnings = parse(system)
    parsed = parsed_values(system, plant)
    aligned = _align(system, plant)
    plant.Finalize()
    return plant, warnings + aligned, parsed


class DrakeRunStats(TypedDict):
    """What `DrakeSource.free_run` says of its run: Drake's steps and derivative evaluations, "ok" or
    "failed", and why it stopped."""

    steps: int
    evaluations: int
    status: str
    reason: str


class DrakeSource:
    name = "drake"

    def __init__(self, system: System) -> None:
        from pydrake.multibody.tree import MultibodyForces

        self.system = system
        self.plant, self.alignments, self.parsed = build_plant(system)
        plant = self.plant
        if plant.num_velocities() != system.nv:
            raise HarnessError(
                f"Drake sees {plant.num_velocities()} degrees of freedom in {system.mjcf.name}; the equations "
                f"have {system.nv}."
            )
        self.context = plant.CreateDefaultContext()
        self.forces = MultibodyForces(plant)
        self.qidx, self.vidx = self._indices(system)
        self.q_default = np.array(plant.GetPositions(self.context), dtype=float)
        self.bodies = [self._body(b) for b in system.bodies]
        # A compared body with the bodies welded to it that MuJoCo fused into it (a URDF's fixed links):
        # one rigid body, as MuJoCo compiled it; a welded body MuJoCo keeps (an MJCF's) stays apart.
        kept = set(names(system.view, "body", "parent"))
        self.groups = [
            [w for w in plant.GetBodiesWeldedTo(b) if w.index() == b.index() or w.name() not in kept]
            for b in self.bodies
        ]
        self.gravity = np.array(plant.gravity_field().gravity_vector(), dtype=float)
        if plant.num_actuated_dofs():
            plant.get_actuation_input_port().FixValue(self.context, np.zeros(plant.num_actuated_dofs()))
        self.applied = plant.get_applied_generalized_force_input_port().FixValue(
            self.context, np.zeros(plant.num_velocities())
        )
        self._trial()

    def _trial(self) -> None:
        """One forward dynamics at the default state: Drake refuses a model it cannot solve (an
        articulated body inertia that is not positive definite: a massless link at a chain's end) only
        when first asked, which would end the comparison; here it sets Drake aside, saying why."""
        try:
            self._forward(np.zeros(self.plant.num_velocities()))
        except RuntimeError as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise HarnessError(f"Drake cannot solve this model's dynamics: {first[:300]}") from None

    def _potential(self) -> float:
        """Drake's own V, the bodies welded to the world included (as MuJoCo counts them; Pinocchio does
        not): V is compared up to a constant (results.schema.SCALED_DEFINITION)."""
        return float(self.plant.CalcPotentialEnergy(self.context))

    def _indices(self, system: System) -> tuple[np.ndarray, np.ndarray]:
        qidx, vidx = [], []
        for j in system.joints:
            if not self.plant.HasJointNamed(j):
                raise HarnessError(f"Drake's model of {system.mjcf.name} has no joint '{j}'.")
            joint = self.plant.GetJointByName(j)
            if joint.num_positions() != 1 or joint.num_velocities() != 1:
                raise HarnessError(f"joint '{j}': only one-degree-of-freedom joints are supported.")
            qidx.append(joint.position_start())
            vidx.append(joint.velocity_start())
        return np.array(qidx, dtype=int), np.array(vidx, dtype=int)

    def _body(self, name: str) -> Any:
        if not self.plant.HasBodyNamed(name):
            raise HarnessError(f"Drake's model of {self.system.mjcf.name} has no body '{name}'.")
        return self.plant.GetBodyByName(name)

    # -- one state ----------------------------------------------------------------------------
    def _set(self, q: np.ndarray, v: np.ndarray) -> None:
        full_q = self.q_default.copy()
        full_q[self.qidx] = q
        full_v = np.zeros(self.plant.num_velocities())
        full_v[self.vidx] = v
        self.plant.SetPositions(self.context, full_q)
        self.plant.SetVelocities(self.context, full_v)

    def _full(self, x: np.ndarray) -> np.ndarray:
        out = np.zeros(self.plant.num_velocities())
        out[self.vidx] = x
        return out

    def _passive(self) -> np.ndarray:
        self.plant.CalcForceElementsContribution(self.context, self.forces)
        return np.array(self.forces.generalized_forces(), dtype=float)

    def _bias(self) -> np.ndarray:
        plant, ctx = self.plant, self.context
        return np.array(plant.CalcBiasTerm(ctx) - plant.CalcGravityGeneralizedForces(ctx), dtype=float)

    def _forward(self, tau: np.ndarray) -> np.ndarray:
        self.applied.GetMutableData().set_value(self._full(tau))
        return np.array(self.plant.get_generalized_acceleration_output_port().Eval(self.context), dtype=float)

    def _inverse(self, a: np.ndarray) -> np.ndarray:
        self.plant.CalcForceElementsContribution(self.context, self.forces)  # gravity and damping, applied
        return np.array(self.plant.CalcInverseDynamics(self.context, self._full(a), self.forces), dtype=float)

    # -- free run -----------------------------------------------------------------------------
    def free_run(
        self,
        q0: np.ndarray,
        v0: np.ndarray,
        tau: np.ndarray,
        t: np.ndarray,
        *,
        scheme: str = "runge_kutta3",
        accuracy: float | None = None,
        max_step: float = 0.01,
    ) -> tuple[np.ndarray, np.ndarray, DrakeRunStats]:
        """Drake's own integration of the continuous plant (joint damping as its force elements apply
        it) from (q0, v0) with constant `tau`, sampled by AdvanceTo at each time of `t` (t[0] the start):
        q, v (K, n) in the system's joint coordinates (mapped by joint name) and stats. `scheme`: one of
        pydrake's GetIntegrationSchemes(), set by ResetIntegratorFromFlags with `max_step`; `accuracy`:
        the target accuracy of an error-controlled scheme (None: fixed steps of `max_step`). A Drake
        error ends the run: the samples after it are NaN and stats["status"] says "failed"."""
        from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator

        ctx = self._run_context(q0, v0, tau, float(t[0]))
        sim = Simulator(self.plant, ctx)
        integrator = ResetIntegratorFromFlags(sim, scheme, max_step)
        if accuracy is not None:
            integrator.set_target_accuracy(accuracy)
        else:
            integrator.set_fixed_step_mode(True)
        n = len(self.qidx)
        q, v = np.full((len(t), n), np.nan), np.full((len(t), n), np.nan)
        status, reason = "ok", ""
        try:
            sim.Initialize()
            for k, tk in enumerate(t):
                if k:
                    sim.AdvanceTo(float(tk))
                x = np.asarray(self.plant.GetPositionsAndVelocities(ctx), dtype=float)
                q[k], v[k] = x[self.qidx], x[self.plant.num_positions() + self.vidx]
        except RuntimeError as exc:  # Drake's step-size or state errors
            status, reason = "failed", f"Drake stopped at t = {ctx.get_time():.6g} s: {str(exc).splitlines()[0]}"
        stats: DrakeRunStats = {
            "steps": int(integrator.get_num_steps_taken()),
            "evaluations": int(integrator.get_num_derivative_evaluations()),
            "status": status,
            "reason": reason,
        }
        return q, v, stats

    def _run_context(self, q0: np.ndarray, v0: np.ndarray, tau: np.ndarray, t0: float) -> Any:
        """A fresh context of the plant at (q0, v0), time t0, with `tau` on the applied-force port."""
        plant = self.plant
        ctx = plant.CreateDefaultContext()
        if plant.num_actuated_dofs():
            plant.get_actuation_input_port().FixValue(ctx, np.zeros(plant.num_actuated_dofs()))
        plant.get_applied_generalized_force_input_port().FixValue(ctx, self._full(np.asarray(tau, dtype=float)))
        full_q = self.q_default.copy()
        full_q[self.qidx] = q0
        plant.SetPositions(ctx, full_q)
        plant.SetVelocities(ctx, self._full(np.asarray(v0, dtype=float)))
        ctx.SetTime(t0)
        return ctx

    # -- batches ------------------------------------------------------------------------------
    def _each(self, q: np.ndarray, v: np.ndarray, fn: Callable[[int], Floats]) -> np.ndarray:
        rows = []
        for i in range(len(q)):
            self._set(q[i], v[i])
            rows.append(fn(i))
        return np.array(rows)

    def _pick(self, x: np.ndarray) -> np.ndarray:
        return x[:, self.vidx]

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        full = self._each(q, np.zeros_like(q), lambda i: self.plant.CalcMassMatrix(self.context))
        return full[:, self.vidx][:, :, self.vidx]

    def bias(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._pick(self._each(q, v, lambda i: self._bias()))

    def passive(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._pick(self._each(q, v, lambda i: self._passive()))

    def forward(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        return self._pick(self._each(q, v, lambda i: self._forward(tau[i])))

    def inverse(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        return self._pick(self._each(q, v, lambda i: self._inverse(a[i])))

    def energies(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        plant, ctx = self.plant, self.context
        out = self._each(q, v, lambda i: (plant.CalcKineticEnergy(ctx), self._potential()))
        return out[:, 0], out[:, 1]

    def evaluate(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, a_ref: np.ndarray | None = None
    ) -> dict[str, np.ndarray]:
        """Every pointwise quantity, one state at a time (Drake has no batched form in Python); the
        inverse dynamics at `a_ref`, or without it at its own accelerations."""
        plant, ctx, n, nb = self.plant, self.context, len(q), len(self.bodies)
        nv = plant.num_velocities()
        M, bias, passive = np.empty((n, nv, nv)), np.empty((n, nv)), np.empty((n, nv))
        qacc, inv, energy = np.empty((n, nv)), np.empty((n, nv)), np.empty((n, 2))
        pos, rot = np.empty((n, nb, 3)), np.empty((n, nb, 3, 3))
        for i in range(n):
            self._set(q[i], v[i])
            M[i] = plant.CalcMassMatrix(ctx)
            bias[i], passive[i] = self._bias(), self._passive()
            qacc[i] = self._forward(tau[i])
            inv[i] = self._inverse(qacc[i][self.vidx] if a_ref is None else a_ref[i])
            energy[i] = plant.CalcKineticEnergy(ctx), self._potential()
            pos[i], rot[i] = self._poses()
        return {
            "M": M[:, self.vidx][:, :, self.vidx],
            "bias": self._pick(bias),
            "passive": self._pick(passive),
            "qacc": self._pick(qacc),
            "tau_inverse": self._pick(inv),
            "T": energy[:, 0],
            "V": energy[:, 1],
            "body_positions": pos,
            "body_rotations": rot,
        }

    def _group_com(self, k: int) -> tuple[float, np.ndarray]:
        """The mass and world centre of mass of compared body k with the bodies welded to it."""
        plant, ctx = self.plant, self.context
        mass, moment = 0.0, np.zeros(3)
        for body in self.groups[k]:
            m = body.get_mass(ctx)
            X = plant.EvalBodyPoseInWorld(ctx, body)
            moment += m * (X @ np.asarray(body.CalcCenterOfMassInBodyFrame(ctx)))
            mass += m
        if mass <= 0.0:  # a massless body: its frame origin stands for it, as in the other engines
            return 0.0, np.array(plant.EvalBodyPoseInWorld(ctx, self.bodies[k]).translation())
        return mass, moment / mass

    def _poses(self) -> tuple[np.ndarray, np.ndarray]:
        nb = len(self.bodies)
        pos, rot = np.empty((nb, 3)), np.empty((nb, 3, 3))
        for k, body in enumerate(self.bodies):
            pos[k] = self._group_com(k)[1]
            rot[k] = self.plant.EvalBodyPoseInWorld(self.context, body).rotation().matrix()
        return pos, rot

    def body_positions(self, q: np.ndarray) -> np.ndarray:
        return self._each(q, np.zeros_like(q), lambda i: self._poses()[0])

    def body_rotations(self, q: np.ndarray) -> np.ndarray:
        return self._each(q, np.zeros_like(q), lambda i: self._poses()[1])

    def kinematics(self, q: np.ndarray, v: np.ndarray) -> Kinematics:
        n, nb = len(q), len(self.bodies)
        cp, op, ov, w = (np.empty((n, nb, 3)) for _ in range(4))
        rot, ke, pe = np.empty((n, nb, 3, 3)), np.empty((n, nb)), np.empty((n, nb))
        plant, ctx = self.plant, self.context
        for i in range(n):
            self._set(q[i], v[i])
            for k, body in enumerate(self.bodies):
                X, V = plant.EvalBodyPoseInWorld(ctx, body), plant.EvalBodySpatialVelocityInWorld(ctx, body)
                op[i, k], rot[i, k] = X.translation(), X.rotation().matrix()
                w[i, k], ov[i, k] = V.rotational(), V.translational()
                mass, cp[i, k] = self._group_com(k)
                ke[i, k] = sum(self._kinetic(b) for b in self.groups[k])
                pe[i, k] = -mass * self.gravity @ cp[i, k]
        cv = ov + np.cross(w, cp - op)  # every state at once: one call per state cost 0.1 ms each
        return Kinematics(cp, cv, op, ov, rot, w, ke, pe)

    def _kinetic(self, body: Any) -> float:
        """One body's kinetic energy, 1/2 V . (M V), its spatial inertia expressed in the world."""
        plant, ctx = self.plant, self.context
        R = plant.EvalBodyPoseInWorld(ctx, body).rotation()
        M_W = body.CalcSpatialInertiaInBodyFrame(ctx).ReExpress(R)
        V = plant.EvalBodySpatialVelocityInWorld(ctx, body)
        return 0.5 * float(V.dot(M_W * V))

    def reading(self) -> dict[str, float | np.ndarray]:
        """How Drake read each compared body and joint, keyed as validate/audit/audit.py compares them:
        mass, centre of mass and inertia about it in the body's frame (with the bodies welded to it),
        and at q = 0 each joint's anchor and axis in the world, its limits, damping and armature."""
        out: dict[str, float | np.ndarray] = {}
        self._set(np.zeros(len(self.qidx)), np.zeros(len(self.vidx)))
        for b, k in zip(self.system.bodies, range(len(self.bodies)), strict=True):
            mass, com, inertia = self._group_inertia(k)
            out |= {f"body/{b}/mass": mass, f"body/{b}/com": com, f"body/{b}/inertia": inertia}
        for j in self.system.joints:
            out |= self._joint_reading(j)
        return out

    def _group_inertia(self, k: int) -> tuple[float, np.ndarray, np.ndarray]:
        """Mass, centre of mass and inertia about it, in body k's frame, of body k and the bodies welded
        to it (each body's spatial inertia moved into k's frame and summed by Drake's own arithmetic)."""
        plant, ctx = self.plant, self.context
        X_WB = plant.EvalBodyPoseInWorld(ctx, self.bodies[k])
        from pydrake.multibody.tree import SpatialInertia

        total = SpatialInertia.Zero()
        for body in self.groups[k]:
            X_Bb = X_WB.inverse() @ plant.EvalBodyPoseInWorld(ctx, body)
            M = body.CalcSpatialInertiaInBodyFrame(ctx).ReExpress(X_Bb.rotation()).Shift(-X_Bb.translation())
            total += M
        mass = float(total.get_mass())
        if mass <= 0.0:
            return 0.0, np.zeros(3), np.zeros((3, 3))
        com: Any = np.array(total.get_com(), dtype=float)  # Any: pydrake's stubs name an unusual ndarray type
        inertia = total.Shift(com).CalcRotationalInertia().CopyToFullMatrix3()
        return mass, com, np.array(inertia, dtype=float)

    def _joint_reading(self, j: str) -> dict[str, float | np.ndarray]:
        """Joint j at q = 0: anchor and motion axis (linear, angular) in the world, limits, damping and
        armature as Drake's parser read them (before any alignment)."""
        plant, ctx = self.plant, self.context
        joint = plant.GetJointByName(j)
        X = joint.frame_on_child().CalcPoseInWorld(ctx)
        R = joint.frame_on_parent().CalcPoseInWorld(ctx).rotation().matrix()
        zero = np.zeros(3)
        if hasattr(joint, "revolute_axis"):
            motion = np.concatenate([zero, R @ np.asarray(joint.revolute_axis())])
        else:
            motion = np.concatenate([R @ np.asarray(joint.translation_axis()), zero])
        damping, armature = self.parsed[j]
        limits = np.array([joint.position_lower_limits()[0], joint.position_upper_limits()[0]], dtype=float)
        return {
            f"joint/{j}/anchor": np.array(X.translation(), dtype=float),
            f"joint/{j}/motion": motion,
            f"joint/{j}/limits": limits,
            f"joint/{j}/damping": damping,
            f"joint/{j}/armature": armature,
        }


def axis_rotation(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Drake's rotation by each angle about the unit `axis` (AngleAxis), (N, 3, 3)."""
    from pydrake.common.eigen_geometry import AngleAxis
    from pydrake.math import RotationMatrix

    out = np.empty((len(angles), 3, 3))
    unit: Any = np.asarray(axis, dtype=float)  # pydrake's stubs name an unusual ndarray type
    for i, ang in enumerate(angles):
        out[i] = RotationMatrix(AngleAxis(float(ang), unit)).matrix()
    return out

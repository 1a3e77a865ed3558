"""The model's own equations of motion, derived symbolically by the notes' section-3 method.

From the compiled model (its ModelView: bodies, joints, inertias, gravity) and nothing else, step by
step as the notes teach it:

1. a rotation matrix per joint (eqs 49-57): R_b = R_parent R(quat_b) R_axis(q_j - ref_j), each body
   frame composed from its parent's; a hinge turns its body about its axis through its anchor, a slide
   moves it along its axis, each by its coordinate less its `ref` (MuJoCo's qpos0: the file writes the
   body where it is at q = ref);
2. positions of the centres of mass r_c(q) = x_b + R_b c_b, their velocities r_c' = J_c q' (eqs 58-61:
   v = omega x r along the chain, here as the Jacobian of r_c), and the angular velocities composed
   along the chain, omega = sum of the world axes of the hinges above a body times their rates,
   expressed in the body frame (omega_b = R_b^T omega);
3. the kinetic energy from the body-frame inertia about the centre of mass (eqs 66, 71-74):
   T = sum_b (m_b |r_c'|^2 + omega_b^T I_b omega_b) / 2, so M(q) = sum_b m_b J_c^T J_c + J_w^T I_b J_w
   (+ the joints' armature on the diagonal). The notes' eq 74 prints the rotational part without
   its 1/2 for the second bar: the derivation here keeps the 1/2 of eq 66;
4. the potential energy (eq 75) V = -sum_b m_b g . r_c (+ k q^2 / 2 for joint springs);
5. Lagrange's equations (eqs 30-31): M(q) q'' + C(q, q') q' + G(q) = tau - D q' - K q, with
   C_ij = sum_k Gamma_ijk q'_k from the Christoffel symbols of M and G = dV/dq.

Parameters are symbols named after the model's elements (`m_link1`, `I_link2_zz`, `c_link1`,
`l_link2`, `b_shoulder`, `g`, ...), so that the result reads like a hand derivation; the numbers are
substituted only for evaluation (`Derivation.values`). Structural numbers (axes, body orientations,
which entries are zero, the direction of gravity) are written as exact numbers: they fix the form
of the equations, and `Derivation.structure` keys a derivation by them alone (a probe that changes
only the values reuses it).
"""

from __future__ import annotations

import functools
import re
from collections.abc import Hashable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypeAlias

import numpy as np

from ..core.arrays import Floats
from ..core.errors import HarnessError
from ..model.modelview import ModelView, names

if TYPE_CHECKING:  # sympy is imported when first used
    import sympy as sp

# where a parameter's number is read in its model key's value: None the value itself, "norm" its length,
# i a vector's entry, (i, j) an inertia's (symmetrized)
Entry: TypeAlias = int | tuple[int, int] | str | None
# one body's share of the mass matrix: its mass, J_com, rotation, J_omega (world) and inertia
BodyTerms: TypeAlias = "tuple[sp.Expr, sp.Matrix, sp.Matrix, sp.Matrix, sp.Matrix]"
Frame: TypeAlias = "tuple[sp.Matrix, sp.Matrix, sp.Matrix]"  # a body frame's origin, rotation, J_omega (world)

# a body frame's rotation entry within this of 0 or +-1 is that number: the float noise of a URDF's rpy
# angles (the UR5's pi/2 leaves 4.9e-12 in two entries of a rotation, and then in every term after it)
ROTATION_ROUND = 1e-10
EXACT_TOL = 1e-12  # a structural number within this of a simple exact value (0, 1, sqrt(2)/2, ...) is that value


@dataclass
class Derivation:
    """The symbolic equations of one model structure (sympy expressions in joint coordinates)."""

    joints: tuple[str, ...]
    q: list[sp.Symbol]  # one per joint
    v: list[sp.Symbol]
    bodies: tuple[str, ...]  # every moving body, in model order
    T: sp.Expr
    V: sp.Expr
    M: sp.Matrix  # (n, n)
    C: sp.Matrix  # Coriolis matrix, C v = the velocity terms
    Cv: sp.Matrix  # (n,) Matrix
    G: sp.Matrix  # (n,) Matrix
    passive: sp.Matrix  # (n,) Matrix
    com: dict[str, sp.Matrix]  # body -> (3,) Matrix, centre of mass in world
    origin: dict[str, sp.Matrix]  # body -> (3,) Matrix, frame origin in world
    rotation: dict[str, sp.Matrix]  # body -> (3, 3) Matrix, body frame in world
    J_com: dict[str, sp.Matrix]  # body -> (3, n) Jacobian of the centre of mass
    J_origin: dict[str, sp.Matrix]  # body -> (3, n)
    J_omega: dict[str, sp.Matrix]  # body -> (3, n) angular velocity Jacobian, world frame
    T_body: dict[str, sp.Expr]
    V_body: dict[str, sp.Expr]
    parameters: dict[sp.Symbol, str] = field(default_factory=dict)  # symbol -> what it is (model key and unit)
    source: dict[sp.Symbol, tuple[str, Entry]] = field(default_factory=dict)  # symbol -> (model key, entry)
    signs: dict[sp.Symbol, int] = field(default_factory=dict)  # symbol -> sign of the model's number (symbols are > 0)
    rounded: int = 0  # rotation entries within ROTATION_ROUND of 0 or +-1 made exact (said in derive's header)


def _clean(name: str) -> str:
    return re.sub(r"\W", "_", name)


@functools.cache  # built once: making these sympy numbers on every call cost 0.8 s of a `check`
def _exact_candidates() -> tuple[tuple[float, sp.Expr], ...]:
    """(value, exact sympy number) of the simple structural numbers, each sign, in the order `exact` tries them."""
    import sympy as sp

    numbers = (
        sp.Integer(0),
        sp.Integer(1),
        sp.Rational(1, 2),
        sp.sqrt(2) / 2,
        sp.sqrt(3) / 2,
        sp.sqrt(3) / 3,
        sp.sqrt(3),
        sp.Integer(2),
    )
    return tuple((sign * float(c), sign * c) for c in numbers for sign in (1, -1))


def exact(x: float) -> sp.Expr:
    """A structural number as an exact sympy number when it is a simple one (0, +-1, +-1/2,
    +-sqrt(2)/2, +-sqrt(3)/2), else as a Float."""
    import sympy as sp

    for value, candidate in _exact_candidates():
        if abs(x - value) <= EXACT_TOL:
            return candidate
    return sp.Float(x, 17)


class _Params:
    """Symbols for the model's numbers: where each is read (model key, entry), and the structure the
    derivation leaves exact (zero patterns, signs, axes, orientations)."""

    def __init__(self, view: ModelView, *, readable: bool = False) -> None:
        self.view = view
        self.readable = readable
        self.source: dict[sp.Symbol, tuple[str, Entry]] = {}  # symbol -> (model key, entry index or None)
        self.meaning: dict[sp.Symbol, str] = {}
        self.sign: dict[sp.Symbol, int] = {}
        self.structure: list[tuple[str, int | tuple[str, ...]]] = []
        self.rounded = 0  # rotation entries made exact (`rotation`)

    def read(self, key: str, entry: Entry = None) -> float:
        x = np.asarray(self.view[key], dtype=float)
        if entry is None:
            return float(x)
        if entry == "norm":
            return float(np.linalg.norm(x))
        if isinstance(entry, tuple) and len(entry) == 2:
            i, j = entry
            return float(0.5 * (x[i, j] + x[j, i]))
        return float(x[entry])

    def scalar(self, name: str, key: str, entry: Entry, unit: str, value: float | None = None) -> sp.Expr:
        """A symbol for a non-zero number (positive, with the sign kept in the expression), 0 for zero."""
        import sympy as sp

        value = self.read(key, entry) if value is None else value
        if value == 0.0:
            self.structure.append((name, 0))
            return sp.Integer(0)
        sym = sp.Symbol(name, positive=True)
        self.source[sym] = (key, entry)
        self.sign[sym] = 1 if value > 0 else -1
        self.meaning[sym] = f"{read_as(key, entry, self.sign[sym])}, {unit}"
        self.structure.append((name, int(np.sign(value))))
        return sym if value > 0 else -sym

    def vector(self, name: str, key: str, unit: str) -> sp.Matrix:
        """A 3-vector: one symbol `name` when a single entry is non-zero (signed), else one per entry."""
        import sympy as sp

        value = np.asarray(self.view[key], dtype=float)
        nonzero = np.flatnonzero(value)
        if len(nonzero) == 1:
            out = [sp.Integer(0)] * 3
            out[int(nonzero[0])] = self.scalar(name, key, int(nonzero[0]), unit)
            return sp.Matrix(out)
        return sp.Matrix([self.scalar(f"{name}_{'xyz'[i]}", key, i, unit) for i in range(3)])

    def inertia(self, body: str, key: str) -> sp.Matrix:
        import sympy as sp

        value = np.asarray(self.view[key], dtype=float)
        out = sp.zeros(3, 3)
        for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)):
            x = self.read(key, (i, j))
            # a product of inertia left by MuJoCo's eigen-decomposition round trip (1e-17) is zero
            if abs(x) <= 1e-14 * max(float(np.abs(value).max()), 1e-300):
                x = 0.0
            out[i, j] = out[j, i] = self.scalar(f"I_{body}_{'xyz'[i]}{'xyz'[j]}", key, (i, j), "kg m^2", value=x)
        return out

    def rotation(self, R: sp.Matrix) -> sp.Matrix:
        """A body frame's rotation with each numeric entry within ROTATION_ROUND of 0 or +-1 made that
        number (counted in `rounded`)."""
        import sympy as sp

        if not self.readable:
            return R

        def clean(x: sp.Expr) -> sp.Expr:
            if not x.is_Number or x in (0, 1, -1):
                return x
            for target in (0, 1, -1):
                if abs(float(x) - target) <= ROTATION_ROUND:
                    self.rounded += 1
                    return sp.Integer(target)
            return x

        return R.applyfunc(clean)

    def fixed(self, name: str, values: Floats) -> list[sp.Expr]:
        """Structural numbers, exact: they are part of the structure key."""
        exacts = [exact(float(x)) for x in np.ravel(values)]
        self.structure.append((name, tuple(str(e) for e in exacts)))
        return exacts


def read_as(key: str, entry: Entry, sign: int) -> str:
    """How a symbol is read from the model, as the symbol table prints it: the symbols are positive,
    so a negative number's symbol is minus its entry ("-body/link1/com[2]"), a norm |key|."""
    if entry == "norm":
        return f"|{key}|"
    where = key if entry is None else f"{key}[{entry if not isinstance(entry, tuple) else ','.join(map(str, entry))}]"
    return ("-" if sign < 0 else "") + where


def parameter_values(derivation: Derivation, view: ModelView) -> dict[sp.Symbol, float]:
    """The value of each of the derivation's parameter symbols in the model `view` (same structure)."""
    reader = _Params(view)
    return {sym: abs(reader.read(key, entry)) for sym, (key, entry) in derivation.source.items()}


def structure_key(view: ModelView, joints: tuple[str, ...]) -> tuple[Hashable, ...]:
    """What fixes the form of the derivation: names, topology, zero patterns, signs, axes, orientations."""
    key: list[Hashable] = [tuple(joints)]
    for k in sorted(view):
        x = view[k]
        if isinstance(x, str):
            key.append((k, x))
            continue
        arr = np.asarray(x, dtype=float)
        if k.endswith("/ref"):  # fixed in the derivation as a number (`reference`)
            key.append((k, repr(float(x))))
        elif k.endswith(("/quat", "/axis")) or k == "gravity":
            norm = float(np.linalg.norm(arr)) or 1.0
            key.append((k, tuple(str(exact(float(e))) for e in arr.ravel() / norm)))
        else:
            key.append((k, tuple(np.sign(arr).ravel().astype(int).tolist())))
    return tuple(key)


def reference(x: float, *, angle: bool) -> sp.Expr:
    """A joint's `ref` (MuJoCo's qpos0) as an exact number: a hinge's whole number of degrees (what a
    degree compiler makes of `ref="-90"`) as that fraction of pi, any other as `exact` gives it. Structural:
    it fixes where the coordinate's zero is, like the joint's axis, and is no parameter of the Params."""
    import sympy as sp

    degrees = x * 180.0 / np.pi
    if angle and x != 0.0 and abs(degrees - round(degrees)) <= 1e-9 * max(1.0, abs(degrees)):
        return sp.Rational(round(degrees), 180) * sp.pi
    return exact(x)


def _quat_matrix(w: sp.Expr, x: sp.Expr, y: sp.Expr, z: sp.Expr) -> sp.Matrix:
    import sympy as sp

    return sp.Matrix(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def axis_rotation(axis: sp.Matrix, angle: sp.Expr) -> sp.Matrix:
    """Rodrigues' rotation about a unit axis; R_z(angle) etc. exactly for the coordinate axes."""
    import sympy as sp

    k = sp.Matrix(axis)
    K = sp.Matrix([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return sp.eye(3) + sp.sin(angle) * K + (1 - sp.cos(angle)) * (K * K)


def _bodies_and_joints(view: ModelView, joints: tuple[str, ...]) -> tuple[list[str], list[str]]:
    """The model's moving bodies and its joints, in model order; each joint must be one of `joints`."""
    order, all_joints = names(view, "body", "mass"), names(view, "joint", "type")
    missing = [j for j in joints if j not in all_joints]
    if missing:
        raise HarnessError(f"the model has no joint '{missing[0]}' (joints: {', '.join(all_joints)}).")
    extra = [j for j in all_joints if j not in joints]
    if extra:
        raise HarnessError(f"joint '{extra[0]}' of the model is not among the coordinates' joints.")
    return order, all_joints


def _gravity(view: ModelView, P: _Params) -> sp.Matrix:
    """The gravity vector: the symbol g times the model's direction of gravity, exact."""
    import sympy as sp

    g_vec = np.asarray(view["gravity"], dtype=float)
    g_norm = float(np.linalg.norm(g_vec))
    g = P.scalar("g", "gravity", "norm", "m/s^2")
    return sp.Matrix(P.fixed("gravity direction", g_vec / g_norm if g_norm else np.zeros(3))) * g


def _through_joint(
    view: ModelView, P: _Params, j: str, qi: sp.Symbol, i: int, x: sp.Matrix, R: sp.Matrix, Jw: sp.Matrix
) -> tuple[sp.Matrix, sp.Matrix]:
    """Step 1 for joint `j` (coordinate `qi`, column `i`): a hinge turns the frame (x, R) about its axis
    through its anchor and writes its world axis into column i of Jw; a slide moves it along its axis."""
    import sympy as sp

    kind = view[f"joint/{j}/type"]
    if kind not in ("hinge", "slide"):
        raise HarnessError(f"joint '{j}' is a {kind} joint: only hinge and slide joints are derived.")
    axis_np = np.asarray(view[f"joint/{j}/axis"], dtype=float)
    axis = sp.Matrix(P.fixed(f"axis {j}", axis_np / np.linalg.norm(axis_np)))
    # MuJoCo's frame as the file writes it is the frame at q = ref (qpos0): the joint moves by q - ref
    ref = view[f"joint/{j}/ref"] if f"joint/{j}/ref" in view else 0.0
    moved = qi - reference(float(ref), angle=kind == "hinge")
    if kind == "slide":
        return x + R * axis * moved, R
    anchor = P.vector(f"a_{_clean(j)}", f"joint/{j}/pos", "m")
    Rj = axis_rotation(axis, moved)
    Jw[:, i] = R * axis
    return x + R * (anchor - Rj * anchor), R * Rj


def _body_frame(
    view: ModelView, P: _Params, b: str, parent: Frame, joints: list[str], q: list[sp.Symbol], index: dict[str, int]
) -> Frame:
    """Step 1 for body `b`: its frame's origin, rotation and angular-velocity Jacobian (world), from its
    parent's frame, its placement and its `joints`."""
    x, R, Jw = parent
    pos = P.vector(f"l_{_clean(b)}", f"body/{b}/pos", "m")
    quat = P.fixed(f"quat {b}", view[f"body/{b}/quat"])
    x = x + R * pos
    R = R * P.rotation(_quat_matrix(*quat))
    Jw = Jw.copy()
    for j in joints:
        x, R = _through_joint(view, P, j, q[index[j]], index[j], x, R, Jw)
    return x, R, Jw


def _bodies(
    view: ModelView,
    P: _Params,
    order: list[str],
    all_joints: list[str],
    *,
    q: list[sp.Symbol],
    v: list[sp.Symbol],
    index: dict[str, int],
    gravity: sp.Matrix,
) -> tuple[dict[str, dict[str, sp.Expr | sp.Matrix]], dict[str, BodyTerms]]:
    """Steps 1-4 body by body, parents before children whatever the model's order: each body's frame,
    centre of mass, Jacobians and energies (by quantity, then body), and the mass, Jacobians and inertia
    its share of the mass matrix is made of (by body). `index`: each joint's coordinate."""
    import sympy as sp

    frames: dict[str, Frame] = {"world": (sp.zeros(3, 1), sp.eye(3), sp.zeros(3, len(q)))}
    quantities = ("com", "origin", "rotation", "J_com", "J_origin", "J_omega", "T_body", "V_body")
    out: dict[str, dict[str, sp.Expr | sp.Matrix]] = {k: {} for k in quantities}
    terms: dict[str, BodyTerms] = {}
    joints_of = {b: [j for j in all_joints if view[f"joint/{j}/body"] == b] for b in order}
    remaining = list(order)
    while remaining:
        b = next(b for b in remaining if view[f"body/{b}/parent"] in frames)
        remaining.remove(b)
        x, R, Jw = frames[b] = _body_frame(view, P, b, frames[view[f"body/{b}/parent"]], joints_of[b], q, index)
        mass = P.scalar(f"m_{_clean(b)}", f"body/{b}/mass", None, "kg")
        com_local = P.vector(f"c_{_clean(b)}", f"body/{b}/com", "m")
        inertia = P.inertia(_clean(b), f"body/{b}/inertia")
        r = x + R * com_local
        Jc, Jo = (r.jacobian(q), x.jacobian(q)) if q else (sp.zeros(3, 0), sp.zeros(3, 0))  # no joint: none
        vc = Jc * sp.Matrix(len(v), 1, list(v))
        w_body = R.T * Jw * sp.Matrix(len(v), 1, list(v))
        out["T_body"][b] = (mass * (vc.T * vc)[0] + (w_body.T * inertia * w_body)[0]) / 2
        out["V_body"][b] = -mass * (gravity.T * r)[0]
        out["com"][b], out["origin"][b], out["rotation"][b] = r, x, R
        out["J_com"][b], out["J_origin"][b], out["J_omega"][b] = Jc, Jo, Jw
        terms[b] = (mass, Jc, R, Jw, inertia)
    return out, terms


def _mass_matrix(terms: dict[str, BodyTerms], order: list[str], n: int) -> sp.Matrix:
    """Step 3: M(q) = sum_b m_b J_c^T J_c + J_b^T I_b J_b, with J_b = R_b^T J_w in the body frame."""
    import sympy as sp

    M = sp.zeros(n, n)
    for b in order:
        mass, Jc, R, Jw, inertia = terms[b]
        Jb = R.T * Jw
        M += mass * Jc.T * Jc + Jb.T * inertia * Jb
    return M


def _joint_parameters(P: _Params, joints: tuple[str, ...]) -> tuple[list[sp.Expr], list[sp.Expr], list[sp.Expr]]:
    """Each joint's armature, damping and stiffness symbols, in the coordinates' order."""
    armature, damping, stiffness = [], [], []
    for j in joints:
        armature.append(P.scalar(f"J_{_clean(j)}", f"joint/{j}/armature", None, "kg m^2"))
        damping.append(P.scalar(f"b_{_clean(j)}", f"joint/{j}/damping", None, "N m s"))
        stiffness.append(P.scalar(f"k_{_clean(j)}", f"joint/{j}/stiffness", None, "N m"))
    return armature, damping, stiffness


def _springrefs(P: _Params, view: ModelView, joints: tuple[str, ...]) -> list[sp.Expr]:
    """Each joint's spring reference (a symbol where the model has one, else 0)."""
    import sympy as sp

    return [
        P.scalar(f"q0_{_clean(j)}", f"joint/{j}/springref", None, "m" if view[f"joint/{j}/type"] == "slide" else "rad")
        if f"joint/{j}/springref" in view
        else sp.Integer(0)
        for j in joints
    ]


def _coriolis(M: sp.Matrix, q: list[sp.Symbol], v: list[sp.Symbol]) -> sp.Matrix:
    """Step 5: C_ij = sum_k Gamma_ijk v_k, from the Christoffel symbols of M."""
    import sympy as sp

    n = len(q)
    dM = [M.diff(qk) for qk in q]
    C = sp.zeros(n, n)
    for i in range(n):
        for j in range(n):
            C[i, j] = sum((dM[k][i, j] + dM[j][i, k] - dM[i][j, k]) * v[k] / 2 for k in range(n))
    return C


def derive(view: ModelView, joints: tuple[str, ...], *, readable: bool = False) -> Derivation:
    """The equations of motion of the model `view` in the coordinates of `joints` (one per joint).
    `readable`: rotation entries within ROTATION_ROUND of 0 or +-1 made exact, for a person to read (never
    for the symbolic source: the rounding changes the model by up to ROTATION_ROUND)."""
    import sympy as sp

    P = _Params(view, readable=readable)
    order, all_joints = _bodies_and_joints(view, joints)
    q = [sp.Symbol(_clean(j), real=True) for j in joints]
    v = [sp.Symbol(f"d{_clean(j)}", real=True) for j in joints]
    index = {j: i for i, j in enumerate(joints)}
    gravity = _gravity(view, P)
    out, terms = _bodies(view, P, order, all_joints, q=q, v=v, index=index, gravity=gravity)
    M = _mass_matrix(terms, order, len(joints))
    armature, damping, stiffness = _joint_parameters(P, joints)
    for i, J in enumerate(armature):
        M[i, i] += J
    # Springs, as MuJoCo counts them: in V (the energy) and in the passive forces, not in G (the bias).
    stretch = [qi - r for qi, r in zip(q, _springrefs(P, view, joints), strict=True)]
    springs = sum((k * x**2 / 2 for k, x in zip(stiffness, stretch, strict=True)), sp.Integer(0))
    gravity_V = sum(out["V_body"].values(), sp.Integer(0))
    V = gravity_V + springs
    # A joint's armature (rotor inertia) is in M, so in T too: T = 1/2 v^T M v.
    T = sum(out["T_body"].values(), sp.Integer(0)) + sum(
        (J * vi**2 / 2 for J, vi in zip(armature, v, strict=True)), sp.Integer(0)
    )
    G = sp.Matrix([sp.diff(gravity_V, qi) for qi in q])
    C = _coriolis(M, q, v)
    passive = sp.Matrix([-b * vi - k * x for b, k, vi, x in zip(damping, stiffness, v, stretch, strict=True)])
    return Derivation(
        joints=tuple(joints),
        q=q,
        v=v,
        bodies=tuple(order),
        T=T,
        V=V,
        M=M,
        C=C,
        Cv=C * sp.Matrix(len(v), 1, list(v)),
        G=G,
        passive=passive,
        parameters=P.meaning,
        source=P.source,
        signs=P.sign,
        rounded=P.rounded,
        **out,
    )

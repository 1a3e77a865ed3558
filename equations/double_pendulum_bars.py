"""Double pendulum of two uniform rigid bars, relative angles (notes, sections 2-3).

Symbols (all read from models/double_pendulum_bars.xml):

    m1, m2   bar masses, kg                          (the notes: m = m1 = m2 = 1)
    l1       length of bar 1 = distance between the joints, m   (the notes: l = 1)
    c1, c2   distance from each bar's joint to its centre of mass, m  (the notes: l/2)
    g        gravitational acceleration, m/s^2       (the notes: 9.81; MJCF gravity is (0, -g, 0))
    I1, I2   central moment of inertia of each bar about z, kg m^2  (the notes: Izz = I_c = m l^2/12)

The length of bar 2 enters only through c2 (nothing hangs from its end). The MJCF gives each bar
the central inertia of a thin bar along its own axis (body y): Ixx = Izz = m l^2/12 across the
bar, Iyy = 1e-14 along it (MuJoCo refuses zero). The motion is planar, so only Izz matters.

Coordinates (the notes' Fig. 6, same as section 1): x to the right, y up, z out of the plane.
theta is bar 1's angle from the downward vertical, positive counter-clockwise about +z; phi is
bar 2's angle relative to bar 1. Bar 1's centre of mass is at c1 (sin th, -cos th).

The notes' frames. Section 3 (eq 62 and the Matlab code) puts x_i along bar i and gravity along
+x_0 (V = -m [g, 0, 0] rc): x_0 points down, y_0 to the right, z_0 out of the plane, so a vector
with notes' coordinates n has MJCF world coordinates P n with P = [[0, 1, 0], [-1, 0, 0],
[0, 0, 1]] (a quarter turn about z). P commutes with every rotation about z, so the notes'
rotation matrices (49)-(52), (56) and z-axis angular velocities carry over unchanged; printed
vectors in the plane are mapped by P (see `_to_world`). The body frames differ the same way
(the notes' x_i along bar i is the MJCF body's -y), so body-frame quantities map by P too.
Section 2's frame origins o_1, o_2 sit at the joints where bars 1 and 2 start; section 3's r_01
(eq 62, Matlab r011) puts the origin of frame 1 at the end of bar 1, which is MJCF body link2's
origin.

Not checked (printed, but nothing the engines compute matches them):
    (37), (44)        sums of symbols, no expression to evaluate.
    (43)              v_o2c2, the velocity of c2 relative to the joint o2: the engines give
                      absolute velocities only (it is com_velocity - origin_velocity of link2).
    (46) alone        the cross term m v_02 . v_o2c2: no engine quantity; it is checked as part
                      of T2 in the (45) step.
    (47)-(48), (50), (53)-(55), (58)-(61), (67)-(70)
                      generic definitions and identities with no system-specific value; the
                      elementary rotations (53)-(54) are checked in equations/gimbal.py, and
                      (58)-(61) are evaluated by (62)-(65).
    (63)-(65)         v_02^0, the velocity of the end of bar 2 (origin of the notes' frame 2):
                      no MJCF body has its origin there (adding one would change the model).
    (73) alone        I^0, an inertia in world axes: no engine quantity; used inside the (71) steps.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from lagrange_xval.forms import (
    DerivationStep,
    Implicit,
    body,
    common,
    hinge,
    planar_inertia,
    rot_z,
    stack_matrix,
    stack_vector,
)

DESCRIPTION = (
    "Two uniform rigid bars, the second angle measured relative to the first bar "
    "(notes sections 2-3, eqs 37-77)."
)
COORDINATES = ("theta", "phi")
JOINTS = ("theta", "phi")
BODIES = ("link1", "link2")
# The notes' Modelica experiment: theta(start = 0), phi(start = 3), at rest, 10 s.
INITIAL_STATE = ((0.0, 3.0), (0.0, 0.0))
NOTES_EXPERIMENT = "the Modelica simulation's start, theta = 0, phi = 3, at rest"

# The notes' printed forms assume one mass, one length with the centres of mass at mid-length and
# one central inertia (m = m1 = m2, l = l1 = 2 c1 = 2 c2, Izz = I1 = I2): their probes keep these
# equalities while every other parameter moves (validate/verdict/probes.py).
PRINTED_FORMS_ASSUME = ({"m1": 1.0, "m2": 1.0}, {"l1": 1.0, "c1": 2.0, "c2": 2.0}, {"I1": 1.0, "I2": 1.0})


@dataclass(frozen=True)
class Params:
    m1: float  # kg
    m2: float  # kg
    l1: float  # m
    c1: float  # m
    c2: float  # m
    g: float  # m/s^2
    I1: float  # kg m^2
    I2: float  # kg m^2

    @property
    def m(self) -> float:
        """The notes' single mass m; their printed forms need m1 == m2."""
        return common("m", m1=self.m1, m2=self.m2)

    @property
    def l(self) -> float:  # noqa: E743 - the notes' symbol
        """The notes' single length l; their printed forms need c1 == c2 == l1 / 2."""
        return common("l", **{"l1": self.l1, "2 c1": 2 * self.c1, "2 c2": 2 * self.c2})

    @property
    def Izz(self) -> float:
        """The notes' single central inertia Izz = I_c; their printed forms need I1 == I2."""
        return common("Izz", I1=self.I1, I2=self.I2)


def parameters(model: Any) -> Params:
    """Reads the parameters from the compiled MJCF (see validate/model/modelview.py for the keys)."""
    return Params(
        m1=model["body/link1/mass"],
        m2=model["body/link2/mass"],
        l1=-model["body/link2/pos"][1],
        c1=-model["body/link1/com"][1],
        c2=-model["body/link2/com"][1],
        g=-model["gravity"][1],
        I1=model["body/link1/inertia"][2, 2],
        I2=model["body/link2/inertia"][2, 2],
    )


def assumptions(p: Params) -> dict[str, Any]:
    """The compiled model this derivation describes: planar chain hanging along -y, hinges about +z."""
    return {
        "gravity": np.array([0.0, -p.g, 0.0]),
        **body("link1", parent="world", mass=p.m1, com=(0, -p.c1, 0), inertia=planar_inertia(p.I1)),
        **body("link2", parent="link1", mass=p.m2, com=(0, -p.c2, 0), inertia=planar_inertia(p.I2), pos=(0, -p.l1, 0)),
        **hinge("theta", body="link1", axis=(0, 0, 1)),
        **hinge("phi", body="link2", axis=(0, 0, 1)),
    }


def mass_matrix(p: Params, q: np.ndarray) -> np.ndarray:
    """M(q) from T = T1 + T2, each bar's translation of its centre of mass plus rotation about it.

    T1 = (m1 c1^2 + I1) th'^2 / 2; c2 moves with l1 th' (perpendicular to bar 1) plus
    c2 (th' + ph') (perpendicular to bar 2), the two at angle phi:
    T2 = m2 (l1^2 th'^2 + c2^2 (th' + ph')^2 + 2 l1 c2 th' (th' + ph') cos ph) / 2 + I2 (th' + ph')^2 / 2.
    """
    c = np.cos(q[..., 1])
    m22 = p.m2 * p.c2**2 + p.I2
    m12 = m22 + p.m2 * p.l1 * p.c2 * c
    m11 = p.m1 * p.c1**2 + p.I1 + p.m2 * p.l1**2 + 2 * p.m2 * p.l1 * p.c2 * c + m22
    return stack_matrix([[m11, m12], [m12, m22 + np.zeros_like(c)]])


def gravity(p: Params, q: np.ndarray) -> np.ndarray:
    """G(q) = dV/dq with V = -(m1 c1 + m2 l1) g cos th - m2 c2 g cos(th + ph)."""
    s1, s12 = np.sin(q[..., 0]), np.sin(q[..., 0] + q[..., 1])
    return stack_vector([(p.m1 * p.c1 + p.m2 * p.l1) * p.g * s1 + p.m2 * p.c2 * p.g * s12, p.m2 * p.c2 * p.g * s12])


def bias(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """C(q, v) v + G(q); with h = m2 l1 c2 sin ph, C v = (-h (2 th' ph' + ph'^2), h th'^2)."""
    h = p.m2 * p.l1 * p.c2 * np.sin(q[..., 1])
    w1, w2 = v[..., 0], v[..., 1]
    return stack_vector([-h * (2 * w1 * w2 + w2**2), h * w1**2]) + gravity(p, q)


def passive(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """No joint friction in this system."""
    return np.zeros(np.broadcast_shapes(np.shape(q), np.shape(v)))


def kinetic_energy(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """T = v^T M v / 2."""
    return 0.5 * np.einsum("...i,...ij,...j->...", v, mass_matrix(p, q), v)


def potential_energy(p: Params, q: np.ndarray) -> np.ndarray:
    """V = -(m1 c1 + m2 l1) g cos th - m2 c2 g cos(th + ph), zero at the pivot's height."""
    th, ph = q[..., 0], q[..., 1]
    return -(p.m1 * p.c1 + p.m2 * p.l1) * p.g * np.cos(th) - p.m2 * p.c2 * p.g * np.cos(th + ph)


def body_positions(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """The bars' centres of mass."""
    th, ph = q[..., 0], q[..., 1]
    zero = np.zeros_like(th)
    u1 = stack_vector([np.sin(th), -np.cos(th), zero])
    u2 = stack_vector([np.sin(th + ph), -np.cos(th + ph), zero])
    return {"link1": p.c1 * u1, "link2": p.l1 * u1 + p.c2 * u2}


def body_rotations(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """Each bar's frame turns about z by its absolute angle."""
    return {"link1": rot_z(q[..., 0]), "link2": rot_z(q[..., 0] + q[..., 1])}


# ---------------------------------------------------------------------------------------------
# The notes' printed forms, transcribed as printed (m, l = l1 = 2 c1 = 2 c2 and Izz = I1 = I2 as
# in the notes). Vectors printed in the notes' section-3 frames are mapped to MJCF axes by P.

_P = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def _to_world(n: np.ndarray) -> np.ndarray:
    """A vector with the notes' section-3 coordinates, in MJCF axes (see the module docstring)."""
    return np.einsum("ij,...j->...i", _P, n)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.cross(*np.broadcast_arrays(a, b), axis=-1)


def _quad(a: np.ndarray, m: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...ij,...j->...", a, m, b)


def _eq76_77(p: Params, q: np.ndarray, v: np.ndarray, a: np.ndarray, tau: np.ndarray) -> np.ndarray:
    th, ph = q[..., 0], q[..., 1]
    dth, dph = v[..., 0], v[..., 1]
    ddth, ddph = a[..., 0], a[..., 1]
    m, l, g, Izz = p.m, p.l, p.g, p.Izz
    r76 = ((Izz + l**2 * m / 4 + l**2 * m / 2 * np.cos(ph)) * ddph
           + (2 * Izz + 3 * l**2 * m / 2 + l**2 * m * np.cos(ph)) * ddth
           - l**2 * m / 2 * np.sin(ph) * dph**2 - l**2 * m * np.sin(ph) * dph * dth
           + g * l * m / 2 * np.sin(ph + th) + 3 * g * l * m / 2 * np.sin(th))
    r77 = ((Izz + l**2 * m / 4) * ddph + (Izz + l**2 * m / 4 + l**2 * m / 2 * np.cos(ph)) * ddth
           + l**2 * m / 2 * np.sin(ph) * dth**2 + g * l * m / 2 * np.sin(ph + th))
    return stack_vector([r76, r77])


def _modelica_double_pendulum_from_rotations(p: Params, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                                              tau: np.ndarray) -> np.ndarray:
    # The two equations of model DoublePendulumFromRotations, left-hand side minus zero. The print
    # shows "1^2" for l^2 in places (and Izz = (m * 1 ^ 2) / 12): read as l, the only length.
    theta, phi = q[..., 0], q[..., 1]
    Dtheta, Dphi = v[..., 0], v[..., 1]
    der_Dtheta, der_Dphi = a[..., 0], a[..., 1]
    m, l, g, Izz = p.m, p.l, p.g, p.Izz
    e1 = ((Izz + l**2 * m / 4 + l**2 * m / 2 * np.cos(phi)) * der_Dphi
          + (2 * Izz + 3 / 2 * l**2 * m + l**2 * m * np.cos(phi)) * der_Dtheta
          - (l**2 * m) / 2 * np.sin(phi) * Dphi**2 - l**2 * m * np.sin(phi) * Dphi * Dtheta
          + g * l * m / 2 * np.sin(phi + theta) + 3 * g * l * m / 2 * np.sin(theta))
    e2 = ((Izz + l**2 / 4 * m) * der_Dphi + (Izz + l**2 / 4 * m + l**2 / 2 * m * np.cos(phi)) * der_Dtheta
          + l**2 / 2 * m * np.sin(phi) * Dtheta**2 + g * l * m / 2 * np.sin(phi + theta))
    return stack_vector([e1, e2])


def _matlab_vectors(p: Params, q: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
    """The section-3 Matlab script's vectors (notes' frames), which (66) and (71)-(75) are evaluated with.

    The print lacks the lines defining omega011 and omega122; they are taken as [0; 0; dthetadt]
    and [0; 0; dphidt], as in the gimbal script of section 4. The print shows r011 = [1;0;0]:
    read as [l;0;0] ("Note that the x axes are aligned with the long axes of the two bars").
    r122 and v022 (the end of bar 2) are printed too but feed nothing evaluated here.
    """
    theta, phi = q[..., 0], q[..., 1]
    dthetadt, dphidt = v[..., 0], v[..., 1]
    l, zero = p.l, np.zeros_like(theta)
    R01 = rot_z(theta)
    R12 = rot_z(phi)
    R02 = R01 @ R12
    R12T = np.swapaxes(R12, -1, -2)
    omega011 = stack_vector([zero, zero, dthetadt])
    omega122 = stack_vector([zero, zero, dphidt])
    omega010 = np.einsum("...ij,...j->...i", R01, omega011)
    omega012 = np.einsum("...ij,...j->...i", R12T, omega011)
    omega020 = omega010 + np.einsum("...ij,...j->...i", R02, omega122)
    omega022 = omega012 + omega122
    r011 = np.array([l, 0.0, 0.0])
    rc011 = np.array([l / 2, 0.0, 0.0])
    rc122 = np.array([l / 2, 0.0, 0.0])
    rc010 = np.einsum("...ij,j->...i", R01, rc011)
    rc022 = np.einsum("...ij,j->...i", R12T, r011) + rc122
    rc020 = np.einsum("...ij,...j->...i", R02, rc022)
    v011 = _cross(omega011, r011)
    vc011 = _cross(omega011, rc011)
    vc022 = np.einsum("...ij,...j->...i", R12T, v011) + _cross(omega022, rc122)
    return {"omega011": omega011, "omega022": omega022, "omega010": omega010, "omega020": omega020,
            "rc010": rc010, "rc020": rc020, "vc011": vc011, "vc022": vc022, "R01": R01, "R02": R02}


def _inertia_zz(izz: float) -> np.ndarray:
    # The body-frame inertia the planar formulas need: every angular velocity here is along z,
    # so only Izz enters (the bar's Ixx and Iyy multiply zero components).
    return np.diag([0.0, 0.0, izz])


def _t66(i: int):
    def evaluate(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        vc = _matlab_vectors(p, q, v)["vc011" if i == 1 else "vc022"]
        return 0.5 * p.m * np.einsum("...i,...i->...", vc, vc)
    return evaluate


def _t71(i: int):
    def evaluate(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        vec = _matlab_vectors(p, q, v)
        w0, R = (vec["omega010"], vec["R01"]) if i == 1 else (vec["omega020"], vec["R02"])
        R_0i = np.swapaxes(R, -1, -2)  # R_0^i = (R_i^0)^T
        I0 = np.swapaxes(R_0i, -1, -2) @ _inertia_zz(p.Izz) @ R_0i  # (73) for frame i
        return 0.5 * _quad(w0, I0, w0)
    return evaluate


def _t72(i: int):
    def evaluate(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        w = _matlab_vectors(p, q, v)["omega011" if i == 1 else "omega022"]
        return 0.5 * _quad(w, _inertia_zz(p.Izz), w)
    return evaluate


def _t74(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    vec = _matlab_vectors(p, q, v)
    I = _inertia_zz(p.Izz)  # noqa: E741 - the notes' symbol
    total = 0.0
    for vc, w in ((vec["vc011"], vec["omega011"]), (vec["vc022"], vec["omega022"])):
        total = total + (p.m * np.einsum("...i,...i->...", vc, vc) + 0.5 * _quad(w, I, w))
    return 0.5 * total


def _v75(i: int):
    def evaluate(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        rc = _matlab_vectors(p, q, v)["rc010" if i == 1 else "rc020"]
        g0 = np.array([p.g, 0.0, 0.0])  # the notes' gravity, along x_0 (Matlab [g,0,0])
        return -p.m * np.einsum("i,...i->...", g0, rc)
    return evaluate


def _r51(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    psi = q[..., 0]
    return stack_matrix([[np.cos(psi), -np.sin(psi), 0.0], [np.sin(psi), np.cos(psi), 0.0], [0.0, 0.0, 1.0]])


def _r56(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    return rot_z(q[..., 0]) @ rot_z(q[..., 1])


def _w56(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    th, ph = q[..., 0], q[..., 1]
    zero = np.zeros_like(th)
    R01, R12 = rot_z(th), rot_z(ph)  # R_1^0, R_2^1
    w011 = stack_vector([zero, zero, v[..., 0]])
    w122 = stack_vector([zero, zero, v[..., 1]])
    w020 = np.einsum("...ij,...j->...i", R01, w011) + np.einsum("...ij,...j->...i", R01 @ R12, w122)
    return _to_world(w020)


def _w57(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    zero = np.zeros_like(v[..., 0])
    w011 = stack_vector([zero, zero, v[..., 0]])
    w121 = stack_vector([zero, zero, v[..., 1]])
    return _to_world(w011 + w121)  # body-frame coordinates map by P as world ones do


def _v62(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    # The right-hand side of (62), the cross product as the print evaluates it.
    th, dth, l = q[..., 0], v[..., 0], p.l
    return _to_world(stack_vector([-dth * l * np.sin(th), dth * l * np.cos(th), np.zeros_like(th)]))


VARIANTS = (
    Implicit(
        name="implicit (76)-(77)",
        notes_equations=("76", "77"),
        residual=_eq76_77,
        row_scale=lambda p: np.ones(2),
        note="Printed undivided (row scale 1); Izz is the bars' central inertia read from the MJCF.",
    ),
    Implicit(
        name="modelica DoublePendulumFromRotations",
        notes_equations=("modelica:DoublePendulumFromRotations",),
        residual=_modelica_double_pendulum_from_rotations,
        row_scale=lambda p: np.ones(2),
        kind="modelica",
        printed_parameters={"m1": 1.0, "m2": 1.0, "l1": 1.0, "g": 9.81, "I1": 1 / 12, "I2": 1 / 12},
        note="The print shows 1^2 where l^2 is meant in places (also in Izz = (m * 1 ^ 2) / 12), read as l^2; "
             "Izz = m l^2 / 12 with m = l = 1 gives the printed I1 = I2 = 1/12.",
    ),
    DerivationStep(
        name="bar 1 centre-of-mass speed (38)", notes_equations=("38",), quantity=("com_speed_squared", "link1"),
        evaluate=lambda p, q, v: (p.l / 2 * v[..., 0]) ** 2,
        note="(38) prints the speed v_c1 = (l/2) theta'; compared through its square, as the engines give a vector.",
    ),
    DerivationStep(
        name="bar 1 translational kinetic energy (39)", notes_equations=("39",),
        quantity=("translational_kinetic_energy", "link1"),
        evaluate=lambda p, q, v: 0.5 * p.m * (p.l / 2) ** 2 * v[..., 0] ** 2,
    ),
    DerivationStep(
        name="bar 1 rotational kinetic energy (40)", notes_equations=("40",),
        quantity=("rotational_kinetic_energy", "link1"),
        evaluate=lambda p, q, v: 0.5 * p.Izz * v[..., 0] ** 2,
        note="I_c is the bar's central inertia Izz.",
    ),
    DerivationStep(
        name="bar 1 kinetic energy (41)", notes_equations=("41",), quantity=("kinetic_energy", "link1"),
        evaluate=lambda p, q, v: 0.5 * (p.Izz + p.m * (p.l / 2) ** 2) * v[..., 0] ** 2,
    ),
    DerivationStep(
        name="bar 1 inertia about the joint (42)", notes_equations=("42",), quantity=("kinetic_energy", "link1"),
        evaluate=lambda p, q, v: 0.5 * (p.Izz + p.m * (p.l / 2) ** 2) * v[..., 0] ** 2,
        note="(42) is a constant, I = I_c + m (l/2)^2; compared as the kinetic energy I theta'^2 / 2 of bar 1 "
             "rotating about the joint, which the text says it gives.",
    ),
    DerivationStep(
        name="bar 2 kinetic energy (45)-(46)", notes_equations=("45", "46"), quantity=("kinetic_energy", "link2"),
        evaluate=lambda p, q, v: (0.5 * p.m * (p.l * v[..., 0]) ** 2
                                  + 0.5 * (p.Izz + p.m * (p.l / 2) ** 2) * (v[..., 0] + v[..., 1]) ** 2
                                  + p.m * p.l * v[..., 0] * p.l / 2 * (v[..., 0] + v[..., 1]) * np.cos(q[..., 1])),
        note="The last member of (45), with the third term as evaluated in (46) and v_02 = l theta' from the text "
             "before (43).",
    ),
    DerivationStep(
        name="R_1^0 (49), (51)-(52)", notes_equations=("49", "51", "52"), quantity=("rotation", "link1"),
        evaluate=_r51,
        note="The notes' generic angle psi is bar 1's angle theta here; (49) is the upper-left block of (51).",
    ),
    DerivationStep(
        name="R_2^0 = R_1^0 R_2^1 (56)", notes_equations=("56",), quantity=("rotation", "link2"),
        evaluate=_r56,
        note="R_2^1 is the Matlab script's R12, the rotation by phi about z.",
    ),
    DerivationStep(
        name="omega_02^0 (56)", notes_equations=("56",), quantity=("angular_velocity", "link2"),
        evaluate=_w56,
        note="omega_01^1 = (0, 0, theta'), omega_12^2 = (0, 0, phi'), R_1^0 = R_z(theta), R_2^1 = R_z(phi).",
    ),
    DerivationStep(
        name="omega_02^1 (57)", notes_equations=("57",), quantity=("angular_velocity_body", "link2"),
        evaluate=_w57,
        note="The text says 'in the second frame', the print has superscript 1; the two coordinates coincide "
             "for a rotation about z. omega_12^1 = (0, 0, phi').",
    ),
    DerivationStep(
        name="v_01^0 (62)", notes_equations=("62",), quantity=("origin_velocity", "link2"),
        evaluate=_v62,
        note="The origin of frame 1 is at the end of bar 1 (r_01^0 = l (cos theta, sin theta, 0)), the origin of "
             "MJCF body link2. Printed in the notes' section-3 frame, mapped to MJCF axes by P.",
    ),
    DerivationStep(
        name="bar 1 translational kinetic energy (66)", notes_equations=("66",),
        quantity=("translational_kinetic_energy", "link1"), evaluate=_t66(1),
        note="v_0i read as the centre-of-mass velocity, as the notes' Matlab script does (T1trans with vc011); "
             "vc011 as the script computes it.",
    ),
    DerivationStep(
        name="bar 2 translational kinetic energy (66)", notes_equations=("66",),
        quantity=("translational_kinetic_energy", "link2"), evaluate=_t66(2),
        note="v_0i read as the centre-of-mass velocity, as the notes' Matlab script does (T2trans with vc022); "
             "vc022 as the script computes it.",
    ),
    DerivationStep(
        name="bar 1 rotational kinetic energy (71), (73)", notes_equations=("71", "73"),
        quantity=("rotational_kinetic_energy", "link1"), evaluate=_t71(1),
        note="omega_01^0 = omega010 of the Matlab script; I^0 from (73) with the body-frame inertia diag(., ., Izz).",
    ),
    DerivationStep(
        name="bar 2 rotational kinetic energy (71), (73)", notes_equations=("71", "73"),
        quantity=("rotational_kinetic_energy", "link2"), evaluate=_t71(2),
        note="omega_02^0 = omega020 of the Matlab script; I^0 from (73) for frame 2, (R_0^2)^T I^2 R_0^2.",
    ),
    DerivationStep(
        name="bar 1 rotational kinetic energy (72)", notes_equations=("72",),
        quantity=("rotational_kinetic_energy", "link1"), evaluate=_t72(1),
        note="omega_01^1 = omega011 of the Matlab script (T1rot).",
    ),
    DerivationStep(
        name="bar 2 rotational kinetic energy (72)", notes_equations=("72",),
        quantity=("rotational_kinetic_energy", "link2"), evaluate=_t72(2),
        note="omega_02^2 = omega022 of the Matlab script (T2rot).",
    ),
    DerivationStep(
        name="kinetic energy (74)", notes_equations=("74",), quantity=("kinetic_energy", None), evaluate=_t74,
        note="Transcribed as printed, with the 1/2 inside the sum in front of the rotational term. v_0i^i read as "
             "the centre-of-mass velocity (the Matlab script's vc011, vc022), omega_0i^i as omega011, omega022.",
    ),
    DerivationStep(
        name="bar 1 potential energy (75)", notes_equations=("75",), quantity=("potential_energy", "link1"),
        evaluate=_v75(1),
        note="g^0 = [g, 0, 0] and r_c1^0 = rc010 as in the Matlab script (x_0 points down).",
    ),
    DerivationStep(
        name="bar 2 potential energy (75)", notes_equations=("75",), quantity=("potential_energy", "link2"),
        evaluate=_v75(2),
        note="g^0 = [g, 0, 0] and r_c2^0 = rc020 as in the Matlab script (x_0 points down).",
    ),
)

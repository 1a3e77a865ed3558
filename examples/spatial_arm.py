"""A 3-DOF spatial arm: base yaw, shoulder pitch, elbow pitch, full inertia tensors (not in the notes).

The notes' section-3 method (rotation matrices, angular velocities in body frames, T from the
body-frame inertia, eqs 47-75) applied to a chain that leaves the plane. Symbols (all read from
examples/spatial_arm.xml; i = 1, 2, 3 for link1, link2, link3):

    h0                    height of link1's origin (the yaw axis' anchor) above the world origin, m
    m_i                   link masses, kg
    c_i = (cix, ciy, ciz) centre of mass of link i in its body frame, m
    d1 = (d1x, d1y, d1z)  shoulder (link2's origin) in link1's frame, m
    d2 = (d2x, d2y, d2z)  elbow (link3's origin) in link2's frame, m
    I_i                   inertia of link i about its centre of mass, body axes, kg m^2: the full
                          tensor [[Iixx, Iixy, Iixz], [Iixy, Iiyy, Iiyz], [Iixz, Iiyz, Iizz]]
                          (MJCF fullinertia: tensor entries, not negated products of inertia);
                          link1 turns about z only, so only I1zz matters
    b1, b2, b3            viscous damping of yaw, shoulder, elbow, N m s/rad (MJCF joint damping)
    g                     gravitational acceleration, m/s^2 (MJCF gravity (0, 0, -g))

Coordinates: q = (q1, q2, q3) = (yaw, shoulder, elbow), the MJCF joints' angles (same sign, same
zero). The world frame has z up. Every body frame is parallel to its parent's at q = 0 and every
joint sits at its body's origin. yaw turns link1 about the world z axis through (0, 0, h0);
shoulder turns link2 about link1's y axis; elbow turns link3 about link2's y axis (a positive pitch
turns the arm's +x end down). With the notes' elementary rotations (53)-(54):
    R_1^0 = R_z(q1),  R_2^1 = R_y(q2),  R_3^2 = R_y(q3),
    R_2^0 = R_z(q1) R_y(q2),  R_3^0 = R_z(q1) R_y(q2 + q3)   (R_y(a) R_y(b) = R_y(a + b)).

The derivation works in frame 1 (axes of link1, origin o1 = (0, 0, h0)): M does not depend on q1,
because T does not. With u2 = R_y(q2) c2, w2 = R_y(q2) d2, u3 = R_y(q2 + q3) c3, the centres of
mass in frame 1 are
    r1 = c1,   r2 = d1 + u2,   r3 = d1 + w2 + u3,
and in the world p_i = (0, 0, h0) + R_z(q1) r_i. Angular velocities in frame 1: omega_1 = q1' z,
omega_2 = q1' z + q2' y, omega_3 = q1' z + (q2' + q3') y (both pitch axes are y of frame 1, the
shoulder axis carried by R_z only). In body frames (eq 84's pattern, omega_i^i = R_i^1^T omega_i^1):
omega_2^2 = (-sin q2 q1', q2', cos q2 q1'), omega_3^3 = (-sin q23 q1', q2' + q3', cos q23 q1').

T = sum_i m_i |v_ci|^2 / 2 + omega_i^i . I_i omega_i^i / 2 (eqs 66, 72) = q'^T M q' / 2 with
    M = sum_i m_i J_vi^T J_vi + J_wi^T (R_i^1 I_i R_i^1^T) J_wi,
J_vi and J_wi the Jacobians of v_ci and omega_i in frame 1, written by hand below (column j of J_vi
is a_j x (r_i - (anchor of joint j)) with a_j the joint's axis). C(q, q') q' follows from M by the
Christoffel symbols of the first kind, with dM/dq differentiated by hand (see `_mass_derivatives`);
G = dV/dq with V = g sum_i m_i (h0 + r_i,z). passive = -(b1 q1', b2 q2', b3 q3').

Inputs: tau is the generalized force on each joint (the motors' torques at the joints); the MJCF
motors have gears 1, 2, 3 and the harness sends ctrl = tau / gear, so the gears do not enter here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from lagrange_xval.forms import NAN, body, hinge, rot_y, rot_z, stack_matrix, stack_vector

DESCRIPTION = (
    "A 3-DOF spatial arm (base yaw about z, shoulder and elbow pitch about y) with full, non-diagonal "
    "inertia tensors, centres of mass off the link axes, viscous damping and a motor on every joint; "
    "the notes' section-3 rotation-matrix method carried to a non-planar chain (not in the notes)."
)
COORDINATES = ("yaw", "shoulder", "elbow")
JOINTS = ("yaw", "shoulder", "elbow")
BODIES = ("link1", "link2", "link3")
# Not from the notes: turning in yaw while the arm, raised above the horizontal, falls and folds.
INITIAL_STATE = ((0.3, -0.6, 1.1), (0.5, 0.0, -0.4))
VARIANTS = ()


@dataclass(frozen=True)
class Params:
    h0: float  # m
    m1: float  # kg
    c1x: float  # m
    c1y: float  # m
    c1z: float  # m
    I1zz: float  # kg m^2
    d1x: float  # m
    d1y: float  # m
    d1z: float  # m
    m2: float  # kg
    c2x: float  # m
    c2y: float  # m
    c2z: float  # m
    I2xx: float  # kg m^2
    I2yy: float  # kg m^2
    I2zz: float  # kg m^2
    I2xy: float  # kg m^2
    I2xz: float  # kg m^2
    I2yz: float  # kg m^2
    d2x: float  # m
    d2y: float  # m
    d2z: float  # m
    m3: float  # kg
    c3x: float  # m
    c3y: float  # m
    c3z: float  # m
    I3xx: float  # kg m^2
    I3yy: float  # kg m^2
    I3zz: float  # kg m^2
    I3xy: float  # kg m^2
    I3xz: float  # kg m^2
    I3yz: float  # kg m^2
    b1: float  # N m s/rad
    b2: float  # N m s/rad
    b3: float  # N m s/rad
    g: float  # m/s^2


def parameters(model: Any) -> Params:
    """Reads the parameters from the compiled MJCF (see validate/model/modelview.py for the keys)."""
    c1, c2, c3 = (model[f"body/link{i}/com"] for i in (1, 2, 3))
    d1, d2 = model["body/link2/pos"], model["body/link3/pos"]
    I2, I3 = model["body/link2/inertia"], model["body/link3/inertia"]
    return Params(
        h0=float(model["body/link1/pos"][2]),
        m1=float(model["body/link1/mass"]),
        c1x=float(c1[0]),
        c1y=float(c1[1]),
        c1z=float(c1[2]),
        I1zz=float(model["body/link1/inertia"][2, 2]),
        d1x=float(d1[0]),
        d1y=float(d1[1]),
        d1z=float(d1[2]),
        m2=float(model["body/link2/mass"]),
        c2x=float(c2[0]),
        c2y=float(c2[1]),
        c2z=float(c2[2]),
        I2xx=float(I2[0, 0]),
        I2yy=float(I2[1, 1]),
        I2zz=float(I2[2, 2]),
        I2xy=float(I2[0, 1]),
        I2xz=float(I2[0, 2]),
        I2yz=float(I2[1, 2]),
        d2x=float(d2[0]),
        d2y=float(d2[1]),
        d2z=float(d2[2]),
        m3=float(model["body/link3/mass"]),
        c3x=float(c3[0]),
        c3y=float(c3[1]),
        c3z=float(c3[2]),
        I3xx=float(I3[0, 0]),
        I3yy=float(I3[1, 1]),
        I3zz=float(I3[2, 2]),
        I3xy=float(I3[0, 1]),
        I3xz=float(I3[0, 2]),
        I3yz=float(I3[1, 2]),
        b1=float(model["joint/yaw/damping"]),
        b2=float(model["joint/shoulder/damping"]),
        b3=float(model["joint/elbow/damping"]),
        g=float(-model["gravity"][2]),
    )


def _inertia(p: Params, i: int) -> np.ndarray:
    """The full body-frame inertia tensor of link i (2 or 3) about its centre of mass."""
    x = {k: getattr(p, f"I{i}{k}") for k in ("xx", "yy", "zz", "xy", "xz", "yz")}
    return np.array([[x["xx"], x["xy"], x["xz"]], [x["xy"], x["yy"], x["yz"]], [x["xz"], x["yz"], x["zz"]]])


def assumptions(p: Params) -> dict[str, Any]:
    """The compiled model this derivation describes: yaw about world z at (0, 0, h0), two pitch
    hinges about y, body frames parallel at q = 0, joints at the body origins, full inertias,
    viscous damping, a motor on each joint (any gear: tau is the generalized force)."""
    # link1 turns about z only: T1 = I1zz q1'^2 / 2, whatever its other entries (products included).
    I1 = np.array([[NAN, NAN, NAN], [NAN, NAN, NAN], [NAN, NAN, p.I1zz]])
    return {
        "gravity": np.array([0.0, 0.0, -p.g]),
        **body("link1", parent="world", mass=p.m1, com=(p.c1x, p.c1y, p.c1z), inertia=I1, pos=(0, 0, p.h0)),
        **body(
            "link2",
            parent="link1",
            mass=p.m2,
            com=(p.c2x, p.c2y, p.c2z),
            inertia=_inertia(p, 2),
            pos=(p.d1x, p.d1y, p.d1z),
        ),
        **body(
            "link3",
            parent="link2",
            mass=p.m3,
            com=(p.c3x, p.c3y, p.c3z),
            inertia=_inertia(p, 3),
            pos=(p.d2x, p.d2y, p.d2z),
        ),
        **hinge("yaw", body="link1", axis=(0, 0, 1), damping=p.b1),
        **hinge("shoulder", body="link2", axis=(0, 1, 0), damping=p.b2),
        **hinge("elbow", body="link3", axis=(0, 1, 0), damping=p.b3),
        "actuator/yaw_motor/joint": "yaw",
        "actuator/yaw_motor/gear": NAN,
        "actuator/shoulder_motor/joint": "shoulder",
        "actuator/shoulder_motor/gear": NAN,
        "actuator/elbow_motor/joint": "elbow",
        "actuator/elbow_motor/gear": NAN,
    }


def _ry(q: np.ndarray, x: float, y: float, z: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Components of R_y(q) (x, y, z) = (cos q x + sin q z, y, -sin q x + cos q z)."""
    c, s = np.cos(q), np.sin(q)
    return c * x + s * z, y + 0.0 * q, -s * x + c * z


def _frame1(p: Params, q: np.ndarray) -> dict[str, Any]:
    """Vectors in frame 1: u2 = R_y(q2) c2, w2 = R_y(q2) d2, u3 = R_y(q2 + q3) c3, r2, r3."""
    q2, q23 = q[..., 1], q[..., 1] + q[..., 2]
    u2x, _, u2z = _ry(q2, p.c2x, p.c2y, p.c2z)
    w2x, _, w2z = _ry(q2, p.d2x, p.d2y, p.d2z)
    u3x, _, u3z = _ry(q23, p.c3x, p.c3y, p.c3z)
    return {
        "q2": q2,
        "q23": q23,
        "u2x": u2x,
        "u2z": u2z,
        "w2x": w2x,
        "w2z": w2z,
        "u3x": u3x,
        "u3z": u3z,
        "r2x": p.d1x + u2x,
        "r2y": p.d1y + p.c2y,
        "r2z": p.d1z + u2z,
        "r3x": p.d1x + w2x + u3x,
        "r3y": p.d1y + p.d2y + p.c3y,
        "r3z": p.d1z + w2z + u3z,
    }


def _jacobians(p: Params, q: np.ndarray) -> list[tuple[float, np.ndarray, np.ndarray, np.ndarray]]:
    """(m_i, J_vi, J_wi, R_i^1) per link, in frame 1 (shapes (..., 3, 3), rows x, y, z, columns q1..q3).

    Column 1 (yaw, axis z through o1): z x r_i = (-r_iy, r_ix, 0).
    Column 2 (shoulder, axis y through d1): y x (r_i - d1) = ((r_i - d1)_z, 0, -(r_i - d1)_x).
    Column 3 (elbow, axis y through d1 + w2): y x u3 = (u3z, 0, -u3x).
    """
    k = _frame1(p, q)
    zero = np.zeros_like(k["q2"])
    Jv1 = stack_matrix([[-p.c1y + zero, zero, zero], [p.c1x + zero, zero, zero], [zero, zero, zero]])
    Jv2 = stack_matrix([[-k["r2y"] + zero, k["u2z"], zero], [k["r2x"], zero, zero], [zero, -k["u2x"], zero]])
    Jv3 = stack_matrix(
        [
            [-k["r3y"] + zero, k["w2z"] + k["u3z"], k["u3z"]],
            [k["r3x"], zero, zero],
            [zero, -(k["w2x"] + k["u3x"]), -k["u3x"]],
        ]
    )
    Jw1 = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    Jw2 = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    Jw3 = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 1.0], [1.0, 0.0, 0.0]])
    # link1's inertia enters only through I1zz (J_w1 has only a z row); R_1^1 = identity.
    I1 = np.diag([0.0, 0.0, p.I1zz])
    return [
        (p.m1, Jv1, Jw1, I1 + 0.0 * Jv1),
        (p.m2, Jv2, Jw2, rot_y(k["q2"]) @ _inertia(p, 2) @ np.swapaxes(rot_y(k["q2"]), -1, -2)),
        (p.m3, Jv3, Jw3, rot_y(k["q23"]) @ _inertia(p, 3) @ np.swapaxes(rot_y(k["q23"]), -1, -2)),
    ]


def mass_matrix(p: Params, q: np.ndarray) -> np.ndarray:
    """M(q) = sum_i m_i J_vi^T J_vi + J_wi^T (R_i^1 I_i R_i^1^T) J_wi, frame-1 Jacobians."""
    M: Any = 0.0
    for m, Jv, Jw, I_1 in _jacobians(p, q):
        M = M + m * np.einsum("...ki,...kj->...ij", Jv, Jv) + np.einsum("ki,...kl,lj->...ij", Jw, I_1, Jw)
    return M


def _mass_derivatives(p: Params, q: np.ndarray) -> np.ndarray:
    """dM[..., k, i, j] = dM_ij/dq_k, by hand from the entries of M written out:

      M11 = I1zz + m1 (c1x^2 + c1y^2) + f2(q2) + f3(q23) + m2 (r2x^2 + r2y^2) + m3 (r3x^2 + r3y^2)
      M12 = g2(q2) + g3(q23) - m2 r2y u2z - m3 r3y (w2z + u3z)
      M13 = g3(q23) - m3 r3y u3z
      M22 = I2yy + m2 (c2x^2 + c2z^2) + I3yy + m3 (d2x^2 + d2z^2 + c3x^2 + c3z^2 + 2 kappa)
      M23 = I3yy + m3 (c3x^2 + c3z^2 + kappa),   M33 = I3yy + m3 (c3x^2 + c3z^2)
    with f_i(a) = Iixx sin^2 a + Iizz cos^2 a - 2 Iixz sin a cos a (the z-z entry of R_y I_i R_y^T),
    g_i(a) = Iiyz cos a - Iixy sin a (its y-z entry), kappa = w2x u3x + w2z u3z = d2 . R_y(q3) c3
    in the x-z plane (a function of q3 only). Every R_y(.)-rotated vector turns as d/da (x, z) =
    (z, -x): d u2x/dq2 = u2z, d u2z/dq2 = -u2x, and so on. M does not depend on q1.
    """
    k = _frame1(p, q)
    u2x, u2z, w2x, w2z, u3x, u3z = (k[n] for n in ("u2x", "u2z", "w2x", "w2z", "u3x", "u3z"))
    r2x, r2y, r3x, r3y = k["r2x"], k["r2y"], k["r3x"], k["r3y"]

    def df(i: int, a: np.ndarray) -> np.ndarray:
        c, s = np.cos(a), np.sin(a)
        xx, zz, xz = getattr(p, f"I{i}xx"), getattr(p, f"I{i}zz"), getattr(p, f"I{i}xz")
        return 2 * (xx - zz) * s * c - 2 * xz * (c**2 - s**2)

    def dg(i: int, a: np.ndarray) -> np.ndarray:
        return -getattr(p, f"I{i}yz") * np.sin(a) - getattr(p, f"I{i}xy") * np.cos(a)

    df2, df3, dg2, dg3 = df(2, k["q2"]), df(3, k["q23"]), dg(2, k["q2"]), dg(3, k["q23"])
    dkappa = w2x * u3z - w2z * u3x
    zero = np.zeros_like(u2x)
    d11_2 = df2 + df3 + 2 * p.m2 * r2x * u2z + 2 * p.m3 * r3x * (w2z + u3z)
    d12_2 = dg2 + dg3 + p.m2 * r2y * u2x + p.m3 * r3y * (w2x + u3x)
    d13 = dg3 + p.m3 * r3y * u3x  # the same for q2 and q3: M13 depends on q2 + q3 only
    d11_3 = df3 + 2 * p.m3 * r3x * u3z
    dq1 = stack_matrix([[zero] * 3] * 3)
    dq2 = stack_matrix([[d11_2, d12_2, d13], [d12_2, zero, zero], [d13, zero, zero]])
    dq3 = stack_matrix(
        [
            [d11_3, d13, d13],
            [d13, 2 * p.m3 * dkappa, p.m3 * dkappa],
            [d13, p.m3 * dkappa, zero],
        ]
    )
    return np.stack(np.broadcast_arrays(dq1, dq2, dq3), axis=-3)


def gravity(p: Params, q: np.ndarray) -> np.ndarray:
    """G = dV/dq, V = g (m1 (h0 + c1z) + m2 (h0 + r2z) + m3 (h0 + r3z)): (0, -g (m2 u2x + m3 (w2x +
    u3x)), -g m3 u3x)."""
    k = _frame1(p, q)
    zero = np.zeros_like(k["u2x"])
    return stack_vector([zero, -p.g * (p.m2 * k["u2x"] + p.m3 * (k["w2x"] + k["u3x"])), -p.g * p.m3 * k["u3x"]])


def bias(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """C(q, q') q' + G(q), with (C q')_i = sum_jk (dM_ij/dq_k - dM_jk/dq_i / 2) q'_j q'_k
    (Christoffel symbols of the first kind, symmetrized over j, k)."""
    dM = _mass_derivatives(p, q)
    cv = np.einsum("...kij,...j,...k->...i", dM, v, v) - 0.5 * np.einsum("...ijk,...j,...k->...i", dM, v, v)
    return cv + gravity(p, q)


def passive(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Viscous friction on each joint: -(b1 q1', b2 q2', b3 q3')."""
    b = np.array([p.b1, p.b2, p.b3])
    return -b * v + np.zeros(np.broadcast_shapes(np.shape(q), np.shape(v)))


def kinetic_energy(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """T = q'^T M q' / 2."""
    return 0.5 * np.einsum("...i,...ij,...j->...", v, mass_matrix(p, q), v)


def potential_energy(p: Params, q: np.ndarray) -> np.ndarray:
    """V = g (m1 (h0 + c1z) + m2 (h0 + r2z) + m3 (h0 + r3z)), zero at the world origin's height."""
    k = _frame1(p, q)
    return p.g * (p.m1 * (p.h0 + p.c1z) + p.m2 * (p.h0 + k["r2z"]) + p.m3 * (p.h0 + k["r3z"]))


def body_positions(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """p_i = (0, 0, h0) + R_z(q1) r_i."""
    k = _frame1(p, q)
    zero = np.zeros_like(k["q2"])
    R1 = rot_z(q[..., 0])
    o1 = np.array([0.0, 0.0, p.h0])
    r = {
        "link1": stack_vector([p.c1x + zero, p.c1y + zero, p.c1z + zero]),
        "link2": stack_vector([k["r2x"], k["r2y"] + zero, k["r2z"]]),
        "link3": stack_vector([k["r3x"], k["r3y"] + zero, k["r3z"]]),
    }
    return {name: o1 + np.einsum("...ij,...j->...i", R1, ri) for name, ri in r.items()}


def body_rotations(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """R_1^0 = R_z(q1), R_2^0 = R_z(q1) R_y(q2), R_3^0 = R_z(q1) R_y(q2 + q3)."""
    R1 = rot_z(q[..., 0])
    return {"link1": R1, "link2": R1 @ rot_y(q[..., 1]), "link3": R1 @ rot_y(q[..., 1] + q[..., 2])}

"""Rotary inverted (Furuta) pendulum: the notes' stated goal, by the method of section 3.

Contract form: energies only. The module gives T(q, v) and V(q) (and the damping); the harness
derives M(q) = d^2 T / dv^2 and the bias forces C(q, v) v + G(q) from the Lagrangian L = T - V.

Symbols (all read from examples/furuta_pendulum.xml):

    h                    height of the arm's pivot above the world origin, m
    m1                   arm mass, kg
    c1 = (c1x, c1y, c1z) arm centre of mass in the arm frame, m
    I1zz                 arm's central moment of inertia about its z axis (the rotation axis), kg m^2.
                         The arm turns about z alone, so its other moments and products do not enter.
    L                    arm length: the pendulum's hinge is at (L, 0, 0) in the arm frame, m
    m2                   pendulum mass, kg
    c2 = (c2x, c2y, c2z) pendulum centre of mass in the pendulum frame, m
    I2 (I2xx, I2yy, I2zz, I2xy, I2xz, I2yz)
                         pendulum's full central inertia in its body axes, kg m^2 (all six enter)
    ktheta, kalpha       viscous friction of the two joints, N m s/rad (MJCF joint damping)
    g                    gravitational acceleration, m/s^2 (MJCF gravity (0, 0, -g))

Coordinates and frames. World (frame 0): z up, gravity -z. theta turns the arm about the world
z axis: R_1^0 = R_z(theta) (eq 51), frame 1's origin o1 = (0, 0, h) on the axis. alpha turns the
pendulum about the arm's x axis (its long axis) at the arm's tip: R_2^1 = R_x(alpha) (eq 53),
R_2^0 = R_1^0 R_2^1, o2 = o1 + R_1^0 (L, 0, 0). alpha = 0 is upright (pendulum body z along world
+z); positive alpha tips the top towards the arm's -y.

Kinetic energy (eqs 56-61, 66, 72, 74), every vector in its body's own frame:

    omega_01^1 = (0, 0, theta')                                       arm
    omega_02^2 = R_x(alpha)^T omega_01^1 + (alpha', 0, 0)              pendulum (eq 57)
    v_c1^1     = omega_01^1 x c1                                       (eq 58; o1 is fixed)
    v_o2^1     = omega_01^1 x (L, 0, 0)                                (eq 58)
    v_c2^2     = R_x(alpha)^T v_o2^1 + omega_02^2 x c2                 (eqs 59-61)
    T = m1 |v_c1^1|^2 / 2 + I1zz theta'^2 / 2 + m2 |v_c2^2|^2 / 2 + (omega_02^2)^T I2 omega_02^2 / 2

Potential energy (eq 75): V = -m1 g^0 . r_c1^0 - m2 g^0 . r_c2^0 with g^0 = (0, 0, -g),
r_c1^0 = o1 + R_1^0 c1 and r_c2^0 = o2 + R_2^0 c2: zero at the world origin's height, as MuJoCo
counts it.

Inputs. tau = (tau_theta, tau_alpha): tau_theta is the motor's torque times its gear (MJCF motor
`motor_theta`, gear 1) on the arm; alpha has no actuator, so tau_alpha is an applied joint torque
that the harness leaves at zero (the pendulum is unactuated). Friction is viscous:
passive = -(ktheta theta', kalpha alpha').
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from lagrange_xval.forms import NAN, body, hinge, rot_z, stack_matrix, stack_vector

DESCRIPTION = (
    "Rotary inverted (Furuta) pendulum: an arm turning about the vertical (theta, motor-driven) and a "
    "pendulum turning about the arm's long axis at its tip (alpha, unactuated, 0 upright), both links "
    "with full 3D inertias and viscous friction; T and V by the rotation matrices of notes section 3 "
    "(eqs 49-61, 66, 71-75), the notes' stated goal."
)
COORDINATES = ("theta", "alpha")
JOINTS = ("theta", "alpha")
BODIES = ("arm", "pendulum")
# Near upright, the arm swinging and the pendulum pushed: a fall, caught and swung by the arm.
INITIAL_STATE = ((0.0, 0.15), (2.0, -0.5))


@dataclass(frozen=True)
class Params:
    h: float  # m
    m1: float  # kg
    c1x: float  # m
    c1y: float  # m
    c1z: float  # m
    I1zz: float  # kg m^2
    L: float  # m
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
    ktheta: float  # N m s/rad
    kalpha: float  # N m s/rad
    g: float  # m/s^2


def parameters(model: Any) -> Params:
    """Reads the parameters from the compiled MJCF (see validate/model/modelview.py for the keys)."""
    c1, c2 = model["body/arm/com"], model["body/pendulum/com"]
    I1, I2 = model["body/arm/inertia"], model["body/pendulum/inertia"]
    return Params(
        h=model["body/arm/pos"][2],
        m1=model["body/arm/mass"],
        c1x=c1[0],
        c1y=c1[1],
        c1z=c1[2],
        I1zz=I1[2, 2],
        L=model["body/pendulum/pos"][0],
        m2=model["body/pendulum/mass"],
        c2x=c2[0],
        c2y=c2[1],
        c2z=c2[2],
        I2xx=I2[0, 0],
        I2yy=I2[1, 1],
        I2zz=I2[2, 2],
        I2xy=I2[0, 1],
        I2xz=I2[0, 2],
        I2yz=I2[1, 2],
        ktheta=model["joint/theta/damping"],
        kalpha=model["joint/alpha/damping"],
        g=-model["gravity"][2],
    )


def _I2(p: Params) -> np.ndarray:
    return np.array([[p.I2xx, p.I2xy, p.I2xz], [p.I2xy, p.I2yy, p.I2yz], [p.I2xz, p.I2yz, p.I2zz]])


def assumptions(p: Params) -> dict[str, Any]:
    """The compiled model this derivation describes: arm on a vertical hinge at height h, pendulum on
    a hinge along the arm's x axis at its tip, no body rotated at q = 0, gravity along -z, viscous
    damping on both joints, a gear-1 motor on theta only."""
    arm_inertia = np.array([[NAN, NAN, NAN], [NAN, NAN, NAN], [NAN, NAN, p.I1zz]])  # only Izz: omega along z
    return {
        "gravity": np.array([0.0, 0.0, -p.g]),
        **body("arm", parent="world", mass=p.m1, com=(p.c1x, p.c1y, p.c1z), inertia=arm_inertia, pos=(0, 0, p.h)),
        **body("pendulum", parent="arm", mass=p.m2, com=(p.c2x, p.c2y, p.c2z), inertia=_I2(p), pos=(p.L, 0, 0)),
        **hinge("theta", body="arm", axis=(0, 0, 1), damping=p.ktheta),
        **hinge("alpha", body="pendulum", axis=(1, 0, 0), damping=p.kalpha),
        "actuator/motor_theta/joint": "theta",
        "actuator/motor_theta/gear": 1.0,
    }


def _rot_x(angle: Any) -> np.ndarray:
    """R_{x, angle} of eq 53, (..., 3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return stack_matrix([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _to_child(R: np.ndarray, x: np.ndarray) -> np.ndarray:
    """R^T x for stacks: a vector's coordinates carried from the parent frame into the child's (eq 50)."""
    return np.einsum("...ji,...j->...i", R, x)


def _velocities(p: Params, q: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
    """Angular velocities and centre-of-mass velocities, each in its own body's frame (eqs 56-61)."""
    al = q[..., 1]
    dth, dal = np.broadcast_arrays(v[..., 0], v[..., 1])
    shape = np.broadcast_shapes(np.shape(al), np.shape(dth))
    zero = np.zeros(shape)
    R21 = _rot_x(al + zero)
    w1 = stack_vector([zero, zero, dth + zero])  # omega_01^1
    w2 = _to_child(R21, w1) + stack_vector([dal + zero, zero, zero])  # omega_02^2
    c1 = np.array([p.c1x, p.c1y, p.c1z])
    c2 = np.array([p.c2x, p.c2y, p.c2z])
    r12 = np.array([p.L, 0.0, 0.0])
    vc1 = np.cross(w1, c1)  # v_c1^1
    vo2 = np.cross(w1, r12)  # v_o2^1, the pendulum's hinge
    vc2 = _to_child(R21, vo2) + np.cross(w2, c2)  # v_c2^2
    return {"w1": w1, "w2": w2, "vc1": vc1, "vc2": vc2}


def kinetic_energy(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """T = sum over the links of m |v_c|^2 / 2 + omega^T I omega / 2, in body frames (eqs 66, 72, 74)."""
    k = _velocities(p, q, v)
    t1 = 0.5 * p.m1 * np.sum(k["vc1"] ** 2, axis=-1) + 0.5 * p.I1zz * k["w1"][..., 2] ** 2
    t2 = 0.5 * p.m2 * np.sum(k["vc2"] ** 2, axis=-1) + 0.5 * np.einsum("...i,ij,...j->...", k["w2"], _I2(p), k["w2"])
    return t1 + t2


def potential_energy(p: Params, q: np.ndarray) -> np.ndarray:
    """V = -sum m_i g^0 . r_ci^0 (eq 75) = g (m1 z_c1 + m2 z_c2), zero at the world origin's height."""
    pos = body_positions(p, q)
    return p.g * (p.m1 * pos["arm"][..., 2] + p.m2 * pos["pendulum"][..., 2])


def passive(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Viscous friction on both joints: -(ktheta theta', kalpha alpha')."""
    k = np.array([p.ktheta, p.kalpha])
    return -k * v + np.zeros(np.broadcast_shapes(np.shape(q), np.shape(v)))


def body_positions(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """r_c1^0 = o1 + R_1^0 c1 and r_c2^0 = o1 + R_1^0 ((L, 0, 0) + R_2^1 c2), with o1 = (0, 0, h)."""
    R = body_rotations(p, q)
    R10 = R["arm"]
    o1 = np.array([0.0, 0.0, p.h])
    c1 = np.array([p.c1x, p.c1y, p.c1z])
    c2 = np.array([p.c2x, p.c2y, p.c2z])
    r12 = np.array([p.L, 0.0, 0.0])
    arm = o1 + np.einsum("...ij,j->...i", R10, c1)
    pendulum = o1 + np.einsum("...ij,j->...i", R10, r12) + np.einsum("...ij,j->...i", R["pendulum"], c2)
    return {"arm": arm, "pendulum": pendulum}


def body_rotations(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """R_1^0 = R_z(theta) (eq 51) and R_2^0 = R_1^0 R_x(alpha) (eqs 53, 56)."""
    R10 = rot_z(q[..., 0])
    return {"arm": R10, "pendulum": R10 @ _rot_x(q[..., 1])}


VARIANTS = ()

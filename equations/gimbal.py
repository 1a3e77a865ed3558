"""Double-gimbal line-of-sight inertially stabilized camera platform (notes, section 4).

Symbols (all read from models/gimbal.xml):

    I1zz                 outer (azimuth) gimbal's moment of inertia about its z axis, kg m^2
                         (the notes: 1e-3; the outer gimbal turns about z only, so its other
                         components do not matter)
    I2xx, I2yy, I2zz     inner (elevation) gimbal's principal moments of inertia, body axes, kg m^2
                         (the notes: 10e-3, 9e-3, 5e-3)
    kpsi, ktheta         viscous friction coefficients of the two axes, N m s/rad (MJCF joint
                         damping; the notes: 0.01 each)

Coordinates (the notes' Fig. 11): the base (carrier) frame has x forward, y to starboard and z
down; it is the MJCF world frame. psi turns the outer gimbal about the base z axis (positive: to
the right); theta turns the inner gimbal about the outer gimbal's y axis (positive: nose up).
R_1^0 = R_z(psi), R_2^1 = R_y(theta).

The platform is perfectly mass-balanced: both centres of mass lie where the axes meet, at the
common origin. Translation and gravity then contribute nothing (V = 0, eq 81), so the masses and
gravity are free; the MJCF disables gravity. The inputs tau are the motor torques (MJCF motors of
gear 1 on both joints); friction is viscous, passive = -(kpsi psi', ktheta theta').

Not checked (printed, but nothing the engines compute matches them):
    (83)    omega_01^2, the outer gimbal's angular velocity in the inner gimbal's frame: the engines
            give a body's angular velocity in the world or in its own frame only.
    the symbolic Matlab script of section 4 (R01, R12, R02 = R01*R12, omega022, T1rot, T2rot)
            repeats (78)-(84) in code; only (85)-(88) and the state-space function are transcribed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from lagrange_xval.forms import (
    NAN,
    DerivationStep,
    Explicit,
    Implicit,
    body,
    hinge,
    planar_inertia,
    rot_y,
    rot_z,
    stack_matrix,
    stack_vector,
)

DESCRIPTION = (
    "Mass-balanced double-gimbal camera platform: azimuth psi about the base z axis, elevation "
    "theta about the outer gimbal's y axis, viscous friction and motor torques (notes section 4, eqs 78-88)."
)
COORDINATES = ("psi", "theta")
JOINTS = ("psi", "theta")
BODIES = ("outer", "inner")
# The notes' experiment: ode45 from [0, -0.9*pi/2, 2*pi, 0] (camera nearly down, azimuth turning).
INITIAL_STATE = ((0.0, -0.9 * np.pi / 2), (2 * np.pi, 0.0))
NOTES_EXPERIMENT = "the ode45 simulation's start, [0, -0.9*pi/2, 2*pi, 0]"


@dataclass(frozen=True)
class Params:
    I1zz: float  # kg m^2
    I2xx: float  # kg m^2
    I2yy: float  # kg m^2
    I2zz: float  # kg m^2
    kpsi: float  # N m s/rad
    ktheta: float  # N m s/rad


def parameters(model: Any) -> Params:
    """Reads the parameters from the compiled MJCF (see validate/model/modelview.py for the keys)."""
    inner = model["body/inner/inertia"]
    return Params(
        I1zz=model["body/outer/inertia"][2, 2],
        I2xx=inner[0, 0],
        I2yy=inner[1, 1],
        I2zz=inner[2, 2],
        kpsi=model["joint/psi/damping"],
        ktheta=model["joint/theta/damping"],
    )


def assumptions(p: Params) -> dict[str, Any]:
    """The compiled model this derivation describes: two gimbals with all centres of mass at the
    origin (so gravity and the masses do not matter), principal axes along the body axes of the inner
    gimbal, hinges about base z and outer y, viscous damping and gear-1 motors on both axes."""
    return {
        "gravity": np.array([NAN, NAN, NAN]),
        **body("outer", parent="world", mass=NAN, com=(0, 0, 0), inertia=planar_inertia(p.I1zz)),
        **body("inner", parent="outer", mass=NAN, com=(0, 0, 0), inertia=np.diag([p.I2xx, p.I2yy, p.I2zz])),
        **hinge("psi", body="outer", axis=(0, 0, 1), damping=p.kpsi),
        **hinge("theta", body="inner", axis=(0, 1, 0), damping=p.ktheta),
        "actuator/motor_psi/joint": "psi",
        "actuator/motor_psi/gear": 1.0,
        "actuator/motor_theta/joint": "theta",
        "actuator/motor_theta/gear": 1.0,
    }


def _angular_velocities(q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """omega_01^1 and omega_02^2: each gimbal's angular velocity in its own frame."""
    th = q[..., 1]
    dpsi, dth = np.broadcast_arrays(v[..., 0], v[..., 1])
    zero = np.zeros(np.broadcast_shapes(np.shape(th), np.shape(dpsi)))
    w1 = stack_vector([zero, zero, dpsi])
    w2 = stack_vector([-np.sin(th) * dpsi, dth + zero, np.cos(th) * dpsi])  # R_y(th)^T w1 + (0, th', 0)
    return w1, w2


def mass_matrix(p: Params, q: np.ndarray) -> np.ndarray:
    """M(q) from T = I1zz psi'^2 / 2 + (I2xx s^2 psi'^2 + I2yy th'^2 + I2zz c^2 psi'^2) / 2."""
    s, c = np.sin(q[..., 1]), np.cos(q[..., 1])
    m11 = p.I1zz + p.I2xx * s**2 + p.I2zz * c**2
    zero = np.zeros_like(m11)
    return stack_matrix([[m11, zero], [zero, p.I2yy + zero]])


def bias(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """C(q, v) v: d/dt dT/dpsi' gives 2 (I2xx - I2zz) s c th' psi'; -dT/dth gives -(I2xx - I2zz) s c psi'^2."""
    sc = np.sin(q[..., 1]) * np.cos(q[..., 1])
    dpsi, dth = v[..., 0], v[..., 1]
    d = p.I2xx - p.I2zz
    return stack_vector([2 * d * sc * dth * dpsi, -d * sc * dpsi**2])


def passive(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Viscous friction on both axes: -(kpsi psi', ktheta theta')."""
    k = np.array([p.kpsi, p.ktheta])
    return -k * v + np.zeros(np.broadcast_shapes(np.shape(q), np.shape(v)))


def kinetic_energy(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """T = v^T M v / 2 (rotation only: the centres of mass do not move)."""
    return 0.5 * np.einsum("...i,...ij,...j->...", v, mass_matrix(p, q), v)


def potential_energy(p: Params, q: np.ndarray) -> np.ndarray:
    """V = 0: the centres of mass stay at the origin."""
    return np.zeros(np.shape(q)[:-1])


def body_positions(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """Both centres of mass stay at the origin."""
    zero = np.zeros(np.shape(q)[:-1] + (3,))
    return {"outer": zero, "inner": zero.copy()}


def body_rotations(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """R_1^0 = R_z(psi) and R_2^0 = R_z(psi) R_y(theta)."""
    r1 = rot_z(q[..., 0])
    return {"outer": r1, "inner": r1 @ rot_y(q[..., 1])}


# ---------------------------------------------------------------------------------------------
# The notes' printed forms, transcribed as printed. The friction torques T_frict are viscous,
# k times the rate with k the MJCF joint damping; the motor torques T_motor are the inputs tau.


def _eq85_86(p: Params, q: np.ndarray, v: np.ndarray, a: np.ndarray, tau: np.ndarray) -> np.ndarray:
    th = q[..., 1]
    dpsi, dth = v[..., 0], v[..., 1]
    ddpsi, ddth = a[..., 0], a[..., 1]
    t_az_frict, t_el_frict = p.kpsi * dpsi, p.ktheta * dth
    t_az_motor, t_el_motor = tau[..., 0], tau[..., 1]
    r85 = ((p.I1zz + p.I2zz * np.cos(th) ** 2 + p.I2xx * np.sin(th) ** 2) * ddpsi
           + 2 * (p.I2xx - p.I2zz) * np.cos(th) * np.sin(th) * dth * dpsi - (-t_az_frict + t_az_motor))
    r86 = p.I2yy * ddth - (p.I2xx - p.I2zz) * np.sin(th) * np.cos(th) * dpsi**2 - (-t_el_frict + t_el_motor)
    return stack_vector([r85, r86])


def _eq87_88(p: Params, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
    th = q[..., 1]
    dpsi, dth = v[..., 0], v[..., 1]
    t_az_frict, t_el_frict = p.kpsi * dpsi, p.ktheta * dth
    t_az_motor, t_el_motor = tau[..., 0], tau[..., 1]
    ddpsi = (-2 * (p.I2xx - p.I2zz) / (p.I1zz + p.I2zz * np.cos(th) ** 2 + p.I2xx * np.sin(th) ** 2)
             * np.cos(th) * np.sin(th) * dth * dpsi - t_az_frict + t_az_motor)
    ddth = (p.I2xx - p.I2zz) / p.I2yy * np.sin(th) * np.cos(th) * dpsi**2 - t_el_frict + t_el_motor
    return stack_vector([ddpsi, ddth])


def _matlab_double_gimbal_state_space_model(p: Params, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
    # dydt(3) and dydt(4) of the printed m-function; it has no input, so tau is not used. The print
    # shows 11zz, 12xx, 12yy, 12zz for I1zz, I2xx, I2yy, I2zz (the function defines only those).
    theta = q[..., 1]
    dpsidt, dthetadt = v[..., 0], v[..., 1]
    I1zz, I2xx, I2yy, I2zz, kpsi, ktheta = p.I1zz, p.I2xx, p.I2yy, p.I2zz, p.kpsi, p.ktheta
    dydt3 = (-2 * (I2xx - I2yy) / (I1zz + I2zz * (np.cos(theta)) ** 2 + I2xx * (np.sin(theta)) ** 2)
             * np.cos(theta) * np.sin(theta) * dpsidt * dthetadt - kpsi * dpsidt)
    dydt4 = (I2xx - I2zz) / I2yy * np.sin(theta) * np.cos(theta) * dpsidt**2 - ktheta * dthetadt
    return stack_vector([dydt3, dydt4 + np.zeros_like(dydt3)])


def _r78(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    psi = q[..., 0]
    return stack_matrix([[np.cos(psi), -np.sin(psi), 0.0], [np.sin(psi), np.cos(psi), 0.0], [0.0, 0.0, 1.0]])


def _r79(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    th = q[..., 1]
    return stack_matrix([[np.cos(th), 0.0, np.sin(th)], [0.0, 1.0, 0.0], [-np.sin(th), 0.0, np.cos(th)]])


def _r80(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    cpsi, spsi = np.cos(q[..., 0]), np.sin(q[..., 0])
    cth, sth = np.cos(q[..., 1]), np.sin(q[..., 1])
    return stack_matrix([[cpsi * cth, -spsi, -cpsi * sth],
                         [spsi * cth, cpsi, -spsi * sth],
                         [-sth, 0.0, -cth]])


def _r53(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    phi = q[..., 0]
    return stack_matrix([[1.0, 0.0, 0.0], [0.0, np.cos(phi), -np.sin(phi)], [0.0, np.sin(phi), np.cos(phi)]])


def _r54(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    th = q[..., 1]
    return stack_matrix([[np.cos(th), 0.0, np.sin(th)], [0.0, 1.0, 0.0], [-np.sin(th), 0.0, np.cos(th)]])


def _w82(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    dpsi = v[..., 0] + np.zeros(np.shape(q)[:-1])
    zero = np.zeros_like(dpsi)
    return stack_vector([zero, zero, dpsi])


def _w84(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    R21 = _r79(p, q, v)
    theta_dot = stack_vector([0.0 * v[..., 1], v[..., 1], 0.0 * v[..., 1]])
    return np.einsum("...ji,...j->...i", R21, _w82(p, q, v)) + theta_dot


def _t81(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    # Only I1zz enters the first term: omega_01^1 is along z.
    I1 = np.diag([0.0, 0.0, p.I1zz])
    I2 = np.diag([p.I2xx, p.I2yy, p.I2zz])
    w1, w2 = _w82(p, q, v), _w84(p, q, v)
    return 0.5 * np.einsum("...i,ij,...j->...", w1, I1, w1) + 0.5 * np.einsum("...i,ij,...j->...", w2, I2, w2)


VARIANTS = (
    Implicit(
        name="implicit (85)-(86)",
        notes_equations=("85", "86"),
        residual=_eq85_86,
        row_scale=lambda p: np.ones(2),
        note="Printed undivided (row scale 1). T_frict is viscous friction k times the rate, k = kpsi, ktheta "
             "(MJCF joint damping); T_motor is the input tau.",
    ),
    Explicit(
        name="explicit (87)-(88)",
        notes_equations=("87", "88"),
        acceleration=_eq87_88,
        note="T_frict is viscous friction k times the rate, k = kpsi, ktheta (MJCF joint damping); T_motor is "
             "the input tau. (88)'s 'T_el. motor.' read as T_el. motor.",
    ),
    Explicit(
        name="matlab double_gimbal_state_space_model",
        notes_equations=("matlab:double_gimbal_state_space_model",),
        acceleration=_matlab_double_gimbal_state_space_model,
        kind="matlab",
        printed_parameters={"I1zz": 1e-3, "I2xx": 10e-3, "I2yy": 9e-3, "I2zz": 5e-3, "kpsi": 0.01, "ktheta": 0.01},
        note="The function has no input: it ignores tau. The print shows 11zz, 12xx, 12yy, 12zz, read as I1zz, "
             "I2xx, I2yy, I2zz; dydt(3)'s difference is transcribed as printed, (I2xx-I2yy). The repeated "
             "lines kpsi = 0.01 and dydt(2) = dthetadt are harmless.",
    ),
    DerivationStep(
        name="R_1^0 (78)", notes_equations=("78",), quantity=("rotation", "outer"), evaluate=_r78,
    ),
    DerivationStep(
        name="R_2^1 (79)", notes_equations=("79",), quantity=("axis_rotation", (0.0, 1.0, 0.0)), evaluate=_r79,
        angle_index=1,
        note="The inner gimbal's frame in the outer gimbal's frame, the rotation by theta about the outer y axis "
             "(in the MJCF the inner body has no rotation of its own and its hinge axis is y).",
    ),
    DerivationStep(
        name="R_2^0 (80)", notes_equations=("80",), quantity=("rotation", "inner"), evaluate=_r80,
    ),
    DerivationStep(
        name="R_x (53)", notes_equations=("53",), quantity=("axis_rotation", (1.0, 0.0, 0.0)), evaluate=_r53,
        angle_index=0,
        note="The notes' generic angle phi, evaluated at the gimbal's first coordinate (any angle would do).",
    ),
    DerivationStep(
        name="R_y (54)", notes_equations=("54",), quantity=("axis_rotation", (0.0, 1.0, 0.0)), evaluate=_r54,
        angle_index=1,
    ),
    DerivationStep(
        name="omega_01^1 (82)", notes_equations=("82",), quantity=("angular_velocity_body", "outer"), evaluate=_w82,
    ),
    DerivationStep(
        name="omega_02^2 (84)", notes_equations=("84",), quantity=("angular_velocity_body", "inner"), evaluate=_w84,
        note="R_2^1 of (79).",
    ),
    DerivationStep(
        name="kinetic energy (81)", notes_equations=("81",), quantity=("kinetic_energy", None), evaluate=_t81,
        note="The last member, with omega_01^1 of (82), omega_02^2 of (84), I_2^2 = diag(I2xx, I2yy, I2zz) and "
             "only I1zz of I_1^1 (omega_01^1 is along z). The middle member's T_rot 1 + T_rot 1 is a label.",
    ),
)

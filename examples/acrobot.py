"""Spong's acrobot with Drake's parameters: a double pendulum driven at the elbow only.

Symbols (all read from examples/acrobot.xml; the values are Drake's AcrobotParameters defaults,
drake/multibody/benchmarks/acrobot/make_acrobot_plant.h, after Spong 1994):

    m1, m2     link masses, kg                                           (Drake: 1, 1)
    l1         length of link 1 = shoulder to elbow, m                   (Drake: 1)
    lc1, lc2   distance from each link's joint to its centre of mass, m  (Drake: 0.5, 1)
    Ic1, Ic2   moment of inertia of each link about its centre of mass, about the hinge axis
               (body y), kg m^2                                          (Drake: 0.083, 0.33)
    b1, b2     viscous damping of the shoulder and elbow, N m s/rad      (Drake: 0.1, 0.1)
    g          gravitational acceleration, m/s^2 (MJCF gravity is (0, 0, -g))  (Drake: 9.81)

Drake's l2 = 2 enters only through lc2 = 1: nothing hangs from link 2's end, so it is not a
parameter here (the MJCF draws link 2 two metres long).

Coordinates, as in Drake's MultibodyPlant acrobot: the chain moves in the world x-z plane, both
hinges turn about +y, gravity is along -z. theta1 (joint "shoulder") is link 1's angle from the
downward vertical, theta2 (joint "elbow") link 2's angle relative to link 1; both are positive
about +y, which swings a link's lower end towards -x. So the centre of mass of link 1 is at
lc1 (-sin th1, 0, -cos th1), and R_1^0 = R_y(th1), R_2^0 = R_y(th1 + th2) (notes, section 3).

Inputs: tau = (tau1, tau2). tau2 is the elbow motor's torque (MJCF motor "elbow_motor", gear 1).
The shoulder is unactuated: tau1 is an applied shoulder torque that the harness leaves at zero; it
is kept so that tau has one entry per coordinate, as the contract wants.

Form (c) of the contract: explicit accelerations qacc(p, q, v, tau). The 2x2 system
M a = tau - b v - C v - G is solved in closed form by hand, as the notes' eqs 35-36 do for the
point-mass pendulum; mass_matrix and bias are not defined. The viscous damping -(b1 th1', b2 th2')
is inside qacc (there is no separate `passive`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from lagrange_xval.forms import NAN, body, hinge, rot_y, stack_vector

DESCRIPTION = (
    "Spong's acrobot with Drake's benchmark parameters (m1 = m2 = 1, l1 = 1, lc1 = 0.5, lc2 = 1, "
    "Ic1 = 0.083, Ic2 = 0.33, b1 = b2 = 0.1): a double pendulum in the x-z plane, hinges about y, "
    "gravity along -z, a motor at the elbow only; explicit accelerations solved by hand."
)
COORDINATES = ("theta1", "theta2")
JOINTS = ("shoulder", "elbow")
BODIES = ("link1", "link2")
# Not from the notes (they have no acrobot): released at rest from a bent pose, both links raised.
INITIAL_STATE = ((1.0, 1.0), (0.0, 0.0))
VARIANTS = ()


@dataclass(frozen=True)
class Params:
    m1: float  # kg
    m2: float  # kg
    l1: float  # m
    lc1: float  # m
    lc2: float  # m
    Ic1: float  # kg m^2
    Ic2: float  # kg m^2
    b1: float  # N m s/rad
    b2: float  # N m s/rad
    g: float  # m/s^2


def parameters(model: Any) -> Params:
    """Reads the parameters from the compiled MJCF (see validate/model/modelview.py for the keys)."""
    return Params(
        m1=float(model["body/link1/mass"]),
        m2=float(model["body/link2/mass"]),
        l1=float(-model["body/link2/pos"][2]),
        lc1=float(-model["body/link1/com"][2]),
        lc2=float(-model["body/link2/com"][2]),
        Ic1=float(model["body/link1/inertia"][1, 1]),
        Ic2=float(model["body/link2/inertia"][1, 1]),
        b1=float(model["joint/shoulder/damping"]),
        b2=float(model["joint/elbow/damping"]),
        g=float(-model["gravity"][2]),
    )


def _about_y(iyy: float) -> np.ndarray:
    # A body turning about y only: just Iyy matters, and no product couples y to x or z.
    return np.array([[NAN, 0.0, NAN], [0.0, iyy, 0.0], [NAN, 0.0, NAN]])


def assumptions(p: Params) -> dict[str, Any]:
    """The compiled model this derivation describes: a chain in the x-z plane hanging along -z,
    hinges about +y, viscous damping on both, one gear-1 motor on the elbow."""
    return {
        "gravity": np.array([0.0, 0.0, -p.g]),
        **body("link1", parent="world", mass=p.m1, com=(0, 0, -p.lc1), inertia=_about_y(p.Ic1)),
        **body("link2", parent="link1", mass=p.m2, com=(0, 0, -p.lc2), inertia=_about_y(p.Ic2), pos=(0, 0, -p.l1)),
        **hinge("shoulder", body="link1", axis=(0, 1, 0), damping=p.b1),
        **hinge("elbow", body="link2", axis=(0, 1, 0), damping=p.b2),
        "actuator/elbow_motor/joint": "elbow",
        # tau is the generalized force: the harness sends ctrl = tau / gear, so any gear would do.
        "actuator/elbow_motor/gear": NAN,
    }


def _inertia_terms(p: Params, q: np.ndarray) -> tuple[Any, Any, np.ndarray]:
    """(A, B, K) with M = [[A + B + 2K, B + K], [B + K, B]].

    T = T1 + T2 with T_i = m_i |v_ci|^2 / 2 + Ic_i w_i^2 / 2, w1 = th1', w2 = th1' + th2'
    (the angular velocities about y, eq 72 with omega along y). v_c1 has length lc1 th1'; v_c2 is
    l1 th1' across link 1 plus lc2 (th1' + th2') across link 2, the two at angle th2:
      A = Ic1 + m1 lc1^2 + m2 l1^2,  B = Ic2 + m2 lc2^2,  K = m2 l1 lc2 cos th2.
    """
    A = p.Ic1 + p.m1 * p.lc1**2 + p.m2 * p.l1**2
    B = p.Ic2 + p.m2 * p.lc2**2
    K = p.m2 * p.l1 * p.lc2 * np.cos(q[..., 1])
    return A, B, K


def qacc(p: Params, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """th'' from M th'' = f, f = tau - (b1 th1', b2 th2') - C th' - G, solved by hand (Cramer).

    With H = m2 l1 lc2 sin th2 and V as in potential_energy:
      C th' = (-H (2 th1' th2' + th2'^2), H th1'^2),
      G = dV/dq = ((m1 lc1 + m2 l1) g sin th1 + m2 lc2 g sin(th1 + th2), m2 lc2 g sin(th1 + th2)),
      det M = (A + B + 2K) B - (B + K)^2 = A B - K^2,
      th1'' = (B f1 - (B + K) f2) / det M,   th2'' = ((A + B + 2K) f2 - (B + K) f1) / det M.
    """
    A, B, K = _inertia_terms(p, q)
    th1, th2 = q[..., 0], q[..., 1]
    w1, w2 = v[..., 0], v[..., 1]
    H = p.m2 * p.l1 * p.lc2 * np.sin(th2)
    s12 = np.sin(th1 + th2)
    G1 = (p.m1 * p.lc1 + p.m2 * p.l1) * p.g * np.sin(th1) + p.m2 * p.lc2 * p.g * s12
    G2 = p.m2 * p.lc2 * p.g * s12
    f1 = tau[..., 0] - p.b1 * w1 + H * (2 * w1 * w2 + w2**2) - G1
    f2 = tau[..., 1] - p.b2 * w2 - H * w1**2 - G2
    det = A * B - K**2
    return stack_vector([(B * f1 - (B + K) * f2) / det, ((A + B + 2 * K) * f2 - (B + K) * f1) / det])


def kinetic_energy(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """T = ((A + B + 2K) th1'^2 + 2 (B + K) th1' th2' + B th2'^2) / 2."""
    A, B, K = _inertia_terms(p, q)
    w1, w2 = v[..., 0], v[..., 1]
    return 0.5 * ((A + B + 2 * K) * w1**2 + 2 * (B + K) * w1 * w2 + B * w2**2)


def potential_energy(p: Params, q: np.ndarray) -> np.ndarray:
    """V = -(m1 lc1 + m2 l1) g cos th1 - m2 lc2 g cos(th1 + th2), zero at the shoulder's height."""
    th1, th2 = q[..., 0], q[..., 1]
    return -(p.m1 * p.lc1 + p.m2 * p.l1) * p.g * np.cos(th1) - p.m2 * p.lc2 * p.g * np.cos(th1 + th2)


def body_positions(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """The links' centres of mass: R_y(angle) (0, 0, -length) = length (-sin, 0, -cos)."""
    th1, th12 = q[..., 0], q[..., 0] + q[..., 1]
    zero = np.zeros_like(th1)
    u1 = stack_vector([-np.sin(th1), zero, -np.cos(th1)])
    u2 = stack_vector([-np.sin(th12), zero, -np.cos(th12)])
    return {"link1": p.lc1 * u1, "link2": p.l1 * u1 + p.lc2 * u2}


def body_rotations(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """R_1^0 = R_y(th1), R_2^0 = R_y(th1) R_y(th2) = R_y(th1 + th2)."""
    return {"link1": rot_y(q[..., 0]), "link2": rot_y(q[..., 0] + q[..., 1])}

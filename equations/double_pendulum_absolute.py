"""DRAFT (needs a coordinate map in the harness). Double pendulum with massless rods and point-mass
bobs, both angles from the downward vertical (notes section 1: "the alternative model where the
angle characterizing the second bob is defined as a deviation from the vertical direction").

Symbols (all read from models/double_pendulum_absolute.xml, the same system as double_pendulum_point):

    m1, m2   bob masses, kg                    (m = m1 = m2 = 1)
    l1, l2   rod lengths, m                    (l = l1 = l2 = 1)
    g        gravitational acceleration, m/s^2 (9.81; MJCF gravity is (0, -g, 0))
    I1, I2   the bobs' rotational inertia about z, kg m^2 (1e-14 each, kept exactly: bob i's frame
             turns with rod i, so T gains I1 th1'^2/2 + I2 th2'^2/2)

Coordinates: x to the right, y up, z out of the plane. theta1 and theta2 are the rods' angles from
the downward vertical, positive counter-clockwise about +z. Bob 1 is at l1 (sin th1, -cos th1),
bob 2 at bob 1 + l2 (sin th2, -cos th2).

MJCF hinges measure angles relative to the parent body, so no MJCF tree with two hinges measures
theta2 directly: the model is the relative chain of double_pendulum_point with joints theta1 and
phi, and q = JOINT_MAP @ (theta1, phi), i.e. theta2 = theta1 + phi.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from lagrange_xval.forms import Implicit, body, hinge, planar_inertia, rot_z, stack_matrix, stack_vector

DESCRIPTION = (
    "Two bobs on massless rods, both angles measured from the downward vertical "
    "(notes section 1, the alternative model; Weisstein's equations)."
)
COORDINATES = ("theta1", "theta2")
JOINTS = ("theta1", "phi")
# q_notes = JOINT_MAP @ (joint angles): the MJCF's second hinge measures phi, relative to link 1.
JOINT_MAP = np.array([[1.0, 0.0], [1.0, 1.0]])
# The same physical system as double_pendulum_point (theta1 = theta, theta2 = theta + phi).
SAME_SYSTEM_AS = "double_pendulum_point"
# The notes' experiment in these coordinates: theta = 0, phi = 3 is theta1 = 0, theta2 = 3.
INITIAL_STATE = ((0.0, 3.0), (0.0, 0.0))
NOTES_EXPERIMENT = "section 1's start, theta = 0, phi = 3, in absolute angles"
BODIES = ("link1", "link2")


@dataclass(frozen=True)
class Params:
    m1: float  # kg
    m2: float  # kg
    l1: float  # m
    l2: float  # m
    g: float  # m/s^2
    I1: float  # kg m^2
    I2: float  # kg m^2


def parameters(model: Any) -> Params:
    """Reads the parameters from the compiled MJCF (see validate/model/modelview.py for the keys)."""
    return Params(
        m1=model["body/link1/mass"],
        m2=model["body/link2/mass"],
        l1=-model["body/link2/pos"][1],
        l2=-model["body/link2/com"][1],
        g=-model["gravity"][1],
        I1=model["body/link1/inertia"][2, 2],
        I2=model["body/link2/inertia"][2, 2],
    )


def assumptions(p: Params) -> dict[str, Any]:
    """The compiled model this derivation describes: planar chain hanging along -y, hinges about +z."""
    return {
        "gravity": np.array([0.0, -p.g, 0.0]),
        **body("link1", parent="world", mass=p.m1, com=(0, -p.l1, 0), inertia=planar_inertia(p.I1)),
        **body("link2", parent="link1", mass=p.m2, com=(0, -p.l2, 0), inertia=planar_inertia(p.I2), pos=(0, -p.l1, 0)),
        **hinge("theta1", body="link1", axis=(0, 0, 1)),
        **hinge("phi", body="link2", axis=(0, 0, 1)),
    }


def mass_matrix(p: Params, q: np.ndarray) -> np.ndarray:
    """M(q) from T = (m1 + m2) l1^2 th1'^2/2 + m2 l2^2 th2'^2/2 + m2 l1 l2 th1' th2' cos(th1 - th2) + bob inertias."""
    c = np.cos(q[..., 0] - q[..., 1])
    m12 = p.m2 * p.l1 * p.l2 * c
    return stack_matrix([[(p.m1 + p.m2) * p.l1**2 + p.I1 + 0 * c, m12], [m12, p.m2 * p.l2**2 + p.I2 + 0 * c]])


def gravity(p: Params, q: np.ndarray) -> np.ndarray:
    """G(q) = dV/dq with V = -(m1 + m2) g l1 cos th1 - m2 g l2 cos th2."""
    return stack_vector([(p.m1 + p.m2) * p.g * p.l1 * np.sin(q[..., 0]), p.m2 * p.g * p.l2 * np.sin(q[..., 1])])


def bias(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """C(q, v) v + G(q); with h = m2 l1 l2 sin(th1 - th2), C v = (h th2'^2, -h th1'^2)."""
    h = p.m2 * p.l1 * p.l2 * np.sin(q[..., 0] - q[..., 1])
    return stack_vector([h * v[..., 1] ** 2, -h * v[..., 0] ** 2]) + gravity(p, q)


def passive(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """No joint friction in this system."""
    return np.zeros(np.broadcast_shapes(np.shape(q), np.shape(v)))


def kinetic_energy(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """T = v^T M v / 2."""
    return 0.5 * np.einsum("...i,...ij,...j->...", v, mass_matrix(p, q), v)


def potential_energy(p: Params, q: np.ndarray) -> np.ndarray:
    """V = -(m1 + m2) g l1 cos th1 - m2 g l2 cos th2, zero at the pivot's height."""
    return -(p.m1 + p.m2) * p.g * p.l1 * np.cos(q[..., 0]) - p.m2 * p.g * p.l2 * np.cos(q[..., 1])


def body_positions(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """The bobs (the bodies' centres of mass)."""
    th1, th2 = q[..., 0], q[..., 1]
    zero = np.zeros_like(th1)
    b1 = stack_vector([p.l1 * np.sin(th1), -p.l1 * np.cos(th1), zero])
    return {"link1": b1, "link2": b1 + stack_vector([p.l2 * np.sin(th2), -p.l2 * np.cos(th2), zero])}


def body_rotations(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """Each link's frame turns about z by its rod's angle."""
    return {"link1": rot_z(q[..., 0]), "link2": rot_z(q[..., 1])}


# ---------------------------------------------------------------------------------------------
# The absolute-angle equations the notes point to (Eric Weisstein's World of Physics), as given.


def _weisstein(p: Params, q: np.ndarray, v: np.ndarray, a: np.ndarray, tau: np.ndarray) -> np.ndarray:
    th1, th2 = q[..., 0], q[..., 1]
    dth1, dth2 = v[..., 0], v[..., 1]
    ddth1, ddth2 = a[..., 0], a[..., 1]
    m1, m2, l1, l2, g = p.m1, p.m2, p.l1, p.l2, p.g
    r1 = ((m1 + m2) * l1 * ddth1 + m2 * l2 * ddth2 * np.cos(th1 - th2) + m2 * l2 * dth2**2 * np.sin(th1 - th2)
          + (m1 + m2) * g * np.sin(th1))
    r2 = (m2 * l2 * ddth2 + m2 * l1 * ddth1 * np.cos(th1 - th2) - m2 * l1 * dth1**2 * np.sin(th1 - th2)
          + m2 * g * np.sin(th2))
    return stack_vector([r1, r2])


VARIANTS = (
    Implicit(
        name="Weisstein absolute-angle equations",
        notes_equations=("weisstein",),
        residual=_weisstein,
        row_scale=lambda p: np.array([1 / p.l1, 1 / p.l2]),
        note="Not printed in the notes, which point to scienceworld.wolfram.com/physics/DoublePendulum.html; "
             "the first equation is the theta1 Lagrange equation divided by l1, the second the theta2 one "
             "divided by l2.",
    ),
)

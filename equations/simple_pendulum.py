"""Simple pendulum: one point-mass bob on a massless rod (the building block of notes section 1).

Symbols (all read from models/simple_pendulum.xml):

    m   bob mass, kg                          (as the notes' bobs: 1)
    l   rod length, m                         (as the notes' rods: 1)
    g   gravitational acceleration, m/s^2     (9.81; MJCF gravity is (0, -g, 0))
    I   the bob's rotational inertia about z, kg m^2. The bob is a point; MuJoCo refuses a moving
        body without rotational inertia, so the MJCF gives it 1e-14. This derivation keeps it
        exactly (T gains I th'^2 / 2).

Coordinates (as the notes' eqs 7-8 for the first bob): x to the right, y up, z out of the plane.
theta is the rod's angle from the downward vertical, positive counter-clockwise about +z; the bob
is at l (sin th, -cos th).

The notes print no form specific to a single bob. Their first-bob forms (7)-(8), (11)-(12), (16)
and (20) describe this bob too; they are checked with the double pendulum
(equations/double_pendulum_point.py), not again here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from lagrange_xval.forms import body, hinge, planar_inertia, rot_z, stack_matrix, stack_vector

DESCRIPTION = (
    "One bob on a massless rod, the angle measured from the downward vertical "
    "(the building block of notes section 1; no printed form of its own)."
)
COORDINATES = ("theta",)
JOINTS = ("theta",)
BODIES = ("link",)
# A large swing (no experiment in the notes for the single bob): 2 rad, at rest.
INITIAL_STATE = ((2.0,), (0.0,))


@dataclass(frozen=True)
class Params:
    m: float  # kg
    l: float  # m  # noqa: E741 - the notes' symbol
    g: float  # m/s^2
    I: float  # kg m^2  # noqa: E741 - the notes' symbol


def parameters(model: Any) -> Params:
    """Reads the parameters from the compiled MJCF (see validate/model/modelview.py for the keys)."""
    return Params(
        m=model["body/link/mass"],
        l=-model["body/link/com"][1],
        g=-model["gravity"][1],
        I=model["body/link/inertia"][2, 2],
    )


def assumptions(p: Params) -> dict[str, Any]:
    """The compiled model this derivation describes: one body hanging along -y, hinge about +z."""
    return {
        "gravity": np.array([0.0, -p.g, 0.0]),
        **body("link", parent="world", mass=p.m, com=(0, -p.l, 0), inertia=planar_inertia(p.I)),
        **hinge("theta", body="link", axis=(0, 0, 1)),
    }


def mass_matrix(p: Params, q: np.ndarray) -> np.ndarray:
    """M = m l^2 + I, from T = (m l^2 + I) th'^2 / 2."""
    return stack_matrix([[p.m * p.l**2 + p.I + np.zeros(np.shape(q)[:-1])]])


def bias(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """G(q) = dV/dth = m g l sin th; one coordinate has no Coriolis or centrifugal term."""
    g = p.m * p.g * p.l * np.sin(q[..., 0])
    return stack_vector([g + np.zeros(np.shape(v)[:-1])])


def passive(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """No joint friction in this system."""
    return np.zeros(np.broadcast_shapes(np.shape(q), np.shape(v)))


def kinetic_energy(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """T = (m l^2 + I) th'^2 / 2."""
    return 0.5 * np.einsum("...i,...ij,...j->...", v, mass_matrix(p, q), v)


def potential_energy(p: Params, q: np.ndarray) -> np.ndarray:
    """V = -m g l cos th, zero at the pivot's height."""
    return -p.m * p.g * p.l * np.cos(q[..., 0])


def body_positions(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """The bob (the body's centre of mass)."""
    th = q[..., 0]
    return {"link": stack_vector([p.l * np.sin(th), -p.l * np.cos(th), np.zeros_like(th)])}


def body_rotations(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """The link's frame turns about z by theta."""
    return {"link": rot_z(q[..., 0])}


VARIANTS = ()

"""Double pendulum with massless rods and point-mass bobs, relative angles (notes, section 1).

Symbols (all read from models/double_pendulum_point.xml):

    m1, m2   bob masses, kg                    (the notes: m = m1 = m2 = 1)
    l1, l2   rod lengths, m                    (the notes: l = l1 = l2 = 1)
    g        gravitational acceleration, m/s^2 (the notes: 9.81; MJCF gravity is (0, -g, 0))
    I1, I2   the bobs' rotational inertia about z, kg m^2. The notes' bobs are points; MuJoCo
             refuses a moving body without rotational inertia, so the MJCF gives each bob 1e-14.
             This derivation keeps them exactly (T gains I1 th'^2/2 + I2 (th' + ph')^2/2); the
             printed forms of the notes omit them, an error of 1e-14 relative in M.

Coordinates (the notes' Fig. 1 and eqs 7-10): x to the right, y up, z out of the plane.
theta is the first rod's angle from the downward vertical, positive counter-clockwise about +z;
phi is the second rod's angle relative to the first. Bob 1 is at l1 (sin th, -cos th).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from lagrange_xval.forms import (
    DerivationStep,
    Explicit,
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
    "Two bobs on massless rods, the second angle measured relative to the first rod "
    "(notes section 1, eqs 1-36)."
)
COORDINATES = ("theta", "phi")
JOINTS = ("theta", "phi")
BODIES = ("link1", "link2")
# The notes' experiment: ode45 from theta = 0, phi = 3, at rest ([0, 3, 0, 0]).
INITIAL_STATE = ((0.0, 3.0), (0.0, 0.0))
NOTES_EXPERIMENT = "section 1: ode45 from theta = 0, phi = 3 and from phi = 3.01, Figs 3-4"
NOTES_SEPARATION = 7.0  # s: "after about 7 s" the two responses stop resembling each other (read by eye)

# The notes' printed forms assume one mass and one length (m = m1 = m2, l = l1 = l2): their probes
# keep these equalities while every other parameter moves (validate/verdict/probes.py).
PRINTED_FORMS_ASSUME = ({"m1": 1.0, "m2": 1.0}, {"l1": 1.0, "l2": 1.0})


@dataclass(frozen=True)
class Params:
    m1: float  # kg
    m2: float  # kg
    l1: float  # m
    l2: float  # m
    g: float  # m/s^2
    I1: float  # kg m^2
    I2: float  # kg m^2

    @property
    def m(self) -> float:
        """The notes' single mass m; their printed forms need m1 == m2."""
        return common("m", m1=self.m1, m2=self.m2)

    @property
    def l(self) -> float:  # noqa: E743 - the notes' symbol
        """The notes' single length l; their printed forms need l1 == l2."""
        return common("l", l1=self.l1, l2=self.l2)


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
        **hinge("theta", body="link1", axis=(0, 0, 1)),
        **hinge("phi", body="link2", axis=(0, 0, 1)),
    }


def mass_matrix(p: Params, q: np.ndarray) -> np.ndarray:
    """M(q) from T of eq (19), generalised to m1, m2, l1, l2 and the bobs' inertia."""
    c = np.cos(q[..., 1])
    m12 = p.m2 * (p.l2**2 + p.l1 * p.l2 * c) + p.I2
    m11 = p.m1 * p.l1**2 + p.m2 * (p.l1**2 + p.l2**2 + 2 * p.l1 * p.l2 * c) + p.I1 + p.I2
    return stack_matrix([[m11, m12], [m12, p.m2 * p.l2**2 + p.I2]])


def gravity(p: Params, q: np.ndarray) -> np.ndarray:
    """G(q) = dV/dq with V of eq (22)."""
    s1, s12 = np.sin(q[..., 0]), np.sin(q[..., 0] + q[..., 1])
    return stack_vector([(p.m1 + p.m2) * p.g * p.l1 * s1 + p.m2 * p.g * p.l2 * s12, p.m2 * p.g * p.l2 * s12])


def bias(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """C(q, v) v + G(q); the velocity terms are those of eqs (33)-(34) times m l^2."""
    h = p.m2 * p.l1 * p.l2 * np.sin(q[..., 1])
    w1, w2 = v[..., 0], v[..., 1]
    return stack_vector([-h * (2 * w1 * w2 + w2**2), h * w1**2]) + gravity(p, q)


def passive(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """No joint friction in this system."""
    return np.zeros(np.broadcast_shapes(np.shape(q), np.shape(v)))


def kinetic_energy(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """T = v^T M v / 2 (eq 19 plus the bobs' tiny rotational energy)."""
    return 0.5 * np.einsum("...i,...ij,...j->...", v, mass_matrix(p, q), v)


def potential_energy(p: Params, q: np.ndarray) -> np.ndarray:
    """V of eq (22), zero at the pivot's height."""
    th, ph = q[..., 0], q[..., 1]
    return -(p.m1 + p.m2) * p.g * p.l1 * np.cos(th) - p.m2 * p.g * p.l2 * np.cos(th + ph)


def body_positions(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """The bobs (the bodies' centres of mass), eqs (7)-(10)."""
    th, ph = q[..., 0], q[..., 1]
    zero = np.zeros_like(th)
    b1 = stack_vector([p.l1 * np.sin(th), -p.l1 * np.cos(th), zero])
    return {"link1": b1, "link2": b1 + stack_vector([p.l2 * np.sin(th + ph), -p.l2 * np.cos(th + ph), zero])}


def body_rotations(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """Each link's frame turns about z by its absolute angle."""
    return {"link1": rot_z(q[..., 0]), "link2": rot_z(q[..., 0] + q[..., 1])}


# ---------------------------------------------------------------------------------------------
# The notes' printed forms, transcribed as printed (m = m1 = m2 and l = l1 = l2 as in the notes).


def _eq33_34(p: Params, q: np.ndarray, v: np.ndarray, a: np.ndarray, tau: np.ndarray) -> np.ndarray:
    # Eq (34) prints g/I; the only g/l-shaped symbol in the section is l, so g/I is read as g/l.
    th, ph = q[..., 0], q[..., 1]
    dth, dph = v[..., 0], v[..., 1]
    ddth, ddph = a[..., 0], a[..., 1]
    g, l = p.g, p.l
    r33 = ((3 + 2 * np.cos(ph)) * ddth + (1 + np.cos(ph)) * ddph - 2 * np.sin(ph) * dph * dth
           - np.sin(ph) * dph**2 + 2 * g / l * np.sin(th) + g / l * np.sin(th + ph))
    r34 = (1 + np.cos(ph)) * ddth + ddph + dth**2 * np.sin(ph) + g / l * np.sin(th + ph)
    return stack_vector([r33, r34])


def _bracket(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    # The square bracket shared by eqs (35) and (36).
    th, ph = q[..., 0], q[..., 1]
    dth, dph = v[..., 0], v[..., 1]
    g, l = p.g, p.l
    return (np.sin(ph) * (2 + np.cos(ph)) * dph**2 + g / l * np.cos(ph) * np.sin(th + ph)
            + 2 * np.sin(ph) * dth * dph - 2 * g / l * np.sin(th))


def _eq35_36(p: Params, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
    th, ph = q[..., 0], q[..., 1]
    dth = v[..., 0]
    g, l = p.g, p.l
    b = _bracket(p, q, v)
    ddth = 1 / (2 - np.cos(ph) ** 2) * b
    ddph = -(1 + np.cos(ph)) / (2 - np.cos(ph) ** 2) * b - np.sin(ph) * dth**2 - g / l * np.sin(th + ph)
    return stack_vector([ddth, ddph])


def _matlab_double_bob_pendulum(p: Params, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
    # dydt(3) and dydt(4) of the printed m-function. The print drops the closing parenthesis of
    # dydt(3)'s bracket; it is closed before the semicolon, matching dydt(4).
    theta, phi = q[..., 0], q[..., 1]
    dthetadt, dphidt = v[..., 0], v[..., 1]
    g, l = p.g, p.l
    bracket = ((2 + np.cos(phi)) * np.sin(phi) * dphidt**2 + np.cos(phi) * g / l * np.sin(theta + phi)
               + 2 * np.sin(phi) * dphidt * dthetadt - 2 * g / l * np.sin(theta))
    dydt3 = 1 / (2 + (np.cos(phi)) ** 2) * bracket
    dydt4 = (-(1 + np.cos(phi)) / (2 + (np.cos(phi)) ** 2) * bracket
             - np.sin(phi) * dthetadt**2 - g / l * np.sin(phi + theta))
    return stack_vector([dydt3, dydt4])


def _xy(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return stack_vector([x, y, np.zeros_like(x)])


VARIANTS = (
    Implicit(
        name="implicit (33)-(34)",
        notes_equations=("33", "34"),
        residual=_eq33_34,
        row_scale=lambda p: np.full(2, 1 / (p.m * p.l**2)),
        note="Both equations are printed divided by m l^2. Eq (34) prints g/I, read as g/l.",
    ),
    Explicit(name="explicit (35)-(36)", notes_equations=("35", "36"), acceleration=_eq35_36),
    Explicit(
        name="matlab double_bob_pendulum",
        notes_equations=("matlab:double_bob_pendulum",),
        acceleration=_matlab_double_bob_pendulum,
        kind="matlab",
        printed_parameters={"g": 9.81, "l1": 1.0, "l2": 1.0, "m1": 1.0, "m2": 1.0},
        note="The printed dydt(3) lacks a closing parenthesis; it is closed before the semicolon.",
    ),
    DerivationStep(
        name="bob 1 position (7)-(8)", notes_equations=("7", "8"), quantity=("com_position", "link1"),
        evaluate=lambda p, q, v: _xy(np.sin(q[..., 0]) * p.l, -np.cos(q[..., 0]) * p.l),
    ),
    DerivationStep(
        name="bob 2 position (9)-(10)", notes_equations=("9", "10"), quantity=("com_position", "link2"),
        evaluate=lambda p, q, v: _xy(np.sin(q[..., 0]) + np.sin(q[..., 0] + q[..., 1]) * p.l,
                                     -np.cos(q[..., 0]) * p.l - np.cos(q[..., 0] + q[..., 1]) * p.l),
        note="Transcribed from the last member of each printed chain (eq 9 prints sin(theta) without l).",
    ),
    DerivationStep(
        name="bob 1 velocity (11)-(12)", notes_equations=("11", "12"), quantity=("com_velocity", "link1"),
        evaluate=lambda p, q, v: _xy(np.cos(q[..., 0]) * v[..., 0] * p.l, np.sin(q[..., 0]) * v[..., 0] * p.l),
    ),
    DerivationStep(
        name="bob 2 velocity (13)-(14)", notes_equations=("13", "14"), quantity=("com_velocity", "link2"),
        evaluate=lambda p, q, v: _xy(
            np.cos(q[..., 0]) * v[..., 0] * p.l + np.cos(q[..., 0] + q[..., 1]) * (v[..., 0] + v[..., 0]) * p.l,
            np.sin(q[..., 0]) * v[..., 0] * p.l + np.sin(q[..., 0] + q[..., 1]) * (v[..., 0] + v[..., 1]) * p.l),
        note="Eq (13) prints (theta' + theta') in its second term; transcribed as printed.",
    ),
    DerivationStep(
        name="bob 1 kinetic energy (16)", notes_equations=("15", "16"), quantity=("kinetic_energy", "link1"),
        evaluate=lambda p, q, v: 0.5 * p.m * p.l**2 * v[..., 0] ** 2,
    ),
    DerivationStep(
        name="bob 2 squared speed (17)", notes_equations=("17",), quantity=("com_speed_squared", "link2"),
        evaluate=lambda p, q, v: ((2 * p.l**2 + 2 * p.l**2 * np.cos(q[..., 1])) * v[..., 0] ** 2
                                  + (2 * p.l**2 + 2 * p.l**2 * np.cos(q[..., 1])) * v[..., 0] * v[..., 1]
                                  + p.l**2 * v[..., 1] ** 2),
    ),
    DerivationStep(
        name="bob 2 kinetic energy (18)", notes_equations=("18",), quantity=("kinetic_energy", "link2"),
        evaluate=lambda p, q, v: (p.m * p.l**2 * (1 + np.cos(q[..., 1])) * v[..., 0] ** 2
                                  + p.m * p.l**2 * (1 + np.cos(q[..., 1])) * v[..., 0] * v[..., 1]
                                  + 0.5 * p.m * p.l**2 * v[..., 1] ** 2),
    ),
    DerivationStep(
        name="kinetic energy (19)", notes_equations=("19",), quantity=("kinetic_energy", None),
        evaluate=lambda p, q, v: (p.m * p.l**2 * (1.5 + np.cos(q[..., 1])) * v[..., 0] ** 2
                                  + p.m * p.l**2 * (1 + np.cos(q[..., 1])) * v[..., 0] * v[..., 1]
                                  + 0.5 * p.m * p.l**2 * v[..., 1] ** 2),
    ),
    DerivationStep(
        name="bob 1 potential energy (20)", notes_equations=("20",), quantity=("potential_energy", "link1"),
        evaluate=lambda p, q, v: -p.m * p.g * p.l * np.cos(q[..., 0]),
    ),
    DerivationStep(
        name="bob 2 potential energy (21)", notes_equations=("21",), quantity=("potential_energy", "link2"),
        evaluate=lambda p, q, v: -p.m * p.g * p.l * np.cos(q[..., 0]) - p.m * p.g * p.l * np.cos(q[..., 0] + q[..., 1]),
    ),
    DerivationStep(
        name="potential energy (22)", notes_equations=("22",), quantity=("potential_energy", None),
        evaluate=lambda p, q, v: (-2 * p.m * p.g * p.l * np.cos(q[..., 0])
                                  - p.m * p.g * p.l * np.cos(q[..., 0] + q[..., 1])),
    ),
)

"""Gymnasium's inverted double pendulum (`gymnasium/envs/mujoco/assets/inverted_double_pendulum.xml`),
derived by hand from its XML: a cart on a rail (slide `slider` along x) carrying two capsule poles on
hinges about y (`hinge`, then `hinge2` relative to the first pole).

Symbols (read from the compiled model: the poles' masses and inertias come from their capsules):

    m0, m1, m2      cart, first and second pole mass, kg
    c1, c2          each pole's centre of mass along its own z axis from its hinge, m
    I1, I2          each pole's central inertia about y, kg m^2
    L               the second hinge along the first pole's z axis, m
    b0, b1, b2      viscous damping of slider, hinge, hinge2, N s/m and N m s
    gx, gz          gravity's x and z components, m/s^2 (the file gives gx = 1e-5)

Coordinates q = (x, a, b): the cart's displacement along world x; a the first pole's angle from the
upright about +y (R_y(a) takes the pole's z axis to (sin a, 0, cos a)); b the second pole's angle
relative to the first. Centres of mass:

    p0 = (x, 0, 0)
    p1 = (x + c1 sin a, 0, c1 cos a)
    p2 = (x + L sin a + c2 sin(a + b), 0, L cos a + c2 cos(a + b))

T = m0 x'^2 / 2 + m1 |p1'|^2 / 2 + I1 a'^2 / 2 + m2 |p2'|^2 / 2 + I2 (a' + b')^2 / 2, so M(q) below;
V = -sum m g . p. The velocity terms come from M by the Christoffel symbols,
C(q, v) v = sum_jk (dM_ij/dq_k - dM_jk/dq_i / 2) v_j v_k, with dM/dq written out by hand.
Inputs: tau on every coordinate (the motor `slide` drives x through its gear).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

COORDINATES = ("x", "a", "b")
JOINTS = ("slider", "hinge", "hinge2")
BODIES = ()


@dataclass(frozen=True)
class Params:
    m0: float  # kg
    m1: float  # kg
    m2: float  # kg
    c1: float  # m
    c2: float  # m
    I1: float  # kg m^2
    I2: float  # kg m^2
    L: float  # m
    b0: float  # N s/m
    b1: float  # N m s
    b2: float  # N m s
    gx: float  # m/s^2
    gz: float  # m/s^2


def parameters(model: Any) -> Params:
    return Params(
        m0=model["body/cart/mass"],
        m1=model["body/pole/mass"],
        m2=model["body/pole2/mass"],
        c1=model["body/pole/com"][2],
        c2=model["body/pole2/com"][2],
        I1=model["body/pole/inertia"][1, 1],
        I2=model["body/pole2/inertia"][1, 1],
        L=model["body/pole2/pos"][2],
        b0=model["joint/slider/damping"],
        b1=model["joint/hinge/damping"],
        b2=model["joint/hinge2/damping"],
        gx=model["gravity"][0],
        gz=model["gravity"][2],
    )


def _entries(p: Params, q: np.ndarray) -> tuple[Any, ...]:
    a, b = q[..., 1], q[..., 2]
    ca, cab, cb = np.cos(a), np.cos(a + b), np.cos(b)
    one = np.ones_like(a)
    mxx = (p.m0 + p.m1 + p.m2) * one
    mxa = p.m1 * p.c1 * ca + p.m2 * (p.L * ca + p.c2 * cab)
    mxb = p.m2 * p.c2 * cab
    maa = p.m1 * p.c1**2 + p.I1 + p.m2 * (p.L**2 + p.c2**2 + 2 * p.L * p.c2 * cb) + p.I2
    mab = p.m2 * (p.c2**2 + p.L * p.c2 * cb) + p.I2
    mbb = (p.m2 * p.c2**2 + p.I2) * one
    return mxx, mxa, mxb, maa, mab, mbb


def _sym(e: tuple[Any, ...]) -> np.ndarray:
    xx, xa, xb, aa, ab, bb = e
    return np.stack([np.stack([xx, xa, xb], -1), np.stack([xa, aa, ab], -1), np.stack([xb, ab, bb], -1)], -2)


def mass_matrix(p: Params, q: np.ndarray) -> np.ndarray:
    return _sym(_entries(p, q))


def _dM(p: Params, q: np.ndarray) -> np.ndarray:
    """dM/dq_k, stacked on the last axis: (..., 3, 3, 3) with [..., i, j, k] = dM_ij/dq_k."""
    a, b = q[..., 1], q[..., 2]
    sa, sab, sb = np.sin(a), np.sin(a + b), np.sin(b)
    zero = np.zeros_like(a)
    by_x = _sym((zero,) * 6)
    by_a = _sym((zero, -p.m1 * p.c1 * sa - p.m2 * (p.L * sa + p.c2 * sab), -p.m2 * p.c2 * sab, zero, zero, zero))
    by_b = _sym(
        (zero, -p.m2 * p.c2 * sab, -p.m2 * p.c2 * sab, -2 * p.m2 * p.L * p.c2 * sb, -p.m2 * p.L * p.c2 * sb, zero)
    )
    return np.stack([by_x, by_a, by_b], -1)


def bias(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    dM = _dM(p, q)
    coriolis = np.einsum("...ijk,...j,...k->...i", dM, v, v) - 0.5 * np.einsum("...jki,...j,...k->...i", dM, v, v)
    a, b = q[..., 1], q[..., 2]
    sa, ca, sab, cab = np.sin(a), np.cos(a), np.sin(a + b), np.cos(a + b)
    gravity = np.stack(
        [
            -(p.m0 + p.m1 + p.m2) * p.gx * np.ones_like(a),
            -p.m1 * p.c1 * (p.gx * ca - p.gz * sa)
            - p.m2 * (p.gx * (p.L * ca + p.c2 * cab) - p.gz * (p.L * sa + p.c2 * sab)),
            -p.m2 * p.c2 * (p.gx * cab - p.gz * sab),
        ],
        -1,
    )
    return coriolis + gravity


def passive(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    return -np.array([p.b0, p.b1, p.b2]) * v


def kinetic_energy(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    return 0.5 * np.einsum("...i,...ij,...j->...", v, mass_matrix(p, q), v)


def potential_energy(p: Params, q: np.ndarray) -> np.ndarray:
    x, a, b = q[..., 0], q[..., 1], q[..., 2]
    p1x, p1z = x + p.c1 * np.sin(a), p.c1 * np.cos(a)
    p2x = x + p.L * np.sin(a) + p.c2 * np.sin(a + b)
    p2z = p.L * np.cos(a) + p.c2 * np.cos(a + b)
    return -(p.m0 * p.gx * x + p.m1 * (p.gx * p1x + p.gz * p1z) + p.m2 * (p.gx * p2x + p.gz * p2z))

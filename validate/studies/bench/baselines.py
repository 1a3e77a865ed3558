"""What the fast-harness ratios are measured against: the double pendulum's right-hand side written
by hand with `math` (and with a 2x2 numpy solve, for context), and the pointwise check's quantities
as the minimal calls (the equations module called directly; MuJoCo's and Pinocchio's raw loops in
sources/baselines.py). They are timing baselines, run by the bench beside the harness; tests/unit/studies/test_bench.py
holds each equal to what it stands for (the generated fast path, the equations module, the harness's
values bit for bit), as MuJoCo's rollout_test.py holds its fast path to a plain loop.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np

from ...handwritten.forms import not_provided_in
from ...sources.base import Source
from ...sources.baselines import raw_mujoco, raw_pinocchio, raw_symbolic
from ...systems import System
from ...verdict.pointwise import States


def hand_math_rhs(p: object) -> Callable[[float, np.ndarray], list[float]]:
    """double_pendulum_point's right-hand side written by hand with `math`: eqs (33)-(34) multiplied
    back by m l^2 and generalised to m1, m2, l1, l2 and the bobs' inertia I1, I2 (what
    equations/double_pendulum_point.py derives), solved for the accelerations by Cramer's rule.

        M11 = m1 l1^2 + m2 (l1^2 + l2^2 + 2 l1 l2 cos phi) + I1 + I2
        M12 = m2 (l2^2 + l1 l2 cos phi) + I2,   M22 = m2 l2^2 + I2
        r1 = m2 l1 l2 sin phi (2 th' ph' + ph'^2) - (m1 + m2) g l1 sin th - m2 g l2 sin(th + ph)
        r2 = -m2 l1 l2 sin phi th'^2 - m2 g l2 sin(th + ph)
        th'' = (M22 r1 - M12 r2) / det,  ph'' = (M11 r2 - M12 r1) / det,  det = M11 M22 - M12^2
    """
    m1, m2, l1, l2, g, i1, i2 = (float(getattr(p, k)) for k in ("m1", "m2", "l1", "l2", "g", "I1", "I2"))
    a0 = m1 * l1 * l1 + m2 * (l1 * l1 + l2 * l2) + i1 + i2
    b = m2 * l1 * l2
    m22 = m2 * l2 * l2 + i2
    g1, g2 = (m1 + m2) * g * l1, m2 * g * l2
    sin, cos = math.sin, math.cos

    def rhs(t: float, y: np.ndarray) -> list[float]:
        th, ph, w1, w2 = y
        c, s = cos(ph), sin(ph)
        m12 = m22 + b * c
        m11 = a0 + 2.0 * b * c
        h = b * s
        grav2 = g2 * sin(th + ph)
        r1 = h * (2.0 * w1 * w2 + w2 * w2) - g1 * sin(th) - grav2
        r2 = -h * w1 * w1 - grav2
        det = m11 * m22 - m12 * m12
        return [w1, w2, (m22 * r1 - m12 * r2) / det, (m11 * r2 - m12 * r1) / det]

    return rhs


def numpy_solve_rhs(p: object) -> Callable[[float, np.ndarray], np.ndarray]:
    """The same formula with a 2x2 `np.linalg.solve` per call (the issue's ~18x, for context)."""
    m1, m2, l1, l2, g, i1, i2 = (float(getattr(p, k)) for k in ("m1", "m2", "l1", "l2", "g", "I1", "I2"))
    a0 = m1 * l1 * l1 + m2 * (l1 * l1 + l2 * l2) + i1 + i2
    b, m22 = m2 * l1 * l2, m2 * l2 * l2 + i2
    g1, g2 = (m1 + m2) * g * l1, m2 * g * l2

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        th, ph, w1, w2 = y
        c, s = np.cos(ph), np.sin(ph)
        M = np.array([[a0 + 2 * b * c, m22 + b * c], [m22 + b * c, m22]])
        grav2 = g2 * np.sin(th + ph)
        r = np.array([b * s * (2 * w1 * w2 + w2 * w2) - g1 * np.sin(th) - grav2, -b * s * w1 * w1 - grav2])
        return np.concatenate([y[2:], np.linalg.solve(M, r)])

    return rhs


def raw_hand(system: System, states: States) -> dict[str, np.ndarray]:
    """The hand side of the pointwise check as the equations module's vectorised numpy formulas,
    called directly (one batched solve; tau_inverse at the computed accelerations)."""
    q, v, tau = states.q, states.v, states.tau
    eq, p = system.derivation, system.params
    M = np.asarray(eq.mass_matrix(p, q), dtype=float)
    bias = np.asarray(eq.bias(p, q, v), dtype=float)
    passive = np.asarray(eq.passive(p, q, v), dtype=float)
    qacc = np.linalg.solve(M, (tau + passive - bias)[..., None])[..., 0]
    out = {
        "M": M,
        "bias": bias,
        "passive": passive,
        "qacc": qacc,
        "tau_inverse": np.einsum("...ij,...j->...i", M, qacc) + bias - passive,
    }
    # what the module leaves out is not computed (the hand source fills NaN for T and V, as here)
    missing = set(not_provided_in(eq))
    nan = np.full(q.shape[:-1], np.nan)
    out["T"] = nan if "kinetic_energy" in missing else eq.kinetic_energy(p, q, v)
    out["V"] = nan if "potential_energy" in missing else eq.potential_energy(p, q)
    if "body_positions" not in missing:
        out["body_positions"] = eq.body_positions(p, q)
    if "body_rotations" not in missing:
        out["body_rotations"] = eq.body_rotations(p, q)
    return out


def raw_pointwise(system: System, sources: Mapping[str, Source], states: States) -> dict[str, object]:
    """What `compare.evaluate` computes, as the minimal loops (`raw_hand`, `raw_mujoco`, `raw_pinocchio`;
    the engines' inverse dynamics at the hand accelerations; `raw_symbolic` where the symbolic source
    is on). {source: {quantity: array}} (the symbolic source: its generated code's raw output)."""
    hand = raw_hand(system, states)
    out: dict[str, object] = {
        "hand": hand,
        "mujoco": raw_mujoco(system, sources["mujoco"], states, hand["qacc"]),
        "pinocchio": raw_pinocchio(system, sources["pinocchio"], states, hand["qacc"]),
    }
    if "symbolic" in sources:
        out["symbolic"] = raw_symbolic(system, sources["symbolic"], states)
    return out

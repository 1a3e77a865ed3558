"""How far each engine's free run can be trusted where there is no symbolic source (a robot's URDF,
a chain of more than SYMBOLIC_MAX_DOF joints): which engine departs from the reference, from when,
and whether that is expected.

The reference is Pinocchio's ABA integrated by DOP853 at rtol 1e-12 (estimate.aba_reference), and
it is itself checked against the same at half the tolerance: where the two part by more than the
trajectory floor (1e-6 rad), the reference says nothing more (`reference_until`). The largest
Lyapunov exponent lambda comes from Benettin's method on the same right-hand side (two runs
DELTA0 apart, renormalised every INTERVAL s; the mean log growth rate), and with it the
predictability horizon t_p = ln(TRUST / ROUNDING) / lambda: the time in which a rounding-size
difference grows to TRUST (1e-3 rad), beyond which no double-precision run is a prediction.

Each run is then trusted until the first of: its distance to the reference passing its own
threshold (max(floor, 10 x its own error estimate): estimate.py), its own error estimate passing
TRUST, the reference's own horizon, the end of the run. A run that departs from the reference by
more than TRUST while within its threshold departs as expected (its integrator's error, grown by
the chaos); one that passes its threshold does not solve the reference's equations.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from ..model.start import Start
from ..results.schema import RunTrust
from ..sources.base import OneStateSource
from . import estimate
from .integrate import Trajectory

TRUST = 1e-3  # rad: a run whose error (or error estimate) passes this is no longer a prediction
ROUNDING = 1e-12  # rad: the difference double-precision runs start from (the reference's tolerance)
DELTA0 = 1e-8  # Benettin's initial separation (state norm)
INTERVAL = 0.5  # s between renormalisations
RTOL = 1e-10  # Benettin's integrations (DOP853): the separation, not the trajectory, is measured


def first_time(t: np.ndarray, above: np.ndarray) -> float | None:
    """The first sample time where `above` holds, or None."""
    hits = np.flatnonzero(above)
    return float(t[hits[0]]) if len(hits) else None


def reference_until(ref: Trajectory, check: Trajectory) -> float:
    """The last time the reference agrees with itself at half the tolerance to the floor (t_end if always)."""
    gap = np.nan_to_num(np.abs(ref.q - check.q).max(axis=1), nan=np.inf)
    hit = first_time(ref.t, gap > estimate.FLOOR)
    return float(ref.t[-1]) if hit is None else hit


def lyapunov(source: OneStateSource, start: Start, t_end: float) -> float:
    """The largest Lyapunov exponent (1/s) by Benettin's method on the source's right-hand side."""
    f = source.rhs(start.tau)
    x = np.concatenate([start.q0, start.v0]).astype(float)
    rng = np.random.default_rng(0)
    d = rng.normal(size=x.shape)
    y = x + DELTA0 * d / np.linalg.norm(d)
    total, steps = 0.0, int(max(1, round(t_end / INTERVAL)))
    for _ in range(steps):
        x = solve_ivp(f, (0.0, INTERVAL), x, method="DOP853", rtol=RTOL, atol=RTOL).y[:, -1]
        y = solve_ivp(f, (0.0, INTERVAL), y, method="DOP853", rtol=RTOL, atol=RTOL).y[:, -1]
        gap = float(np.linalg.norm(y - x))
        if not np.isfinite(gap) or gap == 0.0:
            return float("nan")
        total += np.log(gap / DELTA0)
        y = x + (y - x) * (DELTA0 / gap)
    return total / (steps * INTERVAL)


def horizon(rate: float) -> float | None:
    """t_p = ln(TRUST / ROUNDING) / lambda (s); None where lambda is not positive (no exponential growth)."""
    return float(np.log(TRUST / ROUNDING) / rate) if np.isfinite(rate) and rate > 0 else None


def run_trust(run: dict[str, Any], t: np.ndarray, reference_limit: float) -> RunTrust:
    """Until when one run agrees with the reference, why it stops there, and whether its departure (if
    any) is expected of its integrator."""
    err = np.nan_to_num(np.asarray(run["error_vs_hand"], dtype=float), nan=np.inf)
    thr = np.asarray(run["threshold"], dtype=float)
    est = np.asarray(run.get("error_estimate", np.zeros_like(err)), dtype=float)
    limits = {
        "its distance to the reference passes its own threshold": first_time(t, err > thr),
        f"its own error estimate passes {TRUST:g} rad": first_time(t, est > TRUST),
        "the reference's own horizon (its two tolerances part)": reference_limit if reference_limit < t[-1] else None,
    }
    found = {why: at for why, at in limits.items() if at is not None}
    why, until = min(found.items(), key=lambda kv: kv[1]) if found else ("the end of the run", float(t[-1]))
    departs = first_time(t, err > TRUST)
    out: RunTrust = {"trusted_until": until, "why": why, "departs_at": departs}
    if departs is not None:
        out["expected"] = bool(err[t == departs][0] <= thr[t == departs][0])
    return out


def statement(label: str, trust: RunTrust, t_end: float) -> str:
    """One sentence per engine: how far it is trusted, and of its departure."""
    until = trust["trusted_until"]
    text = (
        f"{label}: agrees with the reference over the whole run ({t_end:g} s)"
        if until >= t_end
        else f"{label}: trusted until {until:.3g} s ({trust['why']})"
    )
    if trust.get("departs_at") is not None:
        how = (
            "as expected of its integrator (within its own error estimate, grown by the chaos)"
            if trust["expected"]
            else "beyond its own error estimate: it does not solve the reference's equations"
        )
        text += f"; departs from it by more than {TRUST:g} rad from {trust['departs_at']:.3g} s, {how}"
    return text

"""The largest Lyapunov exponent (two methods) and the chaos summary of one start, cached."""

from __future__ import annotations

import functools
import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..core import cache
from ..core.errors import HarnessError, unknown_name
from ..model.start import Start
from ..results import dumps
from ..results.schema import ChaosSummary, Lyapunov
from ..systems import System
from .flow import (
    DEFAULT_TOLERANCE,
    amplification,
    flow,
    horizon_from_rounding,
    reset_variational,
    sample_at,
    variational_integrator,
)
from .integrate import DEFAULT_BUDGET, DEFAULT_DT_OUT, DEFAULT_T_END, time_grid
from .reference import DEFAULT_CACHE_DIR, TaylorGuard, cache_key, source_hash, taylor_integrator

LYAPUNOV_T_END = 500.0  # s: finite-time estimates fluctuate by ~+-0.03/s around 0.23/s at 100-2000 s
LYAPUNOV_INTERVAL = 0.5  # s between renormalisations (growth per interval e^0.12: far from overflow)


# ----------------------------------------------------------------------------------------------
# Lyapunov exponent


def lyapunov_exponent(
    system: System,
    start: Start,
    *,
    t_end: float = LYAPUNOV_T_END,
    interval: float = LYAPUNOV_INTERVAL,
    method: str = "variational",
    d0: float = 1e-9,
) -> Lyapunov:
    """The largest Lyapunov exponent (1/s) along the trajectory from `start`, by Benettin's method.

    method "variational": Phi restarted from Q of its QR every `interval`; the log of R's diagonal
    accumulates the whole spectrum (a Hamiltonian system's sums to ~0 and pairs +-lambda: a check).
    method "two trajectories": a companion trajectory at distance d0 (state 2-norm), pulled back to
    d0 along the separation every `interval`; only the largest exponent.

    Returns {"lambda", "spectrum" (variational only), "method", "t_end", "interval",
             "running": [[t, lambda(t)], ...] every 10 % of t_end, "spread": max-min of lambda(t)
             over the second half, "seconds"}.
    """
    began = time.perf_counter()
    n = system.nv
    tau = start.tau
    x0 = np.concatenate([start.q0, start.v0])
    steps = round(t_end / interval)
    if steps < 1 or not np.isclose(steps * interval, t_end, rtol=1e-9, atol=0.0):
        raise HarnessError(f"t_end ({t_end}) must be a whole multiple of interval ({interval}).")
    guard = TaylorGuard(DEFAULT_BUDGET, n)  # one budget for the whole run
    label = f"heyoka Lyapunov exponent ({method}), double"
    if method == "variational":
        logs, running = _variational_logs(system, x0, tau, steps=steps, interval=interval, guard=guard, label=label)
    elif method == "two trajectories":
        logs, running = _two_trajectory_logs(
            system, x0, tau, steps=steps, interval=interval, d0=d0, guard=guard, label=label
        )
    else:
        raise unknown_name("Lyapunov method", method, ("variational", "two trajectories"))
    running_arr = np.array(running)
    times = interval * np.arange(1, steps + 1)
    tenth = max(steps // 10, 1)
    out: Lyapunov = {
        "lambda": float(running_arr[-1]),
        "method": method,
        "t_end": t_end,
        "interval": interval,
        "running": [[float(times[i]), float(running_arr[i])] for i in range(tenth - 1, steps, tenth)],
        "spread": float(np.ptp(running_arr[steps // 2 :])),
        "seconds": time.perf_counter() - began,
    }
    if method == "variational":
        out["spectrum"] = [float(x) for x in logs / t_end]
    else:
        out["d0"] = d0
    return out


def _variational_logs(
    system: System, x0: np.ndarray, tau: np.ndarray, *, steps: int, interval: float, guard: TaylorGuard, label: str
) -> tuple[np.ndarray, list[float]]:
    """The variational method: the summed logs of R's diagonal (the whole spectrum times t) after
    `steps` QR restarts of Phi, and the running largest exponent after each."""
    n = system.nv
    logs = np.zeros(2 * n)
    running = []
    ta = variational_integrator(system, "double")
    reset_variational(ta, n, x0, tau, 0.0, np.eye(2 * n))
    for k in range(1, steps + 1):
        guard.check(ta.propagate_until(k * interval, callback=guard)[0], ta, source="hand", method=label)
        qmat, rmat = np.linalg.qr(ta.state[2 * n :].reshape(2 * n, 2 * n))
        logs += np.log(np.abs(np.diag(rmat)))
        ta.state[2 * n :] = qmat.ravel()
        running.append(logs[0] / (k * interval))
    return logs, running


def _two_trajectory_logs(
    system: System,
    x0: np.ndarray,
    tau: np.ndarray,
    *,
    steps: int,
    interval: float,
    d0: float,
    guard: TaylorGuard,
    label: str,
) -> tuple[np.ndarray, list[float]]:
    """The two-trajectory method: the summed log growth of the separation in logs[0] (the rest stay
    zero) after `steps` pull-backs to d0, and the running largest exponent after each."""
    n = system.nv
    logs = np.zeros(2 * n)
    running = []
    ta = taylor_integrator(system, "double", None)
    ta.pars[:] = tau
    x, y = x0.copy(), x0 + d0 * np.ones(2 * n) / np.sqrt(2 * n)
    for k in range(1, steps + 1):
        ends = []
        for state in (x, y):
            ta.time = (k - 1) * interval
            ta.state[:] = state
            guard.check(ta.propagate_until(k * interval, callback=guard)[0], ta, source="hand", method=label)
            ends.append(ta.state.copy())
        x, sep = ends[0], ends[1] - ends[0]
        dist = float(np.linalg.norm(sep))
        logs[0] += np.log(dist / d0)
        y = x + sep * (d0 / dist)
        running.append(logs[0] / (k * interval))
    return logs, running


@functools.lru_cache(maxsize=64)  # one per (system, start): bounded, recomputed when dropped
def _lyapunov_cached(system: System, x0: tuple[float, ...], tau: tuple[float, ...], method: str) -> Lyapunov:
    n = system.nv
    return lyapunov_exponent(system, Start.of(x0[:n], x0[n:], tau), method=method)


def chaos_summary(
    system: System,
    start: Start,
    *,
    t: np.ndarray | None = None,
    tolerance: float = DEFAULT_TOLERANCE,
    cache_dir: str | os.PathLike[str] | None = DEFAULT_CACHE_DIR,
) -> dict[str, Any]:
    """Lyapunov exponent (two methods), amplification at 2 s and 10 s, and horizons, for one start.

    Cached beside the reference solutions (validate/core/cache.py: verified on every read), keyed by
    everything the numbers depend on (system, parameters, the harness's and the equations' source,
    start, input, grid, tolerance); a loaded summary must also be consistent in itself
    (`_summary_problem`). `cache` in the result says "hit", "miss" or "off"."""

    q0, v0, tau = start.q0, start.v0, start.tau
    t = time_grid(DEFAULT_T_END, DEFAULT_DT_OUT) if t is None else t
    if isinstance(cache_dir, str) and cache_dir == cache.DEFAULT:
        where = cache.folder(cache_dir, "chaos")
    else:  # an explicit reference folder: the chaos entries go beside it
        where = None if cache_dir is None else Path(cache_dir).parent / "chaos"
    if where is None:
        return {**json.loads(dumps(_chaos_summary(system, start, t=t, tolerance=tolerance))), "cache": "off"}
    key = cache_key(system, q0, v0, tau, t, check=f"chaos {tolerance!r} {source_hash(__file__)}")
    path = where / f"{system.name}-{key}.npz"
    entry = cache.load(path, key)
    if entry is not None:
        problem = _summary_problem(entry[1], tolerance)
        if problem is None:
            return {**entry[1], "cache": "hit"}
        cache.invalid(path, problem)
    out = json.loads(dumps(_chaos_summary(system, start, t=t, tolerance=tolerance)))
    cache.store(path, key, {}, out)
    return {**out, "cache": "miss"}


def _summary_problem(summary: dict[str, Any], tolerance: float) -> str | None:
    """Why a stored chaos summary cannot be what `_chaos_summary` computed, or None: its numbers are
    finite and tie together (the agreement of the two exponents, the horizon estimated from lambda)."""
    try:
        lam = summary["lyapunov"]["lambda"]
        lam2 = summary["lyapunov_two_trajectories"]["lambda"]
        e0 = summary["horizon_from_rounding"]["e0"]
        values = [lam, lam2, e0, summary["lyapunov_agreement"], summary["max_amplification"]]
        if not all(isinstance(x, float) and np.isfinite(x) for x in values):
            return "non-finite or missing numbers"
        if summary["lyapunov_agreement"] != abs(lam - lam2):
            return "the two exponents do not match their stored agreement"
        estimate = float(np.log(tolerance / e0) / lam) if lam > 0 else None
        if summary["horizon_estimate_from_lambda"] != estimate:
            return "the horizon estimate does not follow from the exponent"
    except (KeyError, TypeError):
        return "missing fields"
    return None


def _chaos_summary(system: System, start: Start, *, t: np.ndarray, tolerance: float) -> ChaosSummary:
    tau = start.tau
    x0 = tuple(float(x) for x in np.concatenate([start.q0, start.v0]))
    lyap = _lyapunov_cached(system, x0, tuple(float(x) for x in tau), "variational")
    lyap2 = _lyapunov_cached(system, x0, tuple(float(x) for x in tau), "two trajectories")
    amp = amplification(flow(system, start, t))
    rounding = horizon_from_rounding(system, start, tolerance=tolerance)
    lam = lyap["lambda"]
    estimate = float(np.log(tolerance / rounding["e0"]) / lam) if lam > 0 else None
    return {
        "lyapunov": lyap,
        "lyapunov_two_trajectories": lyap2,
        "lyapunov_agreement": abs(lyap["lambda"] - lyap2["lambda"]),
        "amplification_at": sample_at(t, amp),
        "max_amplification": float(amp.max()),
        "horizon_from_rounding": rounding,
        "horizon_estimate_from_lambda": estimate,
    }

"""Chaos-aware trajectory judgement: how errors grow, how far ahead a run can be trusted.

On a chaotic system (the double pendulum of notes section 1 from theta = 0, phi = 3) two correct
integrations of the same equations drift apart: every error, down to the rounding of the initial
state, is amplified roughly like exp(lambda t). A fixed threshold on the trajectory difference then
says more about the horizon than about the equations. This module measures the growth and turns it
into an expectation:

  amplification   A(t) = ||P_q Phi(t)||_2, Phi(t) = dx(t)/dx(0) from the variational equations
                  (heyoka, on the symbolic hand equations of validate/reference.py), P_q the q rows:
                  the largest q error (rad) per unit initial state error.
  Lyapunov        largest exponent lambda, by Benettin's method: tangent vectors renormalised by QR
                  every `interval` (variational), and, as a simple independent path, two nearby
                  trajectories renormalised to d0 (`method="two trajectories"`).
  envelope        e(t_k) = e0 A(t_k) + sum_{j<k} ||P_q Phi(t_k) Phi(t_{j+1})^-1||_2 ||delta_j||_2:
                  the first-order bound on the propagated error of a run whose per-window error
                  (one output interval, restarted from the reference) is delta_j (Lady Windermere's
                  fan with norms). Window errors are measured by restarting the run from the
                  reference at every sample, so chaos cannot amplify them.
  horizon         the first time the envelope reaches a tolerance.
  judge           a free-running error passes if it stays below SAFETY x envelope up to the horizon.

SAFETY = 10: the envelope is already an upper bound to first order (triangle inequality over the
windows, operator norms, the 2-norm of the q error bounding its largest component). The factor
covers what the bound neglects: second-order growth (relative size e / 1 rad, < 1e-6 within the
horizon at 1e-6 rad), Phi's own error (heyoka in double, ~1e-12 relative), and that a free run
rounds differently from the restarted windows that measured delta (same distribution, different
realisation; the sum over ~1000 windows averages that out to well within 10x).

The envelope is built from the run's own window errors, so the judge alone cannot catch a wrong
equation: it says whether the free-run error is explained by the window errors and how far ahead
that holds. Whether the window errors are what they should be is the other half: for a mirror and
mj_step (the same scheme on two sources) they must be round-off (`window_ulps` <= ROUND_OFF_ULPS;
a wrong term makes them ~h |da|, millions of ulps); against the reference they are the scheme's
truncation error, whose order `convergence_order` measures. A free run whose horizon is the first
sample (Euler at 1 ms: window errors 2e-2 rad) passes trivially: nothing beyond 10 ms can be trusted
to the tolerance, which is the finding.

All public functions return JSON-able dicts (floats, lists, None) unless documented as arrays.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import HarnessError, unknown_name
from ..results import dumps
from . import cache
from .integrate import DEFAULT_BUDGET, Budget, Trajectory, energy, initial_state, mujoco_trajectory, time_grid
from .mirror import INTEGRATORS, lockstep, mirror_steps, mirror_trajectory, mujoco_steps
from .reference import (
    CHECK,
    DEFAULT_CACHE_DIR,
    TaylorGuard,
    _integrator,
    _param_key,
    _source_hash,
    cache_key,
    reference_trajectory,
    symbolic_dynamics,
)

SAFETY = 10.0
HORIZON_CHUNK = 100  # grid samples per propagation of `horizon_from_rounding` (10 s at 0.1 s)
ROUND_OFF_ULPS = 16  # window differences of two sources under one scheme (measured <= 3 ulps of max |x|)
DEFAULT_TOLERANCE = 1e-6  # rad, the trajectory tier of validate/tolerances.py
LYAPUNOV_T_END = 500.0  # s: finite-time estimates fluctuate by ~+-0.03/s around 0.23/s at 100-2000 s
LYAPUNOV_INTERVAL = 0.5  # s between renormalisations (growth per interval e^0.12: far from overflow)
CONVERGENCE_T_END = 1.0  # s: short enough that chaos does not bend the error curves (RK4 at 2 s does)
CONVERGENCE_TIMESTEPS = {
    "RK4": (0.02, 0.01, 0.005, 0.0025),
    "Euler": (0.002, 0.001, 0.0005, 0.00025),
    "implicit": (0.002, 0.001, 0.0005, 0.00025),
    "implicitfast": (0.002, 0.001, 0.0005, 0.00025),
}
EXPECTED_ORDER = {"RK4": 4, "Euler": 1, "implicit": 1, "implicitfast": 1}


# ----------------------------------------------------------------------------------------------
# Variational flow


@dataclass(frozen=True)
class Flow:
    """A trajectory and its sensitivity on a grid."""

    t: np.ndarray  # (K,) s
    x: np.ndarray  # (K, 2n) state (q, v)
    phi: np.ndarray  # (K, 2n, 2n) dx(t)/dx(0), row-major: phi[k, i, j] = dx_i(t_k) / dx_j(0)


_VAR_INTEGRATORS: dict[tuple[Any, ...], Any] = {}


def _variational_integrator(system: Any, precision: str) -> Any:
    import heyoka as hy

    key = (system.name, system.overrides, _param_key(system), system.equations, precision)  # the module, not its id
    if key not in _VAR_INTEGRATORS:
        dyn = symbolic_dynamics(system)
        fp = {"double": float, "long double": np.longdouble}[precision]
        vsys = hy.var_ode_sys(dyn.ode, hy.var_args.vars, order=1)
        _VAR_INTEGRATORS[key] = hy.taylor_adaptive(
            vsys, np.zeros(2 * dyn.n, dtype=fp), fp_type=fp, pars=np.zeros(dyn.n, dtype=fp), compact_mode=True
        )
    return _VAR_INTEGRATORS[key]


def _reset_variational(ta: Any, n: int, x0: np.ndarray, tau: np.ndarray, t0: float, tangent: np.ndarray) -> None:
    dtype = ta.state.dtype
    ta.time = dtype.type(t0)
    ta.state[: 2 * n] = np.asarray(x0, dtype=float).astype(dtype)
    ta.state[2 * n :] = np.asarray(tangent, dtype=float).astype(dtype).ravel()
    ta.pars[:] = np.asarray(tau, dtype=float).astype(dtype)


def flow(
    system: Any,
    q0: Any,
    v0: Any,
    tau: Any,
    t: np.ndarray,
    *,
    precision: str = "double",
    budget: Budget = DEFAULT_BUDGET,
) -> Flow:
    """The trajectory and Phi(t) = dx(t)/dx(0) on the grid `t` (starting at t[0]).

    Raises IntegrationStopped (a HarnessError) when the equations blow up or spend `budget`."""
    n = system.nv
    ta = _variational_integrator(system, precision)
    x0 = np.concatenate([np.asarray(q0, dtype=float), np.asarray(v0, dtype=float)])
    _reset_variational(ta, n, x0, np.asarray(tau, dtype=float), float(t[0]), np.eye(2 * n))
    guard = TaylorGuard(budget, n, float(t[0]))
    outcome, *_, states = ta.propagate_grid(np.asarray(t, dtype=float).astype(ta.state.dtype), callback=guard)
    guard.check(outcome, ta, source="hand", method=f"heyoka variational flow, {precision}")
    states = states.astype(float)
    return Flow(np.asarray(t, dtype=float), states[:, : 2 * n], states[:, 2 * n :].reshape(-1, 2 * n, 2 * n))


def _rows(n: int, rows: str) -> slice:
    return {"q": slice(0, n), "v": slice(n, 2 * n), "all": slice(0, 2 * n)}[rows]


def _spectral_norm(a: np.ndarray) -> np.ndarray:
    """||a||_2 for a stack (..., r, c), via the eigenvalues of the smaller Gram matrix."""
    g = a @ np.swapaxes(a, -1, -2) if a.shape[-2] <= a.shape[-1] else np.swapaxes(a, -1, -2) @ a
    return np.sqrt(np.maximum(np.linalg.eigvalsh(g)[..., -1], 0.0))


def amplification(fl: Flow, *, rows: str = "q") -> np.ndarray:
    """A(t_k) = ||P Phi(t_k)||_2, (K,): the largest error in the `rows` part per unit initial error."""
    n = fl.x.shape[1] // 2
    return _spectral_norm(fl.phi[:, _rows(n, rows), :])


def transfer_norms(fl: Flow, *, rows: str = "q") -> np.ndarray:
    """G[k, j] = ||P Phi(t_k) Phi(t_j)^-1||_2 for j <= k, 0 above the diagonal, (K, K)."""
    n = fl.x.shape[1] // 2
    inv = np.linalg.inv(fl.phi)
    g = np.zeros((len(fl.t), len(fl.t)))
    for k in range(len(fl.t)):
        g[k, : k + 1] = _spectral_norm(fl.phi[k, _rows(n, rows), :][None] @ inv[: k + 1])
    return g


def error_envelope(
    fl: Flow,
    *,
    e0: float = 0.0,
    window_errors: np.ndarray | None = None,
    floor: float | np.ndarray = 0.0,
    rows: str = "q",
    transfer: np.ndarray | None = None,
) -> np.ndarray:
    """e(t_k) = e0 A(t_k) + sum_{j<k} G[k, j+1] max(||delta_j||, floor_j), (K,).

    Args:
        e0: size of the initial state difference (2-norm over q and v).
        window_errors: (K-1, 2n) error of each output interval restarted from the reference, or
            (K-1,) their norms; None for an initial difference only.
        floor: smallest window error to assume, scalar or (K-1,): a restarted window can round
            exactly like its partner by chance, a free run from a slightly different state need not.
        transfer: `transfer_norms(fl, rows=rows)` if already computed (it costs O(K^2)).
    """
    env = e0 * amplification(fl, rows=rows)
    if window_errors is not None:
        w = np.asarray(window_errors, dtype=float)
        norms = np.maximum(np.linalg.norm(w, axis=-1) if w.ndim == 2 else w, floor)
        if len(norms) != len(fl.t) - 1:
            raise HarnessError(f"window_errors needs {len(fl.t) - 1} rows (one per output interval); got {len(norms)}.")
        g = transfer_norms(fl, rows=rows) if transfer is None else transfer
        env = env + np.concatenate([[0.0], (g[1:, 1:] * norms[None, :]).sum(axis=1)])  # G[k, j+1] = 0 for j >= k
    return env


def predicted_error(fl: Flow, window_errors: np.ndarray, *, rows: str = "q") -> np.ndarray:
    """The first-order propagation of the window errors, a prediction (not a bound), (K,):

    e(t_k) = max_i |[P Phi(t_k) sum_{j<k} Phi(t_{j+1})^-1 delta_j]_i|.

    Where a run's error is its own truncation error (far above rounding) this reproduces the measured
    error (MuJoCo RK4 at 1 ms on the double pendulum: to 3 digits over 38 s). Rounding-level
    differences are random; their realisation in a free run is not the one the windows measured.
    """
    n = fl.x.shape[1] // 2
    w = np.asarray(window_errors, dtype=float)
    if w.shape != (len(fl.t) - 1, 2 * n):
        raise HarnessError(f"window_errors must be ({len(fl.t) - 1}, {2 * n}); got {w.shape}.")
    pulled_back = np.einsum("kij,kj->ki", np.linalg.inv(fl.phi[1:]), w)
    summed = np.concatenate([np.zeros((1, 2 * n)), np.cumsum(pulled_back, axis=0)])
    return np.abs(np.einsum("kij,kj->ki", fl.phi, summed)[:, _rows(n, rows)]).max(axis=1)


def predictability_horizon(t: np.ndarray, envelope: np.ndarray, tolerance: float) -> float | None:
    """The first grid time at which the envelope reaches `tolerance` (None: not within the grid)."""
    above = np.nonzero(np.asarray(envelope) >= tolerance)[0]
    return float(t[above[0]]) if len(above) else None


def judge_free_run(
    t: np.ndarray,
    error: np.ndarray,
    envelope: np.ndarray,
    *,
    tolerance: float = DEFAULT_TOLERANCE,
    safety: float = SAFETY,
) -> dict[str, Any]:
    """Whether a free-running error stays inside safety x envelope up to the predictability horizon.

    Returns {"passed", "horizon" (s or None = whole grid), "judged_until" (s), "safety",
    "max_ratio" (largest error / envelope within the horizon), "first_violation" (s or None)}.
    """
    horizon = predictability_horizon(t, envelope, tolerance)
    within = t <= (horizon if horizon is not None else t[-1])
    floor = np.finfo(float).tiny
    ratio = np.where(within, np.asarray(error) / np.maximum(envelope, floor), 0.0)
    ratio[0] = 0.0 if error[0] == 0 else ratio[0]
    bad = np.nonzero(ratio > safety)[0]
    return {
        "passed": not len(bad),
        "horizon": horizon,
        "judged_until": float(t[within][-1]),
        "safety": safety,
        "tolerance": tolerance,
        "max_ratio": float(ratio.max()),
        "first_violation": float(t[bad[0]]) if len(bad) else None,
    }


# ----------------------------------------------------------------------------------------------
# Lyapunov exponent


def lyapunov_exponent(
    system: Any,
    q0: Any,
    v0: Any,
    tau: Any = None,
    *,
    t_end: float = LYAPUNOV_T_END,
    interval: float = LYAPUNOV_INTERVAL,
    method: str = "variational",
    d0: float = 1e-9,
) -> dict[str, Any]:
    """The largest Lyapunov exponent (1/s) along the trajectory from (q0, v0), by Benettin's method.

    method "variational": Phi restarted from Q of its QR every `interval`; the log of R's diagonal
    accumulates the whole spectrum (a Hamiltonian system's sums to ~0 and pairs +-lambda: a check).
    method "two trajectories": a companion trajectory at distance d0 (state 2-norm), pulled back to
    d0 along the separation every `interval`; only the largest exponent.

    Returns {"lambda", "spectrum" (variational only), "method", "t_end", "interval",
             "running": [[t, lambda(t)], ...] every 10 % of t_end, "spread": max-min of lambda(t)
             over the second half, "seconds"}.
    """
    start = time.perf_counter()
    n = system.nv
    tau = np.zeros(n) if tau is None else np.asarray(tau, dtype=float)
    x0 = np.concatenate([np.asarray(q0, dtype=float), np.asarray(v0, dtype=float)])
    steps = round(t_end / interval)
    if steps < 1 or not np.isclose(steps * interval, t_end, rtol=1e-9, atol=0.0):
        raise HarnessError(f"t_end ({t_end}) must be a whole multiple of interval ({interval}).")
    logs = np.zeros(2 * n)
    running = []
    guard = TaylorGuard(DEFAULT_BUDGET, n)  # one budget for the whole run
    label = f"heyoka Lyapunov exponent ({method}), double"
    if method == "variational":
        ta = _variational_integrator(system, "double")
        _reset_variational(ta, n, x0, tau, 0.0, np.eye(2 * n))
        for k in range(1, steps + 1):
            guard.check(ta.propagate_until(k * interval, callback=guard)[0], ta, source="hand", method=label)
            qmat, rmat = np.linalg.qr(ta.state[2 * n :].reshape(2 * n, 2 * n))
            logs += np.log(np.abs(np.diag(rmat)))
            ta.state[2 * n :] = qmat.ravel()
            running.append(logs[0] / (k * interval))
    elif method == "two trajectories":
        ta = _integrator(system, "double", None)
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
    else:
        raise unknown_name("Lyapunov method", method, ("variational", "two trajectories"))
    running_arr = np.array(running)
    times = interval * np.arange(1, steps + 1)
    tenth = max(steps // 10, 1)
    out = {
        "lambda": float(running_arr[-1]),
        "method": method,
        "t_end": t_end,
        "interval": interval,
        "running": [[float(times[i]), float(running_arr[i])] for i in range(tenth - 1, steps, tenth)],
        "spread": float(np.ptp(running_arr[steps // 2 :])),
        "seconds": time.perf_counter() - start,
    }
    if method == "variational":
        out["spectrum"] = [float(x) for x in logs / t_end]
    else:
        out["d0"] = d0
    return out


# ----------------------------------------------------------------------------------------------
# Runs, window errors, judging


def _run(
    system: Any,
    sources: dict[str, Any],
    engine: str,
    q0: np.ndarray,
    v0: np.ndarray,
    tau: np.ndarray,
    t: np.ndarray,
    *,
    integrator: str,
    timestep: float,
) -> Trajectory:
    """A free run: MuJoCo stepping (engine "mujoco") or the mirror of its scheme on another source."""
    if engine == "mujoco":
        return mujoco_trajectory(system, sources["mujoco"], q0, v0, tau, t, integrator=integrator, timestep=timestep)
    return mirror_trajectory(system, sources[engine], q0, v0, tau, t, integrator=integrator, timestep=timestep)


def window_errors(
    system: Any,
    sources: dict[str, Any],
    engine: str,
    ref: Trajectory,
    tau: np.ndarray,
    *,
    integrator: str,
    timestep: float,
) -> np.ndarray:
    """(K-1, 2n): the run restarted from the reference at each sample, minus the reference one sample later."""
    dt_out = float(ref.t[1] - ref.t[0])
    steps = round(dt_out / timestep)
    q, v = ref.q[:-1], ref.v[:-1]
    if engine == "mujoco":
        q1, v1 = mujoco_steps(sources["mujoco"], q, v, tau, integrator=integrator, timestep=timestep, steps=steps)
    else:
        q1, v1 = mirror_steps(system, sources[engine], q, v, tau, integrator=integrator, timestep=timestep, steps=steps)
    return np.concatenate([q1 - ref.q[1:], v1 - ref.v[1:]], axis=1)


def free_run_check(
    system: Any,
    sources: dict[str, Any],
    q0: Any,
    v0: Any,
    tau: Any,
    t: np.ndarray,
    *,
    engine: str = "mujoco",
    integrator: str = "RK4",
    timestep: float | None = None,
    tolerance: float = DEFAULT_TOLERANCE,
    ref: Trajectory | None = None,
    cache_dir: Any = DEFAULT_CACHE_DIR,
) -> dict[str, Any]:
    """A free run against the reference, judged against its propagated window errors.

    Returns {"engine", "integrator", "timestep" (s), "max_error", "error_at" {"1 s": .., "10 s": ..},
    "max_window_error", "envelope_at" (the bound), "predicted_at" (the first-order prediction),
    "predicted_horizon" (s or None), "prediction_mismatch" (max |error - predicted| / max error),
    "judge": judge_free_run(...)}; errors in rad (max over q), window errors as state 2-norms.
    """
    q0, v0, tau = (np.asarray(x, dtype=float) for x in (q0, v0, tau))
    dt = float(timestep or system.mujoco_model().opt.timestep)
    if ref is None:
        ref, _ = reference_trajectory(system, q0, v0, tau, t, cache_dir=cache_dir)
    run = _run(system, sources, engine, q0, v0, tau, t, integrator=integrator, timestep=dt)
    err = np.abs(run.q - ref.q).max(axis=1)
    w = window_errors(system, sources, engine, ref, tau, integrator=integrator, timestep=dt)
    fl = flow(system, q0, v0, tau, t)
    env = error_envelope(fl, window_errors=w, floor=rounding_floor(ref))
    return _free_run_entry(engine, integrator, dt, t, err, w, env, predicted_error(fl, w), tolerance)


def _free_run_entry(
    engine: str,
    integrator: str,
    dt: float,
    t: np.ndarray,
    err: np.ndarray,
    w: np.ndarray,
    env: np.ndarray,
    pred: np.ndarray,
    tolerance: float,
) -> dict[str, Any]:
    return {
        "engine": engine,
        "integrator": integrator,
        "timestep": dt,
        "max_error": float(err.max()),
        "error_at": _sample(t, err),
        "max_window_error": float(np.linalg.norm(w, axis=1).max()),
        "envelope_at": _sample(t, env),
        "predicted_at": _sample(t, pred),
        "predicted_horizon": predictability_horizon(t, pred, tolerance),
        "prediction_mismatch": float(np.abs(err - pred).max() / max(float(err.max()), np.finfo(float).tiny)),
        "judge": judge_free_run(t, err, env, tolerance=tolerance),
    }


def pair_check(
    system: Any,
    sources: dict[str, Any],
    a: str,
    b: str,
    q0: Any,
    v0: Any,
    tau: Any,
    t: np.ndarray,
    *,
    integrator: str = "RK4",
    timestep: float | None = None,
    ref: Trajectory | None = None,
    tolerance: float = DEFAULT_TOLERANCE,
    cache_dir: Any = DEFAULT_CACHE_DIR,
) -> dict[str, Any]:
    """Two free runs of the same scheme (e.g. MuJoCo and the hand mirror) judged against the envelope of
    their window-by-window difference (both restarted from the reference at every sample).

    Returns {"pair", "integrator", "timestep", "max_difference", "difference_at", "max_window_difference",
    "window_ulps" (in units of the spacing of doubles at max |x|), "round_off" (<= ROUND_OFF_ULPS),
    "envelope_at", "judge", "passed" (round-off windows and judge passed)}.
    """
    q0, v0, tau = (np.asarray(x, dtype=float) for x in (q0, v0, tau))
    dt = float(timestep or system.mujoco_model().opt.timestep)
    if ref is None:
        ref, _ = reference_trajectory(system, q0, v0, tau, t, cache_dir=cache_dir)
    run_a = _run(system, sources, a, q0, v0, tau, t, integrator=integrator, timestep=dt)
    run_b = _run(system, sources, b, q0, v0, tau, t, integrator=integrator, timestep=dt)
    err = np.abs(run_a.q - run_b.q).max(axis=1)
    w = window_errors(system, sources, a, ref, tau, integrator=integrator, timestep=dt) - window_errors(
        system, sources, b, ref, tau, integrator=integrator, timestep=dt
    )
    env = error_envelope(flow(system, q0, v0, tau, t), window_errors=w, floor=rounding_floor(ref))
    return {
        "pair": f"{a}~{b}",
        "integrator": integrator,
        "timestep": dt,
        "max_difference": float(err.max()),
        "difference_at": _sample(t, err),
        **_mirror_verdict(t, err, w, env, ref, tolerance),
    }


def _mirror_verdict(
    t: np.ndarray, diff: np.ndarray, w: np.ndarray, env: np.ndarray, ref: Trajectory, tolerance: float
) -> dict[str, Any]:
    """Round-off windows and a free-run difference inside the envelope: the two halves of a mirror's verdict."""
    ulp = float(np.spacing(np.abs(np.concatenate([ref.q, ref.v], axis=1)).max()))
    window_ulps = float(np.linalg.norm(w, axis=1).max() / ulp)
    judge = judge_free_run(t, diff, env, tolerance=tolerance)
    return {
        "max_window_difference": float(np.linalg.norm(w, axis=1).max()),
        "window_ulps": window_ulps,
        "round_off": window_ulps <= ROUND_OFF_ULPS,
        "envelope_at": _sample(t, env),
        "judge": judge,
        "passed": window_ulps <= ROUND_OFF_ULPS and judge["passed"],
    }


def _slope(t: np.ndarray, y: np.ndarray) -> float:
    """Least-squares slope of y(t); NaN where y is not finite (a run that diverged or stopped)."""
    return float(np.polyfit(t, y, 1)[0]) if np.isfinite(y).all() else float("nan")


def rounding_floor(ref: Trajectory) -> np.ndarray:
    """(K-1,) one rounding of the state at the end of each window: eps ||x(t_{j+1})||."""
    return np.finfo(float).eps * np.linalg.norm(np.concatenate([ref.q[1:], ref.v[1:]], axis=1), axis=1)


def _sample(t: np.ndarray, y: np.ndarray, at: tuple[float, ...] = (1.0, 2.0, 5.0, 10.0)) -> dict[str, float]:
    out = {}
    for s in at:
        k = int(np.argmin(np.abs(t - s)))
        if abs(t[k] - s) < 1e-9:
            out[f"{s:g} s"] = float(y[k])
    return out


# ----------------------------------------------------------------------------------------------
# Convergence order and energy drift


def convergence_order(
    system: Any,
    sources: dict[str, Any],
    q0: Any,
    v0: Any,
    tau: Any,
    *,
    integrator: str,
    timesteps: tuple[float, ...] | None = None,
    t_end: float = CONVERGENCE_T_END,
    engine: str = "mujoco",
    cache_dir: Any = DEFAULT_CACHE_DIR,
    check: str | None = CHECK,
) -> dict[str, Any]:
    """The observed order of `integrator` from a timestep sweep against the reference.

    error(dt) = max over the grid (output step: the largest timestep) of max |q - q_ref|; the order is
    the least-squares slope of log error against log dt.
    """
    if integrator not in INTEGRATORS:
        raise unknown_name("MuJoCo integrator", integrator, INTEGRATORS)
    dts = tuple(timesteps or CONVERGENCE_TIMESTEPS[integrator])
    q0, v0, tau = (np.asarray(x, dtype=float) for x in (q0, v0, tau))
    t = time_grid(t_end, max(dts))
    ref, _ = reference_trajectory(system, q0, v0, tau, t, cache_dir=cache_dir, check=check)
    errors = []
    for dt in dts:
        run = _run(system, sources, engine, q0, v0, tau, t, integrator=integrator, timestep=dt)
        errors.append(float(np.abs(run.q - ref.q).max()))
    usable = [(dt, e) for dt, e in zip(dts, errors, strict=True) if e > 0 and np.isfinite(e)]  # a diverged run: NaN
    order = (
        float(np.polyfit(np.log([d for d, _ in usable]), np.log([e for _, e in usable]), 1)[0])
        if len(usable) >= 2
        else None
    )
    local = [float(x) for x in np.diff(np.log(errors)) / np.diff(np.log(dts))] if all(e > 0 for e in errors) else None
    return {
        "engine": engine,
        "integrator": integrator,
        "t_end": t_end,
        "timesteps": list(dts),
        "errors": errors,
        "order": order,
        "pairwise_orders": local,
        "expected": EXPECTED_ORDER[integrator],
    }


def energy_drift(
    system: Any,
    sources: dict[str, Any],
    q0: Any,
    v0: Any,
    tau: Any,
    t: np.ndarray,
    *,
    integrator: str,
    timestep: float | None = None,
    engine: str = "mujoco",
    ref: Trajectory | None = None,
    cache_dir: Any = DEFAULT_CACHE_DIR,
) -> dict[str, Any]:
    """Energy of a run minus the reference's energy at the same times (J), by the hand equations.

    For a conservative system (no damping, no input) the reference energy is constant to ~1e-15
    and this is the usual drift; with damping or inputs it is the run's energy error.
    """
    q0, v0, tau = (np.asarray(x, dtype=float) for x in (q0, v0, tau))
    dt = float(timestep or system.mujoco_model().opt.timestep)
    if ref is None:
        ref, _ = reference_trajectory(system, q0, v0, tau, t, cache_dir=cache_dir)
    run = _run(system, sources, engine, q0, v0, tau, t, integrator=integrator, timestep=dt)
    e_run, e_ref = energy(system, sources["hand"], run), energy(system, sources["hand"], ref)
    diff = e_run - e_ref
    scale = float(np.max(np.abs(e_ref)) or 1.0)
    slope = _slope(t, diff)
    return {
        "engine": engine,
        "integrator": integrator,
        "timestep": dt,
        "max_abs": float(np.abs(diff).max()),
        "final": float(diff[-1]),
        "rate": slope,
        "relative": float(np.abs(diff).max() / scale),
        "reference_energy_range": float(np.ptp(e_ref)),
    }


# ----------------------------------------------------------------------------------------------
# Summary for the pipeline


def horizon_from_rounding(
    system: Any,
    q0: Any,
    v0: Any,
    tau: Any,
    *,
    tolerance: float = DEFAULT_TOLERANCE,
    t_end: float = 200.0,
    dt_out: float = 0.1,
) -> dict[str, Any]:
    """Predictability horizon of the initial state's own rounding (e0 = 2^-53 |x0|): the best any double
    precision integration can do. Phi from the variational equations in long double."""
    x0 = np.concatenate([np.asarray(q0, dtype=float), np.asarray(v0, dtype=float)])
    e0 = float(np.finfo(float).eps) / 2 * max(float(np.linalg.norm(x0)), 1.0)
    t = time_grid(t_end, dt_out)
    precision = "long double" if np.finfo(np.longdouble).eps < 1e-18 else "double"
    # In chunks, stopping at the first chunk where the envelope reaches the tolerance: the horizon is
    # the first crossing, and the chaotic systems cross it halfway (~100 s of the 200).
    n, chunk = system.nv, HORIZON_CHUNK
    ta = _variational_integrator(system, precision)
    _reset_variational(ta, n, x0, np.asarray(tau, dtype=float), float(t[0]), np.eye(2 * n))
    guard = TaylorGuard(DEFAULT_BUDGET, n, float(t[0]))
    horizon = None
    for start in range(0, max(len(t) - 1, 1), chunk):
        grid = t[start : start + chunk + 1]  # each chunk starts where the last ended
        outcome, *_, states = ta.propagate_grid(grid.astype(ta.state.dtype), callback=guard)
        guard.check(outcome, ta, source="hand", method=f"heyoka variational flow, {precision}")
        phi = states.astype(float)[:, 2 * n :].reshape(-1, 2 * n, 2 * n)
        horizon = predictability_horizon(grid, e0 * _spectral_norm(phi[:, :n, :]), tolerance)
        if horizon is not None:
            break
    return {"e0": e0, "tolerance": tolerance, "horizon": horizon, "t_end": t_end}


@functools.cache
def _lyapunov_cached(system: Any, x0: tuple[float, ...], tau: tuple[float, ...], method: str) -> dict[str, Any]:
    n = system.nv
    return lyapunov_exponent(system, x0[:n], x0[n:], tau, method=method)


def chaos_summary(
    system: Any,
    q0: Any,
    v0: Any,
    tau: Any,
    *,
    t: np.ndarray | None = None,
    tolerance: float = DEFAULT_TOLERANCE,
    cache_dir: Any = DEFAULT_CACHE_DIR,
) -> dict[str, Any]:
    """Lyapunov exponent (two methods), amplification at 2 s and 10 s, and horizons, for one start.

    Cached beside the reference solutions (validate/cache.py: verified on every read), keyed by
    everything the numbers depend on (system, parameters, the harness's and the equations' source,
    start, input, grid, tolerance); a loaded summary must also be consistent in itself
    (`_summary_problem`). `cache` in the result says "hit", "miss" or "off"."""
    import json

    q0, v0, tau = (np.asarray(x, dtype=float) for x in (q0, v0, tau))
    t = time_grid(10.0, 0.01) if t is None else t
    if isinstance(cache_dir, str) and cache_dir == cache.DEFAULT:
        where = cache.folder(cache_dir, "chaos")
    else:  # an explicit reference folder: the chaos entries go beside it
        where = None if cache_dir is None else Path(cache_dir).parent / "chaos"
    if where is None:
        return {**json.loads(dumps(_chaos_summary(system, q0, v0, tau, t=t, tolerance=tolerance))), "cache": "off"}
    key = cache_key(system, q0, v0, tau, t, check=f"chaos {tolerance!r} {_source_hash(__file__)}")
    path = where / f"{system.name}-{key}.npz"
    entry = cache.load(path, key)
    if entry is not None:
        problem = _summary_problem(entry[1], tolerance)
        if problem is None:
            return {**entry[1], "cache": "hit"}
        cache.invalid(path, problem)
    out = json.loads(dumps(_chaos_summary(system, q0, v0, tau, t=t, tolerance=tolerance)))
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


def _chaos_summary(
    system: Any, q0: np.ndarray, v0: np.ndarray, tau: np.ndarray, *, t: np.ndarray, tolerance: float
) -> dict[str, Any]:
    x0 = tuple(float(x) for x in np.concatenate([q0, v0]))
    lyap = _lyapunov_cached(system, x0, tuple(float(x) for x in tau), "variational")
    lyap2 = _lyapunov_cached(system, x0, tuple(float(x) for x in tau), "two trajectories")
    amp = amplification(flow(system, q0, v0, tau, t))
    rounding = horizon_from_rounding(system, q0, v0, tau, tolerance=tolerance)
    lam = lyap["lambda"]
    estimate = float(np.log(tolerance / rounding["e0"]) / lam) if lam > 0 else None
    return {
        "lyapunov": lyap,
        "lyapunov_two_trajectories": lyap2,
        "lyapunov_agreement": abs(lyap["lambda"] - lyap2["lambda"]),
        "amplification_at": _sample(t, amp),
        "max_amplification": float(amp.max()),
        "horizon_from_rounding": rounding,
        "horizon_estimate_from_lambda": estimate,
    }


# ----------------------------------------------------------------------------------------------
# Everything for one system, as the pipeline's results


def crossvalidate(
    system: Any,
    sources: dict[str, Any],
    *,
    q0: Any = None,
    v0: Any = None,
    tau: Any = None,
    t_end: float = 10.0,
    dt_out: float = 0.01,
    tolerance: float = DEFAULT_TOLERANCE,
    integrators: tuple[str, ...] = INTEGRATORS,
    mirror_engines: tuple[str, ...] = ("hand", "pinocchio"),
    cache_dir: Any = DEFAULT_CACHE_DIR,
    lockstep_every: int = 10,
) -> dict[str, Any]:
    """Trajectory cross-validation of one system, JSON-able: reference, chaos measures, and per MuJoCo
    integrator (at the MJCF's timestep) the free run against the reference, the mirrors against
    mj_step (free run judged by the round-off envelope, and lockstep), convergence order and energy.

    The start is the module's INITIAL_STATE (or the harness's generic one) with zero input unless given.
    """

    if q0 is None or v0 is None:
        q0_default, v0_default = initial_state(system)
        q0 = q0_default if q0 is None else q0
        v0 = v0_default if v0 is None else v0
    q0, v0 = np.asarray(q0, dtype=float), np.asarray(v0, dtype=float)
    tau = np.zeros(system.nv) if tau is None else np.asarray(tau, dtype=float)
    t = time_grid(t_end, dt_out)
    dt = float(system.mujoco_model().opt.timestep)
    ref, ref_info = reference_trajectory(system, q0, v0, tau, t, cache_dir=cache_dir)
    fl = flow(system, q0, v0, tau, t)
    g = transfer_norms(fl)
    floor = rounding_floor(ref)
    out: dict[str, Any] = {
        "q0": q0.tolist(),
        "v0": v0.tolist(),
        "tau": tau.tolist(),
        "t_end": t_end,
        "dt_out": dt_out,
        "timestep": dt,
        "tolerance": tolerance,
        "safety": SAFETY,
        "reference": ref_info,
        "chaos": chaos_summary(system, q0, v0, tau, t=t, tolerance=tolerance, cache_dir=cache_dir),
        "amplification": amplification(fl),  # (K,) on the grid t: how much the dynamics amplify an error
        "integrators": {},
    }
    lock_states = (ref.q[::lockstep_every], ref.v[::lockstep_every])
    for integrator in integrators:
        runs, windows = {}, {}
        for engine in ("mujoco", *mirror_engines):
            runs[engine] = _run(system, sources, engine, q0, v0, tau, t, integrator=integrator, timestep=dt)
            windows[engine] = window_errors(system, sources, engine, ref, tau, integrator=integrator, timestep=dt)
        err = np.abs(runs["mujoco"].q - ref.q).max(axis=1)
        env = error_envelope(fl, window_errors=windows["mujoco"], floor=floor, transfer=g)
        entry: dict[str, Any] = {
            "free_run": _free_run_entry(
                "mujoco",
                integrator,
                dt,
                t,
                err,
                windows["mujoco"],
                env,
                predicted_error(fl, windows["mujoco"]),
                tolerance,
            ),
            "mirrors": {},
        }
        for engine in mirror_engines:
            diff = np.abs(runs["mujoco"].q - runs[engine].q).max(axis=1)
            w = windows["mujoco"] - windows[engine]
            env_m = error_envelope(fl, window_errors=w, floor=floor, transfer=g)
            entry["mirrors"][f"mujoco~{engine}"] = {
                "max_difference": float(diff.max()),
                "difference_at": _sample(t, diff),
                **_mirror_verdict(t, diff, w, env_m, ref, tolerance),
            }
            status = runs[engine].stats.get("status", "ok")  # a mirror that diverged or stopped fails, with its reason
            if status != "ok":
                entry["mirrors"][f"mujoco~{engine}"].update(
                    passed=False, status=status, reason=runs[engine].stats.get("reason", "")
                )
        entry["lockstep"] = lockstep(
            system,
            {k: sources[k] for k in ("mujoco", *mirror_engines)},
            lock_states,
            integrator=integrator,
            timestep=dt,
            tau=tau,
        )["pairs"]
        entry["convergence"] = convergence_order(
            system, sources, q0, v0, tau, integrator=integrator, cache_dir=cache_dir
        )
        e_run = energy(system, sources["hand"], runs["mujoco"])
        e_ref = energy(system, sources["hand"], ref)
        entry["energy"] = {
            "max_abs": float(np.abs(e_run - e_ref).max()),
            "relative": float(np.abs(e_run - e_ref).max() / (np.abs(e_ref).max() or 1.0)),
            "rate": _slope(t, e_run - e_ref),
        }
        out["integrators"][integrator] = entry
    # The mirrors decide (round-off windows, difference inside the envelope); the free runs against the
    # reference are findings about the integrators (horizon, prediction), judged but not decisive.
    out["passed"] = all(m["passed"] for e in out["integrators"].values() for m in e["mirrors"].values())
    return out

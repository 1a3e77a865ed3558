"""The variational flow of the hand equations and what it says about errors: amplification,
transfer of window errors, the error envelope, the predictability horizon (see dynamics/chaos.py)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.cachedir import heyoka
from ..core.errors import HarnessError
from ..core.memo import Memo
from ..core.tolerances import TOLERANCES
from ..model.start import Start
from ..results.schema import Judgement, RoundingHorizon
from ..systems import System
from .integrate import DEFAULT_BUDGET, Budget, time_grid
from .reference import Taylor, TaylorGuard, param_key, symbolic_dynamics

SAFETY = 10.0
HORIZON_CHUNK = 100  # grid samples per propagation of `horizon_from_rounding` (10 s at 0.1 s)
DEFAULT_TOLERANCE = TOLERANCES.trajectory.rtol  # rad, the trajectory tier


# ----------------------------------------------------------------------------------------------
# Variational flow


@dataclass(frozen=True)
class Flow:
    """A trajectory and its sensitivity on a grid."""

    t: np.ndarray  # (K,) s
    x: np.ndarray  # (K, 2n) state (q, v)
    phi: np.ndarray  # (K, 2n, 2n) dx(t)/dx(0), row-major: phi[k, i, j] = dx_i(t_k) / dx_j(0)


_VAR_INTEGRATORS = Memo(maxsize=32)  # bounded: one per system, parameter set and precision (issue 36)


def variational_integrator(system: System, precision: str) -> Taylor:
    hy = heyoka()

    key = (system.name, system.overrides, param_key(system), system.equations, precision)  # the module, not its id

    def make() -> Taylor:
        dyn = symbolic_dynamics(system)
        fp = {"double": float, "long double": np.longdouble}[precision]
        vsys = hy.var_ode_sys(dyn.ode, hy.var_args.vars, order=1)
        return hy.taylor_adaptive(
            vsys,
            np.zeros(2 * dyn.n, dtype=fp),
            fp_type=fp,
            pars=np.zeros(dyn.n, dtype=fp),
            compact_mode=True,
            opt_level=1,
        )

    return _VAR_INTEGRATORS.get(key, make)


def reset_variational(ta: Taylor, n: int, x0: np.ndarray, tau: np.ndarray, t0: float, tangent: np.ndarray) -> None:
    dtype = ta.state.dtype
    ta.time = dtype.type(t0)
    ta.state[: 2 * n] = np.asarray(x0, dtype=float).astype(dtype)
    ta.state[2 * n :] = np.asarray(tangent, dtype=float).astype(dtype).ravel()
    ta.pars[:] = np.asarray(tau, dtype=float).astype(dtype)


def flow(
    system: System,
    start: Start,
    t: np.ndarray,
    *,
    precision: str = "double",
    budget: Budget = DEFAULT_BUDGET,
) -> Flow:
    """The trajectory and Phi(t) = dx(t)/dx(0) on the grid `t` (starting at t[0]).

    Raises IntegrationStopped (a HarnessError) when the equations blow up or spend `budget`."""
    q0, v0, tau = start.q0, start.v0, start.tau
    n = system.nv
    ta = variational_integrator(system, precision)
    x0 = np.concatenate([np.asarray(q0, dtype=float), np.asarray(v0, dtype=float)])
    reset_variational(ta, n, x0, np.asarray(tau, dtype=float), float(t[0]), np.eye(2 * n))
    guard = TaylorGuard(budget, n, float(t[0]))
    outcome, *_, states = ta.propagate_grid(np.asarray(t, dtype=float).astype(ta.state.dtype), callback=guard)
    guard.check(outcome, ta, source="hand", method=f"heyoka variational flow, {precision}")
    states = states.astype(float)
    return Flow(np.asarray(t, dtype=float), states[:, : 2 * n], states[:, 2 * n :].reshape(-1, 2 * n, 2 * n))


def _rows(n: int, rows: str) -> slice:
    return {"q": slice(0, n), "v": slice(n, 2 * n), "all": slice(0, 2 * n)}[rows]


def spectral_norm(a: np.ndarray) -> np.ndarray:
    """||a||_2 for a stack (..., r, c), via the largest eigenvalue of the smaller Gram matrix (in closed
    form for a 1x1 or 2x2 one: (g11 + g22)/2 + hypot((g11 - g22)/2, g12), no cancellation; LAPACK's
    eigvalsh beyond)."""
    g = a @ np.swapaxes(a, -1, -2) if a.shape[-2] <= a.shape[-1] else np.swapaxes(a, -1, -2) @ a
    if g.shape[-1] == 1:
        largest = g[..., 0, 0]
    elif g.shape[-1] == 2:
        half_sum, half_diff = (g[..., 0, 0] + g[..., 1, 1]) / 2, (g[..., 0, 0] - g[..., 1, 1]) / 2
        largest = half_sum + np.hypot(half_diff, g[..., 0, 1])
    else:
        largest = np.linalg.eigvalsh(g)[..., -1]
    return np.sqrt(np.maximum(largest, 0.0))


def inverse(phi: np.ndarray) -> np.ndarray:
    """Phi^-1 for a stack; a damped flow contracts phase volume (det Phi = exp(-int tr(M^-1 D) dt)),
    so over long runs Phi can become singular in double precision: there the pseudo-inverse stands
    in (it drops the directions the damping has already erased, which no error can grow along)."""
    try:
        return np.linalg.inv(phi)
    except np.linalg.LinAlgError:
        return np.linalg.pinv(phi)


def amplification(fl: Flow, *, rows: str = "q") -> np.ndarray:
    """A(t_k) = ||P Phi(t_k)||_2, (K,): the largest error in the `rows` part per unit initial error."""
    n = fl.x.shape[1] // 2
    return spectral_norm(fl.phi[:, _rows(n, rows), :])


def transfer_norms(fl: Flow, *, rows: str = "q") -> np.ndarray:
    """G[k, j] = ||P Phi(t_k) Phi(t_j)^-1||_2 for j <= k, 0 above the diagonal, (K, K)."""
    n = fl.x.shape[1] // 2
    inv = inverse(fl.phi)
    head = fl.phi[:, _rows(n, rows), :]  # P Phi(t_k), (K, r, 2n)
    size = len(fl.t)
    g = np.zeros((size, size))
    block = max(1, 2**20 // (size * head.shape[1] * head.shape[2]))  # rows of G at once: ~8 MB of products
    for start in range(0, size, block):
        stop = min(size, start + block)
        # rows start..stop-1 need the columns up to stop-1 only; the ones above the diagonal are zeroed
        g[start:stop, :stop] = spectral_norm(head[start:stop, None] @ inv[None, :stop])
    return np.tril(g)


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
    pulled_back = np.einsum("kij,kj->ki", inverse(fl.phi[1:]), w)
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
    until: float | None = None,
) -> Judgement:
    """Whether a free-running error stays inside safety x envelope up to the predictability horizon
    (and no later than `until`, where another prediction ends: a mirror's, where its scheme's own
    truncation error leaves the tolerance and the reference's flow no longer bounds how the scheme
    amplifies a difference).

    Returns {"passed", "horizon" (s or None = whole grid), "judged_until" (s), "safety",
    "max_ratio" (largest error / envelope within the horizon), "first_violation" (s or None)}.
    """
    horizon = predictability_horizon(t, envelope, tolerance)
    if until is not None:
        horizon = until if horizon is None else min(horizon, until)
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


def sample_at(t: np.ndarray, y: np.ndarray, at: tuple[float, ...] = (1.0, 2.0, 5.0, 10.0)) -> dict[str, float]:
    out = {}
    for s in at:
        k = int(np.argmin(np.abs(t - s)))
        if abs(t[k] - s) < 1e-9:
            out[f"{s:g} s"] = float(y[k])
    return out


def horizon_from_rounding(
    system: System,
    start: Start,
    *,
    tolerance: float = DEFAULT_TOLERANCE,
    t_end: float = 200.0,
    dt_out: float = 0.1,
) -> RoundingHorizon:
    """Predictability horizon of the initial state's own rounding (e0 = 2^-53 |x0|): the best any double
    precision integration can do. Phi from the variational equations in long double."""
    q0, v0, tau = start.q0, start.v0, start.tau
    x0 = np.concatenate([np.asarray(q0, dtype=float), np.asarray(v0, dtype=float)])
    e0 = float(np.finfo(float).eps) / 2 * max(float(np.linalg.norm(x0)), 1.0)
    t = time_grid(t_end, dt_out)
    precision = "long double" if np.finfo(np.longdouble).eps < 1e-18 else "double"
    # In chunks, stopping at the first chunk where the envelope reaches the tolerance: the horizon is
    # the first crossing, and the chaotic systems cross it halfway (~100 s of the 200).
    n, chunk = system.nv, HORIZON_CHUNK
    ta = variational_integrator(system, precision)
    reset_variational(ta, n, x0, np.asarray(tau, dtype=float), float(t[0]), np.eye(2 * n))
    guard = TaylorGuard(DEFAULT_BUDGET, n, float(t[0]))
    horizon = None
    for first in range(0, max(len(t) - 1, 1), chunk):
        grid = t[first : first + chunk + 1]  # each chunk starts where the last ended
        outcome, *_, states = ta.propagate_grid(grid.astype(ta.state.dtype), callback=guard)
        guard.check(outcome, ta, source="hand", method=f"heyoka variational flow, {precision}")
        phi = states.astype(float)[:, 2 * n :].reshape(-1, 2 * n, 2 * n)
        horizon = predictability_horizon(grid, e0 * spectral_norm(phi[:, :n, :]), tolerance)
        if horizon is not None:
            break
    return {"e0": e0, "tolerance": tolerance, "horizon": horizon, "t_end": t_end}

"""Trajectories of each source on a common time grid.

scipy integrates the hand equations and Pinocchio's ABA; MuJoCo steps its own integrator. Loops
are driven by step counts, never by accumulated time, so every sample falls on the grid exactly.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, TypedDict, TypeVar

import numpy as np

from ..core.arrays import Floats
from ..core.errors import HarnessError, unknown_name
from ..model.start import Start
from ..sources.base import MUJOCO_INTEGRATORS as MUJOCO_INTEGRATORS  # re-exported: dynamics names them
from ..sources.base import RightHandSide, Source, SteppedSource
from ..systems import System


class ScipyOptions(TypedDict):
    """A scipy integration: `scipy_trajectory`'s method (a solve_ivp method or "odeint") and tolerances."""

    method: str
    rtol: float
    atol: float


class Outcome(TypedDict):
    """How a guarded integration ended (`outcome`): "ok" or why not, and the last good sample's time (s)."""

    status: str
    stopped_at: float
    reason: str


class RunStats(TypedDict, total=False):
    """What a run says of itself: its steps and right-hand-side evaluations, how it ended (`Outcome`'s
    keys), why the fast path stood aside (dynamics/fast.py) and its label (a perturbed start)."""

    steps: int | None  # None: a cached reference that did not record them
    nfev: int
    evaluations: int
    status: str
    stopped_at: float
    reason: str
    fast_path: str
    label: str


R = TypeVar("R")  # what a right-hand side returns (an array, or the generated code's list)

DEFAULT_T_END = 10.0  # s
DEFAULT_DT_OUT = 0.01  # s
# The default scipy integration: the compiled LSODA driver (`odeint`), the fastest scipy driver to
# 1e-9 rad at t = 2 s on the double pendulum (`lagrange-xval bench` measures it against the others).
SCIPY_DEFAULT: ScipyOptions = {"method": "odeint", "rtol": 1e-11, "atol": 1e-14}


def mujoco_integrator(name: str) -> Any:
    """MuJoCo's enum value for an integrator name; an unknown name lists the valid ones."""
    from ..sources.mujoco import integrator_enum

    return integrator_enum(name)


@dataclass
class Trajectory:
    source: str  # "hand", "mujoco" or "pinocchio"
    method: str  # how it was integrated, for the report
    t: np.ndarray  # (K,) s
    q: np.ndarray  # (K, n) rad
    v: np.ndarray  # (K, n) rad/s
    stats: RunStats = field(default_factory=lambda: RunStats())  # e.g. right-hand-side evaluations

    @property
    def label(self) -> str:
        return f"{self.source} ({self.method})"


def initial_state(system: System) -> tuple[np.ndarray, np.ndarray]:
    """The module's INITIAL_STATE (the notes' experiment) or a generic 0.5 rad, at rest."""
    q0, v0 = getattr(system.equations, "INITIAL_STATE", (np.full(system.nv, 0.5), np.zeros(system.nv)))
    return np.asarray(q0, dtype=float), np.asarray(v0, dtype=float)


def output_grid(t_end: float, dt_out: float, timestep: float) -> tuple[float, float]:
    """(t_end, dt_out) for a model stepping at `timestep`: `dt_out`, or where the timestep does not
    divide it (a published model stepping at 0.02 s), the smallest whole multiple of the timestep at
    least as long (MuJoCo's runs are sampled every whole number of steps); t_end a whole number of them."""
    steps = dt_out / timestep
    if not (steps >= 1 and np.isclose(steps, round(steps), rtol=1e-9, atol=0.0)):
        dt_out = float(timestep * max(1, int(np.ceil(steps - 1e-9))))
    return dt_out * max(1, round(t_end / dt_out)), dt_out


def time_grid(t_end: float, dt_out: float) -> np.ndarray:
    samples = round(t_end / dt_out)
    if samples < 1 or not np.isclose(samples * dt_out, t_end, rtol=1e-12, atol=0.0):
        raise HarnessError(f"--t-end ({t_end}) must be a positive whole multiple of --dt-out ({dt_out}).")
    return np.arange(samples + 1) * dt_out


# ----------------------------------------------------------------------------------------------
# Budgets: a wrong derivation is the normal input, so every integration is bounded and its end is
# reported as a finding (Trajectory.stats["status"]), never raised.

STATUSES = ("ok", "diverged", "stopped: budget", "failed")
WALL_TIME_STOP = "stopped: budget: wall time"  # how a reason starts where the wall-time budget stopped a run


def wall_time_stop(stats: Mapping[str, object]) -> float | None:
    """Where the harness's wall-time budget stopped a run (s, its last good sample), or None. That budget
    guards against a slow source; a loaded machine can spend it on a right derivation, so its stop is no
    evidence about the equations (the evaluation budget's is: a wrong derivation spends it)."""
    if stats.get("status") != "stopped: budget" or not str(stats.get("reason", "")).startswith(WALL_TIME_STOP):
        return None
    stop = stats["stopped_at"]
    return float(stop) if isinstance(stop, int | float) else None


@dataclass(frozen=True, kw_only=True)
class Budget:
    """What one integration may spend before it is stopped and reported.

    The defaults were measured on the five systems of the notes (every scipy, Taylor and mirror
    integration `run` and `stress` do, 2026-11) and sit far above all of them:

    max_rhs_evaluations  largest measured: 12,095 (double_pendulum_bars, DOP853 rtol 1e-12, 10 s); the
                         default odeint run <= 7,058, the notes' experiments <= 3,968, stress's stiff
                         reference (gimbal damping x1000, DOP853, 2 s) 4,889. 200,000 is 16x the largest;
                         the gimbal with friction of the wrong sign spends it by t = 7.2 s (~2 s of CPU).
    max_taylor_steps     Taylor steps allowed at the start of a heyoka integration, plus
    taylor_steps_per_s   this many per simulated second since (the step density of a blow-up grows
                         without bound). Largest measured: 461 steps over 10 s (the references, 46/s)
                         and 20,737 over the 500 s Lyapunov run (double_pendulum_point, 41/s): the
                         allowance, 10,000 + 1,000/s, is 20x the density and 20x the 10 s total.
    max_wall_s           slowest guarded correct integration: 3.2 s (double_pendulum_bars, variational
                         flow in long double over 200 s); 60 s is ~20x, a guard for slow sources only.
    max_abs_state        largest measured |q| 15 rad and |v| 75 rad/s (the notes' wrong printed forms
                         included; stress starts at 50 rad/s): a state beyond 1e6 has blown up.

    Fixed-step runs (the mirrors) do a known number of evaluations (steps x stages), so only the
    wall time and the blow-up bound apply to them. For a horizon far beyond the harness's 10 s,
    `scaled(t_end / DEFAULT_T_END)` keeps the same evaluations per simulated second.
    """

    max_rhs_evaluations: int = 200_000
    max_taylor_steps: int = 10_000
    taylor_steps_per_s: float = 1_000.0  # 1/s
    max_wall_s: float = 60.0  # s
    max_abs_state: float = 1e6  # rad and rad/s

    def scaled(self, factor: float) -> Budget:
        """The evaluation, step and wall-time allowances times `factor` (at least 1); the bound unchanged."""
        k = max(float(factor), 1.0)
        return replace(
            self,
            max_rhs_evaluations=int(self.max_rhs_evaluations * k),
            max_taylor_steps=int(self.max_taylor_steps * k),
            max_wall_s=self.max_wall_s * k,
        )


DEFAULT_BUDGET = Budget()

# What a derivation's arithmetic raises: ZeroDivisionError and OverflowError (ArithmeticError) from the
# generated `math` code, math domain errors and numpy's LinAlgError (ValueError). Anything else (a
# KeyboardInterrupt, a caller's own stop signal) passes through.
EQUATION_ERRORS: tuple[type[BaseException], ...] = (ArithmeticError, ValueError)
_CHECK_EVERY = 256  # evaluations between wall-time and blow-up checks
_RING_MASK = 255  # odeint keeps its last 256 evaluation times: far more than one step's attempts


class _Stop(Exception):
    """Ends an integration from inside its right-hand side."""

    def __init__(self, kind: str, t: float, y: np.ndarray, detail: str) -> None:
        super().__init__(detail)
        self.kind, self.t, self.y, self.detail = kind, float(t), np.array(y, dtype=float, copy=True), detail


class _Guard:
    """Counts right-hand-side evaluations and stops the integration past its budget or on a blow-up.

    The wrapped function is a closure over plain ints (one comparison and one increment per call,
    ~1.5 % of the default run; odeint's ring of evaluation times another ~3 %); the wall clock and
    the state are checked every _CHECK_EVERY evaluations.
    """

    def __init__(self, budget: Budget) -> None:
        self.budget = budget
        self.deadline = time.perf_counter() + budget.max_wall_s
        self.ring = [math.nan] * (_RING_MASK + 1)  # the latest evaluation times (odeint: its last good output)
        self._count: Callable[[], int] = lambda: 0

    @property
    def nfev(self) -> int:
        return self._count()

    def check(self, nfev: int, t: float, y: np.ndarray) -> int:
        """Before evaluating at (t, y): raises _Stop past the budget or on a blow-up, else the next checkpoint."""
        b = self.budget
        if nfev >= b.max_rhs_evaluations:
            raise _Stop("evaluations", t, y, f"{b.max_rhs_evaluations} right-hand-side evaluations")
        if time.perf_counter() > self.deadline:
            raise _Stop("wall", t, y, f"wall time {b.max_wall_s:g} s")
        largest = float(np.max(np.abs(y)))
        if not largest <= b.max_abs_state:
            what = "a non-finite state" if not np.isfinite(largest) else f"|x| = {largest:.3g} > {b.max_abs_state:g}"
            raise _Stop("bound", t, y, what)
        return min(nfev + _CHECK_EVERY, b.max_rhs_evaluations)

    def wrap(self, f: Callable[..., R], *args: object, record_times: bool = False) -> Callable[[float, np.ndarray], R]:
        """f(t, y, *args) guarded; one extra argument (the hand equations' tau) is passed without unpacking."""
        nfev = 0
        checkpoint = min(_CHECK_EVERY, self.budget.max_rhs_evaluations)
        check = self.check

        def count() -> int:
            return nfev

        self._count = count
        if len(args) > 1:
            raise TypeError("wrap passes at most one extra argument")
        if not args:  # engines' right-hand sides: one more call layer, ~1 % of their cost
            inner = f
            f, args = (lambda t, y, _: inner(t, y)), (None,)
        if record_times:  # the last _RING evaluation times, in a ring (no allocation)
            (arg,) = args
            ring = self.ring

            def g1(t: float, y: np.ndarray) -> R:
                nonlocal nfev, checkpoint
                if nfev >= checkpoint:
                    checkpoint = check(nfev, t, y)
                ring[nfev & 255] = t  # _RING_MASK as a literal
                nfev += 1
                try:
                    return f(t, y, arg)
                except EQUATION_ERRORS as exc:
                    raise _Stop("raised", t, y, _exception_line(exc)) from exc

            return g1
        (arg,) = args

        def g2(t: float, y: np.ndarray) -> R:
            nonlocal nfev, checkpoint
            if nfev >= checkpoint:
                checkpoint = check(nfev, t, y)
            nfev += 1
            try:
                return f(t, y, arg)
            except EQUATION_ERRORS as exc:
                raise _Stop("raised", t, y, _exception_line(exc)) from exc

        return g2


def _exception_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__


def _fmt(x: Floats) -> str:
    return "[" + ", ".join(f"{float(v):.6g}" for v in np.ravel(x)) + "]"


def source_rhs(source: Source, tau: np.ndarray) -> RightHandSide:
    """scipy's right-hand side f(t, y) for constant `tau`: the source's own one-state `rhs` where it
    has one (the hand equations' generated code, Pinocchio's ABA), else its batched forward dynamics."""
    if hasattr(source, "rhs"):
        return source.rhs(tau)  # type: ignore[no-any-return]
    n = len(tau)

    def h(t: float, y: np.ndarray) -> np.ndarray:
        a = source.forward(y[None, :n], y[None, n:], tau[None])[0]
        return np.concatenate([y[n:], a])

    return h


@dataclass
class Integration:
    """The raw outcome of one guarded scipy integration on a grid."""

    y: np.ndarray  # (K, m): the samples, NaN after the last good one
    good: int  # samples 0..good-1 are the solver's own
    nfev: int
    stop: _Stop | None  # the budget, blow-up or exception that ended it early
    failure: str | None  # the solver's own message when it gave up
    failure_t: float | None  # s, where it gave up
    failure_y: np.ndarray | None


def integrate_rhs(
    f: Callable[..., Floats],
    y0: np.ndarray,
    t: np.ndarray,
    *,
    method: str,
    rtol: float,
    atol: float,
    budget: Budget = DEFAULT_BUDGET,
    args: tuple[object, ...] = (),
) -> Integration:
    """scipy on `f(t, y, *args)` (at most one extra argument) over the grid `t` under `budget`; never
    raises for anything `f` computes.

    `method` is a `solve_ivp` method (integrated by the same step loop as `solve_ivp` with `t_eval`,
    so the samples are identical to solve_ivp's) or "odeint" (the compiled LSODA driver: stopped by an
    exception from the right-hand side, then rerun up to its last good output, which LSODA reproduces
    step for step).
    """
    t = np.asarray(t, dtype=float)
    y0 = np.asarray(y0, dtype=float)
    with np.errstate(all="ignore"):
        if method == "odeint":
            return _odeint(f, args, y0, t, rtol=rtol, atol=atol, budget=budget)
        return _solve_ivp(f, args, y0, t, method=method, rtol=rtol, atol=atol, budget=budget)


def _odeint(
    f: Callable[..., Floats],
    args: tuple[object, ...],
    y0: np.ndarray,
    t: np.ndarray,
    *,
    rtol: float,
    atol: float,
    budget: Budget,
) -> Integration:
    import warnings

    from scipy.integrate import odeint

    guard = _Guard(budget)
    g = guard.wrap(f, *args, record_times=True)
    kw: dict[str, bool | float | int] = {
        "tfirst": True,
        "rtol": rtol,
        "atol": atol,
        "full_output": True,
        "mxstep": 100000,
    }
    out = np.full((len(t), len(y0)), np.nan)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # odeint warns on failure; the message is in info
            y, info = odeint(g, y0, t, **kw)
    except _Stop as stop:
        # odeint returns nothing when the right-hand side raises (it stops at once). Its outputs
        # before the stop are those whose time LSODA had passed: the last accepted step ended at the
        # latest earlier evaluation time below every later one (rejected and current attempts all
        # lie beyond it). A rerun to that output takes the same steps (the first step depends on
        # t[1] only) and ends before the stop.
        reached = _last_accepted(guard, stop.t)
        good = int(np.searchsorted(t, reached, side="right")) if np.isfinite(reached) else 1
        good = max(1, min(good, len(t)))
        out[0] = y0
        back = 1
        while good >= 2:
            rerun = _Guard(replace(budget, max_rhs_evaluations=guard.nfev, max_wall_s=2 * budget.max_wall_s))
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    y2, _ = odeint(rerun.wrap(f, *args), y0, t[:good], **kw)
            except _Stop:  # the output was not reached after all: step back, further each time
                good, back = max(1, good - back), 2 * back
                continue
            out[:good] = y2
            break
        return Integration(out, good, guard.nfev, stop, None, None, None)
    if info["message"] == "Integration successful.":
        return Integration(y, len(t), guard.nfev, None, None, None, None)
    tcur = np.concatenate([[t[0]], np.asarray(info["tcur"], dtype=float)])
    reached_all = tcur >= t
    good = int(np.argmin(reached_all)) if not reached_all.all() else len(t)
    out[:good] = y[:good]
    failure_t = float(tcur[good]) if good < len(t) else float(t[-1])
    failure_y = np.asarray(y[good], dtype=float) if good < len(t) else None
    return Integration(out, good, guard.nfev, None, str(info["message"]), failure_t, failure_y)


def _last_accepted(guard: _Guard, stopped_at: float) -> float:
    """The end of LSODA's last accepted step before a stop at `stopped_at`: the latest recorded
    evaluation time below every later one (-inf if none is)."""
    k = guard.nfev  # the ring holds evaluations k-256 .. k-1, oldest first after rotation
    ring = guard.ring[k & _RING_MASK :] + guard.ring[: k & _RING_MASK] if k > _RING_MASK else guard.ring[:k]
    times = [s for s in ring if s == s]
    reached, later = -np.inf, stopped_at
    for s in reversed(times):
        if s < later:  # below every later evaluation: the end of the last accepted step
            reached = s
            break
        later = min(later, s)
    return reached


def _solve_ivp(
    f: Callable[..., Floats],
    args: tuple[object, ...],
    y0: np.ndarray,
    t: np.ndarray,
    *,
    method: str,
    rtol: float,
    atol: float,
    budget: Budget,
) -> Integration:
    """`solve_ivp(f, (t[0], t[-1]), y0, method=method, t_eval=t, rtol=rtol, atol=atol)`'s own loop,
    keeping the samples before a stop (solve_ivp drops them when the right-hand side raises)."""
    from scipy.integrate._ivp.ivp import METHODS

    if method not in METHODS:
        raise unknown_name("scipy method", method, ("odeint", *METHODS))
    guard = _Guard(budget)
    g = guard.wrap(f, *args)
    out = np.full((len(t), len(y0)), np.nan)
    good = 0
    stop: _Stop | None = None
    failure = failure_t = failure_y = None
    try:
        solver = METHODS[method](g, float(t[0]), y0, float(t[-1]), vectorized=False, rtol=rtol, atol=atol)
        i = 0
        while True:
            message = solver.step()
            if solver.status == "failed":
                failure, failure_t, failure_y = str(message), float(solver.t), np.array(solver.y, dtype=float)
                break
            i_new = int(np.searchsorted(t, solver.t, side="right"))
            if i_new > i:
                out[i:i_new] = solver.dense_output()(t[i:i_new]).T
                good = i = i_new
            if solver.status == "finished":
                break
    except _Stop as exc:
        stop = exc
    except EQUATION_ERRORS as exc:  # inside the solver on what the equations returned (e.g. NaN in Radau's LU)
        failure = _exception_line(exc)
        failure_t = float(t[good - 1]) if good else float(t[0])
    if good == 0:  # stopped within the first step: the start is all there is (solve_ivp's t[0] sample is y0)
        out[0], good = y0, 1
    return Integration(out, good, guard.nfev, stop, failure, failure_t, failure_y)


def outcome(
    integration: Integration,
    t: np.ndarray,
    *,
    budget: Budget,
    equations: str,
    solver: str,
    mass_matrix: Callable[[np.ndarray], np.ndarray] | None = None,
    n: int,
) -> Outcome:
    """status, stopped_at, reason of a guarded integration, after truncating its samples in place at
    the first non-finite or blown-up sample. `mass_matrix` (q -> M, batched) names a singular or
    indefinite M(q) in the reason."""
    y, good = integration.y, integration.good
    with np.errstate(invalid="ignore"):
        bad = ~(np.abs(y[:good]) <= budget.max_abs_state).all(axis=1)
    diverged_at = int(np.argmax(bad)) if bad.any() else None
    status, reason = "ok", ""
    stop = integration.stop
    if diverged_at is not None:
        k = diverged_at
        what = "a non-finite state" if not np.isfinite(y[k]).all() else f"|x| > {budget.max_abs_state:g}"
        status, reason = "diverged", f"diverged at t = {t[k]:.6g} s: {what} (x = {_fmt(y[k])})"
        good = k
    elif stop is not None and (stop.kind == "bound" or stop.detail.startswith("OverflowError")):
        status, reason = "diverged", f"diverged at t = {stop.t:.6g} s: {stop.detail} (x = {_fmt(stop.y)})"
    elif stop is not None and stop.kind in ("evaluations", "wall"):
        status, reason = "stopped: budget", f"stopped: budget: {stop.detail} spent by t = {stop.t:.6g} s"
    elif stop is not None:
        status = "failed"
        reason = f"the {equations} raised {stop.detail} at t = {stop.t:.6g} s, x = {_fmt(stop.y)}"
    elif integration.failure is not None:
        status = "failed"
        reason = f"{solver} gave up at t = {integration.failure_t:.6g} s: {integration.failure}"
    elif good < len(t):
        status, reason = "failed", f"{solver} stopped at t = {t[max(good - 1, 0)]:.6g} s"
    y[good:] = np.nan
    stopped_at = float(t[good - 1]) if good else float(t[0])
    if status != "ok" and mass_matrix is not None:  # a singular or indefinite M is the likely cause: say so first
        finding = _mass_matrix_finding(mass_matrix, t[:good], y[:good, :n], stop, integration, n)
        if finding:
            reason = f"{finding}; {reason}"
    return {"status": status, "stopped_at": stopped_at, "reason": reason}


SINGULAR_COND = 1.0 / (1e3 * np.finfo(float).eps)  # cond(M) beyond which M is singular to working precision
NEAR_SINGULAR_COND = 1e8  # at the state where an integration broke down: nearly singular, the likely cause


def _mass_matrix_finding(
    mass_matrix: Callable[[np.ndarray], np.ndarray],
    ts: np.ndarray,
    qs: np.ndarray,
    stop: _Stop | None,
    integration: Integration,
    n: int,
) -> str | None:
    """The first sample (or else the breakdown state) where M(q) is not finite, not positive definite
    or singular, as one line; None when M is fine there. Never raises."""
    try:
        end_y = stop.y if stop is not None else integration.failure_y
        end_t = stop.t if stop is not None else integration.failure_t
        cands: list[tuple[np.ndarray, np.ndarray, float]] = [(ts, qs, float(SINGULAR_COND))]
        if end_y is not None and end_t is not None and np.isfinite(end_y[:n]).all():
            cands.append((np.array([end_t]), np.asarray(end_y[:n])[None], NEAR_SINGULAR_COND))
        for times, q, limit in cands:
            if not len(q):
                continue
            with np.errstate(all="ignore"):
                M = np.asarray(mass_matrix(q), dtype=float).reshape(len(q), n, n)
                finite = np.isfinite(M).all(axis=(1, 2))
                sym = np.where(finite[:, None, None], (M + np.swapaxes(M, 1, 2)) / 2, np.eye(n))
                eig = np.linalg.eigvalsh(sym)
            lo, hi = eig[:, 0], np.abs(eig).max(axis=1)
            bad = ~finite | (lo <= 0) | (lo * limit < hi)
            if bad.any():
                k = int(np.argmax(bad))
                if not finite[k]:
                    what = "not finite"
                elif lo[k] <= 0 and lo[k] < -hi[k] / limit:
                    what = f"not positive definite (eigenvalues {_fmt(eig[k])})"
                else:
                    what = f"singular (eigenvalues {_fmt(eig[k])})"
                return f"M(q) is {what} at t = {times[k]:.6g} s, q = {_fmt(q[k])}"
    except Exception:  # noqa: BLE001 - a diagnosis must never replace the finding it explains
        return None
    return None


def scipy_trajectory(
    system: System,
    source: Source,
    start: Start,
    t: np.ndarray,
    *,
    method: str = "DOP853",
    rtol: float = 1e-12,
    atol: float = 1e-12,
    budget: Budget = DEFAULT_BUDGET,
) -> Trajectory:
    """scipy on a source's forward dynamics (the hand equations or Pinocchio's ABA): a `solve_ivp`
    method, or "odeint" for the compiled LSODA driver.

    Never raises for anything the equations compute: `stats` holds "nfev", "status" (one of
    STATUSES), "stopped_at" (s, the last good sample; t[-1] when "ok") and "reason" (one line, empty
    when "ok"); the samples after "stopped_at" are NaN.
    """
    q0, v0, tau = start.q0, start.v0, start.tau
    n = system.nv
    f = source_rhs(source, tau)
    y0 = np.concatenate([q0, v0])
    run = integrate_rhs(f, y0, t, method=method, rtol=rtol, atol=atol, budget=budget)
    label = f"scipy {method}"
    mass = source.mass_matrix  # to say "singular M" where a run fails
    ended = outcome(run, t, budget=budget, equations=f"{source.name} equations", solver=label, mass_matrix=mass, n=n)
    stats: RunStats = {"nfev": run.nfev, **ended}
    return Trajectory(
        source.name,
        f"{label} rtol {rtol:g}",
        np.asarray(t, dtype=float).copy(),
        run.y[:, :n].copy(),
        run.y[:, n:].copy(),
        stats,
    )


def mujoco_trajectory(
    system: System,
    source: SteppedSource,
    start: Start,
    t: np.ndarray,
    *,
    integrator: str = "RK4",
    timestep: float | None = None,
) -> Trajectory:
    """MuJoCo stepping its own integrator; samples every round(dt_out / timestep) steps. A run that
    went unstable (a warning, after which MuJoCo resets the state, or a non-finite state) raises
    Diverged naming the interval: its samples are never data."""
    from ..model.start import Scheme
    from ..sources.mujoco import free_run

    dt = float(timestep or source.m.opt.timestep)
    dt_out = t[1] - t[0] if len(t) > 1 else dt
    steps = round(dt_out / dt)
    if steps < 1 or not np.isclose(steps * dt, dt_out, rtol=1e-9, atol=0.0):
        raise HarnessError(f"MuJoCo timestep {dt} must divide the output step {dt_out}.")
    q, v, clock, raised = free_run(source, start, len(t), steps, Scheme(integrator, dt))
    # The first sample whose clock fell behind or whose state is not finite, or the last if only a
    # warning counter says so (checked once, after the loop: per sample it cost a tenth of the stepping).
    behind = np.abs(clock - (clock[0] + np.arange(len(t)) * steps * dt)) > 0.5 * dt
    broken = behind | ~np.all(np.isfinite(q), axis=1) | ~np.all(np.isfinite(v), axis=1)
    if broken.any() or raised:
        k = max(int(np.argmax(broken)) if broken.any() else len(t) - 1, 1)
        _diverged(system, integrator, dt, t, k, q[k], v[k], raised)
    return Trajectory("mujoco", f"MuJoCo {integrator} dt {dt:g}", t.copy(), q, v, {"steps": steps * (len(t) - 1)})


class Diverged(HarnessError):
    """A run that went unstable: its samples from here on are not data."""


def _diverged(
    system: System,
    integrator: str,
    dt: float,
    t: np.ndarray,
    k: int,
    q: Floats,
    v: Floats,
    raised: list[tuple[str, int]],
) -> None:
    """Refuses sample k of a MuJoCo run: one line naming the time and what went wrong."""
    names = [name for name, _ in raised]
    what = (
        f"MuJoCo warned {', '.join(names)} (bad {'/'.join(n.removeprefix('mjWARN_BAD').lower() for n in names)}"
        f", DOF {raised[0][1]}) and reset the state"
        if raised
        else f"q = {np.asarray(q).tolist()}, v = {np.asarray(v).tolist()} is not finite or was reset"
    )
    raise Diverged(
        f"{system.name}: MuJoCo {integrator} at dt {dt:g} diverged between t = {t[k - 1]:g} s and "
        f"t = {t[k]:g} s: {what}; nothing written."
    )


def energy(system: System, hand: Source, traj: Trajectory) -> np.ndarray:
    """Total energy T + V along a trajectory, by the hand equations (J)."""
    kin, pot = hand.energies(traj.q, traj.v)
    return kin + pot


def energy_missing(meter: object) -> str:
    """ "T not provided" (or V, or both) where the source that measures the energy leaves it out."""
    gone = set(getattr(meter, "not_provided", ()) or ())
    names = [x for x, f in (("T", "kinetic_energy"), ("V", "potential_energy")) if f in gone]
    return f"{' and '.join(names)} not provided" if names else ""


def error_against(traj: Trajectory, ref: Trajectory) -> np.ndarray:
    """max over coordinates of |q - q_ref| at each sample, rad."""
    return np.abs(traj.q - ref.q).max(axis=1)


def first_exceeding(t: np.ndarray, err: np.ndarray, threshold: float | np.ndarray) -> float | None:
    """The first sample time where err > threshold (a number, or one per sample), or None if it never does."""
    above = np.nonzero(err > threshold)[0]
    return float(t[above[0]]) if len(above) else None

"""Reference solutions: heyoka's Taylor integrator on the hand equations, in extended precision.

A trajectory judged over 10 s of a chaotic system needs a reference far more accurate than the
errors judged: DOP853 at rtol 1e-13 is only good to ~5e-10 rad after 10 s on the double pendulum.
Here the hand equations are integrated by a Taylor method in 80-bit long double at a tolerance of
its machine epsilon (1.1e-19), and the result is checked against a second run in quadruple precision
(real128, tol 1.9e-34, a different order and step sequence): their largest difference over the grid
is reported as the reference's measured accuracy (`info["agreement_q"]`).

The Taylor integrator needs the right-hand side as symbolic expressions. Nothing here is specific
to a system: the equations module's own `mass_matrix`, `bias` and `passive` are called with arrays
of heyoka variables (validate/handwritten/tracing.py: numpy object arrays, `np.sin` on them calls the element's
`.sin()`), and a ← M⁻¹ (tau + passive − bias) is formed by symbolic elimination (M is symmetric
positive definite, so no pivoting is needed). The module runs unmodified. The trace is
validated on every call against the numpy source (`info["rhs_check"]`: traced accelerations vs
`HandSource.forward` at random states, relative to their range).

Results are cached on disk (validate/core/cache.py: `.npz` named by a hash of everything that determines
them: system, overrides, parameters, the harness's and the equations' source, initial state, input,
time grid, heyoka version and precisions), so a second run only loads arrays. A loaded entry is
verified (checksum, key, schema), then checked like a fresh one: the trace against the numpy module
(`rhs_check`), finite values on the requested grid from the requested state, and every one of its
windows restarted from the stored states by RK4 (`window_check`), so an entry edited with a valid
checksum still cannot pass for the solution.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import time
import types
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias, TypedDict

import numpy as np

from .. import forms
from ..core import cache
from ..core.arrays import Floats
from ..core.cachedir import heyoka
from ..core.errors import HarnessError, IntegrationStopped, unknown_name
from ..core.memo import Memo
from ..handwritten import tracing
from ..handwritten.forms import accelerations_only
from ..model.start import Start
from ..sources.hand import HandSource
from ..systems import System
from .integrate import DEFAULT_BUDGET, Budget, Trajectory

if TYPE_CHECKING:  # heyoka is imported when first used (core/cachedir.heyoka)
    from heyoka import cfunc_dbl, expression, taylor_adaptive_dbl, taylor_adaptive_f128, taylor_adaptive_ldbl

# a compiled Taylor integrator in one of the precisions (PRIMARY, CHECK, double)
Taylor: TypeAlias = "taylor_adaptive_dbl | taylor_adaptive_ldbl | taylor_adaptive_f128"

CACHE_VERSION = 2  # bump when the cached content changes meaning
DEFAULT_CACHE_DIR = cache.DEFAULT  # the configured cache (validate/core/cache.py), "reference" folder
PRIMARY = "long double"
CHECK = "quad"
RHS_CHECK_TOLERANCE = 1e-12  # relative; the trace reproduces the numpy equations to a few ulps (~1e-15)
WINDOW_CHECK_STEP = 2.5e-4  # s: RK4 restarted in every stored window when a cached entry is read
# rad and rad/s over one window: RK4 at 2.5e-4 s is within 4e-11 on every system's 10 s reference; a
# forgery below this moves no verdict (the trajectory tier is 1e-6 rad)
WINDOW_CHECK_TOLERANCE = 1e-7
WINDOW_CHECK_HALVINGS = 6  # the check's step down to 2.5e-4 / 64 s (max |lambda| up to ~1e5 /s)


# ----------------------------------------------------------------------------------------------
# Symbolic trace of an equations module


@dataclass(frozen=True)
class SymbolicDynamics:
    """The hand equations as heyoka expressions: x' = rhs(x, tau), x = (q, v), tau = par[0:n]."""

    n: int
    state: tuple[expression, ...]  # (2n,) heyoka variables q0.., v0..
    rhs: tuple[expression, ...]  # (2n,) expressions: v, then a = M^-1 (tau + passive - bias)

    @property
    def ode(self) -> list[tuple[expression, expression]]:
        return list(zip(self.state, self.rhs, strict=True))


def param_key(system: System) -> tuple[tuple[str, str], ...]:
    return tuple((k, float(v).hex()) for k, v in sorted(vars(system.params).items()))


@functools.lru_cache(maxsize=64)  # one per parameter set: probes and overrides make many
def _symbolic(name: str, module: types.ModuleType, p: object, n: int) -> SymbolicDynamics:
    hy = heyoka()

    qs = [hy.expression(f"q{i}") for i in range(n)]
    vs = [hy.expression(f"v{i}") for i in range(n)]
    try:
        system = tracing.SystemParts(nv=n, equations=module, params=p)
        m, bias, passive = tracing.dynamics(system, qs, vs, tracing.heyoka_backend())
        f = [hy.par[i] + passive[i] - bias[i] for i in range(n)]
        a = tracing.solve_spd(m, f)
    except HarnessError:
        raise  # already one line naming the module's function and line (tracing.traced_call)
    except Exception as exc:
        raise HarnessError(
            f"equations/{name}.py: cannot trace mass_matrix/bias/passive symbolically for the Taylor "
            f"reference ({type(exc).__name__}: {exc}); only numpy arithmetic and elementary functions "
            f"are supported."
        ) from None
    return SymbolicDynamics(n=n, state=tuple(qs + vs), rhs=tuple(vs + a))


def symbolic_dynamics(system: System) -> SymbolicDynamics:
    """The system's hand equations as heyoka expressions (traced once per parameter set)."""
    return _symbolic(system.name, system.derivation, system.params, system.nv)


def rhs_check(system: System, *, n_states: int = 64, seed: int = 0) -> float:
    """max |a_traced - a_numpy| / max |a_numpy| at random states: the trace reproduces the module."""

    dyn = symbolic_dynamics(system)
    n = dyn.n
    rng = np.random.default_rng(seed)
    x = np.concatenate([rng.uniform(-np.pi, np.pi, (n_states, n)), rng.uniform(-5, 5, (n_states, n))], axis=1)
    tau = rng.uniform(-1, 1, (n_states, n))
    if accelerations_only(system.equations):  # traced at zero input only (the runs have none): forms.py
        tau = np.zeros_like(tau)
    cf = _cfunc(dyn)
    traced = np.asarray(cf(np.ascontiguousarray(x.T), pars=np.ascontiguousarray(tau.T))).T
    numpy_a = HandSource(system).forward(x[:, :n], x[:, n:], tau)
    scale = max(float(np.abs(numpy_a).max()), np.finfo(float).tiny)
    return float(np.abs(traced - numpy_a).max() / scale)


@functools.lru_cache(maxsize=64)  # one per SymbolicDynamics, as _symbolic (compiled code: a few MB each)
def _cfunc(dyn: SymbolicDynamics) -> cfunc_dbl:
    hy = heyoka()

    return hy.cfunc(list(dyn.rhs[dyn.n :]), list(dyn.state))


# ----------------------------------------------------------------------------------------------
# Taylor integration


def _fp_types() -> dict[str, type]:
    hy = heyoka()

    return {"double": float, "long double": np.longdouble, "quad": hy.real128}


def _extended_available() -> bool:
    return bool(np.finfo(np.longdouble).eps < 1e-18)  # 80-bit x87 (x86-64 Linux); double elsewhere


_INTEGRATORS = Memo(maxsize=64)  # bounded: one per system, parameter set, precision and tolerance (issue 36)


def taylor_integrator(system: System, precision: str, tol: float | None) -> Taylor:
    """A compiled heyoka integrator for the system (kept for the process; state reset per use)."""
    hy = heyoka()

    fp = _fp_types()[precision]
    # the module itself, not its id or name: a mutated module of the same name gets its own integrator
    key = (system.name, system.overrides, param_key(system), system.equations, precision, tol)

    def make() -> Taylor:
        dyn = symbolic_dynamics(system)
        state = np.zeros(2 * dyn.n, dtype=fp) if fp is not hy.real128 else np.array([hy.real128(0)] * 2 * dyn.n)
        pars = np.zeros(dyn.n, dtype=fp) if fp is not hy.real128 else np.array([hy.real128(0)] * dyn.n)
        # compact mode: compiling the unrolled Taylor code took 4 s in quad and 0.7 s in long double per
        # system (the whole of a cold run's extra time); compact code compiles in 0.2 s and runs as fast.
        kwargs: dict[str, object] = {"fp_type": fp, "pars": pars, "compact_mode": True, "opt_level": 1}
        if tol is not None:
            kwargs["tol"] = tol
        return hy.taylor_adaptive(dyn.ode, state, **kwargs)

    return _INTEGRATORS.get(key, make)


def _to_fp(x: np.ndarray, precision: str) -> np.ndarray:
    hy = heyoka()

    fp = _fp_types()[precision]
    x = np.asarray(x, dtype=float)
    return x.astype(hy.real128) if fp is hy.real128 else x.astype(fp)


class TaylorGuard:
    """A heyoka step callback bounding one integration (every propagate_* call it is passed to):
    stops it once its steps exceed `budget.max_taylor_steps + budget.taylor_steps_per_s * |t - t0|`
    (a blow-up's step density grows without bound), past `budget.max_wall_s`, or once a coordinate
    or velocity (the first 2n state entries) leaves `budget.max_abs_state` or is not finite.

    heyoka calls it after every step; returning False ends the propagation with outcome cb_stop
    (propagate_grid then returns the rows it reached). `why` says what stopped it.
    """

    def __init__(self, budget: Budget, n: int, t0: float = 0.0) -> None:
        self.budget, self.n, self.t0 = budget, n, float(t0)
        self.steps = 0
        self.deadline = time.perf_counter() + budget.max_wall_s
        self.why: str | None = None

    def __call__(self, ta: Taylor) -> bool:
        self.steps += 1
        b = self.budget
        if self.steps > b.max_taylor_steps:
            elapsed = abs(float(ta.time) - self.t0)
            if self.steps > b.max_taylor_steps + b.taylor_steps_per_s * elapsed:
                self.why = (
                    f"stopped: budget: {self.steps} Taylor steps in {elapsed:.4g} s (allowed "
                    f"{b.max_taylor_steps} + {b.taylor_steps_per_s:g}/s)"
                )
                return False
        if not self.steps % 64 and time.perf_counter() > self.deadline:
            self.why = f"stopped: budget: wall time {b.max_wall_s:g} s"
            return False
        largest = float(np.max(np.abs(np.asarray(ta.state[: 2 * self.n]).astype(float))))
        if largest <= b.max_abs_state:
            return True
        self.why = "diverged: a non-finite state" if not np.isfinite(largest) else f"diverged: |x| = {largest:.3g}"
        return False

    def check(self, outcome: object, ta: Taylor, *, source: str, method: str) -> None:
        """Raises IntegrationStopped unless a propagation's `outcome` reached its time limit."""
        if "time_limit" in str(outcome):
            return
        if self.why is not None:
            reason = self.why
        elif "err_nf_state" in str(outcome):
            reason = "diverged: a non-finite state"
        elif "step_limit" in str(outcome):
            reason = f"stopped: budget: {self.steps} Taylor steps"
        else:
            reason = f"stopped early ({outcome})"
        x = np.asarray(ta.state[: 2 * self.n]).astype(float)
        raise IntegrationStopped(source=source, method=method, t=float(ta.time), reason=f"{reason} (x = {x.tolist()})")


class TaylorRun(TypedDict):
    """How `taylor_solve` ran: its method in words, precision, tolerance and order, the Taylor steps
    taken and the seconds spent compiling and integrating."""

    method: str
    precision: str
    tolerance: float
    order: int
    steps: int
    compile_s: float
    integrate_s: float


def taylor_solve(
    system: System,
    q0: np.ndarray,
    v0: np.ndarray,
    tau: np.ndarray,
    t: np.ndarray,
    *,
    precision: str = PRIMARY,
    tol: float | None = None,
    budget: Budget = DEFAULT_BUDGET,
) -> tuple[np.ndarray, TaylorRun]:
    """The state (K, 2n) on the grid `t` by heyoka's Taylor method, in the precision's own dtype.

    `tol` defaults to heyoka's: the machine epsilon of the precision. Bounded by `budget` (steps,
    wall time, blow-up bound): equations that explode or break down raise IntegrationStopped (source,
    method, t, reason), never hang.
    """
    precisions = _fp_types()
    if precision not in precisions:
        raise unknown_name("precision", precision, precisions)
    t0 = time.perf_counter()
    ta = taylor_integrator(system, precision, tol)
    t1 = time.perf_counter()
    ta.time = _to_fp(np.array(t[0]), precision)[()]
    ta.state[:] = _to_fp(np.concatenate([q0, v0]), precision)
    ta.pars[:] = _to_fp(np.asarray(tau, dtype=float), precision)
    guard = TaylorGuard(budget, system.nv, float(t[0]))
    method = f"heyoka Taylor, {precision}"
    try:
        outcome, _min_h, _max_h, steps, _cb, states = ta.propagate_grid(
            _to_fp(np.asarray(t, dtype=float), precision), callback=guard
        )
    except (ArithmeticError, ValueError) as exc:  # e.g. a non-finite time after a blow-up
        raise IntegrationStopped(source="hand", method=method, t=float(ta.time), reason=f"{exc}") from None
    guard.check(outcome, ta, source="hand", method=method)
    t2 = time.perf_counter()
    return states, {
        "method": f"heyoka Taylor, {precision}, tol {float(ta.tol):.3g}, order {ta.order}",
        "precision": precision,
        "tolerance": float(ta.tol),
        "order": int(ta.order),
        "steps": int(steps),
        "compile_s": t1 - t0,
        "integrate_s": t2 - t1,
    }


def _difference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a - b| in float for states of two precisions, without rounding either to double first."""
    hy = heyoka()

    def as_quad(x: np.ndarray) -> np.ndarray:
        if x.dtype == np.dtype(hy.real128):
            return x
        hi = x.astype(float)
        lo = (x - hi).astype(float)  # long double = hi + lo exactly
        return hi.astype(hy.real128) + lo.astype(hy.real128)

    if a.dtype == b.dtype and a.dtype != np.dtype(hy.real128):
        return np.abs(a - b).astype(float)
    return np.abs((as_quad(a) - as_quad(b)).astype(float))


# ----------------------------------------------------------------------------------------------
# Cached reference


def source_hash(path: str | None) -> str:
    return hashlib.sha256(Path(path or "").read_bytes()).hexdigest() if path else ""


def cache_key(
    system: System, q0: np.ndarray, v0: np.ndarray, tau: np.ndarray, t: np.ndarray, *, check: str | None
) -> str:
    """Hash of everything the reference depends on."""
    hy = heyoka()

    blob = {
        "version": CACHE_VERSION,
        "system": system.name,
        "overrides": [[k, float(v).hex()] for k, v in system.overrides],
        "params": param_key(system),
        # What the equations compute, not where they came from: the traced right-hand side (a module
        # changed in memory, or two files of one name, never share an entry).
        "equations": hashlib.sha256(str(symbolic_dynamics(system).rhs).encode()).hexdigest(),
        "forms": source_hash(forms.__file__),
        "reference": source_hash(__file__),
        "harness": cache.harness_hash(),
        "heyoka": hy.__version__,
        "primary": PRIMARY if _extended_available() else CHECK,
        "check": check,
        "q0": [float(x).hex() for x in np.asarray(q0, dtype=float)],
        "v0": [float(x).hex() for x in np.asarray(v0, dtype=float)],
        "tau": [float(x).hex() for x in np.asarray(tau, dtype=float)],
        "t": hashlib.sha256(np.ascontiguousarray(t, dtype=float).tobytes()).hexdigest(),
    }
    return hashlib.sha256(json.dumps(blob, sort_keys=True).encode()).hexdigest()[:24]


def _check_inputs(system: System, q0: Floats, v0: Floats, tau: Floats, t: Floats) -> tuple[np.ndarray, ...]:
    n = system.nv
    arrays = []
    for name, x in (("q0", q0), ("v0", v0), ("tau", tau)):
        x = np.asarray(x, dtype=float)
        if x.shape != (n,):
            raise HarnessError(f"{name} must have shape ({n},) for {system.name}; got {x.shape}.")
        if not np.all(np.isfinite(x)):
            raise HarnessError(f"{name} has a non-finite entry: {x.tolist()}.")
        arrays.append(x)
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or len(t) < 2 or not np.all(np.diff(t) > 0):
        raise HarnessError("t must be an increasing 1-D grid of at least two times.")
    return (*arrays, t)


def reference_trajectory(
    system: System,
    start: Start,
    t: Floats,
    *,
    cache_dir: str | os.PathLike[str] | None = DEFAULT_CACHE_DIR,
    check: str | None = CHECK,
) -> tuple[Trajectory, dict[str, Any]]:
    """The hand equations' solution on the grid `t`, accurate far below any error judged.

    Args:
        system: a `System`.
        start: the (n,) initial state and constant input.
        t: (K,) increasing output times, s.
        cache_dir: where results are cached (None: no cache).
        check: precision of the second, independent run ("quad", "double", or None to skip).

    Returns:
        The trajectory (float64 arrays; `stats` holds the step count) and a JSON-able info dict:
        method, tolerance, order, check_method, agreement_q / agreement_v (max |difference| between
        the two runs over the grid, rad and rad/s), rhs_check, timing (s), cache ("hit"/"miss"/"off").
    """
    q0, v0, tau, t = _check_inputs(system, start.q0, start.v0, start.tau, t)
    began = time.perf_counter()
    n = system.nv
    where = cache.folder(cache_dir, "reference")
    path = key = None
    if where is not None:
        key = cache_key(system, q0, v0, tau, t, check=check)
        path = where / f"{system.name}-{key}.npz"
        hit = _cached_reference(system, path, key, q0, v0, tau, t, start=began)
        if hit is not None:
            return hit

    primary = PRIMARY if _extended_available() else CHECK
    states, meta = taylor_solve(system, q0, v0, tau, t, precision=primary)
    info: dict[str, Any] = {
        "method": meta["method"],
        "precision": primary,
        "tolerance": meta["tolerance"],
        "order": meta["order"],
        "steps": meta["steps"],
        "timing": {"compile_s": meta["compile_s"], "integrate_s": meta["integrate_s"]},
        "rhs_check": _checked_rhs(system),
    }
    if check is not None and check != primary:
        other, cmeta = taylor_solve(system, q0, v0, tau, t, precision=check)
        diff = _difference(states, other)
        info.update(
            check_method=cmeta["method"], agreement_q=float(diff[:, :n].max()), agreement_v=float(diff[:, n:].max())
        )
        info["timing"].update(check_compile_s=cmeta["compile_s"], check_integrate_s=cmeta["integrate_s"])
    else:
        info.update(check_method=None, agreement_q=None, agreement_v=None)
    x = states.astype(float)
    traj = Trajectory(
        "hand", f"reference: {info['method']}", t.copy(), x[:, :n].copy(), x[:, n:].copy(), {"steps": info["steps"]}
    )
    if not (np.all(np.isfinite(traj.q)) and np.all(np.isfinite(traj.v))):
        k = int(np.argwhere(~np.isfinite(np.hstack([traj.q, traj.v])))[0][0])
        raise HarnessError(f"{system.name}: the reference solution is not finite at t = {t[k]:g} s (heyoka {primary}).")
    info["timing"]["total_s"] = time.perf_counter() - began
    if path is not None and key is not None:
        written = cache.store(path, key, {"t": traj.t, "q": traj.q, "v": traj.v}, info)
        info.update(cache="miss", cache_file=str(path) if written else None)
    else:
        info.update(cache="off", cache_file=None)
    return traj, info


def _cached_reference(
    system: System,
    path: Path,
    key: str,
    q0: np.ndarray,
    v0: np.ndarray,
    tau: np.ndarray,
    t: np.ndarray,
    *,
    start: float,
) -> tuple[Trajectory, dict[str, Any]] | None:
    """`reference_trajectory`'s answer from the cache entry at `path`, or None when there is none or it
    fails the checks (then it is reported invalid)."""
    n = system.nv
    entry = cache.load(path, key)
    if entry is None:
        return None
    arrays, stored = entry
    traj = Trajectory(
        "hand",
        f"reference: {stored.get('method')}",
        arrays.get("t", np.empty(0)),
        arrays.get("q", np.empty((0, n))),
        arrays.get("v", np.empty((0, n))),
        {"steps": stored.get("steps")},
    )
    rhs = _checked_rhs(system)  # the trace is checked on every read, before the window check uses it
    problem = _content_problem(system, traj, q0, v0, tau, t)
    if problem is not None:
        cache.invalid(path, problem)
        return None
    stored["rhs_check"] = rhs
    stored.update(cache="hit", cache_file=str(path))
    stored["timing"]["load_s"] = time.perf_counter() - start
    return traj, stored


def _checked_rhs(system: System) -> float:
    """`rhs_check`, refusing a trace that does not reproduce the module."""
    error = rhs_check(system)
    if error > RHS_CHECK_TOLERANCE:
        raise HarnessError(
            f"{system.name}: the traced equations differ from equations/{system.name}.py by "
            f"{error:.2e} (relative); the symbolic trace is wrong."
        )
    return error


def window_check(system: System, traj: Trajectory, tau: np.ndarray) -> float:
    """Largest difference (rad, rad/s) between stored samples k+1 and classic RK4 (all windows at
    once) restarted from stored sample k: a stored solution satisfies the hand equations in every
    window (a shifted, scaled or spliced one does not). The check's own step comes from the model:
    steps of at most WINDOW_CHECK_STEP, halved until halving moves the windows' ends by less than
    WINDOW_CHECK_TOLERANCE / 10 (step doubling; at most WINDOW_CHECK_HALVINGS times), so a stiff model
    (a 1:50 mass ratio: 2.5e-4 s left 5e-5 rad) does not fail the check of the entry just written."""

    n = system.nv
    x0 = np.hstack([traj.q[:-1], traj.v[:-1]])
    h0 = np.diff(traj.t)[:, None]
    steps = max(1, int(np.ceil(float(h0.max()) / WINDOW_CHECK_STEP)))
    u = np.broadcast_to(np.asarray(tau, dtype=float), (len(x0), n))
    f = _window_rhs(system, u)
    end = _rk4_windows(f, x0, h0 / steps, steps)
    for _ in range(WINDOW_CHECK_HALVINGS):
        steps *= 2
        finer = _rk4_windows(f, x0, h0 / steps, steps)
        moved = float(np.abs(finer - end).max())
        end = finer
        if moved <= WINDOW_CHECK_TOLERANCE / 10:
            break
    stored = np.hstack([traj.q[1:], traj.v[1:]])
    return float(np.abs(end - stored).max())


def _window_rhs(system: System, u: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """f(y) = (v, a) for rows y = (q, v) at the inputs u (K, n): the hand equations' traced code (a tenth
    of the numpy module's cost per call; `reference_trajectory` checks the trace against the module
    before a stored entry is window-checked), or the module itself where the trace cannot stand in
    (a module that cannot be traced; explicit accelerations, traced at zero input only, with an input)."""
    n = system.nv
    try:
        traced = not (accelerations_only(system.equations) and np.any(u)) and _cfunc(symbolic_dynamics(system))
    except HarnessError:
        traced = False
    if traced:
        pars = np.ascontiguousarray(u.T)

        def compiled(y: np.ndarray) -> np.ndarray:
            return np.hstack([y[:, n:], np.asarray(traced(np.ascontiguousarray(y.T), pars=pars)).T])

        return compiled
    hand = HandSource(system)

    def module(y: np.ndarray) -> np.ndarray:
        return np.hstack([y[:, n:], hand.forward(y[:, :n], y[:, n:], u)])

    return module


def _rk4_windows(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, h: np.ndarray, steps: int) -> np.ndarray:
    """Classic RK4, `steps` steps of h (one per window, (K, 1)) from every row of x at once."""
    for _ in range(steps):
        k1 = f(x)
        k2 = f(x + h / 2 * k1)
        k3 = f(x + h / 2 * k2)
        k4 = f(x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def _content_problem(
    system: System, traj: Trajectory, q0: np.ndarray, v0: np.ndarray, tau: np.ndarray, t: np.ndarray
) -> str | None:
    """Why a stored reference cannot be the solution asked for, or None."""
    n = system.nv
    if traj.t.shape != t.shape or traj.q.shape != (len(t), n) or traj.v.shape != (len(t), n):
        return f"shapes t {traj.t.shape}, q {traj.q.shape}, v {traj.v.shape}; expected ({len(t)},) and ({len(t)}, {n})"
    for name, x in (("t", traj.t), ("q", traj.q), ("v", traj.v)):
        if not np.all(np.isfinite(x)):
            return f"{name} has non-finite values"
    if not np.array_equal(traj.t, t):
        return "another time grid"
    if not (np.array_equal(traj.q[0], q0) and np.array_equal(traj.v[0], v0)):
        return "another initial state"
    error = window_check(system, traj, tau)
    if not error <= WINDOW_CHECK_TOLERANCE:
        return f"its windows disagree with the hand equations by {error:.1e}"
    return None

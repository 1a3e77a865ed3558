"""One timed run of the sweep in a worker: the run's resources, the guard (deadline, finiteness),
scipy's drivers, MuJoCo stepping, the mirror, the harness's default, and `execute`.
"""

from __future__ import annotations

import hashlib
import math
import statistics
import threading
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TypedDict

import numpy as np

from ...core.errors import HarnessError
from ...dynamics.chaos import chaos_summary
from ...dynamics.compiled import compiled_rhs, compiled_rk4, rk4_grid, rk4_plan, taylor_grid, taylor_integrator
from ...dynamics.drakerun import drake_trajectory
from ...dynamics.integrate import SCIPY_DEFAULT, initial_state, scipy_trajectory, time_grid
from ...dynamics.mirror import mirror_trajectory
from ...dynamics.reference import DEFAULT_CACHE_DIR, reference_trajectory
from ...model.start import Scheme, Start
from ...results.schema import Case, Spec
from ...sources import Sources, make_sources
from ...sources.base import OneStateSource, Source, SteppedSource, one_state, stepped
from ...sources.fastpath import scalar_rhs
from ...systems import System, from_key, key_of
from .plan import CHECK_EVERY, ERROR_TIMES, SCIPY_DRIVERS, Plan
from .shapes import Execution, Outcome, Prepared

CacheDir = Path | str | None  # reference_trajectory's cache_dir: a folder, None (no cache) or cache.DEFAULT


Taus = list[float] | np.ndarray  # the torques handed to a right-hand side f(t, y, tau)
Rates = Sequence[float] | np.ndarray  # what a right-hand side returns: y' = [v, a]
Rhs = Callable[[float, np.ndarray], Rates]  # a right-hand side as scipy calls it


class GuardStats(TypedDict):
    """A guarded right-hand side's calls so far, and why it stopped (None, "timeout" or "diverged")."""

    nfev: int
    stop: str | None


class DrakeOptions(TypedDict):
    """`drake_trajectory`'s integrator settings for one run."""

    scheme: str
    accuracy: float | None
    max_step: float


class Stop(Exception):
    """Raised from inside a right-hand side to end a run ("timeout" or "diverged")."""


LOCAL = threading.local()


def resources(name: str) -> tuple[System, Sources]:
    """The system and its three sources, built once per worker thread (setup is never timed)."""
    cache = LOCAL.__dict__.setdefault("systems", {})  # per worker thread: one entry per system benched
    if name not in cache:
        system = from_key(name)  # a repository system's name, or a person's files (systems.key_of)
        cache[name] = (system, make_sources(system))
    return cache[name]


def case_for(system: System, plan: Plan) -> Case:
    """The start the bench integrates from: the system's `initial_state`, tau = 0, the plan's grid."""
    q0, v0 = initial_state(system)
    return {
        "system": key_of(system),  # what the workers find it by
        "q0": q0.tolist(),
        "v0": v0.tolist(),
        "tau": [0.0] * system.nv,
        "t_end": plan.t_end,
        "dt_out": plan.dt_out,
    }


def prepare(name: str, plan: Plan, cache_dir: CacheDir = DEFAULT_CACHE_DIR) -> Prepared:
    """Reference trajectory and predictability horizon of one system on the plan's grid (a worker task),
    kept in `cache_dir` (reference_trajectory's: a folder, None for none, or the configured cache)."""
    system, _ = resources(name)
    case = case_for(system, plan)
    t = time_grid(case["t_end"], case["dt_out"])
    ref, info = reference_trajectory(system, Start.of(case["q0"], case["v0"], case["tau"]), t, cache_dir=cache_dir)
    summary = chaos_summary(
        system,
        Start.of(case["q0"], case["v0"], case["tau"]),
        t=t,
        tolerance=plan.horizon_tolerance,
        cache_dir=cache_dir,
    )
    horizon = summary["horizon_from_rounding"]["horizon"]
    return {
        "case": case,
        "t": ref.t,
        "q": ref.q,
        "reference": {
            "method": info.get("method"),
            "precision": info.get("precision"),
            "agreement_q": info.get("agreement_q"),
            "cache": info.get("cache"),
        },
        "horizon_s": horizon,
        "horizon_window_s": min(horizon, case["t_end"]) if horizon is not None else case["t_end"],
        "lyapunov_per_s": summary["lyapunov"]["lambda"],
    }


def nonfinite(out: Rates) -> bool:
    try:
        s = sum(out)
    except TypeError:
        return True
    return not math.isfinite(s)


def guarded(
    f: Callable[..., Rates], deadline: float, *, tau: Taus | None = None, stop_with_nan: bool = False
) -> tuple[Rhs, Callable[[], GuardStats]]:
    """`f` counted, and stopped once past `deadline` (perf_counter) or once it returns non-finite values.

    The checks run every CHECK_EVERY calls, so they cost nothing measurable. Stopping raises `Stop`,
    or with `stop_with_nan` (scipy's `ode`, which crashes on an exception in the callback) returns
    NaN from then on, which makes the driver give up. `tau`, when given, is passed as f's third
    argument (the scalar fast path's signature) without another call layer.

    Returns:
        The guarded f(t, y) and a function giving {"nfev": calls, "stop": None | "timeout" | "diverged"}.
    """
    n = 0
    stop: list[str | None] = [None]
    mask = CHECK_EVERY - 1

    def check(out: Rates) -> str | None:
        if nonfinite(out):
            return "diverged"
        if time.perf_counter() > deadline:
            return "timeout"
        return None

    if stop_with_nan:

        def g_nan(t: float, y: np.ndarray) -> Rates:
            nonlocal n
            n += 1
            if stop[0] is not None:
                return [math.nan] * len(y)
            out = f(t, y, tau) if tau is not None else f(t, y)
            if not n & mask:
                stop[0] = check(out)
            return out

        g = g_nan
    elif tau is not None:

        def g_tau(t: float, y: np.ndarray) -> Rates:
            nonlocal n
            n += 1
            out = f(t, y, tau)
            if not n & mask:
                reason = check(out)
                if reason:
                    stop[0] = reason
                    raise Stop(reason)
            return out

        g = g_tau
    else:

        def g_plain(t: float, y: np.ndarray) -> Rates:
            nonlocal n
            n += 1
            out = f(t, y)
            if not n & mask:
                reason = check(out)
                if reason:
                    stop[0] = reason
                    raise Stop(reason)
            return out

        g = g_plain
    return g, lambda: {"nfev": n, "stop": stop[0]}


def result_row(
    status: str,
    message: str,
    cpu: float,
    wall: float,
    *,
    t: np.ndarray | None = None,
    q: np.ndarray | None = None,
    nfev: int | None = None,
    steps: int | None = None,
) -> Outcome:
    if status == "ok" and q is not None and not np.all(np.isfinite(q)):
        status, message = "diverged", "non-finite state"
    return {
        "status": status,
        "message": message,
        "cpu_s": cpu,
        "wall_s": wall,
        "t": t,
        "q": q,
        "nfev": nfev,
        "steps": steps,
    }


def run_scipy(
    driver: str,
    scheme: str,
    f: Callable[..., Rates],
    y0: np.ndarray,
    t: np.ndarray,
    *,
    rtol: float,
    atol: float,
    deadline: float,
    tau: Taus | None = None,
) -> Outcome:
    """One scipy integration of y' = f(t, y) (or f(t, y, tau)), timed around the driver call alone.

    Args:
        driver: "solve_ivp" (scheme: RK45, DOP853, Radau, LSODA), "ode" (dop853, stopping at every
            sample of `t`), "ode_endpoints" (dop853, outputs at ERROR_TIMES only) or "odeint".
        y0: (2n,) initial state; t: (K,) output grid from 0.
    Returns:
        status ("ok", "diverged", "failed", "timeout"), message, cpu_s, wall_s, t, q (K, n), nfev.
    """
    from scipy.integrate import odeint, solve_ivp  # ~0.5 s to import: loaded when first used

    n = len(y0) // 2
    g, stats = guarded(f, deadline, tau=tau, stop_with_nan=driver in ("ode", "ode_endpoints"))
    ok, message, out_t = True, "", t
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            if driver == "solve_ivp":
                c0, w0 = time.process_time(), time.perf_counter()
                sol = solve_ivp(g, (t[0], t[-1]), y0, method=scheme, t_eval=t, rtol=rtol, atol=atol)
                cpu, wall = time.process_time() - c0, time.perf_counter() - w0
                ok, message, y = bool(sol.success), str(sol.message), sol.y.T
            elif driver in ("ode", "ode_endpoints"):
                out_t = t if driver == "ode" else np.array([t[0], *ERROR_TIMES])
                ok, message, y, cpu, wall = _run_ode(g, y0, out_t, rtol=rtol, atol=atol)
            elif driver == "odeint":
                c0, w0 = time.process_time(), time.perf_counter()
                y, info = odeint(g, y0, t, rtol=rtol, atol=atol, tfirst=True, full_output=True, mxstep=10**8)
                cpu, wall = time.process_time() - c0, time.perf_counter() - w0
                message = str(info["message"])
                ok = message == "Integration successful."
            else:
                raise HarnessError(f"unknown scipy driver '{driver}'; valid: {', '.join(SCIPY_DRIVERS)}.")
        except Stop:
            cpu, wall = time.process_time() - c0, time.perf_counter() - w0
            s = stats()
            return result_row(str(s["stop"]), f"stopped after {s['nfev']} evaluations", cpu, wall, nfev=s["nfev"])
    s = stats()
    if s["stop"] is not None:  # `ode`: stopped by NaN
        return result_row(s["stop"], f"stopped after {s['nfev']} evaluations", cpu, wall, nfev=s["nfev"])
    if not ok:
        bad = not np.all(np.isfinite(y))
        return result_row("diverged" if bad else "failed", message, cpu, wall, nfev=s["nfev"])
    return result_row("ok", "", cpu, wall, t=np.asarray(out_t), q=np.ascontiguousarray(y[:, :n]), nfev=s["nfev"])


def _run_ode(
    g: Rhs, y0: np.ndarray, out_t: np.ndarray, *, rtol: float, atol: float
) -> tuple[bool, str, np.ndarray, float, float]:
    """scipy's `ode` (dop853) stopping at every time of `out_t`, timed around the stepping loop alone.
    `g` must stop with NaN (scipy's `ode` crashes on an exception in the callback), never `Stop`.

    Returns:
        ok, message, y (len(out_t), 2n; NaN past a failure), cpu_s, wall_s.
    """
    from scipy.integrate import ode  # loaded by run_scipy already

    ok, message = True, ""
    r = ode(g).set_integrator("dop853", rtol=rtol, atol=atol, nsteps=10**9)
    r.set_initial_value(y0, out_t[0])
    y = np.full((len(out_t), len(y0)), np.nan)
    y[0] = y0
    c0, w0 = time.process_time(), time.perf_counter()
    for k in range(1, len(out_t)):
        r.integrate(out_t[k])
        if not r.successful():
            ok, message = False, f"dop853 return code {r.get_return_code()}"
            break
        y[k] = r.y
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    return ok, message, y, cpu, wall


def run_mujoco(
    system: System,
    source: SteppedSource,
    start: Start,
    t: np.ndarray,
    stepping: Scheme,
    *,
    deadline: float,
) -> Outcome:
    """MuJoCo stepping its own integrator from `start`; only the stepping loop is timed.

    The model's integrator and timestep are set for the run and restored after it. A run that sets
    any of MuJoCo's bad-state warnings (MuJoCo then resets the state and carries on) has diverged.
    """
    from ...sources import mujoco as engine  # imports MuJoCo: loaded when first used

    dt_out, timestep = float(t[1] - t[0]), stepping.timestep
    steps = round(dt_out / timestep)
    if steps < 1 or not np.isclose(steps * timestep, dt_out, rtol=1e-9, atol=0.0):
        raise HarnessError(f"MuJoCo timestep {timestep} must divide the output step {dt_out}.")
    out = engine.timed_run(source, start, len(t), steps, stepping, deadline=deadline)
    cpu, wall, bad, printed, k = out["cpu_s"], out["wall_s"], out["bad"], out["printed"], out["stopped_at"]
    total = steps * (len(t) - 1)
    if bad:
        first = f" (first: {printed[0]})" if printed else ""
        return result_row("diverged", f"MuJoCo warnings: {', '.join(bad)}{first}", cpu, wall, steps=total)
    if k is not None:  # stopped by the deadline
        return result_row("timeout", f"stopped at t = {t[k]:g} s", cpu, wall, steps=steps * k)
    q = out["q"]
    A = system.joint_map
    if A is not None:
        q = q @ A.T
    return result_row("ok", "", cpu, wall, t=t, q=np.ascontiguousarray(q), steps=total)


class GuardedSource:
    """A source whose `rhs` is guarded (deadline, finiteness), for the mirror integrators."""

    def __init__(self, source: OneStateSource, deadline: float) -> None:
        self._source, self._deadline = source, deadline
        self.name = source.name
        self.stats: Callable[[], GuardStats] = lambda: {"nfev": 0, "stop": None}

    def __getattr__(self, attr: str) -> Any:
        return getattr(self._source, attr)

    def rhs(self, tau: np.ndarray) -> Rhs:
        g, self.stats = guarded(self._source.rhs(tau), self._deadline)
        return g


def run_mirror(
    system: System,
    source: Source,
    start: Start,
    t: np.ndarray,
    stepping: Scheme,
    *,
    deadline: float,
) -> Outcome:
    """`mirror_trajectory` (MuJoCo's scheme on an engine's per-call rhs), timed around the call."""
    src = GuardedSource(one_state(source), deadline)
    c0, w0 = time.process_time(), time.perf_counter()
    try:
        traj = mirror_trajectory(system, src, start, t, integrator=stepping.integrator, timestep=stepping.timestep)
    except Stop:
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        s = src.stats()
        return result_row(str(s["stop"]), f"stopped after {s['nfev']} evaluations", cpu, wall, nfev=s["nfev"])
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    return result_row(
        "ok", "", cpu, wall, t=t, q=traj.q, nfev=int(traj.stats["evaluations"]), steps=traj.stats["steps"]
    )


def run_taylor(
    system: System, start: Start, t: np.ndarray, *, tol: float, max_steps: int, source: str = "hand"
) -> Outcome:
    """heyoka's Taylor integrator in double precision at `tol` on the hand equations or the derived
    ones ("symbolic": joint coordinates, JOINT_MAP applied outside the clock); compiled before the
    clock starts, `propagate_grid` alone timed. At most `max_steps` steps."""
    q0, v0, tau = start.q0, start.v0, start.tau
    n = len(q0)
    A = system.joint_map if source == "symbolic" else None
    if A is not None:  # q_notes = A q_joint, and the inputs' work: tau_joint = A^T tau_notes
        q0, v0, tau = np.linalg.solve(A, q0), np.linalg.solve(A, v0), A.T @ np.asarray(tau, dtype=float)
    ta = taylor_integrator(system, tol, source=source)
    c0, w0 = time.process_time(), time.perf_counter()
    outcome, states, steps = taylor_grid(ta, Start.of(q0, v0, tau), t, max_steps=max_steps)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    if outcome != "ok":
        status = "diverged" if "nf_state" in outcome else "failed"
        return result_row(status, f"heyoka stopped: {outcome} after {steps} steps", cpu, wall, steps=steps)
    q = states[:, :n] if A is None else states[:, :n] @ A.T
    return result_row("ok", "", cpu, wall, t=t, q=np.ascontiguousarray(q), steps=steps)


def run_compiled_rk4(system: System, start: Start, t: np.ndarray, *, timestep: float, deadline: float) -> Outcome:
    """Classic RK4 with its steps compiled (heyoka cfunc, `compiled.rk4_plan` steps per call), one
    Python call per group of steps; the loop over the samples is timed."""
    n = len(start.q0)
    per_call, calls = rk4_plan(float(t[1] - t[0]), timestep)
    cf = compiled_rk4(system, per_call)
    c0, w0 = time.process_time(), time.perf_counter()
    status, states = rk4_grid(cf, calls, start, t, timestep=timestep, deadline=deadline)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    total = calls * per_call * (len(t) - 1)
    if status != "ok":
        return result_row(status, f"{status} before t = {t[-1]:g} s", cpu, wall, steps=total)
    return result_row("ok", "", cpu, wall, t=t, q=np.ascontiguousarray(states[:, :n]), nfev=4 * total, steps=total)


def run_rollout(
    system: System,
    source: SteppedSource,
    start: Start,
    t: np.ndarray,
    stepping: Scheme,
    *,
    batch: int,
) -> Outcome:
    """MuJoCo's `rollout` of `batch` copies of the start (sources/mujoco.rollout_run); the row's time is
    the batch's CPU time divided by `batch` (per trajectory), its samples those of the first copy."""
    from ...sources import mujoco as engine  # imports MuJoCo: loaded when first used

    steps = round(float(t[1] - t[0]) / stepping.timestep)
    out = engine.rollout_run(source, start, len(t), steps, stepping, batch=batch, nthread=batch)
    cpu, wall, total = out["cpu_s"] / batch, out["wall_s"] / batch, steps * (len(t) - 1)
    if out["bad"]:
        return result_row("diverged", f"MuJoCo warnings: {', '.join(out['bad'])}", cpu, wall, steps=total)
    if not out["identical"]:
        return result_row("failed", "the copies of one start gave different states", cpu, wall, steps=total)
    q = out["q"] if system.joint_map is None else out["q"] @ system.joint_map.T
    return result_row("ok", "", cpu, wall, t=t, q=np.ascontiguousarray(q), steps=total)


def run_drake(system: System, source: Source, start: Start, t: np.ndarray, *, spec: Spec) -> Outcome:
    """Drake's own integrator on its continuous plant (dynamics/integrate.py `drake_trajectory`): at a
    target accuracy (setting "accuracy", max step one output interval) or fixed steps ("timestep");
    the whole run, context and Simulator setup included, is timed."""
    fixed = spec["setting"] == "timestep"
    dt_out = float(t[1] - t[0])
    opts: DrakeOptions = {
        "scheme": spec["scheme"],
        "accuracy": None if fixed else spec["value"],
        "max_step": spec["value"] if fixed else dt_out,
    }
    c0, w0 = time.process_time(), time.perf_counter()
    traj = drake_trajectory(system, source, start, t, **opts)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    steps = traj.stats["steps"]  # an int: Drake counts its steps
    if traj.stats["status"] != "ok":
        return result_row("failed", traj.stats["reason"], cpu, wall, steps=steps)
    nfev = int(traj.stats["evaluations"])
    return result_row("ok", "", cpu, wall, t=t, q=np.ascontiguousarray(traj.q), nfev=nfev, steps=steps)


def run_default(system: System, source: Source, start: Start, t: np.ndarray) -> Outcome:
    """The harness's default scipy integration, as `run` calls it (no budget: it has no hook)."""
    c0, w0 = time.process_time(), time.perf_counter()
    try:
        default: dict[str, Any] = dict(SCIPY_DEFAULT)
        traj = scipy_trajectory(system, source, start, t, **default)
    except HarnessError as exc:
        return result_row("failed", str(exc), time.process_time() - c0, time.perf_counter() - w0)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    return result_row("ok", "", cpu, wall, t=traj.t, q=traj.q, nfev=int(traj.stats["nfev"]))


def run_once(spec: Spec, case: Case, plan: Plan) -> Outcome:
    """One execution of one spec on one case, in this process, within the plan's budget."""
    system, sources = resources(case["system"])
    t = time_grid(case["t_end"], case["dt_out"])
    start = Start.of(case["q0"], case["v0"], case["tau"])
    q0, v0, tau = start.q0, start.v0, start.tau
    driver, engine, budget = spec["driver"], spec["engine"], plan.budget
    if driver in SCIPY_DRIVERS:
        atol = spec["atol"]
        if atol is None:  # every rtol spec has one (plan.scipy_spec)
            raise HarnessError(f"a {driver} run needs an atol.")
        y0 = np.concatenate([q0, v0])
        tau_list: Taus | None = None
        f: Callable[..., Rates]  # the generated code, the compiled function, or a source's rhs
        if engine == "hand":
            f, tau_list = scalar_rhs(system), [float(x) for x in tau]  # compiled before the clock starts
        elif engine == "hand-cfunc":
            f, tau_list = compiled_rhs(system), np.array(tau, dtype=float)
        else:
            f = one_state(sources[engine]).rhs(tau)
        deadline = time.perf_counter() + budget
        return run_scipy(
            driver, spec["scheme"], f, y0, t, rtol=spec["value"], atol=atol, deadline=deadline, tau=tau_list
        )
    if driver == "mujoco":
        return run_mujoco(
            system,
            stepped(sources["mujoco"]),
            start,
            t,
            Scheme(spec["scheme"], spec["value"]),
            deadline=time.perf_counter() + budget,
        )
    if driver == "mirror":
        if engine == "hand":
            scalar_rhs(system)
        return run_mirror(
            system,
            sources[engine],
            start,
            t,
            Scheme(spec["scheme"], spec["value"]),
            deadline=time.perf_counter() + budget,
        )
    if driver == "taylor":
        if engine not in sources:
            return result_row("skipped", f"no {engine} source for {system.name}", 0.0, 0.0)
        return run_taylor(system, start, t, tol=spec["value"], max_steps=plan.taylor_max_steps, source=engine)
    if driver == "compiled_rk4":
        return run_compiled_rk4(system, start, t, timestep=spec["value"], deadline=time.perf_counter() + budget)
    if driver in ("rollout", "rollout_batch"):
        batch = spec["batch"] if driver == "rollout_batch" else 1
        return run_rollout(
            system, stepped(sources["mujoco"]), start, t, Scheme(spec["scheme"], spec["value"]), batch=batch
        )
    if driver == "drake":
        if "drake" not in sources:
            return result_row("skipped", f"no drake source for {system.name}", 0.0, 0.0)
        return run_drake(system, sources["drake"], start, t, spec=spec)
    if driver == "default":
        scalar_rhs(system)
        return run_default(system, sources["hand"], start, t)
    raise HarnessError(f"unknown driver '{driver}'.")


def digest(q: np.ndarray | None) -> str | None:
    return None if q is None else hashlib.sha256(np.ascontiguousarray(q).tobytes()).hexdigest()[:16]


def execute(spec: Spec, case: Case, *, plan: Plan, samples: bool = True) -> Execution:
    """One timing of one spec (a worker task): the run, repeated back to back while the total time is
    under the plan's `min_timed` (the first, cold, execution then dropped), mean per execution.

    Returns plain data: status, message, cpu_s, wall_s, executions, nfev, steps, digest of the samples
    (every execution must give the same bits), and the samples t, q when `samples`.
    """
    first = run_once(spec, case, plan)
    cpus, walls, deterministic = [first["cpu_s"]], [first["wall_s"]], True
    if first["status"] == "ok":
        while sum(walls) < plan.min_timed and len(walls) < plan.max_executions:
            again = run_once(spec, case, plan)
            if again["status"] != "ok" or digest(again["q"]) != digest(first["q"]):
                deterministic = False
                break
            cpus.append(again["cpu_s"])
            walls.append(again["wall_s"])
        if len(walls) > 1:
            cpus, walls = cpus[1:], walls[1:]
    return {
        "status": first["status"],
        "message": first["message"],
        "cpu_s": statistics.fmean(cpus),
        "wall_s": statistics.fmean(walls),
        "executions": len(walls),
        "nfev": first["nfev"],
        "steps": first["steps"],
        "digest": digest(first["q"]),
        "deterministic": deterministic,
        "t": first["t"] if samples else None,
        "q": first["q"] if samples else None,
    }

"""Run time against error: a work-precision sweep of every integrator the harness can use, and the
"fast harness" ratios, measured in one run and written to `bench.json` (data only; the report
module draws the plots from it).

What is swept, per system, from its `initial_state` with tau = 0, on the grid t = 0, 0.01, ..., 10 s:

  scipy on the hand equations (the generated scalar fast path) and on Pinocchio's ABA
  (`PinocchioSource.rhs`): `solve_ivp` RK45, DOP853, Radau, LSODA; the compiled drivers
  `scipy.integrate.ode("dop853")` and `odeint` (LSODA); rtol 1e-3 ... 1e-12, atol = rtol * 1e-3
  (the states are O(1) rad and rad/s, so the relative test is the one that binds; the small atol
  only matters where a component crosses zero). `ode` has no dense output: on a 10 ms grid it must
  stop at every sample, which caps its step at 10 ms and sets its error, whatever rtol; it is
  therefore also run with two outputs only ("(2 outputs)": t = 2 s and 10 s), where rtol governs.
  MuJoCo's Euler, implicit, implicitfast, RK4 at timesteps 1e-2 ... 1e-5 s (the model's own
  `opt.integrator`/`opt.timestep` are set and restored), and the mirror RK4 on Pinocchio's ABA.
  The harness's default (`integrate.scipy_trajectory` with `integrate.SCIPY_DEFAULT`) as one more run.

What is measured per run: the error against the reference (heyoka Taylor in long double, accurate
to ~1e-17, cached) as max over coordinates of |q - q_ref| at t = 2 s and 10 s, and its maximum over
the predictability horizon (the chaos summary's horizon at 1e-6 rad; it is 73 s for the double
pendulums and none for the regular systems, so on this 10 s grid the window is the whole run, as
`horizon_window_s` says); the first time the error exceeds 1e-6 rad (the run's own horizon);
CPU time (`time.process_time`) and wall time (`time.perf_counter`) of the integration alone (no
setup, no compilation, no error computation; for MuJoCo the loop of `mj_step(m, d, nstep=k)` with a
copy of qpos/qvel per sample, ~0.3 us each); right-hand-side evaluations (steps for MuJoCo).
A run shorter than MIN_TIMED is executed back to back until the total reaches it and the mean is
taken, the first (cold) execution dropped (timeit's autorange); the row's time is the median over
repeats. Runs that diverge (non-finite values, MuJoCo's bad-qpos/qvel/qacc warnings), fail (the
solver gives up) or exceed the per-run budget are recorded with that status, not dropped; a timeout
is enforced from inside the right-hand side (checked every 128 calls: it raises, or for `ode`, whose
compiled driver crashes on a Python exception, returns NaN so the driver stops), and for MuJoCo
between samples. A setting tighter than one that timed out is not run (status "skipped").

Parallelism. Timing runs execute in the workers of a `concurrent.futures.Executor` (a process pool
with one worker per core by default; any executor will do, a distributed one included) and each run
is timed inside its worker. Both cores time at once: measured on this 2-core machine, DOP853 on the
double pendulum costs 0.052 s of CPU alone and 0.052-0.053 s with a second timing process on the
other core (wall time alone 0.052 s, but 0.10 s whenever another engineer's process shared the
machine). CPU time is therefore the cost the tables rank by; wall time is recorded beside it and is
only as fair as the machine is quiet. CPU time is less sensitive to load, not immune (a virtual CPU
the host preempts still accrues it; single --quick measurements have varied by 1.7x under other
engineers' load), hence medians over interleaved repeats in the full bench (the median spread of a
row's repeats was 2%). To keep whatever noise there is even, each repeat submits the runs
round-robin over all methods (one setting of every method, then the next setting; later repeats
rotate the method order) so both workers stay busy until the queue drains and noise hits all
methods alike. The ratio measurements interleave their sides inside one task, so they are fair
whatever runs beside them. Only `lagrange-xval run`, which uses both cores itself, is timed with
nothing else of ours running (after the pool is shut down).
"""

from __future__ import annotations

import hashlib
import math
import statistics
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterable
from concurrent.futures import Executor, Future, as_completed
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import HarnessError

# ----------------------------------------------------------------------------------------------
# The plan

T_END = 10.0  # s: the grid of `run` (the reference cache is keyed by it)
DT_OUT = 0.01  # s
ERROR_TIMES = (2.0, 10.0)  # s
HORIZON_TOLERANCE = 1e-6  # rad: the trajectory tier, and the chaos summary's horizon tolerance
EPSILONS = (1e-3, 1e-6, 1e-9)  # rad, for "time to reach error eps" at t = 2 s
ATOL_FACTOR = 1e-3  # atol = rtol * ATOL_FACTOR
RTOLS = tuple(10.0**-k for k in range(3, 13))
QUICK_RTOLS = (1e-3, 1e-6, 1e-9, 1e-12)
IVP_METHODS = ("RK45", "DOP853", "Radau", "LSODA")
QUICK_IVP_METHODS = ("DOP853", "RK45", "LSODA")
MUJOCO_INTEGRATORS = ("Euler", "implicit", "implicitfast", "RK4")
QUICK_MUJOCO_INTEGRATORS = ("RK4", "Euler")
TIMESTEPS = (1e-2, 1e-3, 1e-4, 1e-5)  # s
QUICK_TIMESTEPS = (1e-2, 1e-3, 1e-4)
QUICK_SYSTEMS = ("double_pendulum_point", "gimbal")
BUDGET = 20.0  # s of wall time per run
QUICK_BUDGET = 5.0
MIN_TIMED = 0.05  # s: shorter runs are repeated back to back (autorange)
MAX_EXECUTIONS = 200
DEFAULT_REPEATS = 3
QUICK_REPEATS = 1
QUICK_TARGET_S = 60.0
CHECK_EVERY = 128  # right-hand-side calls between deadline / finiteness checks (a power of two)

# The ratios of "a fast harness", each with its target.
RHS_SYSTEM = "double_pendulum_point"
RHS_TARGET = 1.5  # fast path time / hand-written math time
POINTWISE_STATES = 10_000
POINTWISE_TARGET = 1.5  # harness time / raw engine calls time
DEFAULT_EPSILON = 1e-9  # rad at t = 2 s
DEFAULT_TARGET = 1.5  # default scipy time / fastest scipy driver reaching DEFAULT_EPSILON
RUN_REPEATS = 5
RUN_TARGET_S = 20.0  # s wall for `lagrange-xval run` on all systems, warm or cold cache (issue 10)
RUN_WARM_TARGET_S = 15.0  # s wall with a warm cache (issue 6)
FLAG_INTEGRATORS = ("RK4", "Euler")

SCIPY_DRIVERS = ("solve_ivp", "ode", "ode_endpoints", "odeint")
STATUSES = ("ok", "diverged", "failed", "timeout", "skipped")  # a row's "status"


class _Stop(Exception):
    """Raised from inside a right-hand side to end a run ("timeout" or "diverged")."""


def method_name(spec: dict[str, Any]) -> str:
    """The row's method label, e.g. "hand solve_ivp DOP853", "mujoco RK4", "pinocchio mirror RK4"."""
    engine, driver, scheme = spec["engine"], spec["driver"], spec.get("scheme")
    label = {
        "solve_ivp": f"solve_ivp {scheme}",
        "ode": "ode dop853",
        "ode_endpoints": "ode dop853 (2 outputs)",
        "odeint": "odeint",
        "mujoco": str(scheme),
        "mirror": f"mirror {scheme}",
        "default": "default scipy_trajectory",
    }[driver]
    return f"{engine} {label}"


def _scipy_spec(engine: str, driver: str, scheme: str | None, rtol: float) -> dict[str, Any]:
    return {
        "engine": engine,
        "driver": driver,
        "scheme": scheme,
        "setting": "rtol",
        "value": rtol,
        "atol": rtol * ATOL_FACTOR,
    }


def _step_spec(engine: str, driver: str, scheme: str, timestep: float) -> dict[str, Any]:
    return {
        "engine": engine,
        "driver": driver,
        "scheme": scheme,
        "setting": "timestep",
        "value": timestep,
        "atol": None,
    }


def plan(*, quick: bool) -> list[dict[str, Any]]:
    """Every run of one system, loosest setting first within each method."""
    from ..dynamics.integrate import SCIPY_DEFAULT

    specs: list[dict[str, Any]] = []
    if quick:
        for m in QUICK_IVP_METHODS:
            specs += [_scipy_spec("hand", "solve_ivp", m, r) for r in QUICK_RTOLS]
        for integ in QUICK_MUJOCO_INTEGRATORS:
            specs += [_step_spec("mujoco", "mujoco", integ, dt) for dt in QUICK_TIMESTEPS]
    else:
        for engine in ("hand", "pinocchio"):
            for m in IVP_METHODS:
                specs += [_scipy_spec(engine, "solve_ivp", m, r) for r in RTOLS]
            for driver in ("ode", "ode_endpoints"):
                specs += [_scipy_spec(engine, driver, "dop853", r) for r in RTOLS]
            specs += [_scipy_spec(engine, "odeint", "LSODA", r) for r in RTOLS]
        for integ in MUJOCO_INTEGRATORS:
            specs += [_step_spec("mujoco", "mujoco", integ, dt) for dt in TIMESTEPS]
        specs += [_step_spec("pinocchio", "mirror", "RK4", dt) for dt in TIMESTEPS]
    specs.append(
        {
            "engine": "hand",
            "driver": "default",
            "scheme": SCIPY_DEFAULT["method"],
            "setting": "rtol",
            "value": SCIPY_DEFAULT["rtol"],
            "atol": SCIPY_DEFAULT["atol"],
        }
    )
    for s in specs:
        s["method"] = method_name(s)
    return specs


# ----------------------------------------------------------------------------------------------
# Worker-side resources (one set per thread: a process worker, or a thread of a thread pool)

_local = threading.local()


def _resources(name: str) -> tuple[Any, dict[str, Any]]:
    """The system and its three sources, built once per worker thread (setup is never timed)."""
    cache = _local.__dict__.setdefault("systems", {})
    if name not in cache:
        from ..engines import make_sources
        from ..systems import load

        system = load(name)
        cache[name] = (system, make_sources(system))
    return cache[name]


def case_for(system: Any) -> dict[str, Any]:
    """The start the bench integrates from: the system's `initial_state`, tau = 0, the 10 s grid."""
    from ..dynamics.integrate import initial_state

    q0, v0 = initial_state(system)
    return {
        "system": system.name,
        "q0": q0.tolist(),
        "v0": v0.tolist(),
        "tau": [0.0] * system.nv,
        "t_end": T_END,
        "dt_out": DT_OUT,
    }


def prepare(name: str) -> dict[str, Any]:
    """Reference trajectory and predictability horizon of one system (cached on disk; a worker task)."""
    from ..dynamics.chaos import chaos_summary
    from ..dynamics.integrate import time_grid
    from ..dynamics.reference import reference_trajectory

    system, _ = _resources(name)
    case = case_for(system)
    t = time_grid(case["t_end"], case["dt_out"])
    ref, info = reference_trajectory(system, case["q0"], case["v0"], case["tau"], t)
    summary = chaos_summary(system, case["q0"], case["v0"], case["tau"], t=t, tolerance=HORIZON_TOLERANCE)
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


# ----------------------------------------------------------------------------------------------
# One run


def _nonfinite(out: Any) -> bool:
    try:
        s = sum(out)
    except TypeError:
        return True
    return not math.isfinite(s)


def guarded(
    f: Callable[..., Any], deadline: float, *, tau: list[float] | None = None, stop_with_nan: bool = False
) -> tuple[Callable[[float, Any], Any], Callable[[], dict[str, Any]]]:
    """`f` counted, and stopped once past `deadline` (perf_counter) or once it returns non-finite values.

    The checks run every CHECK_EVERY calls, so they cost nothing measurable. Stopping raises `_Stop`,
    or with `stop_with_nan` (scipy's `ode`, which crashes on an exception in the callback) returns
    NaN from then on, which makes the driver give up. `tau`, when given, is passed as f's third
    argument (the scalar fast path's signature) without another call layer.

    Returns:
        The guarded f(t, y) and a function giving {"nfev": calls, "stop": None | "timeout" | "diverged"}.
    """
    n = 0
    stop: list[str | None] = [None]
    mask = CHECK_EVERY - 1

    def check(out: Any) -> str | None:
        if _nonfinite(out):
            return "diverged"
        if time.perf_counter() > deadline:
            return "timeout"
        return None

    if stop_with_nan:

        def g_nan(t: float, y: Any) -> Any:
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

        def g_tau(t: float, y: Any) -> Any:
            nonlocal n
            n += 1
            out = f(t, y, tau)
            if not n & mask:
                reason = check(out)
                if reason:
                    stop[0] = reason
                    raise _Stop(reason)
            return out

        g = g_tau
    else:

        def g_plain(t: float, y: Any) -> Any:
            nonlocal n
            n += 1
            out = f(t, y)
            if not n & mask:
                reason = check(out)
                if reason:
                    stop[0] = reason
                    raise _Stop(reason)
            return out

        g = g_plain
    return g, lambda: {"nfev": n, "stop": stop[0]}


def _result(
    status: str,
    message: str,
    cpu: float,
    wall: float,
    *,
    t: np.ndarray | None = None,
    q: np.ndarray | None = None,
    nfev: int | None = None,
    steps: int | None = None,
) -> dict[str, Any]:
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
    f: Callable[..., Any],
    y0: np.ndarray,
    t: np.ndarray,
    *,
    rtol: float,
    atol: float,
    deadline: float,
    tau: list[float] | None = None,
) -> dict[str, Any]:
    """One scipy integration of y' = f(t, y) (or f(t, y, tau)), timed around the driver call alone.

    Args:
        driver: "solve_ivp" (scheme: RK45, DOP853, Radau, LSODA), "ode" (dop853, stopping at every
            sample of `t`), "ode_endpoints" (dop853, outputs at ERROR_TIMES only) or "odeint".
        y0: (2n,) initial state; t: (K,) output grid from 0.
    Returns:
        status ("ok", "diverged", "failed", "timeout"), message, cpu_s, wall_s, t, q (K, n), nfev.
    """
    from scipy.integrate import ode, odeint, solve_ivp

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
            elif driver == "odeint":
                c0, w0 = time.process_time(), time.perf_counter()
                y, info = odeint(g, y0, t, rtol=rtol, atol=atol, tfirst=True, full_output=True, mxstep=10**8)
                cpu, wall = time.process_time() - c0, time.perf_counter() - w0
                message = str(info["message"])
                ok = message == "Integration successful."
            else:
                raise HarnessError(f"unknown scipy driver '{driver}'; valid: {', '.join(SCIPY_DRIVERS)}.")
        except _Stop:
            cpu, wall = time.process_time() - c0, time.perf_counter() - w0
            s = stats()
            return _result(str(s["stop"]), f"stopped after {s['nfev']} evaluations", cpu, wall, nfev=s["nfev"])
    s = stats()
    if s["stop"] is not None:  # `ode`: stopped by NaN
        return _result(s["stop"], f"stopped after {s['nfev']} evaluations", cpu, wall, nfev=s["nfev"])
    if not ok:
        bad = not np.all(np.isfinite(y))
        return _result("diverged" if bad else "failed", message, cpu, wall, nfev=s["nfev"])
    return _result("ok", "", cpu, wall, t=np.asarray(out_t), q=np.ascontiguousarray(y[:, :n]), nfev=s["nfev"])


MJ_BAD_WARNINGS = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")


def run_mujoco(
    system: Any,
    source: Any,
    q0: Any,
    v0: Any,
    tau: Any,
    t: np.ndarray,
    *,
    integrator: str,
    timestep: float,
    deadline: float,
) -> dict[str, Any]:
    """MuJoCo stepping its own integrator from (q0, v0); only the stepping loop is timed.

    The model's integrator and timestep are set for the run and restored after it. A run that sets
    any of MuJoCo's bad-state warnings (MuJoCo then resets the state and carries on) has diverged.
    """
    import mujoco

    from ..dynamics.integrate import mujoco_integrator

    enum = mujoco_integrator(integrator)
    inner = getattr(source, "inner", source)
    m, d = inner.m, inner.d
    dt_out = float(t[1] - t[0])
    steps = round(dt_out / timestep)
    if steps < 1 or not np.isclose(steps * timestep, dt_out, rtol=1e-9, atol=0.0):
        raise HarnessError(f"MuJoCo timestep {timestep} must divide the output step {dt_out}.")
    saved = (m.opt.integrator, m.opt.timestep)
    qpos, qvel = np.full((len(t), m.nq), np.nan), np.full((len(t), m.nv), np.nan)
    timed_out = False
    printed: list[str] = []  # MuJoCo's warning texts, collected instead of printed and logged to a file
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda msg: printed.append(str(msg).strip()))
    try:
        m.opt.integrator, m.opt.timestep = enum, timestep
        mujoco.mj_resetData(m, d)
        source.set_state(np.asarray(q0, dtype=float), np.asarray(v0, dtype=float), np.asarray(tau, dtype=float))
        qpos[0], qvel[0] = d.qpos, d.qvel
        step, clock = mujoco.mj_step, time.perf_counter
        c0, w0 = time.process_time(), time.perf_counter()
        for k in range(1, len(t)):
            step(m, d, nstep=steps)
            qpos[k] = d.qpos
            qvel[k] = d.qvel
            if clock() > deadline:
                timed_out = True
                break
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        bad = [w for w in MJ_BAD_WARNINGS if d.warning[int(getattr(mujoco.mjtWarning, w))].number > 0]
    finally:
        m.opt.integrator, m.opt.timestep = saved
        mujoco.set_mju_user_warning(previous)
    total = steps * (len(t) - 1)
    if bad:
        first = f" (first: {printed[0]})" if printed else ""
        return _result("diverged", f"MuJoCo warnings: {', '.join(bad)}{first}", cpu, wall, steps=total)
    if timed_out:
        return _result("timeout", f"stopped at t = {t[k]:g} s", cpu, wall, steps=steps * k)
    q = qpos[:, inner.qadr]
    A = system.joint_map
    if A is not None:
        q = q @ A.T
    return _result("ok", "", cpu, wall, t=t, q=np.ascontiguousarray(q), steps=total)


class _GuardedSource:
    """A source whose `rhs` is guarded (deadline, finiteness), for the mirror integrators."""

    def __init__(self, source: Any, deadline: float) -> None:
        self._source, self._deadline = source, deadline
        self.name = source.name
        self.stats: Callable[[], dict[str, Any]] = lambda: {"nfev": 0, "stop": None}

    def __getattr__(self, attr: str) -> Any:
        return getattr(self._source, attr)

    def rhs(self, tau: np.ndarray) -> Callable[[float, Any], Any]:
        g, self.stats = guarded(self._source.rhs(tau), self._deadline)
        return g


def run_mirror(
    system: Any,
    source: Any,
    q0: Any,
    v0: Any,
    tau: Any,
    t: np.ndarray,
    *,
    integrator: str,
    timestep: float,
    deadline: float,
) -> dict[str, Any]:
    """`mirror_trajectory` (MuJoCo's scheme on an engine's per-call rhs), timed around the call."""
    from ..dynamics.mirror import mirror_trajectory

    src = _GuardedSource(source, deadline)
    c0, w0 = time.process_time(), time.perf_counter()
    try:
        traj = mirror_trajectory(system, src, q0, v0, tau, t, integrator=integrator, timestep=timestep)
    except _Stop:
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        s = src.stats()
        return _result(str(s["stop"]), f"stopped after {s['nfev']} evaluations", cpu, wall, nfev=s["nfev"])
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    return _result(
        "ok", "", cpu, wall, t=t, q=traj.q, nfev=int(traj.stats["evaluations"]), steps=int(traj.stats["steps"])
    )


def run_default(system: Any, source: Any, q0: Any, v0: Any, tau: Any, t: np.ndarray) -> dict[str, Any]:
    """The harness's default scipy integration, as `run` calls it (no budget: it has no hook)."""
    from ..dynamics import integrate

    c0, w0 = time.process_time(), time.perf_counter()
    try:
        default: dict[str, Any] = dict(integrate.SCIPY_DEFAULT)
        traj = integrate.scipy_trajectory(system, source, np.asarray(q0), np.asarray(v0), np.asarray(tau), t, **default)
    except HarnessError as exc:
        return _result("failed", str(exc), time.process_time() - c0, time.perf_counter() - w0)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    return _result("ok", "", cpu, wall, t=traj.t, q=traj.q, nfev=int(traj.stats["nfev"]))


def run_once(spec: dict[str, Any], case: dict[str, Any], *, budget: float) -> dict[str, Any]:
    """One execution of one spec on one case, in this process."""
    from ..dynamics.integrate import time_grid
    from ..engines.fastpath import scalar_rhs

    system, sources = _resources(case["system"])
    t = time_grid(case["t_end"], case["dt_out"])
    q0, v0, tau = (np.asarray(case[k], dtype=float) for k in ("q0", "v0", "tau"))
    driver, engine = spec["driver"], spec["engine"]
    if driver in SCIPY_DRIVERS:
        y0 = np.concatenate([q0, v0])
        if engine == "hand":
            f, tau_list = scalar_rhs(system), [float(x) for x in tau]  # compiled before the clock starts
        else:
            f, tau_list = sources[engine].rhs(tau), None
        deadline = time.perf_counter() + budget
        return run_scipy(
            driver, spec["scheme"], f, y0, t, rtol=spec["value"], atol=spec["atol"], deadline=deadline, tau=tau_list
        )
    if driver == "mujoco":
        return run_mujoco(
            system,
            sources["mujoco"],
            q0,
            v0,
            tau,
            t,
            integrator=spec["scheme"],
            timestep=spec["value"],
            deadline=time.perf_counter() + budget,
        )
    if driver == "mirror":
        if engine == "hand":
            scalar_rhs(system)
        return run_mirror(
            system,
            sources[engine],
            q0,
            v0,
            tau,
            t,
            integrator=spec["scheme"],
            timestep=spec["value"],
            deadline=time.perf_counter() + budget,
        )
    if driver == "default":
        scalar_rhs(system)
        return run_default(system, sources["hand"], q0, v0, tau, t)
    raise HarnessError(f"unknown driver '{driver}'.")


def _digest(q: np.ndarray | None) -> str | None:
    return None if q is None else hashlib.sha256(np.ascontiguousarray(q).tobytes()).hexdigest()[:16]


def execute(
    spec: dict[str, Any], case: dict[str, Any], *, budget: float, min_timed: float = MIN_TIMED, samples: bool = True
) -> dict[str, Any]:
    """One timing of one spec (a worker task): the run, repeated back to back while the total time is
    under `min_timed` (the first, cold, execution then dropped), mean per execution.

    Returns plain data: status, message, cpu_s, wall_s, executions, nfev, steps, digest of the samples
    (every execution must give the same bits), and the samples t, q when `samples`.
    """
    first = run_once(spec, case, budget=budget)
    cpus, walls, deterministic = [first["cpu_s"]], [first["wall_s"]], True
    if first["status"] == "ok":
        while sum(walls) < min_timed and len(walls) < MAX_EXECUTIONS:
            again = run_once(spec, case, budget=budget)
            if again["status"] != "ok" or _digest(again["q"]) != _digest(first["q"]):
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
        "digest": _digest(first["q"]),
        "deterministic": deterministic,
        "t": first["t"] if samples else None,
        "q": first["q"] if samples else None,
    }


# ----------------------------------------------------------------------------------------------
# Errors, rows, Pareto fronts, time to epsilon


def errors_against(
    t: np.ndarray, q: np.ndarray, ref_t: np.ndarray, ref_q: np.ndarray, *, window: float
) -> dict[str, Any]:
    """error_2s, error_10s (max over coordinates of |q - q_ref|, rad), error_horizon (max over the
    samples up to `window`; None when the run was sampled at ERROR_TIMES only) and t_exceeds_tolerance."""
    dt = float(ref_t[1] - ref_t[0])
    idx = np.rint(np.asarray(t) / dt).astype(int)
    if np.any(idx >= len(ref_t)) or not np.allclose(ref_t[idx], t, rtol=0.0, atol=1e-9):
        raise HarnessError("run samples are not on the reference grid.")
    err = np.abs(q - ref_q[idx]).max(axis=1)
    at = {tt: float(err[i]) for i, tt in enumerate(np.asarray(t)) if any(abs(tt - e) < 1e-9 for e in ERROR_TIMES)}
    full = len(t) == len(ref_t)
    inside = np.asarray(t) <= window + 1e-9
    above = np.nonzero(err > HORIZON_TOLERANCE)[0]
    return {
        "error_2s": at.get(2.0),
        "error_10s": at.get(10.0),
        "error_horizon": float(err[inside].max()) if full else None,
        "t_exceeds_tolerance": (float(t[above[0]]) if len(above) else None) if full else None,
    }


def _row(system: str, spec: dict[str, Any]) -> dict[str, Any]:
    return {
        "system": system,
        "method": spec["method"],
        "engine": spec["engine"],
        "driver": spec["driver"],
        "scheme": spec["scheme"],
        "setting": spec["setting"],
        "value": spec["value"],
        "atol": spec["atol"],
        "status": "skipped",
        "message": "",
        "error_2s": None,
        "error_10s": None,
        "error_horizon": None,
        "t_exceeds_tolerance": None,
        "cpu_s": None,
        "wall_s": None,
        "cpu_s_repeats": [],
        "wall_s_repeats": [],
        "executions": None,
        "nfev": None,
        "steps": None,
        "deterministic": True,
    }


def _sort_key(row: dict[str, Any]) -> tuple[Any, ...]:
    return (row["system"], row["method"], -row["value"])


def pareto_front(rows: Iterable[dict[str, Any]], error: str, *, cost: str = "cpu_s") -> list[dict[str, Any]]:
    """The runs no other run beats in both `cost` and `error` (status ok, finite values), cheapest first."""
    ok = [
        r
        for r in rows
        if r["status"] == "ok"
        and r.get(error) is not None
        and r.get(cost) is not None
        and math.isfinite(r[error])
        and math.isfinite(r[cost])
    ]
    ok.sort(key=lambda r: (r[cost], r[error]))
    front, best = [], math.inf
    for r in ok:
        if r[error] < best:
            best = r[error]
            front.append(
                {"method": r["method"], "setting": r["setting"], "value": r["value"], cost: r[cost], error: r[error]}
            )
    return front


def time_to_epsilon(
    rows: Iterable[dict[str, Any]],
    epsilons: Iterable[float] = EPSILONS,
    *,
    error: str = "error_2s",
    cost: str = "cpu_s",
) -> list[dict[str, Any]]:
    """Per system, method and epsilon: the cheapest run of that method with `error` <= epsilon, or
    "not reached". Sorted by system, method, epsilon (largest first)."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["system"], r["method"]), []).append(r)
    out = []
    for (system, method), runs in sorted(groups.items()):
        for eps in sorted(epsilons, reverse=True):
            good = [
                r
                for r in runs
                if r["status"] == "ok" and r.get(error) is not None and r[error] <= eps and r.get(cost) is not None
            ]
            entry: dict[str, Any] = {"system": system, "method": method, "epsilon": eps}
            if good:
                best = min(good, key=lambda r: (r[cost], -r["value"]))
                entry.update(
                    result="reached",
                    setting=best["setting"],
                    value=best["value"],
                    cpu_s=best["cpu_s"],
                    wall_s=best["wall_s"],
                    error=best[error],
                )
            else:
                entry.update(result="not reached", setting=None, value=None, cpu_s=None, wall_s=None, error=None)
            out.append(entry)
    return out


# ----------------------------------------------------------------------------------------------
# The sweep


def _interleave(groups: list[list[Any]], rotate: int) -> list[Any]:
    """Round-robin: the first item of every group, then the second, ...; the group order rotated."""
    if groups:
        rotate %= len(groups)
        groups = groups[rotate:] + groups[:rotate]
    out = []
    for level in range(max((len(g) for g in groups), default=0)):
        out += [g[level] for g in groups if level < len(g)]
    return out


def _looser(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Whether setting a is looser (cheaper) than b: larger rtol or timestep."""
    return a["value"] > b["value"]


def sweep(
    prepared: dict[str, dict[str, Any]],
    specs: list[dict[str, Any]],
    *,
    repeats: int,
    executor: Executor,
    budget: float,
    min_timed: float = MIN_TIMED,
    progress: Callable[[str], None] | None = None,
    extra: dict[str, tuple[Callable[..., Any], tuple[Any, ...]]] | None = None,
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Every spec on every prepared system, `repeats` times, interleaved; rows sorted.

    Args:
        prepared: {system: prepare(system)}.
        specs: the plan (see `plan`), the same for every system.
        extra: more worker tasks {key: (fn, args)} submitted with the last repeat (the ratio measurements);
            their results are returned in the second value.
    """
    if repeats < 1:
        raise HarnessError(f"repeats must be at least 1; got {repeats}.")
    rows = {(name, s["method"], s["value"]): _row(name, s) for name in prepared for s in specs}
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for name in prepared:
        for s in specs:
            groups.setdefault((name, s["method"]), []).append(s)
    for g in groups.values():
        g.sort(key=lambda s: -s["value"])
    extras: dict[str, Any] = {}
    digests: dict[tuple[str, str, float], str | None] = {}
    for rep in range(repeats):
        if rep == 0:
            todo = [[(key[0], s) for s in g] for key, g in groups.items()]
        else:
            todo = [
                [(key[0], s) for s in g if rows[(key[0], s["method"], s["value"])]["status"] == "ok"]
                for key, g in groups.items()
            ]
        order = _interleave(todo, rep)
        futures: dict[Future[Any], tuple[str, dict[str, Any]]] = {}
        for name, s in order:
            fut = executor.submit(
                execute, s, prepared[name]["case"], budget=budget, min_timed=min_timed, samples=rep == 0
            )
            futures[fut] = (name, s)
        extra_futures: dict[Future[Any], str] = {}
        if rep == repeats - 1:
            for label, (fn, args) in (extra or {}).items():
                extra_futures[executor.submit(fn, *args)] = label
        done = 0
        for fut in as_completed([*futures, *extra_futures]):
            if fut in extra_futures:
                extras[extra_futures[fut]] = fut.result()
                continue
            if fut.cancelled():
                continue
            name, s = futures[fut]
            res = fut.result()
            done += 1
            key = (name, s["method"], s["value"])
            row = rows[key]
            if rep == 0:
                row.update(
                    status=res["status"],
                    message=res["message"],
                    nfev=res["nfev"],
                    steps=res["steps"],
                    executions=res["executions"],
                    deterministic=res["deterministic"],
                )
                digests[key] = res["digest"]
                if res["status"] == "ok":
                    ref = prepared[name]
                    row.update(errors_against(res["t"], res["q"], ref["t"], ref["q"], window=ref["horizon_window_s"]))
                elif res["status"] == "timeout":  # tighter settings of the same method cost more: not run
                    for other, (oname, os_) in futures.items():
                        if oname == name and os_["method"] == s["method"] and _looser(s, os_) and other.cancel():
                            rows[(oname, os_["method"], os_["value"])].update(
                                status="skipped",
                                message=f"not run: {s['setting']} {s['value']:g} already exceeded the "
                                f"{budget:g} s budget",
                            )
            elif res["status"] != "ok" or res["digest"] != digests[key]:
                row["deterministic"] = False
                if res["status"] != "ok":
                    row["message"] = f"repeat {rep + 1}: {res['status']} {res['message']}".strip()
                    continue
            if res["status"] in ("ok", "timeout", "diverged", "failed"):
                row["cpu_s_repeats"].append(res["cpu_s"])
                row["wall_s_repeats"].append(res["wall_s"])
            if progress and done % max(1, len(futures) // 10) == 0:
                progress(f"repeat {rep + 1}/{repeats}: {done}/{len(futures)} runs")
    out = []
    for row in rows.values():
        if row["cpu_s_repeats"]:
            row["cpu_s"] = statistics.median(row["cpu_s_repeats"])
            row["wall_s"] = statistics.median(row["wall_s_repeats"])
        out.append(row)
    return sorted(out, key=_sort_key), extras


# ----------------------------------------------------------------------------------------------
# Ratio 1: the fast path against hand-written scalar math (eqs 33-34 with the bobs' inertia)


def hand_math_rhs(p: Any) -> Callable[[float, Any], list[float]]:
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

    def rhs(t: float, y: Any) -> list[float]:
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


def numpy_solve_rhs(p: Any) -> Callable[[float, Any], np.ndarray]:
    """The same formula with a 2x2 `np.linalg.solve` per call (the issue's ~18x, for context)."""
    m1, m2, l1, l2, g, i1, i2 = (float(getattr(p, k)) for k in ("m1", "m2", "l1", "l2", "g", "I1", "I2"))
    a0 = m1 * l1 * l1 + m2 * (l1 * l1 + l2 * l2) + i1 + i2
    b, m22 = m2 * l1 * l2, m2 * l2 * l2 + i2
    g1, g2 = (m1 + m2) * g * l1, m2 * g * l2

    def rhs(t: float, y: Any) -> np.ndarray:
        th, ph, w1, w2 = y
        c, s = np.cos(ph), np.sin(ph)
        M = np.array([[a0 + 2 * b * c, m22 + b * c], [m22 + b * c, m22]])
        grav2 = g2 * np.sin(th + ph)
        r = np.array([b * s * (2 * w1 * w2 + w2 * w2) - g1 * np.sin(th) - grav2, -b * s * w1 * w1 - grav2])
        return np.concatenate([y[2:], np.linalg.solve(M, r)])

    return rhs


def _interleaved_medians(fns: dict[str, Callable[[], Any]], reps: int) -> dict[str, dict[str, Any]]:
    """Each callable timed `reps` times, in rotating order; medians of CPU and wall seconds."""
    names = list(fns)
    cpu: dict[str, list[float]] = {k: [] for k in names}
    wall: dict[str, list[float]] = {k: [] for k in names}
    for rep in range(reps):
        for k in names[rep % len(names) :] + names[: rep % len(names)]:
            c0, w0 = time.process_time(), time.perf_counter()
            fns[k]()
            cpu[k].append(time.process_time() - c0)
            wall[k].append(time.perf_counter() - w0)
    return {
        k: {
            "cpu_s": statistics.median(cpu[k]),
            "wall_s": statistics.median(wall[k]),
            "cpu_s_repeats": cpu[k],
            "wall_s_repeats": wall[k],
        }
        for k in names
    }


def rhs_ratio(*, reps: int, calls: int = 10_000, n_states: int = 1000, seed: int = 0) -> dict[str, Any]:
    """Ratio 1 (a worker task): the right-hand side scipy gets for the hand equations
    (`integrate.source_rhs`: the generated fast path behind the harness's counter) against `hand_math_rhs`,
    per call, both called as scipy calls them (f(t, y), y a float64 array) over `n_states` states."""
    from ..dynamics.integrate import source_rhs
    from ..engines import make_source

    system, _ = _resources(RHS_SYSTEM)
    hand = make_source(system, "hand")
    harness = source_rhs(hand, np.zeros(system.nv))
    from ..engines.fastpath import scalar_rhs

    fast, tau0 = scalar_rhs(system), [0.0] * system.nv
    math_rhs, np_rhs = hand_math_rhs(system.params), numpy_solve_rhs(system.params)
    rng = np.random.default_rng(seed)
    ys = [rng.uniform(-3, 3, 2 * system.nv) for _ in range(n_states)]
    passes = max(1, calls // n_states)

    def loop(f: Callable[..., Any], *extra: Any) -> Callable[[], None]:
        def run() -> None:
            for _ in range(passes):
                for y in ys:
                    f(0.0, y, *extra)

        return run

    timed = _interleaved_medians(
        {
            "harness": loop(harness),
            "hand_math": loop(math_rhs),
            "fast_path_bare": loop(fast, tau0),
            "numpy_solve": loop(np_rhs),
        },
        reps,
    )
    per_call = {k: v["cpu_s"] / (passes * n_states) * 1e6 for k, v in timed.items()}
    ratio = per_call["harness"] / per_call["hand_math"]
    return {
        "system": RHS_SYSTEM,
        "value": ratio,
        "target": RHS_TARGET,
        "passed": ratio <= RHS_TARGET,
        "per_call_us": per_call,
        "numpy_vs_hand_math": per_call["numpy_solve"] / per_call["hand_math"],
        "calls_per_measurement": passes * n_states,
        "repeats": reps,
        "how": "CPU time per call (median of interleaved repeats) of the function scipy receives "
        "(integrate._rhs: counter + generated fast path) over the hand-written math version; "
        "both f(t, y) with y a float64 array; the loop overhead (~30 ns/call) is in both",
    }


# ----------------------------------------------------------------------------------------------
# Ratio 2: the pointwise check against the raw engine calls it needs


def _joint_coordinates(system: Any, states: Any, a: np.ndarray) -> tuple[np.ndarray, ...]:
    """q, v, a, tau in joint coordinates (engines see joints; JOINT_MAP maps them to the notes')."""
    A = system.joint_map
    if A is None:
        return states.q, states.v, a, states.tau
    Ainv = np.linalg.inv(A)
    return states.q @ Ainv.T, states.v @ Ainv.T, a @ Ainv.T, states.tau @ A


def _to_notes(system: Any, out: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    A = system.joint_map
    if A is None:
        return out
    Ainv = np.linalg.inv(A)
    out["M"] = Ainv.T @ out["M"] @ Ainv
    for k in ("bias", "passive", "tau_inverse"):
        out[k] = out[k] @ Ainv
    out["qacc"] = out["qacc"] @ A.T
    return out


def raw_hand(system: Any, states: Any) -> dict[str, Any]:
    """The hand side of the pointwise check as the equations module's vectorised numpy formulas,
    called directly (one batched solve; tau_inverse at the computed accelerations)."""
    q, v, tau = states.q, states.v, states.tau
    eq, p = system.equations, system.params
    M = np.asarray(eq.mass_matrix(p, q), dtype=float)
    bias = np.asarray(eq.bias(p, q, v), dtype=float)
    passive = np.asarray(eq.passive(p, q, v), dtype=float)
    qacc = np.linalg.solve(M, (tau + passive - bias)[..., None])[..., 0]
    return {
        "M": M,
        "bias": bias,
        "passive": passive,
        "qacc": qacc,
        "tau_inverse": np.einsum("...ij,...j->...i", M, qacc) + bias - passive,
        "T": eq.kinetic_energy(p, q, v),
        "V": eq.potential_energy(p, q),
        "body_positions": eq.body_positions(p, q),
        "body_rotations": eq.body_rotations(p, q),
    }


def raw_mujoco(system: Any, source: Any, states: Any, a_ref: np.ndarray) -> dict[str, np.ndarray]:
    """Per state: write qpos/qvel/ctrl (or qfrc_applied), mj_forward, mj_fullM; write qacc = a_ref,
    mj_inverse. The same outputs as `MujocoSource.evaluate`, in the notes' coordinates."""
    import mujoco

    qj, vj, aj, tauj = _joint_coordinates(system, states, a_ref)
    n_states, n = qj.shape
    mj = getattr(source, "inner", source)
    m, d = mj.m, mj.d
    driven = mj.ctrl_of_coord >= 0
    ctrl = np.zeros((n_states, m.nu))
    ctrl[:, mj.ctrl_of_coord[driven]] = tauj[:, driven] / mj.gear[driven]
    applied = np.zeros((n_states, m.nv))
    applied[:, mj.dadr[~driven]] = tauj[:, ~driven]
    ident = np.array_equal(mj.qadr, np.arange(m.nq)) and np.array_equal(mj.dadr, np.arange(m.nv)) and m.nv == n
    qa: Any = slice(None) if ident else mj.qadr
    da: Any = slice(None) if ident else mj.dadr
    ix = np.ix_(mj.dadr, mj.dadr)
    bodies = mj.body_ids
    full = np.zeros((m.nv, m.nv))
    M, bias, passive = np.empty((n_states, n, n)), np.empty((n_states, n)), np.empty((n_states, n))
    qacc, tau_inv, energy = np.empty((n_states, n)), np.empty((n_states, n)), np.empty((n_states, 2))
    pos, rot = np.empty((n_states, len(bodies), 3)), np.empty((n_states, len(bodies), 9))
    forward, full_m, inverse = mujoco.mj_forward, mujoco.mj_fullM, mujoco.mj_inverse
    for i in range(n_states):
        d.qpos[qa] = qj[i]
        d.qvel[da] = vj[i]
        d.ctrl[:] = ctrl[i]
        d.qfrc_applied[:] = applied[i]
        forward(m, d)
        full_m(m, d, full)
        M[i] = full if ident else full[ix]
        bias[i], passive[i], qacc[i] = d.qfrc_bias[da], d.qfrc_passive[da], d.qacc[da]
        energy[i] = d.energy
        pos[i], rot[i] = d.xipos[bodies], d.xmat[bodies]
        d.qacc[da] = aj[i]
        d.ctrl[:] = 0.0
        d.qfrc_applied[:] = 0.0
        inverse(m, d)
        tau_inv[i] = d.qfrc_inverse[da]
    out = {
        "M": M,
        "bias": bias,
        "passive": passive,
        "qacc": qacc,
        "tau_inverse": tau_inv,
        "T": energy[:, 1],
        "V": energy[:, 0],
        "body_positions": pos,
        "body_rotations": rot.reshape(n_states, len(bodies), 3, 3),
    }
    return _to_notes(system, out)


def raw_pinocchio(system: Any, source: Any, states: Any, a_ref: np.ndarray) -> dict[str, np.ndarray]:
    """Per state: crba, nonLinearEffects, aba, rnea, computeKineticEnergy, computePotentialEnergy (which
    also places the joints, read for the body poses). The same outputs as `PinocchioSource.evaluate`."""
    import pinocchio as pin

    qj, vj, aj, tauj = _joint_coordinates(system, states, a_ref)
    n_states, n = qj.shape
    pn = getattr(source, "inner", source)
    model, data = pn.model, pn.data
    qfull, vfull, ffull, afull = pin.neutral(model), np.zeros(model.nv), np.zeros(model.nv), np.zeros(model.nv)
    vi, qi = pn.vidx, pn.qidx
    ix = np.ix_(vi, vi)
    passive = -pn.damping * vj
    joints = pn.joint_of_body
    levers = [model.inertias[j].lever for j in joints]
    frame_rot = [model.frames[f].placement.rotation for f in pn.frames]
    M, bias, qacc, tau_inv = (
        np.empty((n_states, n, n)),
        np.empty((n_states, n)),
        np.empty((n_states, n)),
        np.empty((n_states, n)),
    )
    kin, pot = np.empty(n_states), np.empty(n_states)
    pos, rot = np.empty((n_states, len(joints), 3)), np.empty((n_states, len(joints), 3, 3))
    crba, nle, aba, rnea = pin.crba, pin.nonLinearEffects, pin.aba, pin.rnea
    kinetic, potential = pin.computeKineticEnergy, pin.computePotentialEnergy
    for i in range(n_states):
        qfull[qi] = qj[i]
        vfull[vi] = vj[i]
        ffull[vi] = tauj[i] + passive[i]
        afull[vi] = aj[i]
        full = crba(model, data, qfull)
        M[i] = (np.triu(full) + np.triu(full, 1).T)[ix]
        bias[i] = nle(model, data, qfull, vfull)[vi]
        qacc[i] = aba(model, data, qfull, vfull, ffull)[vi]
        tau_inv[i] = rnea(model, data, qfull, vfull, afull)[vi]
        kin[i] = kinetic(model, data, qfull, vfull)
        pot[i] = potential(model, data, qfull)
        for k, (jid, lever) in enumerate(zip(joints, levers, strict=True)):
            oMi = data.oMi[jid]
            pos[i, k] = oMi.act(lever)
            rot[i, k] = oMi.rotation @ frame_rot[k]
    out = {
        "M": M,
        "bias": bias,
        "passive": passive,
        "qacc": qacc,
        "tau_inverse": tau_inv - passive,
        "T": kin,
        "V": pot,
        "body_positions": pos,
        "body_rotations": rot,
    }
    return _to_notes(system, out)


def raw_pointwise(system: Any, sources: dict[str, Any], states: Any) -> dict[str, dict[str, Any]]:
    """What `compare.evaluate` computes, as the minimal loops (`raw_hand`, `raw_mujoco`, `raw_pinocchio`;
    the engines' inverse dynamics at the hand accelerations). {source: {quantity: array}}."""
    hand = raw_hand(system, states)
    return {
        "hand": hand,
        "mujoco": raw_mujoco(system, sources["mujoco"], states, hand["qacc"]),
        "pinocchio": raw_pinocchio(system, sources["pinocchio"], states, hand["qacc"]),
    }


def pointwise_ratio(name: str, *, reps: int, n_states: int = POINTWISE_STATES, seed: int = 0) -> dict[str, Any]:
    """Ratio 2 for one system (a worker task): `compare.evaluate` on `n_states` states through all
    three sources against `raw_pointwise`, interleaved; sources and states built before timing.
    Each source's share is timed too (harness: its `evaluate`, plus the hand's `inverse`)."""
    from ..checks import pointwise as compare

    system, sources = _resources(name)
    states = compare.random_states(system, n=n_states, seed=seed)
    q, v, tau = states.q, states.v, states.tau
    a_hand = sources["hand"].forward(q, v, tau)

    def harness_hand() -> None:
        out = sources["hand"].evaluate(q, v, tau, np.zeros_like(q))
        sources["hand"].inverse(q, v, out["qacc"])

    timed = _interleaved_medians(
        {
            "harness": lambda: compare.evaluate(sources, states),
            "raw": lambda: raw_pointwise(system, sources, states),
            "harness hand": harness_hand,
            "raw hand": lambda: raw_hand(system, states),
            "harness mujoco": lambda: sources["mujoco"].evaluate(q, v, tau, a_hand),
            "raw mujoco": lambda: raw_mujoco(system, sources["mujoco"], states, a_hand),
            "harness pinocchio": lambda: sources["pinocchio"].evaluate(q, v, tau, a_hand),
            "raw pinocchio": lambda: raw_pinocchio(system, sources["pinocchio"], states, a_hand),
        },
        reps,
    )
    ratio = timed["harness"]["cpu_s"] / timed["raw"]["cpu_s"]
    return {
        "system": name,
        "value": ratio,
        "target": POINTWISE_TARGET,
        "passed": ratio <= POINTWISE_TARGET,
        "harness_cpu_s": timed["harness"]["cpu_s"],
        "raw_cpu_s": timed["raw"]["cpu_s"],
        "harness_wall_s": timed["harness"]["wall_s"],
        "raw_wall_s": timed["raw"]["wall_s"],
        "by_source": {
            src: {
                "harness_cpu_s": timed[f"harness {src}"]["cpu_s"],
                "raw_cpu_s": timed[f"raw {src}"]["cpu_s"],
                "ratio": timed[f"harness {src}"]["cpu_s"] / timed[f"raw {src}"]["cpu_s"],
            }
            for src in ("hand", "mujoco", "pinocchio")
        },
        "n_states": n_states,
        "repeats": reps,
    }


# ----------------------------------------------------------------------------------------------
# Ratio 5: what the scene's disable flags save per mj_step


def flag_names(flags: int) -> list[str]:
    import mujoco

    return sorted(
        k.removeprefix("mjDSBL_").lower()
        for k, v in mujoco.mjtDisableBit.__members__.items()
        if k != "mjNDISABLE" and flags & int(v)
    )


def flags_ratio(name: str, *, steps: int, reps: int) -> list[dict[str, Any]]:
    """Per integrator (RK4, Euler): CPU time per mj_step at the MJCF's timestep from the system's start,
    with the model's disable flags and with `disableflags = 0`, interleaved (a worker task)."""
    import mujoco

    system, sources = _resources(name)
    src = sources["mujoco"]
    m, d = getattr(src, "inner", src).m, getattr(src, "inner", src).d
    case = case_for(system)
    names = {"RK4": mujoco.mjtIntegrator.mjINT_RK4, "Euler": mujoco.mjtIntegrator.mjINT_EULER}
    saved = (m.opt.integrator, m.opt.disableflags)
    out = []
    try:
        for integ in FLAG_INTEGRATORS:
            m.opt.integrator = names[integ]

            def stepping(flags: int) -> Callable[[], None]:
                def run() -> None:
                    m.opt.disableflags = flags
                    mujoco.mj_resetData(m, d)
                    src.set_state(np.array(case["q0"]), np.array(case["v0"]), np.array(case["tau"]))
                    mujoco.mj_step(m, d, nstep=steps)

                return run

            timed = _interleaved_medians({"model": stepping(saved[1]), "none": stepping(0)}, reps)
            per_model = timed["model"]["cpu_s"] / steps * 1e6
            per_none = timed["none"]["cpu_s"] / steps * 1e6
            out.append(
                {
                    "system": name,
                    "integrator": integ,
                    "timestep": float(m.opt.timestep),
                    "model_flags": flag_names(saved[1]),
                    "us_per_step_model_flags": per_model,
                    "us_per_step_all_enabled": per_none,
                    "all_enabled_over_model": per_none / per_model,
                    "saving": 1.0 - per_model / per_none,
                    "steps": steps,
                    "repeats": reps,
                }
            )
    finally:
        m.opt.integrator, m.opt.disableflags = saved
    return out


# ----------------------------------------------------------------------------------------------
# Ratio 3: the default scipy integration against the fastest scipy driver at 1e-9


def default_ratio(
    rows: list[dict[str, Any]],
    *,
    system: str = RHS_SYSTEM,
    epsilon: float = DEFAULT_EPSILON,
    target: float = DEFAULT_TARGET,
) -> dict[str, Any]:
    """From the sweep: the default's CPU time over that of the fastest scipy run on the hand equations
    reaching `epsilon` at t = 2 s (drivers giving the whole 10 ms grid, as the default must), and which
    (method, rtol) runs would meet the target."""
    mine = [r for r in rows if r["system"] == system]
    default = next((r for r in mine if r["driver"] == "default"), None)
    candidates = [
        r
        for r in mine
        if r["engine"] == "hand"
        and r["driver"] in ("solve_ivp", "ode", "odeint")
        and r["status"] == "ok"
        and r["error_2s"] is not None
        and r["error_2s"] <= epsilon
    ]
    out: dict[str, Any] = {"system": system, "epsilon": epsilon, "target": target}
    if default is None or not candidates or default.get("cpu_s") is None:
        return {**out, "value": None, "passed": False, "why": "no default run or no scipy run reached epsilon"}
    fastest = min(candidates, key=lambda r: r["cpu_s"])
    ivp = [r for r in candidates if r["driver"] == "solve_ivp"]
    fastest_ivp = min(ivp, key=lambda r: r["cpu_s"]) if ivp else None
    reached = default["status"] == "ok" and default["error_2s"] is not None and default["error_2s"] <= epsilon
    ratio = default["cpu_s"] / fastest["cpu_s"]

    def brief(r: dict[str, Any] | None) -> dict[str, Any] | None:
        return (
            None
            if r is None
            else {
                "method": r["method"],
                "rtol": r["value"],
                "atol": r["atol"],
                "cpu_s": r["cpu_s"],
                "error_2s": r["error_2s"],
            }
        )

    return {
        **out,
        "value": ratio,
        "passed": bool(reached and ratio <= target),
        "default": {**brief(default), "reached": reached},  # type: ignore[dict-item]
        "fastest": brief(fastest),
        "fastest_solve_ivp": brief(fastest_ivp),
        "default_over_fastest_solve_ivp": default["cpu_s"] / fastest_ivp["cpu_s"] if fastest_ivp else None,
        "would_pass": [
            brief(r) for r in sorted(candidates, key=lambda r: r["cpu_s"]) if r["cpu_s"] <= target * fastest["cpu_s"]
        ],
        "how": "median CPU time of each run in the interleaved sweep; the default is integrate.scipy_trajectory "
        "with integrate.SCIPY_DEFAULT on the hand source",
    }


# ----------------------------------------------------------------------------------------------
# Ratio 4: `lagrange-xval run` wall time


RUN_CONDITIONS = {
    "fresh machine": "no reference or chaos cache and an empty heyoka JIT cache (XDG_CACHE_HOME in a new folder)",
    "cold cache": "no reference or chaos cache (an empty --cache-dir); heyoka's JIT cache as the first run left it",
    "warm cache": "the reference and chaos cache the second run wrote",
}


def run_wall_times(repeats: int = RUN_REPEATS, *, timeout: float = 900.0) -> dict[str, Any]:
    """`python -m lagrange_xval.validate.cli run` (all systems, reports and replays) timed as
    subprocesses one after another, with nothing else of the bench running: per repeat, three runs
    into new folders, one per condition of RUN_CONDITIONS (fresh machine, cold cache, warm cache)."""
    import os
    import resource
    import subprocess
    import tempfile

    walls: dict[str, list[float]] = {c: [] for c in RUN_CONDITIONS}
    cpus: dict[str, list[float]] = {c: [] for c in RUN_CONDITIONS}
    codes: list[int] = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory(prefix="bench-run-") as tmp:
            env = {**os.environ, "XDG_CACHE_HOME": str(Path(tmp) / "xdg")}
            for k, condition in enumerate(RUN_CONDITIONS):
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                w0 = time.perf_counter()
                out, cache = Path(tmp) / f"out{k}", Path(tmp) / ("cache0" if k == 0 else "cache1")
                proc = subprocess.run(
                    [
                        sys.executable,
                        "-m",
                        "lagrange_xval.validate.cli",
                        "run",
                        "--out",
                        str(out),
                        "--cache-dir",
                        str(cache),
                    ],
                    capture_output=True,
                    text=True,
                    timeout=timeout,
                    env=env,
                )
                walls[condition].append(time.perf_counter() - w0)
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpus[condition].append((after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime))
                codes.append(proc.returncode)
    medians = {c: statistics.median(w) for c, w in walls.items()}
    worst = max(medians.values())
    return {
        "value": worst,
        "target": RUN_TARGET_S,
        "passed": worst < RUN_TARGET_S and medians["warm cache"] < RUN_WARM_TARGET_S,
        "median_s": medians,
        "warm_target": RUN_WARM_TARGET_S,
        "wall_s_all": walls,
        "cpu_s_all": cpus,
        "exit_codes": codes,
        "repeats": repeats,
        "conditions": RUN_CONDITIONS,
        "how": "wall time of `python -m lagrange_xval.validate.cli run --out <new folder> --cache-dir <folder>` "
        f"(every system, reports and rerun replays), {repeats} repeats of three runs one after another: "
        + "; ".join(f"{c}: {why}" for c, why in RUN_CONDITIONS.items())
        + "; value = the slowest condition's median; CPU = user + system of the process tree",
    }


# ----------------------------------------------------------------------------------------------
# The whole bench


def run_bench(
    names: list[str] | None,
    *,
    quick: bool,
    repeats: int | None = None,
    executor: Executor | None = None,
    progress: Callable[[str], None] | None = None,
    time_run: bool | None = None,
) -> dict[str, Any]:
    """The work-precision sweep and the ratios, as JSON-able data.

    Args:
        names: systems (default: every system; with `quick`, QUICK_SYSTEMS).
        quick: the small plan (QUICK_*), one repeat, 5 s budget; `lagrange-xval run` is not timed.
        repeats: timing repeats (default 3, quick 1).
        executor: where the worker tasks run (default: a process pool on every core).
        time_run: time `lagrange-xval run` (default: not quick).
    """
    from ..results import provenance
    from ..systems import load_all, system_names

    start = time.perf_counter()
    chosen = list(names) if names else list(QUICK_SYSTEMS if quick else system_names())
    systems = load_all(chosen)  # unknown names fail here, before any work starts
    chosen = [s.name for s in systems]
    repeats = repeats if repeats is not None else (QUICK_REPEATS if quick else DEFAULT_REPEATS)
    if repeats < 1:
        raise HarnessError(f"--repeats must be at least 1; got {repeats}.")
    budget = QUICK_BUDGET if quick else BUDGET
    specs = plan(quick=quick)
    reps_small = 3 if quick else 7
    from ..parallel import executor_for

    with executor_for(executor) as pool:
        if progress:
            progress(f"preparing references for {', '.join(chosen)}")
        prepared = dict(zip(chosen, pool.map(prepare, chosen), strict=True))
        extra: dict[str, tuple[Callable[..., Any], tuple[Any, ...]]] = {}
        if RHS_SYSTEM in system_names():
            extra["rhs"] = (_rhs_task, (15 if not quick else 7,))
        for name in chosen:
            extra[f"pointwise {name}"] = (_pointwise_task, (name, 5 if not quick else 3))
            extra[f"flags {name}"] = (_flags_task, (name, 20_000 if not quick else 5_000, reps_small))
        rows, extras = sweep(
            prepared, specs, repeats=repeats, executor=pool, budget=budget, progress=progress, extra=extra
        )
        workers = getattr(pool, "_max_workers", None)
    sweep_s = time.perf_counter() - start
    ratios: dict[str, Any] = {}
    ratios["rhs_fast_path_vs_hand_math"] = extras.get(
        "rhs", {"value": None, "passed": False, "why": f"{RHS_SYSTEM} not available"}
    )
    point = [extras[f"pointwise {n}"] for n in chosen]
    ratios["pointwise_vs_raw_engine_calls"] = {
        "value": max(p["value"] for p in point),
        "target": POINTWISE_TARGET,
        "passed": all(p["passed"] for p in point),
        "per_system": point,
        "how": "CPU time (median of interleaved repeats) of compare.evaluate(make_sources(s), random_states(s, "
        f"n={POINTWISE_STATES}, seed=0)) over raw_pointwise (the minimal loops); value = worst system",
    }
    ratios["default_scipy_vs_fastest_scipy"] = (
        default_ratio(rows)
        if RHS_SYSTEM in chosen
        else {"value": None, "passed": None, "why": f"{RHS_SYSTEM} not in this bench"}
    )
    ratios["mujoco_disable_flags"] = {
        "target": None,
        "rows": sorted((r for n in chosen for r in extras[f"flags {n}"]), key=lambda r: (r["system"], r["integrator"])),
        "how": "CPU time per mj_step (median of interleaved repeats) with the MJCF's disableflags and with "
        "disableflags = 0. The scenes have no contacts (contype 0), constraints, limits, springs or "
        "friction loss, so enabling them changes no force: the difference is the cost of the pipeline "
        "stages that run and find nothing (collision, constraint assembly, passive forces), plus, "
        "where the flags disable them, gravity (gimbal: balanced, zero torque), damper and actuation "
        "(the double pendulums have neither), and Euler's implicit damping (gimbal).",
    }
    if time_run if time_run is not None else not quick:
        if progress:
            progress(f"timing `lagrange-xval run` {RUN_REPEATS} x {len(RUN_CONDITIONS)} times")
        ratios["run_wall_time"] = run_wall_times()
    else:
        ratios["run_wall_time"] = {
            "value": None,
            "target": RUN_TARGET_S,
            "passed": None,
            "why": "not measured in --quick (5 full runs take over a minute)",
        }
    duration = time.perf_counter() - start
    return {
        "meta": provenance(),
        "config": {
            "quick": quick,
            "systems": chosen,
            "repeats": repeats,
            "budget_s": budget,
            "min_timed_s": MIN_TIMED,
            "t_end": T_END,
            "dt_out": DT_OUT,
            "error_times": list(ERROR_TIMES),
            "atol": f"rtol * {ATOL_FACTOR:g}",
            "horizon_tolerance": HORIZON_TOLERANCE,
            "epsilons": list(EPSILONS),
            "workers": workers,
            "cost": "cpu_s (time.process_time, median)",
        },
        "systems": {
            n: {k: prepared[n][k] for k in ("case", "reference", "horizon_s", "horizon_window_s", "lyapunov_per_s")}
            for n in chosen
        },
        "rows": rows,
        "pareto": {
            n: {e: pareto_front([r for r in rows if r["system"] == n], e) for e in ("error_10s", "error_2s")}
            for n in chosen
        },
        "time_to_epsilon": time_to_epsilon(rows),
        "ratios": ratios,
        "duration_s": duration,
        "sweep_s": sweep_s,
        "quick_target_s": QUICK_TARGET_S if quick else None,
    }


def _rhs_task(reps: int) -> dict[str, Any]:
    return rhs_ratio(reps=reps)


def _pointwise_task(name: str, reps: int) -> dict[str, Any]:
    return pointwise_ratio(name, reps=reps)


def _flags_task(name: str, steps: int, reps: int) -> list[dict[str, Any]]:
    return flags_ratio(name, steps=steps, reps=reps)


def write_bench(results: dict[str, Any], out: Path) -> Path:
    """`out/bench.json`, written atomically (serialised first, then a temporary file and a rename)."""
    from ..results import atomic_write, dumps

    text = dumps(results)
    path = Path(out) / "bench.json"
    atomic_write(path, text)
    return path


# ----------------------------------------------------------------------------------------------
# Printing


def _ms(x: float | None) -> str:
    if x is None:
        return "-"
    return f"{x * 1e3:.3g} ms" if x < 1 else f"{x:.3g} s"


def _setting(setting: str | None, value: float | None) -> str:
    if setting is None or value is None:
        return ""
    return f"{'rtol' if setting == 'rtol' else 'dt'} {value:.0e}"


def summary(results: dict[str, Any], console: Any = None) -> None:
    """A readable summary: per system, time to reach eps and the Pareto front; the ratios; failures."""
    from rich.console import Console
    from rich.table import Table

    console = console or (Console() if sys.stdout.isatty() else Console(width=150))
    cfg = results["config"]
    console.print(
        f"[bold]bench[/bold] ({'quick' if cfg['quick'] else 'full'}): {', '.join(cfg['systems'])}; "
        f"{cfg['repeats']} repeat(s), budget {cfg['budget_s']:g} s per run; took "
        f"{results['duration_s']:.1f} s. Times are CPU (process_time), medians."
    )
    tte = results["time_to_epsilon"]
    for name in cfg["systems"]:
        sysinfo = results["systems"][name]
        table = Table(
            title=f"{name}: time to reach error eps at t = 2 s (horizon window {sysinfo['horizon_window_s']:g} s)",
            title_justify="left",
        )
        table.add_column("method")
        for eps in sorted(cfg["epsilons"], reverse=True):
            table.add_column(f"eps {eps:.0e}", justify="right")
        methods = sorted({e["method"] for e in tte if e["system"] == name})
        for method in methods:
            cells = []
            for eps in sorted(cfg["epsilons"], reverse=True):
                e = next(x for x in tte if x["system"] == name and x["method"] == method and x["epsilon"] == eps)
                cells.append(
                    "not reached"
                    if e["result"] != "reached"
                    else f"{_ms(e['cpu_s'])} ({_setting(e['setting'], e['value'])})"
                )
            table.add_row(method, *cells)
        console.print(table)
        front = results["pareto"][name]["error_10s"]
        console.print(
            "  Pareto front (CPU vs error at 10 s): "
            + "; ".join(
                f"{p['method']} {_setting(p['setting'], p['value'])}: {_ms(p['cpu_s'])}, {p['error_10s']:.1e}"
                for p in front
            )
        )
        bad = [r for r in results["rows"] if r["system"] == name and r["status"] != "ok"]
        if bad:
            console.print(
                "  not ok: "
                + "; ".join(f"{r['method']} {_setting(r['setting'], r['value'])}: {r['status']}" for r in bad)
            )
    ratios = results["ratios"]
    table = Table(title="A fast harness: ratios (measured in this run)", title_justify="left")
    for col in ("ratio", "measured", "target", "verdict"):
        table.add_column(col)

    def verdict(r: dict[str, Any]) -> str:
        return "-" if r.get("passed") is None else ("pass" if r["passed"] else "FAIL")

    r1 = ratios["rhs_fast_path_vs_hand_math"]
    if r1.get("value") is not None:
        pc = r1["per_call_us"]
        table.add_row(
            "rhs: fast path / hand-written math",
            f"{r1['value']:.2f}x ({pc['harness']:.2f} vs "
            f"{pc['hand_math']:.2f} us/call; np.linalg.solve {r1['numpy_vs_hand_math']:.1f}x)",
            f"<= {r1['target']}x",
            verdict(r1),
        )
    r2 = ratios["pointwise_vs_raw_engine_calls"]
    table.add_row(
        "pointwise 10k states: harness / raw calls",
        f"{r2['value']:.2f}x (worst of: "
        + ", ".join(
            f"{p['system']} {p['value']:.2f}x = "
            + " / ".join(f"{k} {b['ratio']:.2f}x" for k, b in p["by_source"].items())
            for p in r2["per_system"]
        )
        + ")",
        f"<= {r2['target']}x",
        verdict(r2),
    )
    r3 = ratios["default_scipy_vs_fastest_scipy"]
    if r3.get("value") is not None:
        table.add_row(
            f"default scipy / fastest scipy at {r3['epsilon']:.0e} (2 s)",
            f"{r3['value']:.2f}x (default {_ms(r3['default']['cpu_s'])}, error "
            f"{r3['default']['error_2s']:.1e}; fastest {r3['fastest']['method']} rtol "
            f"{r3['fastest']['rtol']:.0e} {_ms(r3['fastest']['cpu_s'])})",
            f"<= {r3['target']}x",
            verdict(r3),
        )
    else:
        table.add_row("default scipy / fastest scipy", r3.get("why", "-"), "<= 1.5x", verdict(r3))
    r4 = ratios["run_wall_time"]
    if r4.get("value") is None or not isinstance(r4.get("median_s"), dict):
        table.add_row("`lagrange-xval run` wall time", r4.get("why", "-"), f"< {r4['target']:g} s", verdict(r4))
    else:
        for condition, median in r4["median_s"].items():
            target = f"< {r4['target']:g} s" + (f" (< {r4['warm_target']:g} s)" if condition == "warm cache" else "")
            runs = ", ".join(f"{w:.1f}" for w in r4["wall_s_all"][condition])
            table.add_row(
                f"`lagrange-xval run`, {condition} (median of {r4['repeats']})",
                f"{median:.1f} s (all: {runs})",
                target,
                verdict(r4),
            )
    console.print(table)
    if r3.get("value") is not None and not r3["passed"]:
        console.print(
            "  default scipy misses its target; runs that would pass: "
            + (
                "; ".join(
                    f"{w['method']} rtol {w['rtol']:.0e} ({_ms(w['cpu_s'])}, {w['error_2s']:.1e})"
                    for w in r3["would_pass"]
                )
                or "none"
            )
        )
    table = Table(
        title="MuJoCo step cost: model's disable flags vs all enabled (us per step, CPU)", title_justify="left"
    )
    for col in ("system", "integrator", "model flags", "all enabled", "saving"):
        table.add_column(col)
    for r in ratios["mujoco_disable_flags"]["rows"]:
        table.add_row(
            r["system"],
            r["integrator"],
            f"{r['us_per_step_model_flags']:.2f}",
            f"{r['us_per_step_all_enabled']:.2f}",
            f"{100 * r['saving']:.0f}%",
        )
    console.print(table)


def bench_command(args: Any) -> int:
    """`lagrange-xval bench [SYSTEM ...] [--quick] [--out DIR] [--repeats N]`.

    Writes DIR/bench.json and prints the summary. Exit status 0 when every ratio with a target meets
    it, 1 otherwise (the numbers are the point; the status lets CI notice a regression).
    """
    from rich.console import Console

    err = Console(stderr=True)
    start = time.perf_counter()
    if getattr(args, "run_time", False):
        return _run_time_command(getattr(args, "repeats", None) or RUN_REPEATS)

    def progress(msg: str) -> None:
        err.print(f"[{time.perf_counter() - start:6.1f} s] {msg}", highlight=False)

    results = run_bench(
        list(getattr(args, "systems", None) or []) or None,
        quick=bool(getattr(args, "quick", False)),
        repeats=getattr(args, "repeats", None),
        progress=progress,
    )
    path = write_bench(results, Path(getattr(args, "out", None) or "reports"))
    summary(results)
    print(f"wrote {path}")
    targeted = [r for k, r in results["ratios"].items() if k != "mujoco_disable_flags" and r.get("passed") is not None]
    return 0 if all(r["passed"] for r in targeted) else 1


def _run_time_command(repeats: int) -> int:
    """`lagrange-xval bench --run-time`: the run-time target alone, printed (nothing is written)."""
    r = run_wall_times(repeats)
    for condition, walls in r["wall_s_all"].items():
        runs = ", ".join(f"{w:.1f}" for w in walls)
        cpu = statistics.median(r["cpu_s_all"][condition])
        print(f"{condition:14s} median {r['median_s'][condition]:5.1f} s wall (runs: {runs}; CPU {cpu:.1f} s)")
    bad = [c for c in r["exit_codes"] if c != 0]
    verdict = "meets" if r["passed"] and not bad else "MISSES"
    print(
        f"{verdict} the target: every condition < {r['target']:g} s, warm < {r['warm_target']:g} s"
        + (f"; {len(bad)} runs exited non-zero" if bad else "")
    )
    return 0 if r["passed"] and not bad else 1

"""The harness's own fast trajectories: the fastest method the benchmark found at the error a check needs.

`lagrange-xval bench` times every method against the long-double reference (studies/bench); the
harness's own trajectory checks use what it found fastest at their error, and the bench's table
"the harness's own checks against the fastest contender" measures each of them again:

  taylor_trajectory  free runs of the hand equations or of the model's derived equations that must be
                     accurate (the perturbed start beside the reference, the notes' experiments' accurate
                     run, the symbolic source's free run): heyoka's adaptive Taylor method in double
                     precision at FAST_TOLERANCE with no per-step callback. Measured on
                     double_pendulum_point (0, 3) over 10 s: 0.44-0.53 ms for a 1e-14 error, where scipy's
                     DOP853 at rtol 1e-12 takes ~30 ms for 1e-9 and odeint at rtol 1e-11 13 ms for 1e-8.
                     The integrator compiles once per process after the trace the reference and the flow
                     already need; heyoka keeps the code on disk, so later processes load it (0.015 s).
                     Up to UNROLLED_MAX_DOF joints the code is unrolled (the fastest per run: compact mode
                     is 1.2-1.9x slower); beyond, compact, because unrolled code compiles too slowly to pay
                     for a handful of runs: on a fresh machine the 3-joint spatial arm's derived equations
                     took 13.7 s unrolled against 1.3 s compact (the notes' 2-joint systems 0.3-0.9 s).
  mirror RK4 (hand)  MuJoCo's RK4 on the hand equations as compiled steps (dynamics/compiled.py
                     `compiled_rk4`): 5.2 ms over 10 s at 1 ms against 60 ms for the generated Python
                     scheme, the windows restarted from the reference 0.2 ms for 1000 states in one call
                     against 7.7 ms; both within 1.03 ulp of MuJoCo's own windows (mirror.py).

Where the equations cannot be traced (a module heyoka's expressions do not pass through), the scipy
path is used instead and the trajectory's method says so; nothing is silently replaced.

The scipy integration of the hand equations (integrate.scipy_trajectory with SCIPY_DEFAULT) stays
beside them as the path a user of scipy takes; the bench reports how far it is from the frontier.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from ..core.errors import HarnessError
from ..model.start import Start
from ..results.stages import Clock, lap
from ..sources.base import Source, stepped
from ..systems import System
from .compiled import UNROLLED_MAX_DOF, taylor_grid, taylor_integrator
from .drakerun import drake_trajectory
from .integrate import (
    DEFAULT_BUDGET,
    DEFAULT_DT_OUT,
    DEFAULT_T_END,
    EQUATION_ERRORS,
    SCIPY_DEFAULT,
    Budget,
    RunStats,
    ScipyOptions,
    Trajectory,
    initial_state,
    mujoco_trajectory,
    scipy_trajectory,
    time_grid,
)

FAST_TOLERANCE = 1e-15  # heyoka's Taylor in double: ~1e-14 rad after 10 s on the double pendulum (bench)
TAYLOR_SOURCES = ("hand", "symbolic")


def taylor_method(tol: float = FAST_TOLERANCE) -> str:
    return f"heyoka Taylor (double) tol {tol:g}"


def taylor_trajectory(
    system: System,
    source: str,
    start: Start,
    t: np.ndarray,
    *,
    tol: float = FAST_TOLERANCE,
    budget: Budget = DEFAULT_BUDGET,
) -> Trajectory:
    """A free run of the hand equations (source "hand") or of the model's derived equations ("symbolic",
    integrated in the joints' coordinates and mapped to the equations' by JOINT_MAP) by heyoka's Taylor
    method in double precision, on the grid `t`.

    Never raises for what the equations compute: `stats` holds "steps", "status" (integrate.STATUSES),
    "stopped_at" and "reason" as integrate.scipy_trajectory's do; the samples after a stop are NaN. The
    budget bounds the Taylor steps (max_taylor_steps + taylor_steps_per_s x the span) and the state
    (max_abs_state, checked on the grid): heyoka takes no per-step callback here, which would cost more
    than the step itself.
    """
    if source not in TAYLOR_SOURCES:
        raise HarnessError(f"no Taylor trajectory of the '{source}' source; valid: {', '.join(TAYLOR_SOURCES)}.")
    n = system.nv
    q0, v0, tau = start.q0, start.v0, start.tau
    A = system.joint_map if source == "symbolic" else None
    if A is not None:  # q_notes = A q_joint; the inputs' work: tau_joint = A^T tau_notes
        q0, v0, tau = np.linalg.solve(A, q0), np.linalg.solve(A, v0), A.T @ tau
    ta = taylor_integrator(system, tol, source=source, compact=system.nv > UNROLLED_MAX_DOF)
    span = abs(float(t[-1] - t[0]))
    max_steps = int(budget.max_taylor_steps + budget.taylor_steps_per_s * span)
    try:
        word, states, steps = taylor_grid(ta, Start.of(q0, v0, tau), t, max_steps=max_steps)
    except EQUATION_ERRORS as exc:  # e.g. a non-finite time after a blow-up
        word, states, steps = f"failed ({exc})", np.full((len(t), 2 * n), np.nan), 0
    status, reason, k = "ok", "", len(t)
    if not np.abs(states).max() <= budget.max_abs_state:  # NaN fails too: rows not reached
        big = ~(np.abs(states) <= budget.max_abs_state).all(axis=1)
        k = int(np.argmax(big))
        states[k:] = np.nan
        if word == "ok" or "nf_state" in word:
            status, reason = "diverged", f"diverged at t = {t[k]:.6g} s"
        elif "step_limit" in word:
            status, reason = "stopped: budget", f"stopped: budget: {steps} Taylor steps by t = {t[k]:.6g} s"
        else:
            status, reason = "failed", f"heyoka stopped ({word}) at t = {t[k]:.6g} s"
    q, v = states[:, :n], states[:, n:]
    if A is not None:
        q, v = q @ A.T, v @ A.T
    stats: RunStats = {
        "steps": steps,
        "status": status,
        "stopped_at": float(t[max(k - 1, 0)]),
        "reason": reason,
    }
    return Trajectory(source, taylor_method(tol), np.array(t, dtype=float), q, v, stats)


def accurate_trajectory(
    system: System,
    source: Source,
    start: Start,
    t: np.ndarray,
    *,
    budget: Budget = DEFAULT_BUDGET,
    fallback: ScipyOptions | None = None,
) -> Trajectory:
    """The fastest accurate free run of a source the Taylor method can integrate (`taylor_trajectory`);
    scipy (`fallback`, default SCIPY_DEFAULT) for any other source, or where the equations cannot be
    turned into heyoka's expressions, in which case `stats["fast_path"]` says why."""
    why = None
    if source.name in TAYLOR_SOURCES:
        try:
            taylor_integrator(system, FAST_TOLERANCE, source=source.name, compact=system.nv > UNROLLED_MAX_DOF)
        except Exception as exc:  # noqa: BLE001 - any failure to trace or compile: the scipy path, said
            said = str(exc) if isinstance(exc, HarnessError) else f"{type(exc).__name__}: {exc}"
            why = f"not available ({said.strip()})"
        else:
            return taylor_trajectory(system, source.name, start, t, budget=budget)
    traj = scipy_trajectory(system, source, start, t, **(fallback or SCIPY_DEFAULT), budget=budget)
    if why is not None:
        traj.stats["fast_path"] = why
    return traj


def run_trajectories(
    system: System,
    sources: Mapping[str, Source],
    *,
    t_end: float = DEFAULT_T_END,
    dt_out: float = DEFAULT_DT_OUT,
    clock: Clock | None = None,
    drake: bool = True,
) -> list[Trajectory]:
    """The sources' free runs from the system's initial state: scipy (SCIPY_DEFAULT) on the hand
    equations, the path a user of scipy takes, and on Pinocchio's ABA (an engine's right-hand side
    called from Python: odeint is its fastest driver, bench); MuJoCo's RK4 at the model's timestep; the
    model's derived equations by the fast path (`accurate_trajectory`); Drake's own integrator
    (DRAKE_DEFAULT) where the drake source exists and `drake` asks for it. Each run's wall seconds go
    on `clock` as "trajectories: SOURCE"."""
    start = Start.at_rest(*initial_state(system))
    t = time_grid(t_end, dt_out)
    runs: dict[str, Callable[[], Trajectory]] = {
        "hand": lambda: scipy_trajectory(system, sources["hand"], start, t, **SCIPY_DEFAULT),
        "mujoco": lambda: mujoco_trajectory(system, stepped(sources["mujoco"]), start, t, integrator="RK4"),
        "pinocchio": lambda: scipy_trajectory(system, sources["pinocchio"], start, t, **SCIPY_DEFAULT),
        "symbolic": lambda: accurate_trajectory(system, sources["symbolic"], start, t),
        "drake": lambda: drake_trajectory(system, sources["drake"], start, t),
    }
    out = []
    for source, run in runs.items():
        if source in sources and (drake or source != "drake"):
            out.append(run())
            lap(clock, f"trajectories: {source}")
    return out

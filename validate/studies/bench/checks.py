"""The harness's own trajectory checks against the fastest method at the same error.

`lagrange-xval run` integrates more than the hand equations' scipy run (the path a user of scipy
takes, which stays and is compared with the frontier in ratios.frontier_ratios): the accurate runs of
the hand and derived equations, the mirrors of MuJoCo's RK4 and their windows restarted from the
reference, Pinocchio's free run. Each is timed here as `run` calls it (a worker task; compiling is
done before the clock, as for the sweep's contenders), its error measured against the reference as
the sweep measures every row's, and set against the fastest run of the sweep that computes the same
thing at least as accurately:

  accurate runs        any method on the same equations whose error at t = 2 s is at most the check's
                       (the hand equations: "hand" and "hand-cfunc" rows; the derived: "symbolic" rows);
  Pinocchio's run      any method on Pinocchio's ABA reaching the check's error ("pinocchio" rows);
  a mirror of RK4      a mirror must reproduce the scheme, not merely reach its error: every run of
                       MuJoCo's RK4 at the model's timestep on the same equations (the hand mirror: the
                       compiled RK4 contender; Pinocchio's: the sweep's Pinocchio mirror);
  the mirror's windows one window (dt_out) from each reference sample: MuJoCo's own windows
                       (mj_step from each state, sources/mujoco.py), timed in the same task.

Timings taken minutes apart differ by whatever else the machine did meanwhile, so each check and the
run chosen for it are then timed again side by side in one task (`paired_timings`, alternating) and the
ratio is that pair's. The hand equations' scipy run is listed beside them with its ratio and no target. Beyond
compiled.UNROLLED_MAX_DOF joints the harness compiles its Taylor code compact (fast.py: unrolled code
compiles too slowly to pay for a handful of runs), while the sweep's Taylor rows are unrolled: there
the accurate runs' ratio is expected at 1.2-1.9x, the price of a bounded compile. The mirrors of
MuJoCo's Euler are not listed: no other run of the sweep integrates the same equations with that
scheme (MuJoCo's own Euler integrates MuJoCo's equations).
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable

import numpy as np

from ...dynamics.fast import accurate_trajectory
from ...dynamics.integrate import SCIPY_DEFAULT, Trajectory, scipy_trajectory, time_grid
from ...dynamics.mirror import mirror_steps, mirror_trajectory, mujoco_steps
from ...dynamics.reference import DEFAULT_CACHE_DIR, reference_trajectory
from ...model.start import Scheme, Start
from ...results.schema import BenchRow, CheckBest, CheckCost, CheckRow, Checks, Paired, Spec
from ...sources.base import stepped
from .plan import GRID_DRIVERS, Plan
from .ratios import interleaved_medians
from .runners import CacheDir, case_for, execute, resources
from .shapes import MeasuredChecks, cpu_of

SAME_EQUATIONS = {"hand": ("hand", "hand-cfunc"), "symbolic": ("symbolic",), "pinocchio": ("pinocchio",)}


def _error_2s(t: np.ndarray, q: np.ndarray, ref_q: np.ndarray) -> float:
    k = int(np.argmin(np.abs(t - 2.0)))
    return float(np.abs(q[k] - ref_q[k]).max())


def _looped(fn: Callable[[], object], plan: Plan) -> tuple[Callable[[], None], int]:
    """`fn` executed back to back often enough to last the plan's `min_timed` (as the sweep times its
    short runs), and how many times: the execution count is set from one untimed call."""
    w0 = time.perf_counter()
    fn()
    once = time.perf_counter() - w0
    k = max(1, min(plan.max_executions, math.ceil(plan.min_timed / max(once, 1e-9))))

    def run() -> None:
        for _ in range(k):
            fn()

    return run, k


def check_jobs(name: str, plan: Plan) -> dict[str, tuple[str, str, Callable[[], Trajectory]]]:
    """The harness's trajectory checks on one system as `run` calls them, on the plan's grid:
    {label: (engine, kind, run)}."""
    system, sources = resources(name)
    case = case_for(system, plan)
    t = time_grid(case["t_end"], case["dt_out"])
    q0, v0, tau = (np.asarray(case[k], dtype=float) for k in ("q0", "v0", "tau"))
    dt = float(stepped(sources["mujoco"]).m.opt.timestep)
    hand = sources["hand"]
    jobs: dict[str, tuple[str, str, Callable[[], Trajectory]]] = {
        "hand accurate run": ("hand", "accurate", lambda: accurate_trajectory(system, hand, Start.of(q0, v0, tau), t)),
        "hand scipy run (the user's path)": (
            "hand",
            "user",
            lambda: scipy_trajectory(system, hand, Start.of(q0, v0, tau), t, **SCIPY_DEFAULT),
        ),
        "hand mirror RK4": (
            "hand",
            "scheme",
            lambda: mirror_trajectory(system, hand, Start.of(q0, v0, tau), t, integrator="RK4", timestep=dt),
        ),
        "pinocchio mirror RK4": (
            "pinocchio",
            "scheme",
            lambda: mirror_trajectory(
                system, sources["pinocchio"], Start.of(q0, v0, tau), t, integrator="RK4", timestep=dt
            ),
        ),
        "pinocchio scipy run": (
            "pinocchio",
            "accurate",
            lambda: scipy_trajectory(system, sources["pinocchio"], Start.of(q0, v0, tau), t, **SCIPY_DEFAULT),
        ),
    }
    if "symbolic" in sources:
        jobs["symbolic accurate run"] = (
            "symbolic",
            "accurate",
            lambda: accurate_trajectory(system, sources["symbolic"], Start.of(q0, v0, tau), t),
        )
    return jobs


def measure_checks(name: str, *, plan: Plan, reps: int, cache_dir: CacheDir = DEFAULT_CACHE_DIR) -> MeasuredChecks:
    """Each of the harness's own trajectory checks on one system (a worker task): CPU time (median of
    `reps` interleaved repeats of back-to-back executions lasting the plan's `min_timed`, per execution,
    after untimed calls that compile what they need), error at t = 2 s
    against the reference, and what it is compared with (`kind`, see the module docstring)."""
    system, sources = resources(name)
    case = case_for(system, plan)
    t = time_grid(case["t_end"], case["dt_out"])
    q0, v0, tau = (np.asarray(case[k], dtype=float) for k in ("q0", "v0", "tau"))
    ref, _ = reference_trajectory(system, Start.of(q0, v0, tau), t, cache_dir=cache_dir)
    mj = stepped(sources["mujoco"])
    dt = float(mj.m.opt.timestep)
    steps = round(float(t[1] - t[0]) / dt)
    hand = sources["hand"]
    jobs = check_jobs(name, plan)
    qw, vw = ref.q[:-1], ref.v[:-1]
    windows = {
        "hand mirror RK4 windows": lambda: mirror_steps(system, hand, qw, vw, tau, Scheme("RK4", dt), steps=steps),
        "MuJoCo RK4 windows": lambda: mujoco_steps(mj, qw, vw, tau, Scheme("RK4", dt), steps=steps),
    }
    outputs = {k: fn() for k, (_, _, fn) in jobs.items()}  # compiles, and gives the errors
    ends = {k: fn() for k, fn in windows.items()}
    loops = {k: _looped(fn, plan) for k, fn in {**{k: fn for k, (_, _, fn) in jobs.items()}, **windows}.items()}
    medians = interleaved_medians({k: run for k, (run, _) in loops.items()}, reps)
    timed = {k: {c: medians[k][c] / loops[k][1] for c in ("cpu_s", "wall_s")} for k in loops}
    out: list[CheckRow] = []
    for label, (engine, kind, _) in jobs.items():
        tr = outputs[label]
        out.append(
            {
                "system": system.name,
                "check": label,
                "engine": engine,
                "kind": kind,
                "method": tr.method,
                "cpu_s": timed[label]["cpu_s"],
                "wall_s": timed[label]["wall_s"],
                "error_2s": _error_2s(t, tr.q, ref.q),
                "status": tr.stats.get("status", "ok"),
                "timestep": dt if kind == "scheme" else None,
            }
        )
    ulp = float(np.spacing(np.abs(np.concatenate([ref.q, ref.v], axis=1)).max()))
    mine, theirs = ends["hand mirror RK4 windows"], ends["MuJoCo RK4 windows"]
    out.append(
        {
            "system": system.name,
            "check": "hand mirror RK4 windows",
            "engine": "hand",
            "kind": "windows",
            "method": f"{len(qw)} windows of {steps} steps, compiled RK4 in one batched call",
            "cpu_s": timed["hand mirror RK4 windows"]["cpu_s"],
            "wall_s": timed["hand mirror RK4 windows"]["wall_s"],
            "error_2s": None,
            "status": "ok",
            "timestep": dt,
            "windows_ulps_vs_mujoco": float(
                max(np.abs(mine[0] - theirs[0]).max(), np.abs(mine[1] - theirs[1]).max()) / ulp
            ),
            "mujoco_windows_cpu_s": timed["MuJoCo RK4 windows"]["cpu_s"],
        }
    )
    return {"system": system.name, "rows": out, "repeats": reps}


def paired_timings(name: str, pairs: list[tuple[str, Spec]], *, plan: Plan, reps: int) -> dict[str, Paired]:
    """Each check of `pairs` and the sweep run it is set against (its spec), timed again side by side in
    one worker task: `reps` alternations of the check (as `measure_checks` times it) and
    the run (as the sweep times it, `execute`), medians of each. A ratio of two timings taken minutes
    apart carries whatever else the machine did meanwhile; these two share it. {label: {cpu_s,
    fastest_cpu_s}}."""
    system, _ = resources(name)
    case = case_for(system, plan)
    jobs = check_jobs(name, plan)
    out: dict[str, Paired] = {}
    for label, spec in pairs:
        fn = jobs[label][2]
        fn()  # compiles what it needs, untimed
        run, k = _looped(fn, plan)
        execute(spec, case, plan=plan, samples=False)  # the same for the run
        mine, theirs = [], []
        for rep in range(reps):
            for side in ("check", "run") if rep % 2 == 0 else ("run", "check"):
                if side == "check":
                    c0 = time.process_time()
                    run()
                    mine.append((time.process_time() - c0) / k)
                else:
                    theirs.append(execute(spec, case, plan=plan, samples=False)["cpu_s"])
        out[label] = {"cpu_s": statistics.median(mine), "fastest_cpu_s": statistics.median(theirs)}
    return out


def pairs_to_time(ratios: Checks) -> dict[str, list[tuple[str, Spec]]]:
    """From `checks_ratios`: per system, the targeted checks set against a sweep run, with that run's spec."""
    out: dict[str, list[tuple[str, Spec]]] = {}
    for e in ratios["rows"]:
        if e["target"] is not None and e["fastest"] is not None and "spec" in e["fastest"]:
            out.setdefault(e["system"], []).append((e["check"], e["fastest"]["spec"]))
    return out


def _fastest(check: CheckRow, rows: list[BenchRow]) -> BenchRow | None:
    """The sweep's fastest run computing what `check` computes (module docstring), or None."""
    mine = [
        r
        for r in rows
        if r["system"] == check["system"]
        and r["status"] == "ok"
        and r.get("cpu_s") is not None
        and r["engine"] in SAME_EQUATIONS[check["engine"]]
        and r["driver"] in GRID_DRIVERS
    ]
    step = check["timestep"]
    if check["kind"] == "scheme":
        same = [
            r
            for r in mine
            if r.get("scheme") == "RK4"
            and r.get("setting") == "timestep"
            and step is not None  # a scheme's check has its timestep
            and np.isclose(r["value"], step, rtol=1e-9)
        ]
    else:
        err = check["error_2s"]
        same = [r for r in mine if r["error_2s"] is not None and err is not None and r["error_2s"] <= err]
    return min(same, key=cpu_of) if same else None


def _best(check: CheckRow, rows: list[BenchRow]) -> CheckBest | None:
    """What `check` is set against: MuJoCo's windows for the windows, else the sweep's fastest run (with
    its spec, to time it again), or None."""
    if check["kind"] == "windows":
        return {
            "method": "MuJoCo mj_step windows",
            "setting": "timestep",
            "value": check["timestep"],
            "cpu_s": check["mujoco_windows_cpu_s"],
            "error_2s": None,
        }
    found = _fastest(check, rows)
    if found is None:
        return None
    spec: Spec = {  # what the sweep's row was run from
        "engine": found["engine"],
        "driver": found["driver"],
        "scheme": found["scheme"],
        "setting": found["setting"],
        "value": found["value"],
        "atol": found.get("atol"),
    }
    return {
        "method": found["method"],
        "setting": found["setting"],
        "value": found["value"],
        "cpu_s": found["cpu_s"],
        "error_2s": found["error_2s"],
        "spec": spec,
    }


def checks_ratios(
    measured: list[MeasuredChecks],
    rows: list[BenchRow],
    paired: dict[str, dict[str, Paired]] | None = None,
    *,
    target: float,
) -> Checks:
    """Per check: the ratio of its CPU time to the fastest comparable run (the sweep's, or MuJoCo's
    windows for the windows); `target` (the plan's `checks_target`) applies to every check but the user's path.
    `paired` ({system: `paired_timings`}): where a check and its fastest run were timed again side by
    side, the ratio is theirs (the separate timings stay in the entry, as `sweep_ratio`)."""
    entries: list[CheckCost] = []
    for per_system in measured:
        for check in per_system["rows"]:
            best = _best(check, rows)
            ratio = check["cpu_s"] / best["cpu_s"] if best and best["cpu_s"] else None
            again = (paired or {}).get(check["system"], {}).get(check["check"])
            sweep_ratio = ratio
            if again is not None and again["fastest_cpu_s"] > 0:
                ratio = again["cpu_s"] / again["fastest_cpu_s"]
            targeted = check["kind"] != "user"
            entries.append(
                {
                    **check,
                    "fastest": best,
                    "ratio": ratio,
                    "sweep_ratio": sweep_ratio,
                    "paired": again,
                    "target": target if targeted else None,
                    "passed": (ratio is not None and ratio <= target) if targeted else None,
                    "why": None if best else "no run of the sweep computes the same thing at this error",
                }
            )
    judged = [e for e in entries if e["target"] is not None and e["ratio"] is not None]
    return {
        "value": max((r for e in judged if (r := e["ratio"]) is not None), default=None),
        "target": target,
        "passed": bool(judged) and all(e["passed"] for e in judged),
        "rows": entries,
        "how": "CPU time (median of interleaved repeats) of each check as `run` calls it, over the CPU time of "
        "the sweep's fastest run computing the same thing at least as accurately (error at t = 2 s against "
        "the long-double reference; for a mirror, the same scheme at the same timestep; for the windows, "
        "MuJoCo's own windows timed in the same task); compiling is not timed, as for the sweep's contenders. "
        "Each check and its fastest run are then timed again side by side in one task (alternating, medians) "
        "and the ratio is theirs: two timings minutes apart differ by what else the machine did "
        "(sweep_ratio keeps the separate one)",
    }

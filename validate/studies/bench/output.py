"""The whole bench (`run_bench`) by stage, bench.json and the command (the summary: tables.py)."""

from __future__ import annotations

import statistics
import time
from argparse import Namespace
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import replace
from pathlib import Path
from typing import cast

from ...core.errors import HarnessError
from ...core.guard import DEFAULT_TIME_LIMIT
from ...core.parallel import completed, executor_for
from ...dynamics.reference import DEFAULT_CACHE_DIR
from ...results import atomic_write, dumps, provenance
from ...results.schema import (
    BenchRatios,
    BenchResults,
    BenchRow,
    DefaultRatio,
    Durations,
    FlagsRatio,
    FlagsRow,
    Paired,
    PointwiseRatio,
    PointwiseSummary,
    RhsRatio,
    RunWallTimes,
    SystemReference,
)
from ...systems import System, key_of, load_all, system_names
from .analysis import Tasks, pareto_front, sweep, time_to_epsilon
from .checks import checks_ratios, measure_checks, paired_timings, pairs_to_time
from .plan import ERROR_TIMES, FULL, QUICK, Plan
from .ratios import (
    RUN_CONDITIONS,
    default_ratio,
    flags_ratio,
    frontier_ratios,
    pointwise_ratio,
    rhs_ratio,
    run_wall_times,
)
from .runners import CacheDir, prepare
from .shapes import MeasuredChecks, Prepared
from .tables import summary

Progress = Callable[[str], None] | None


def run_bench(
    names: list[str] | None,
    *,
    plan: Plan,
    executor: Executor | None = None,
    progress: Progress = None,
    files: list[tuple[Path, Path]] | None = None,
    locked: tuple[str, ...] = (),
    cache_dir: CacheDir = DEFAULT_CACHE_DIR,
    time_limit: float = DEFAULT_TIME_LIMIT,
) -> BenchResults:
    """The work-precision sweep and the ratios, as JSON-able data.

    Args:
        names: systems (default: the plan's `systems`, or every system when it names none).
        plan: what is swept, the budgets and targets (`FULL`, `QUICK`, or either `replace`d).
        executor: where the worker tasks run (default: a process pool on every core).
        files: (model, equations) pairs of a person's own systems, benched beside (or instead of) names.
        locked: URDF joints of the `files` systems made fixed (a gripper's fingers; `--lock`).
        cache_dir: where the references and chaos summaries are kept, handed to every worker (a
            folder, None for no cache; default the configured cache).
    """
    start = time.perf_counter()
    if plan.repeats < 1:
        raise HarnessError(f"--repeats must be at least 1; got {plan.repeats}.")
    named = chosen_systems(
        names, plan, files=files, locked=locked, time_limit=time_limit
    )  # unknown names fail here, before any work
    chosen = list(named)  # what the workers find each system by (systems.key_of)
    with executor_for(executor) as pool:
        if progress:
            progress(f"preparing references for {', '.join(named.values())}")
        prepared = prepare_all(pool, chosen, named, progress, plan, cache_dir)
        extra = ratio_tasks(chosen, plan, cache_dir)
        rows, extras = sweep(prepared, plan.specs(), plan=plan, executor=pool, progress=progress, extra=extra)
        workers = getattr(pool, "_max_workers", None)
    sweep_s = time.perf_counter() - start
    ratios = ratios_of(rows, extras, chosen, plan, progress)
    for r in rows:  # a person's systems are keyed by their files in the workers, named in the results
        r["system"] = named.get(r["system"], r["system"])
    measured = [cast(MeasuredChecks, extras[f"checks {n}"]) for n in chosen]  # checks_task's
    paired = paired_checks(measured, rows, named, plan, executor=executor, progress=progress)
    ratios["harness_checks_vs_fastest"] = checks_ratios(measured, rows, paired, target=plan.checks_target)
    prepared = {named[k]: v for k, v in prepared.items()}
    durations: Durations = {"duration_s": time.perf_counter() - start, "sweep_s": sweep_s}
    return bench_results(rows, prepared, ratios, plan, workers=workers, durations=durations)


def chosen_systems(
    names: list[str] | None,
    plan: Plan,
    *,
    files: list[tuple[Path, Path]] | None,
    locked: tuple[str, ...],
    time_limit: float = DEFAULT_TIME_LIMIT,
) -> dict[str, str]:
    """{key: name} of the systems benched: `names`, or the plan's (every one when it names none), and
    a person's `files`."""
    chosen = list(names) if names else ([] if files else list(plan.systems or system_names()))
    systems = load_all(chosen) if chosen else []
    systems += [System.from_files(m, e, locked=locked, time_limit=time_limit) for m, e in (files or [])]
    return {key_of(s): s.name for s in systems}


def ratio_tasks(chosen: list[str], plan: Plan, cache_dir: CacheDir) -> Tasks:
    """The ratio measurements, submitted with the sweep's last repeat: the rhs (where its system is
    available), and per system the pointwise check, the disable flags and the harness's checks."""
    extra: Tasks = {}
    if plan.rhs_system in system_names():
        extra["rhs"] = (rhs_task, (plan,))
    for name in chosen:
        extra[f"pointwise {name}"] = (pointwise_task, (name, plan))
        extra[f"flags {name}"] = (flags_task, (name, plan))
        extra[f"checks {name}"] = (checks_task, (name, plan, cache_dir))
    return extra


def ratios_of(
    rows: list[BenchRow], extras: dict[str, object], chosen: list[str], plan: Plan, progress: Progress
) -> BenchRatios:
    """The fast-harness ratios from the sweep's rows and the ratio measurements; `lagrange-xval run`
    timed here where the plan says so (after the pool is shut down: nothing else of ours running)."""
    rhs: RhsRatio = {"value": None, "passed": False, "why": f"{plan.rhs_system} not available"}
    if "rhs" in extras:
        rhs = cast(RhsRatio, extras["rhs"])  # rhs_task's
    point = pointwise_summary([cast(PointwiseRatio, extras[f"pointwise {n}"]) for n in chosen], plan)  # its task's
    default: DefaultRatio = (
        default_ratio(rows, plan)
        if plan.rhs_system in chosen
        else {"value": None, "passed": None, "why": f"{plan.rhs_system} not in this bench"}
    )
    flags = [r for n in chosen for r in cast(list[FlagsRow], extras[f"flags {n}"])]  # flags_task's
    return {
        "rhs_fast_path_vs_hand_math": rhs,
        "pointwise_vs_raw_engine_calls": point,
        "default_scipy_vs_fastest_scipy": default,
        "default_path_vs_frontier": frontier_ratios(rows, plan.frontier_epsilons),
        "mujoco_disable_flags": flags_summary(flags),
        "run_wall_time": run_time(plan, progress),
    }


def flags_summary(rows: list[FlagsRow]) -> FlagsRatio:
    """MuJoCo's disable flags on every system, sorted by system and integrator."""
    return {
        "target": None,
        "rows": sorted(rows, key=lambda r: (r["system"], r["integrator"])),
        "how": "CPU time per mj_step (median of interleaved repeats) with the MJCF's disableflags and with "
        "disableflags = 0. The scenes have no contacts (contype 0), constraints, limits, springs or "
        "friction loss, so enabling them changes no force: the difference is the cost of the pipeline "
        "stages that run and find nothing (collision, constraint assembly, passive forces), plus, "
        "where the flags disable them, gravity (gimbal: balanced, zero torque), damper and actuation "
        "(the double pendulums have neither), and Euler's implicit damping (gimbal).",
    }


def run_time(plan: Plan, progress: Progress) -> RunWallTimes:
    """`lagrange-xval run` timed where the plan says so, or why not."""
    if plan.time_run:
        if progress:
            progress(f"timing `lagrange-xval run` {plan.run_repeats} x {len(RUN_CONDITIONS)} times")
        return run_wall_times(plan)
    return {
        "value": None,
        "target": plan.run_warm_target_s,
        "passed": None,
        "why": "not measured in --quick (5 full runs take over a minute)",
    }


def pointwise_summary(point: list[PointwiseRatio], plan: Plan) -> PointwiseSummary:
    """The pointwise ratio over every system: the worst, and each system's."""
    return {
        "value": max(p["value"] for p in point),
        "target": plan.pointwise_target,
        "passed": all(p["passed"] for p in point),
        "per_system": point,
        "how": "CPU time (median of interleaved repeats) of compare.evaluate(make_sources(s), random_states(s, "
        f"n, seed=0)) over raw_pointwise (the minimal loops computing the same), at n = "
        f"{', '.join(str(n) for n in plan.pointwise_sizes)} states; per source, its evaluate over its raw calls "
        "(the equations module's functions on the batch and one solve; MuJoCo's and Pinocchio's calls state "
        "by state in a bare loop; the derived equations' generated code alone), in CPU microseconds per state. "
        "The harness's MuJoCo batch runs mj_forward in mujoco.batch on a thread pool and Pinocchio's "
        "RNEA in its C++ loop (ABA per state): CPU time counts every thread; value = worst system and size",
    }


def paired_checks(
    measured: list[MeasuredChecks],
    rows: list[BenchRow],
    named: dict[str, str],
    plan: Plan,
    *,
    executor: Executor | None,
    progress: Progress,
) -> dict[str, dict[str, Paired]]:
    """The targeted checks timed again side by side with their fastest runs, per system, in a new pool."""
    pairs = pairs_to_time(checks_ratios(measured, rows, target=plan.checks_target))
    if not pairs:
        return {}
    if progress:
        progress(f"timing {sum(len(v) for v in pairs.values())} checks again beside their fastest runs")
    key = {v: k for k, v in named.items()}
    paired: dict[str, dict[str, Paired]] = {}
    with executor_for(executor, tasks=len(pairs)) as pool:
        futures = {n: pool.submit(paired_timings, key[n], p, plan=plan, reps=plan.ratio_reps) for n, p in pairs.items()}
        for n, f in futures.items():
            paired[n] = f.result()
            if progress:
                progress(f"checks of {n} timed beside their fastest runs")
    return paired


def bench_results(
    rows: list[BenchRow],
    prepared: dict[str, Prepared],
    ratios: BenchRatios,
    plan: Plan,
    *,
    workers: int | None,
    durations: Durations,
) -> BenchResults:
    """bench.json's content: provenance, the configuration, the systems' references, the rows, Pareto
    fronts, time to reach each epsilon, the ratios and how long it all took (`durations`)."""
    chosen = list(prepared)
    return {
        "meta": provenance(),
        "config": {
            "quick": plan.quick,
            "systems": chosen,
            "repeats": plan.repeats,
            "budget_s": plan.budget,
            "min_timed_s": plan.min_timed,
            "t_end": plan.t_end,
            "dt_out": plan.dt_out,
            "error_times": list(ERROR_TIMES),
            "atol": f"rtol * {plan.atol_factor:g}",
            "horizon_tolerance": plan.horizon_tolerance,
            "epsilons": list(plan.epsilons),
            "workers": workers,
            "cost": "cpu_s (time.process_time, median)",
        },
        "systems": {n: system_reference(prepared[n]) for n in chosen},
        "rows": rows,
        "pareto": {
            n: {e: pareto_front([r for r in rows if r["system"] == n], e) for e in ("error_10s", "error_2s")}
            for n in chosen
        },
        "time_to_epsilon": time_to_epsilon(rows, plan.epsilons),
        "ratios": ratios,
        **durations,
        "quick_target_s": plan.target_s,
    }


def system_reference(p: Prepared) -> SystemReference:
    """bench.json's entry of one system: its case, reference and horizon (not the reference's samples)."""
    return {
        "case": p["case"],
        "reference": p["reference"],
        "horizon_s": p["horizon_s"],
        "horizon_window_s": p["horizon_window_s"],
        "lyapunov_per_s": p["lyapunov_per_s"],
    }


def prepare_all(
    pool: Executor,
    chosen: list[str],
    named: dict[str, str],
    progress: Progress,
    plan: Plan,
    cache_dir: CacheDir = DEFAULT_CACHE_DIR,
) -> dict[str, Prepared]:
    """`prepare` on every system in the pool, a progress line as each reference is ready."""
    futures = {pool.submit(prepare, k, plan, cache_dir=cache_dir): k for k in chosen}
    out: dict[str, Prepared] = {}
    for fut in completed(futures):
        out[futures[fut]] = fut.result()
        if progress:
            progress(f"reference of {named[futures[fut]]} ready ({len(out)}/{len(chosen)})")
    return {k: out[k] for k in chosen}


def rhs_task(plan: Plan) -> RhsRatio:
    """The rhs ratio (a worker task)."""
    return rhs_ratio(plan, reps=plan.rhs_reps)


def pointwise_task(name: str, plan: Plan) -> PointwiseRatio:
    """The pointwise ratio of one system (a worker task)."""
    return pointwise_ratio(name, plan, reps=plan.pointwise_reps)


def flags_task(name: str, plan: Plan) -> list[FlagsRow]:
    """MuJoCo's disable flags on one system (a worker task)."""
    return flags_ratio(name, plan, reps=plan.ratio_reps)


def checks_task(name: str, plan: Plan, cache_dir: CacheDir = DEFAULT_CACHE_DIR) -> MeasuredChecks:
    """The harness's own checks on one system (a worker task)."""
    return measure_checks(name, plan=plan, reps=plan.ratio_reps, cache_dir=cache_dir)


def write_bench(results: BenchResults, out: Path) -> Path:
    """`out/bench.json`, written atomically (serialised first, then a temporary file and a rename)."""
    text = dumps(results)
    path = Path(out) / "bench.json"
    atomic_write(path, text)
    return path


def bench_command(args: Namespace, executor: Executor | None = None) -> int:
    """`lagrange-xval bench [SYSTEM ...] [--quick] [--out DIR] [--repeats N]`.

    Writes DIR/bench.json and prints the summary. Exit status 0 when every ratio with a target meets
    it, 1 otherwise (the numbers are the point; the status lets CI notice a regression).
    """
    from rich.console import Console

    err = Console(stderr=True)
    start = time.perf_counter()
    repeats = getattr(args, "repeats", None)
    if getattr(args, "run_time", False):
        return run_time_command(replace(FULL, run_repeats=repeats) if repeats else FULL)
    plan = QUICK if getattr(args, "quick", False) else FULL
    if repeats is not None:
        plan = replace(plan, repeats=repeats)

    def progress(msg: str) -> None:
        err.print(f"[{time.perf_counter() - start:6.1f} s] {msg}", highlight=False)

    results = run_bench(
        list(getattr(args, "systems", None) or []) or None,
        plan=plan,
        progress=progress,
        files=getattr(args, "files", None),
        locked=tuple(getattr(args, "locked", None) or ()),
        executor=executor,
        cache_dir=getattr(args, "reference_cache", DEFAULT_CACHE_DIR),
        time_limit=getattr(args, "time_limit", DEFAULT_TIME_LIMIT),
    )
    results["config"]["executor"] = getattr(args, "executor", None) or "local"
    path = write_bench(results, Path(getattr(args, "out", None) or "reports"))
    summary(results)
    print(f"wrote {path}")
    targeted = [
        r
        for k, r in results["ratios"].items()
        if k != "mujoco_disable_flags" and isinstance(r, dict) and r.get("passed") is not None
    ]
    return 0 if all(r["passed"] for r in targeted) else 1


def run_time_command(plan: Plan) -> int:
    """`lagrange-xval bench --run-time`: the plan's run-time target alone, printed (nothing is written)."""
    r = run_wall_times(plan)
    for condition, walls in r["wall_s_all"].items():
        runs = ", ".join(f"{w:.1f}" for w in walls)
        cpu = statistics.median(r["cpu_s_all"][condition])
        print(f"{condition:14s} median {r['median_s'][condition]:5.1f} s wall (runs: {runs}; CPU {cpu:.1f} s)")
        split = sorted(r.get("stages_s", {}).get(condition, {}).items(), key=lambda kv: -kv[1])
        if split:  # each stage summed over the systems (in their workers, side by side: more than the wall)
            print("    stages, s summed over the systems: " + ", ".join(f"{n} {s:.1f}" for n, s in split))
    bad = [c for c in r["exit_codes"] if c != 0]
    verdict = "meets" if r["passed"] and not bad else "MISSES"
    medians = r["median_s"]
    print(
        f"{verdict} the target (warm <= {r['target']:g} s): warm {medians['warm cache']:.1f} s "
        f"(fresh machine {medians['fresh machine']:.1f} s, cold cache {medians['cold cache']:.1f} s: reported, "
        "not judged)" + (f"; {len(bad)} runs exited non-zero" if bad else "")
    )
    return 0 if r["passed"] and not bad else 1

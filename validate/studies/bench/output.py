"""The whole bench (`run_bench`), bench.json, the console summary and the command."""

from __future__ import annotations

import statistics
import sys
import time
from collections.abc import Callable
from concurrent.futures import Executor, as_completed
from pathlib import Path
from typing import Any

from ...dynamics.reference import DEFAULT_CACHE_DIR
from ...errors import HarnessError
from ...parallel import executor_for
from ...results import atomic_write, dumps, provenance
from ...systems import System, key_of, load_all, system_names
from .analysis import pareto_front, sweep, time_to_epsilon
from .checks import checks_ratios, measure_checks, paired_timings, pairs_to_time
from .plan import (
    ATOL_FACTOR,
    BUDGET,
    DEFAULT_REPEATS,
    DT_OUT,
    EPSILONS,
    ERROR_TIMES,
    HORIZON_TOLERANCE,
    MIN_TIMED,
    POINTWISE_SIZES,
    POINTWISE_TARGET,
    QUICK_BUDGET,
    QUICK_REPEATS,
    QUICK_SYSTEMS,
    QUICK_TARGET_S,
    RHS_SYSTEM,
    RUN_REPEATS,
    RUN_TARGET_S,
    T_END,
    plan,
)
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


def run_bench(
    names: list[str] | None,
    *,
    quick: bool,
    repeats: int | None = None,
    executor: Executor | None = None,
    progress: Callable[[str], None] | None = None,
    time_run: bool | None = None,
    files: list[tuple[Path, Path]] | None = None,
    locked: tuple[str, ...] = (),
    cache_dir: CacheDir = DEFAULT_CACHE_DIR,
) -> dict[str, Any]:
    """The work-precision sweep and the ratios, as JSON-able data.

    Args:
        names: systems (default: every system; with `quick`, QUICK_SYSTEMS).
        quick: the small plan (QUICK_*), one repeat, 5 s budget; `lagrange-xval run` is not timed.
        repeats: timing repeats (default 3, quick 1).
        executor: where the worker tasks run (default: a process pool on every core).
        time_run: time `lagrange-xval run` (default: not quick).
        files: (model, equations) pairs of a person's own systems, benched beside (or instead of) names.
        locked: URDF joints of the `files` systems made fixed (a gripper's fingers; `--lock`).
        cache_dir: where the references and chaos summaries are kept, handed to every worker (a
            folder, None for no cache; default the configured cache).
    """
    start = time.perf_counter()
    chosen = list(names) if names else ([] if files else list(QUICK_SYSTEMS if quick else system_names()))
    systems = load_all(chosen) if chosen else []  # unknown names and unreadable files fail here, before any work
    systems += [System.from_files(m, e, locked=locked) for m, e in (files or [])]
    chosen = [key_of(s) for s in systems]  # what the workers find each system by
    named = {key_of(s): s.name for s in systems}
    repeats = repeats if repeats is not None else (QUICK_REPEATS if quick else DEFAULT_REPEATS)
    if repeats < 1:
        raise HarnessError(f"--repeats must be at least 1; got {repeats}.")
    budget = QUICK_BUDGET if quick else BUDGET
    specs = plan(quick=quick)
    reps_small = 3 if quick else 7
    with executor_for(executor) as pool:
        if progress:
            progress(f"preparing references for {', '.join(named[k] for k in chosen)}")
        prepared = prepare_all(pool, chosen, named, progress, cache_dir)
        extra: dict[str, tuple[Callable[..., Any], tuple[Any, ...]]] = {}
        if RHS_SYSTEM in system_names():
            extra["rhs"] = (rhs_task, (15 if not quick else 7,))
        for name in chosen:
            extra[f"pointwise {name}"] = (pointwise_task, (name, 5 if not quick else 3))
            extra[f"flags {name}"] = (flags_task, (name, 20_000 if not quick else 5_000, reps_small))
            extra[f"checks {name}"] = (checks_task, (name, reps_small, cache_dir))
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
        f"n, seed=0)) over raw_pointwise (the minimal loops computing the same), at n = "
        f"{', '.join(str(n) for n in POINTWISE_SIZES)} states; per source, its evaluate over its raw calls "
        "(the equations module's functions on the batch and one solve; MuJoCo's and Pinocchio's calls state "
        "by state in a bare loop; the derived equations' generated code alone), in CPU microseconds per state. "
        "The harness's MuJoCo batch runs mj_forward in mujoco.batch on a thread pool and Pinocchio's "
        "RNEA in its C++ loop (ABA per state): CPU time counts every thread; value = worst system and size",
    }
    ratios["default_scipy_vs_fastest_scipy"] = (
        default_ratio(rows)
        if RHS_SYSTEM in chosen
        else {"value": None, "passed": None, "why": f"{RHS_SYSTEM} not in this bench"}
    )
    ratios["default_path_vs_frontier"] = frontier_ratios(rows)
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
    for r in rows:  # a person's systems are keyed by their files in the workers, named in the results
        r["system"] = named.get(r["system"], r["system"])
    measured = [extras[f"checks {n}"] for n in chosen]
    pairs = pairs_to_time(checks_ratios(measured, rows))
    if pairs:
        if progress:
            progress(f"timing {sum(len(v) for v in pairs.values())} checks again beside their fastest runs")
        key = {v: k for k, v in named.items()}
        with executor_for(executor, tasks=len(pairs)) as pool:
            futures = {
                n: pool.submit(paired_timings, key[n], p, reps=reps_small, budget=budget) for n, p in pairs.items()
            }
            paired = {}
            for n, f in futures.items():
                paired[n] = f.result()
                if progress:
                    progress(f"checks of {n} timed beside their fastest runs")
    else:
        paired = {}
    ratios["harness_checks_vs_fastest"] = checks_ratios(measured, rows, paired)
    duration = time.perf_counter() - start
    prepared = {named[k]: v for k, v in prepared.items()}
    chosen = [named[k] for k in chosen]
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


def prepare_all(
    pool: Executor,
    chosen: list[str],
    named: dict[str, str],
    progress: Callable[[str], None] | None,
    cache_dir: CacheDir = DEFAULT_CACHE_DIR,
) -> dict[str, Any]:
    """`prepare` on every system in the pool, a progress line as each reference is ready."""
    futures = {pool.submit(prepare, k, cache_dir=cache_dir): k for k in chosen}
    out: dict[str, Any] = {}
    for fut in as_completed(futures):
        out[futures[fut]] = fut.result()
        if progress:
            progress(f"reference of {named[futures[fut]]} ready ({len(out)}/{len(chosen)})")
    return {k: out[k] for k in chosen}


def rhs_task(reps: int) -> dict[str, Any]:
    return rhs_ratio(reps=reps)


def pointwise_task(name: str, reps: int) -> dict[str, Any]:
    return pointwise_ratio(name, reps=reps)


def flags_task(name: str, steps: int, reps: int) -> list[dict[str, Any]]:
    return flags_ratio(name, steps=steps, reps=reps)


def checks_task(name: str, reps: int, cache_dir: CacheDir = DEFAULT_CACHE_DIR) -> dict[str, Any]:
    return measure_checks(name, reps=reps, cache_dir=cache_dir)


def write_bench(results: dict[str, Any], out: Path) -> Path:
    """`out/bench.json`, written atomically (serialised first, then a temporary file and a rename)."""
    text = dumps(results)
    path = Path(out) / "bench.json"
    atomic_write(path, text)
    return path


def fmt_ms(x: float | None) -> str:
    if x is None:
        return "-"
    return f"{x * 1e3:.3g} ms" if x < 1 else f"{x:.3g} s"


def fmt_setting(setting: str | None, value: float | None) -> str:
    if setting is None or value is None:
        return ""
    return f"{ {'rtol': 'rtol', 'tol': 'tol', 'accuracy': 'accuracy'}.get(setting, 'dt') } {value:.0e}"


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
                    else f"{fmt_ms(e['cpu_s'])} ({fmt_setting(e['setting'], e['value'])})"
                )
            table.add_row(method, *cells)
        console.print(table)
        front = results["pareto"][name]["error_10s"]
        console.print(
            "  Pareto front (CPU vs error at 10 s): "
            + "; ".join(
                f"{p['method']} {fmt_setting(p['setting'], p['value'])}: {fmt_ms(p['cpu_s'])}, {p['error_10s']:.1e}"
                for p in front
            )
        )
        bad = [r for r in results["rows"] if r["system"] == name and r["status"] != "ok"]
        if bad:
            console.print(
                "  not ok: "
                + "; ".join(f"{r['method']} {fmt_setting(r['setting'], r['value'])}: {r['status']}" for r in bad)
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
    for p in r2["per_system"]:
        for size in p.get("per_size", []):
            table.add_row(
                f"pointwise {p['system']}, {size['n_states']:,} states: harness / raw calls",
                f"{size['value']:.2f}x ({size['harness_us_per_state']:.2f} vs {size['raw_us_per_state']:.2f} "
                "us/state; per source, us/state harness vs raw: "
                + ", ".join(
                    f"{k} {b['harness_us_per_state']:.2f} vs {b['raw_us_per_state']:.2f} ({b['ratio']:.2f}x)"
                    for k, b in size["by_source"].items()
                )
                + ")",
                f"<= {r2['target']}x",
                "pass" if size["value"] <= r2["target"] else "FAIL",
            )
    r3 = ratios["default_scipy_vs_fastest_scipy"]
    if r3.get("value") is not None:
        table.add_row(
            f"default scipy / fastest scipy at {r3['epsilon']:.0e} (2 s)",
            f"{r3['value']:.2f}x (default {fmt_ms(r3['default']['cpu_s'])}, error "
            f"{r3['default']['error_2s']:.1e}; fastest {r3['fastest']['method']} rtol "
            f"{r3['fastest']['rtol']:.0e} {fmt_ms(r3['fastest']['cpu_s'])})",
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
                    f"{w['method']} rtol {w['rtol']:.0e} ({fmt_ms(w['cpu_s'])}, {w['error_2s']:.1e})"
                    for w in r3["would_pass"]
                )
                or "none"
            )
        )
    frontier_table(ratios["default_path_vs_frontier"], console)
    if "harness_checks_vs_fastest" in ratios:
        checks_table(ratios["harness_checks_vs_fastest"], console)
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


def frontier_table(frontier: dict[str, Any], console: Any) -> None:
    """The harness's default trajectory path against the fastest method at equal error, per system."""
    from rich.table import Table

    table = Table(
        title="Default trajectory path (hand odeint) vs the fastest method at equal error (error at 2 s <= eps, CPU)",
        title_justify="left",
    )
    for col in ("system", "eps", "default path", "fastest", "ratio", "fastest contender"):
        table.add_column(col)

    def cell(r: dict[str, Any] | None) -> str:
        if r is None:
            return "not reached"
        return f"{r['method']} {fmt_setting(r['setting'], r['value'])}: {fmt_ms(r['cpu_s'])} ({r['error_2s']:.1e})"

    for system, per_eps in frontier.get("per_system", {}).items():
        for e in per_eps:
            ratio = f"{e['ratio']:.1f}x" if e["ratio"] is not None else str(e["why"])
            table.add_row(
                system,
                f"{e['epsilon']:.0e}",
                cell(e["default_path"]),
                cell(e["fastest"]),
                ratio,
                cell(e["fastest_contender"]),
            )
    console.print(table)


def checks_table(checks: dict[str, Any], console: Any) -> None:
    """The harness's own trajectory checks against the fastest run computing the same at their error."""
    from rich.table import Table

    table = Table(
        title="The harness's own trajectory checks vs the fastest run computing the same at their error "
        f"(CPU; target <= {checks['target']}x)",
        title_justify="left",
    )
    for col in ("system", "check", "method", "time", "error at 2 s", "fastest at that error", "ratio", "verdict"):
        table.add_column(col)
    for e in checks["rows"]:
        best = e["fastest"]
        fastest = (
            str(e["why"])
            if best is None
            else f"{best['method']} {fmt_setting(best['setting'], best['value'])}: {fmt_ms(best['cpu_s'])}"
        )
        if e["kind"] == "windows":
            err = f"{e['windows_ulps_vs_mujoco']:.2f} ulp of MuJoCo's"
        else:
            err = f"{e['error_2s']:.1e}" if e["error_2s"] is not None else "-"
        verdict = "-" if e["passed"] is None else ("pass" if e["passed"] else "FAIL")
        if e["kind"] == "user":
            verdict = "no target: stays as the user's path"
        table.add_row(
            e["system"],
            e["check"],
            e["method"],
            fmt_ms(e["cpu_s"]),
            err,
            fastest,
            _ratio_cell(e, fmt_ms),
            verdict,
        )
    console.print(table)


def _ratio_cell(e: dict[str, Any], fmt: Callable[[Any], str]) -> str:
    """The ratio, and where it was timed again beside its fastest run, both times and the ratio apart."""
    if e.get("ratio") is None:
        return "-"
    pair = e.get("paired")
    if not pair:
        return f"{e['ratio']:.2f}x"
    apart = e.get("sweep_ratio")
    return f"{e['ratio']:.2f}x (side by side: {fmt(pair['cpu_s'])} vs {fmt(pair['fastest_cpu_s'])}" + (
        f"; timed apart {apart:.2f}x)" if apart is not None else ")"
    )


def bench_command(args: Any, executor: Executor | None = None) -> int:
    """`lagrange-xval bench [SYSTEM ...] [--quick] [--out DIR] [--repeats N]`.

    Writes DIR/bench.json and prints the summary. Exit status 0 when every ratio with a target meets
    it, 1 otherwise (the numbers are the point; the status lets CI notice a regression).
    """
    from rich.console import Console

    err = Console(stderr=True)
    start = time.perf_counter()
    if getattr(args, "run_time", False):
        return run_time_command(getattr(args, "repeats", None) or RUN_REPEATS)

    def progress(msg: str) -> None:
        err.print(f"[{time.perf_counter() - start:6.1f} s] {msg}", highlight=False)

    results = run_bench(
        list(getattr(args, "systems", None) or []) or None,
        quick=bool(getattr(args, "quick", False)),
        repeats=getattr(args, "repeats", None),
        progress=progress,
        files=getattr(args, "files", None),
        locked=tuple(getattr(args, "locked", None) or ()),
        executor=executor,
        cache_dir=getattr(args, "reference_cache", DEFAULT_CACHE_DIR),
    )
    results["config"]["executor"] = getattr(args, "executor", None) or "local"
    path = write_bench(results, Path(getattr(args, "out", None) or "reports"))
    summary(results)
    print(f"wrote {path}")
    targeted = [r for k, r in results["ratios"].items() if k != "mujoco_disable_flags" and r.get("passed") is not None]
    return 0 if all(r["passed"] for r in targeted) else 1


def run_time_command(repeats: int) -> int:
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

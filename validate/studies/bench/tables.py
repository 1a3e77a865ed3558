"""The console summary of bench.json's results: per system, time to reach eps and the Pareto front;
the fast-harness ratios; the default path against the frontier; the harness's checks; MuJoCo's flags."""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

from ...results.schema import (
    BenchRatios,
    BenchResults,
    CheckCost,
    Checks,
    DefaultRatio,
    FlagsRatio,
    Frontier,
    PointwiseSummary,
    RhsRatio,
    RunBrief,
    RunWallTimes,
    TimeToEpsilon,
)

if TYPE_CHECKING:  # rich is imported when the summary is printed
    from rich.console import Console
    from rich.table import Table


def fmt_ms(x: float | None) -> str:
    """Seconds as "12.3 ms" or "4.56 s"; "-" for none."""
    if x is None:
        return "-"
    return f"{x * 1e3:.3g} ms" if x < 1 else f"{x:.3g} s"


def fmt_setting(setting: str | None, value: float | None) -> str:
    """A run's setting, e.g. "rtol 1e-06", "dt 1e-03"; "" for none."""
    if setting is None or value is None:
        return ""
    return f"{ {'rtol': 'rtol', 'tol': 'tol', 'accuracy': 'accuracy'}.get(setting, 'dt') } {value:.0e}"


def verdict(r: Mapping[str, object]) -> str:
    """ "pass", "FAIL", or "-" for a ratio without a target."""
    return "-" if r.get("passed") is None else ("pass" if r["passed"] else "FAIL")


def summary(results: BenchResults, console: Console | None = None) -> None:
    """A readable summary: per system, time to reach eps and the Pareto front; the ratios; failures."""
    from rich.console import Console

    console = console or (Console() if sys.stdout.isatty() else Console(width=150))
    cfg = results["config"]
    console.print(
        f"[bold]bench[/bold] ({'quick' if cfg['quick'] else 'full'}): {', '.join(cfg['systems'])}; "
        f"{cfg['repeats']} repeat(s), budget {cfg['budget_s']:g} s per run; took "
        f"{results['duration_s']:.1f} s. Times are CPU (process_time), medians."
    )
    for name in cfg["systems"]:
        system_section(results, name, console)
    ratios = results["ratios"]
    ratios_table(ratios, console)
    frontier_table(ratios["default_path_vs_frontier"], console)
    if "harness_checks_vs_fastest" in ratios:
        checks_table(ratios["harness_checks_vs_fastest"], console)
    flags_table(ratios["mujoco_disable_flags"], console)


def system_section(results: BenchResults, name: str, console: Console) -> None:
    """One system: its time-to-eps table, its Pareto front at 10 s and the runs that were not ok."""
    from rich.table import Table

    epsilons = sorted(results["config"]["epsilons"], reverse=True)
    tte = [e for e in results["time_to_epsilon"] if e["system"] == name]
    table = Table(
        title=f"{name}: time to reach error eps at t = 2 s (horizon window "
        f"{results['systems'][name]['horizon_window_s']:g} s)",
        title_justify="left",
    )
    table.add_column("method")
    for eps in epsilons:
        table.add_column(f"eps {eps:.0e}", justify="right")
    for method in sorted({e["method"] for e in tte}):
        entries = [next(x for x in tte if x["method"] == method and x["epsilon"] == eps) for eps in epsilons]
        table.add_row(method, *(_reached(e) for e in entries))
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


def _reached(e: TimeToEpsilon) -> str:
    """A time-to-eps cell: the cheapest run's time and setting, or "not reached"."""
    if e["result"] != "reached":
        return "not reached"
    return f"{fmt_ms(e['cpu_s'])} ({fmt_setting(e['setting'], e['value'])})"


def ratios_table(ratios: BenchRatios, console: Console) -> None:
    """The fast-harness ratios against their targets; where default scipy misses, the runs that would pass."""
    from rich.table import Table

    table = Table(title="A fast harness: ratios (measured in this run)", title_justify="left")
    for col in ("ratio", "measured", "target", "verdict"):
        table.add_column(col)
    rhs_row(ratios["rhs_fast_path_vs_hand_math"], table)
    pointwise_rows(ratios["pointwise_vs_raw_engine_calls"], table)
    default_row(ratios["default_scipy_vs_fastest_scipy"], table)
    run_time_rows(ratios["run_wall_time"], table)
    console.print(table)
    r3 = ratios["default_scipy_vs_fastest_scipy"]
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


def rhs_row(r1: RhsRatio, table: Table) -> None:
    """The generated right-hand side against hand-written math (none where its system was not benched)."""
    if r1.get("value") is None:
        return
    pc = r1["per_call_us"]
    table.add_row(
        "rhs: fast path / hand-written math",
        f"{r1['value']:.2f}x ({pc['harness']:.2f} vs "
        f"{pc['hand_math']:.2f} us/call; np.linalg.solve {r1['numpy_vs_hand_math']:.1f}x)",
        f"<= {r1['target']}x",
        verdict(r1),
    )


def pointwise_rows(r2: PointwiseSummary, table: Table) -> None:
    """The pointwise check against the raw engine calls, per system and batch size."""
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


def default_row(r3: DefaultRatio, table: Table) -> None:
    """Default scipy against the fastest scipy run at its epsilon, or why it was not measured."""
    if r3.get("value") is None:
        table.add_row("default scipy / fastest scipy", r3.get("why", "-"), "<= 1.5x", verdict(r3))
        return
    table.add_row(
        f"default scipy / fastest scipy at {r3['epsilon']:.0e} (2 s)",
        f"{r3['value']:.2f}x (default {fmt_ms(r3['default']['cpu_s'])}, error "
        f"{r3['default']['error_2s']:.1e}; fastest {r3['fastest']['method']} rtol "
        f"{r3['fastest']['rtol']:.0e} {fmt_ms(r3['fastest']['cpu_s'])})",
        f"<= {r3['target']}x",
        verdict(r3),
    )


def run_time_rows(r4: RunWallTimes, table: Table) -> None:
    """`lagrange-xval run`'s wall time per condition, or why it was not measured."""
    if r4.get("value") is None or not isinstance(r4.get("median_s"), dict):
        table.add_row("`lagrange-xval run` wall time", r4.get("why", "-"), f"warm <= {r4['target']:g} s", verdict(r4))
        return
    for condition, median in r4["median_s"].items():
        target = f"<= {r4['target']:g} s" if condition == "warm cache" else "reported"
        runs = ", ".join(f"{w:.1f}" for w in r4["wall_s_all"][condition])
        table.add_row(
            f"`lagrange-xval run`, {condition} (median of {r4['repeats']})",
            f"{median:.1f} s (all: {runs})",
            target,
            verdict(r4),
        )


def flags_table(flags: FlagsRatio, console: Console) -> None:
    """MuJoCo's step cost with the model's disable flags against every stage enabled."""
    from rich.table import Table

    table = Table(
        title="MuJoCo step cost: model's disable flags vs all enabled (us per step, CPU)", title_justify="left"
    )
    for col in ("system", "integrator", "model flags", "all enabled", "saving"):
        table.add_column(col)
    for r in flags["rows"]:
        table.add_row(
            r["system"],
            r["integrator"],
            f"{r['us_per_step_model_flags']:.2f}",
            f"{r['us_per_step_all_enabled']:.2f}",
            f"{100 * r['saving']:.0f}%",
        )
    console.print(table)


def frontier_table(frontier: Frontier, console: Console) -> None:
    """The harness's default trajectory path against the fastest method at equal error, per system."""
    from rich.table import Table

    table = Table(
        title="Default trajectory path (hand odeint) vs the fastest method at equal error (error at 2 s <= eps, CPU)",
        title_justify="left",
    )
    for col in ("system", "eps", "default path", "fastest", "ratio", "fastest contender"):
        table.add_column(col)

    def cell(r: RunBrief | None) -> str:
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


def checks_table(checks: Checks, console: Console) -> None:
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


def _ratio_cell(e: CheckCost, fmt: Callable[[float | None], str]) -> str:
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

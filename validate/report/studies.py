"""The benchmark and stress-test sections, rendered from bench.json and stress.json (never recomputing)."""

from __future__ import annotations

import numpy as np

from ..results.schema import (
    BenchResults,
    BenchRow,
    CheckCost,
    Checks,
    ConditioningRow,
    ConditioningSummary,
    DriftRow,
    Frontier,
    FrontPoint,
    RunBrief,
    StabilityRow,
    StiffRow,
    StressResults,
)
from .document import NOT_RUN, PAIR_COLOURS, Cell, Document, Num, as_float, pass_mark, sci, slug
from .figures import LEGEND_W, legend_right, new_figure, png, rc, series

LINE_STYLES = ("-", (0, (5, 2)), (0, (1, 1.5)), (0, (6, 2, 1, 2)))

NO_RANGE = (None, None)  # a sweep's range not in the file: shown as "–"

WORK_PRECISION_COLOURS = ("#1f2937", *PAIR_COLOURS, "#475569")


def section_bench(doc: Document, bench: BenchResults | None) -> None:
    if not bench:
        doc.p(
            f"Benchmark: {NOT_RUN} (`lagrange-xval bench` writes reports/bench.json; this report shows it "
            "when present).",
            "missing",
        )
        return
    cfg = bench.get("config", {})
    doc.p(
        f"`{bench.get('meta', {}).get('command', 'lagrange-xval bench')}` on {bench.get('meta', {}).get('cpu', '?')}, "
        f"{bench.get('meta', {}).get('date', '?')}: {'quick plan' if cfg.get('quick') else 'full plan'}, "
        f"{cfg.get('repeats')} repeat(s), median CPU time of interleaved repeats; errors against the reference "
        f"solution at t = 2 s and 10 s."
    )
    frontier_section(doc, bench.get("ratios", {}).get("default_path_vs_frontier"))
    checks_section(doc, bench.get("ratios", {}).get("harness_checks_vs_fastest"))
    if bench.get("ratios"):
        doc.p(
            "The fast-harness ratios and MuJoCo's step costs are for the harness's developers: `lagrange-xval bench` "
            "prints them and bench.json keeps them; this report shows what the methods cost and how accurate they are.",
            "note",
        )
    rows_all = bench.get("rows", [])
    for system in bench.get("systems", []):
        srows = [r for r in rows_all if r.get("system") == system]
        if not srows:
            continue
        doc.figure(
            f"img/bench_{slug(system)}.png",
            _work_precision_figure(system, srows),
            f"Work-precision diagram of {system}",
            "CPU time against the error at t = 10 s, one line per method (log-log); lower left is better.",
        )
        front: dict[str, list[FrontPoint]] | list[FrontPoint] = (bench.get("pareto", {}) or {}).get(system, [])
        if isinstance(front, dict):
            front = front.get("10s") or front.get("error_10s") or next(iter(front.values()), [])
        if front:
            doc.table(
                f"Pareto front of {system} (CPU time against error at 10 s)",
                ("method", "setting", "CPU (s)", "error at 10 s (rad)"),
                [
                    (
                        r.get("method"),
                        f"{r.get('setting', '')} {sci(r.get('value'))}",
                        Num(r.get("cpu_s")),
                        Num(r.get("error_10s")),
                    )
                    for r in front
                ],
            )
        tte = [r for r in bench.get("time_to_epsilon", []) if r.get("system") == system]
        if tte:
            eps = sorted({r["epsilon"] for r in tte}, reverse=True)
            methods = sorted({r["method"] for r in tte})
            table = []
            for m in methods:
                cells: list[Cell] = [m]
                for e in eps:
                    hit = next((r for r in tte if r["method"] == m and r["epsilon"] == e), None)
                    cells.append(Num(hit["cpu_s"], 3) if hit and hit.get("result") == "reached" else "not reached")
                table.append(tuple(cells))
            doc.table(
                f"CPU time (s) to reach an error below eps at t = 2 s, {system}",
                ("method", *[f"eps {e:g}" for e in eps]),
                table,
            )


def frontier_section(doc: Document, frontier: Frontier | None) -> None:
    """Per system and eps: the fastest method measured, and the harness's default path against it."""
    if not isinstance(frontier, dict) or not frontier.get("per_system"):
        return

    def run(r: RunBrief | None) -> str:
        if not isinstance(r, dict):
            return "not reached"
        return f"{r.get('method')} ({r.get('setting')} {sci(r.get('value'))}): {sci(r.get('cpu_s'))} s"

    rows = []
    for system, per_eps in sorted(frontier["per_system"].items()):
        for e in per_eps:
            ratio = e.get("ratio")
            rows.append(
                (
                    system,
                    sci(e.get("epsilon")),
                    run(e.get("fastest")),
                    run(e.get("default_path")),
                    f"{ratio:.1f}x" if ratio is not None else e.get("why") or "-",
                )
            )
    doc.table(
        "The fastest method measured at each error (error at t = 2 s <= eps, whole 10 ms grid) and the harness's "
        "default trajectory path (odeint on the hand equations) at the same error",
        ("system", "eps (rad)", "fastest", "default path", "default / fastest (CPU)"),
        rows,
    )


def checks_section(doc: Document, checks: Checks | None) -> None:
    """The harness's own trajectory checks, each against the fastest run computing the same at its error."""
    if not isinstance(checks, dict) or not checks.get("rows"):
        return
    rows = []
    for e in checks["rows"]:
        best = e.get("fastest")
        fastest = (
            f"{best.get('method')} ({best.get('setting')} {sci(best.get('value'))}): {sci(best.get('cpu_s'))} s"
            if isinstance(best, dict)
            else e.get("why") or "-"
        )
        if e.get("kind") == "windows":
            error = f"{e.get('windows_ulps_vs_mujoco', float('nan')):.2f} ulp of MuJoCo's windows"
        else:
            error = sci(e.get("error_2s"))
        verdict = (
            "no target: the path a user of scipy takes"
            if e.get("kind") == "user"
            else ("-" if e.get("passed") is None else "within" if e["passed"] else "beyond")
        )
        rows.append(
            (
                e.get("system"),
                e.get("check"),
                f"{e.get('method')}: {sci(e.get('cpu_s'))} s",
                error,
                fastest,
                _ratio_text(e),
                verdict,
            )
        )
    doc.table(
        f"The harness's own trajectory checks against the fastest run computing the same thing at their error "
        f"(CPU; target {checks.get('target')}x): accurate runs against any method on the same equations, a "
        "mirror of RK4 against every run of that scheme at the model's timestep, the windows against MuJoCo's",
        ("system", "check", "as `run` does it", "error at 2 s (rad)", "fastest at that error", "ratio", "target"),
        rows,
    )


def _ratio_text(e: CheckCost) -> str:
    """The ratio; where the check was timed again beside its fastest run, both times and the ratio apart."""
    ratio, pair, apart = e.get("ratio"), e.get("paired"), e.get("sweep_ratio")
    if ratio is None:
        return "-"
    if not isinstance(pair, dict):
        return f"{ratio:.2f}x"
    text = f"{ratio:.2f}x (side by side: {sci(pair.get('cpu_s'))} s vs {sci(pair.get('fastest_cpu_s'))} s"
    return text + (f"; timed apart {apart:.2f}x)" if apart is not None else ")")


def _work_precision_figure(system: str, rows: list[BenchRow]) -> bytes:
    methods = sorted({r["method"] for r in rows})
    with rc():
        fig, (ax,) = new_figure(8.6, 4.2, legend_right=2.3)
        for i, m in enumerate(methods):
            pts = sorted(
                (as_float(r.get("cpu_s")), as_float(r.get("error_10s")))
                for r in rows
                if r["method"] == m and r.get("status") == "ok"
            )
            pts = [(c, e) for c, e in pts if c > 0 and e > 0 and np.isfinite(e)]
            if not pts:
                continue
            c, e = zip(*pts, strict=True)
            ax.loglog(
                c,
                e,
                marker="o",
                markersize=3,
                linewidth=1.1,
                label=m,
                color=WORK_PRECISION_COLOURS[i % len(WORK_PRECISION_COLOURS)],
                linestyle=LINE_STYLES[(i // len(WORK_PRECISION_COLOURS)) % len(LINE_STYLES)],
            )
        ax.set_xlabel("CPU time (s)")
        ax.set_ylabel("error at t = 10 s (rad)")
        ax.set_title(f"{system}: work against precision")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=7)
        return png(fig)


def section_stress(doc: Document, stress: StressResults | None) -> None:
    if not stress:
        doc.p(
            f"Stress tests: {NOT_RUN} (`lagrange-xval stress` writes reports/stress.json; this report shows it "
            "when present).",
            "missing",
        )
        return
    prov = stress.get("meta") or stress.get("provenance", {})  # stress.json before the block was named "meta"
    doc.p(
        f"`{prov.get('command', 'lagrange-xval stress')}`, {prov.get('date', '?')}"
        f"{' (quick plan)' if stress.get('quick') else ''}."
    )
    crit = stress.get("criteria", {})
    if crit.get("instability"):
        doc.p(f"Instability: {crit['instability']}")
    stab = stress.get("stability", [])
    if stab:
        stability_table(doc, stab)
    drift = stress.get("drift", [])
    if drift:
        drift_section(doc, drift)
    cond = stress.get("conditioning_summary", [])
    if cond:
        conditioning_section(doc, cond, stress.get("conditioning", []))
    prop = stress.get("solve_tier_proposal", {})
    if prop:
        doc.p(
            f"Measured: the worst state needed {sci(prop.get('measured_C_cond'))} cond(M) eps; the solve tier "
            f"uses C = 20 (formula: {prop.get('formula', '')})."
        )
    stiff = stress.get("stiff_friction", [])
    if stiff:
        stiff_friction(doc, stiff)


def stability_table(doc: Document, stab: list[StabilityRow]) -> None:
    """The largest stable timestep of each system, integrator, engine and initial speed, by criterion."""
    keys = sorted({(r["system"], r["integrator"], r["engine"], as_float(r["speed"])) for r in stab})
    table = []
    for system, integrator, engine, speed in keys:
        by = {
            r["criterion"]: r
            for r in stab
            if (r["system"], r["integrator"], r["engine"], as_float(r["speed"])) == (system, integrator, engine, speed)
        }
        cells: list[Cell] = [system, integrator, engine, Num(speed, 2)]
        for c in ("energy x2", "divergence"):
            r = by.get(c)
            cells.append(Num(r["max_stable"], 2) if r and r.get("max_stable") is not None else "–")
        table.append(tuple(cells))
    doc.table(
        "Largest stable timestep (s), by bisection over log(dt)",
        ("system", "integrator", "engine", "initial speed (rad/s)", "energy x2 criterion", "divergence only"),
        table,
    )


def drift_section(doc: Document, drift: list[DriftRow]) -> None:
    """The long-horizon energy of the conservative systems: a table of each run's class and its figure."""
    doc.table(
        "Energy over long horizons at the MJCF timestep (conservative systems)",
        ("system", "integrator", "engine", "horizon (s)", "class", "max |dE| / available", "rate (J/s)"),
        [
            (
                r.get("system"),
                r.get("integrator"),
                r.get("engine"),
                Num(r.get("horizon"), 3),
                r.get("class"),
                Num(r.get("relative_max")),
                Num(r.get("rate")),
            )
            for r in drift
        ],
    )
    doc.figure(
        "img/stress_drift.png",
        _drift_figure(drift),
        "Energy error against time over the long horizon",
        "E(t) - E(0) of each integrator on the first conservative system, MuJoCo's own runs.",
    )


def conditioning_section(doc: Document, cond: list[ConditioningSummary], points: list[ConditioningRow]) -> None:
    """The sources' disagreement against cond(M): the summary of each sweep (cond) and the figure of every
    sweep point (points)."""
    doc.table(
        "Disagreement between the sources against the mass matrix's conditioning",
        ("system", "sweep", "quantity", "cond range", "disagreement range", "flat 1e-10 tier fails from cond"),
        [
            (
                r.get("system"),
                r.get("sweep", r.get("kind")),
                r.get("quantity"),
                "{} to {}".format(*(sci(x) for x in (r.get("cond_range") or NO_RANGE))),
                f"{sci((r.get('disagreement_range') or NO_RANGE)[0])} to "
                f"{sci((r.get('disagreement_range') or NO_RANGE)[1])}",
                sci(r.get("base_tier_fails_from_cond")) if r.get("base_tier_fails_from_cond") else "never",
            )
            for r in cond
        ],
    )
    doc.figure(
        "img/stress_conditioning.png",
        _conditioning_figure(points),
        "Disagreement of the sources against cond(M)",
        "Largest disagreement in q'' (scaled) against the largest cond(M) of each sweep point; the solve "
        "tier max(1e-10, 20 cond(M) eps) dashed, cond(M) eps dotted.",
    )


def stiff_friction(doc: Document, stiff: list[StiffRow]) -> None:
    """The stiff-friction sweep as a compact grid (the largest stable timestep of each integrator at each
    damping factor), every run folded below it."""
    factors = sorted({as_float(r.get("damping_factor")) for r in stiff})
    methods = sorted({(str(r.get("integrator", "")), str(r.get("engine", ""))) for r in stiff})
    grid = []
    for integrator, engine in methods:
        cells: list[Cell] = [integrator, engine]
        for f in factors:
            runs = [
                r
                for r in stiff
                if (r.get("integrator"), r.get("engine"), as_float(r.get("damping_factor"))) == (integrator, engine, f)
            ]
            stable = [as_float(r.get("timestep")) for r in runs if r.get("stable")]
            cells.append(Num(max(stable), 1, unit="s") if stable else ("none stable" if runs else "–"))
        grid.append(tuple(cells))
    doc.table(
        "Stiff friction: the gimbal with damping up to 1e3 times the notes' value, largest stable timestep tried",
        ("integrator", "engine", *[f"damping x{f:g}" for f in factors]),
        grid,
    )
    inner = Document()
    inner.table(
        "Every stiff-friction run",
        ("damping factor", "integrator", "engine", "timestep (s)", "stable", "max error (rad)"),
        [
            (
                Num(r.get("damping_factor"), 1),
                r.get("integrator"),
                r.get("engine"),
                Num(r.get("timestep"), 1),
                pass_mark(r.get("stable"), "stable", "unstable"),
                Num(r.get("max_error")),
            )
            for r in sorted(
                stiff,
                key=lambda r: (
                    as_float(r.get("damping_factor")),
                    r.get("integrator", ""),
                    r.get("engine", ""),
                    as_float(r.get("timestep")),
                ),
            )
        ],
    )
    doc.fold(f"All {len(stiff)} stiff-friction runs, with their errors", inner)


def _drift_figure(drift: list[DriftRow]) -> bytes:
    system = drift[0].get("system")
    runs = [r for r in drift if r.get("system") == system and r.get("engine") == "mujoco" and r.get("series")]
    with rc():
        fig, (ax,) = new_figure(8.6, 3.2, legend_right=LEGEND_W + 0.3)
        for i, r in enumerate(runs):
            ser = r["series"]
            t, de = series(ser.get("t", [])), series(ser.get("dE", []))
            if len(t) and len(t) == len(de):
                # every series visible where two coincide: its own dash pattern, later ones thinner and on top
                ax.plot(
                    t,
                    de,
                    linewidth=max(2.4 - 0.6 * i, 0.9),
                    linestyle=LINE_STYLES[i % len(LINE_STYLES)],
                    zorder=2 + i,
                    color=WORK_PRECISION_COLOURS[i % len(WORK_PRECISION_COLOURS)],
                    label=f"{r.get('integrator')} ({r.get('horizon'):g} s)",
                )
        ax.set_xlabel("t (s)")
        ax.set_ylabel("E(t) - E(0) (J)")
        ax.set_title(f"{system}: energy error of MuJoCo's integrators")
        if ax.get_legend_handles_labels()[0]:
            legend_right(ax)
        return png(fig)


def _conditioning_figure(rows: list[ConditioningRow]) -> bytes:
    eps = float(np.finfo(float).eps)
    pts = [(as_float(r.get("cond_max")), as_float(r.get("scaled"))) for r in rows if r.get("quantity") == "qacc"]
    pts = [(c, e) for c, e in pts if c > 0 and np.isfinite(e)]
    with rc():
        fig, (ax,) = new_figure(8.6, 3.6, legend_right=LEGEND_W + 0.2)
        if pts:
            c, e = zip(*pts, strict=True)
            ax.loglog(c, np.maximum(e, 1e-18), "o", markersize=3, color="#2563eb", label="measured (any pair)")
            grid = np.logspace(0, np.log10(max(c)) + 0.3, 50)
            ax.loglog(grid, np.maximum(1e-10, 20 * grid * eps), "--", color="#dc2626", label="solve tier")
            ax.loglog(grid, grid * eps, ":", color="#6b7280", label="cond(M) eps")
        ax.set_xlabel("cond(M)")
        ax.set_ylabel("scaled disagreement in q''")
        ax.set_title("Sources' disagreement against conditioning")
        if ax.get_legend_handles_labels()[0]:
            legend_right(ax)
        return png(fig)

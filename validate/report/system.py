"""The section of one system: model, model checks, pointwise agreement, the derivation's terms,
printed forms, trajectories, chaos and experiments; a pure function of that system's results.
"""

from __future__ import annotations

from typing import Any

from .document import (
    NOT_RUN,
    Document,
    Items,
    Mark,
    Num,
    as_float,
    cell_text,
    fmt_time,
    is_number,
    pass_mark,
    sci,
    slug,
    vec,
)
from .figures import energy_figure, error_figure, pointwise_figure, run_label, series, trajectory_figure
from .system_parts import (
    system_chaos,
    system_derivation,
    system_derived,
    system_equivalence,
    system_experiments,
    system_skipped,
)


def section_system(doc: Document, name: str, s: dict[str, Any], results: dict[str, Any]) -> None:
    doc.h(2, f"System {name}", f"system-{slug(name)}")
    doc.p(s.get("description", ""))
    mark = pass_mark(s.get("passed"))
    doc.p(f"Verdict: {cell_text(mark)}.", {"ok": "pass", "bad": "fail"}.get(mark.state, ""))

    # Model
    doc.h(3, "Model", f"{slug(name)}-model")
    doc.p(
        f"{str(s.get('model_format', 'mjcf')).upper()} `{s.get('mjcf', '?')}`; "
        f"hand derivation `{s.get('equations', '?')}`; the scene uses "
        f"{', '.join(s.get('uses', [])) or 'nothing beyond the chain'}; MuJoCo timestep "
        f"{sci(s.get('timestep'))} s."
    )
    params = s.get("parameters", {})
    doc.table(
        f"Parameters of {name}, read from the compiled MJCF",
        ("parameter", "value"),
        [(k, Num(v, short=True)) for k, v in sorted(params.items(), key=lambda kv: (kv[0].lower(), kv[0]))],
    )
    coords, joints = s.get("coordinates", []), s.get("joints", [])
    bodies = s.get("bodies", [])
    doc.table(
        f"Coordinates of {name} and the MJCF joints they map to",
        ("coordinate", "MJCF joint", "body moved"),
        [
            (c, joints[i] if i < len(joints) else None, bodies[i] if i < len(bodies) else None)
            for i, c in enumerate(coords)
        ],
    )

    # Model checks
    mc = s.get("model_checks")
    doc.h(3, "Model checks", f"{slug(name)}-model-checks")
    if not mc:
        doc.p(f"Model checks: {NOT_RUN}.", "missing")
    else:
        mism = mc.get("mismatches", [])
        by_check: dict[str, int] = {}
        for m in mism:
            by_check[m.get("check", "?")] = by_check.get(m.get("check", "?"), 0) + 1
        doc.p(
            "Before any dynamics: every key of the compiled model against what the hand equations state they "
            "assume (equations~mjcf), and every compared body's mass, centre of mass and inertia, and every "
            "compared joint's anchor and axis, as Pinocchio and MuJoCo read them (pinocchio~mujoco)."
        )
        if mc.get("alignments"):
            doc.p(
                "The model is a URDF, which each engine reads with its own parser; what the harness aligned "
                "between the two readings before comparing them:"
            )
            doc.blocks.append(Items(tuple(mc["alignments"])))
        doc.table(
            f"Model checks of {name}",
            ("check", "keys checked", "mismatches", "verdict"),
            [
                ("equations~mjcf and pinocchio~mujoco", mc.get("n_checked"), len(mism), pass_mark(mc.get("passed"))),
                *[(f"of which {k}", None, n, Mark("bad", "FAIL")) for k, n in sorted(by_check.items())],
            ],
        )
        if mism:
            doc.table(
                f"Model check mismatches of {name}",
                ("check", "key", "expected", "actual", "why"),
                [
                    (m.get("check"), m.get("key"), shorten(m.get("expected")), shorten(m.get("actual")), m.get("why"))
                    for m in mism
                ],
            )

    system_derived(doc, name, s)

    doc.h(3, "Derivation verdict", f"{slug(name)}-derivation")
    system_derivation(doc, name, s)

    # Pointwise
    pw = s.get("pointwise")
    doc.h(3, "Pointwise agreement", f"{slug(name)}-pointwise")
    if not pw:
        doc.p(f"Pointwise agreement: {NOT_RUN}.", "missing")
    else:
        rows = pw.get("rows", [])
        doc.p(
            f"Every quantity of every pair of sources at {pw.get('n_states')} random states (seed "
            f"{pw.get('seed')}): the hand derivation, MuJoCo, Pinocchio and the model's own equations derived "
            "symbolically (`symbolic`). `max abs` is the largest `|a - b|`; `scaled` divides it by the largest "
            "magnitude the quantity takes over the states; a row passes when scaled ≤ tolerance."
        )
        for bug in pw.get("harness_bugs", []):
            doc.p(f"✗ Harness bug: {bug}.", "fail")
        doc.table(
            f"Pointwise agreement of {name} at {pw.get('n_states')} random states (seed {pw.get('seed')})",
            ("quantity", "pair", "tier", "max abs", "scale", "scaled", "tolerance", "verdict"),
            [
                (
                    r.get("quantity"),
                    r.get("pair"),
                    r.get("tier"),
                    Num(r.get("max_abs")),
                    Num(r.get("scale")),
                    Num(r.get("scaled")),
                    Num(r.get("tolerance"), short=True),
                    pass_mark(r.get("passed")),
                )
                for r in rows
            ],
        )
        failing = [r for r in rows if r.get("passed") is False and r.get("worst_state")]
        if failing:
            doc.table(
                f"States where {name}'s failing quantities disagree most",
                ("quantity", "pair", "q", "v", "tau"),
                [
                    (
                        r["quantity"],
                        r["pair"],
                        vec(r["worst_state"].get("q", [])),
                        vec(r["worst_state"].get("v", [])),
                        vec(r["worst_state"].get("tau", [])),
                    )
                    for r in failing
                ],
            )
        if rows:
            doc.figure(
                f"img/{name}_pointwise.png",
                pointwise_figure(name, rows),
                f"Bar chart of the scaled error of each quantity and source pair for {name}",
                "Scaled error per quantity and source pair, log axis; the red bar over each group is its "
                "tolerance. The results keep only the largest error over the random states, not each "
                "state's, so this is a bar chart of those maxima rather than a histogram of the "
                "per-state errors.",
            )

    # Trajectories
    tr = s.get("trajectories")
    doc.h(3, "Trajectories", f"{slug(name)}-trajectories")
    if not tr or not tr.get("runs"):
        doc.p(f"Trajectories: {NOT_RUN}.", "missing")
    else:
        t = series(tr.get("t", []))
        thr = as_float(tr.get("threshold"))
        doc.p(
            f"Free motion from q0 = {vec(tr.get('q0', []))} rad, v0 = {vec(tr.get('v0', []))} rad/s, "
            f"tau = {vec(tr.get('tau', []))}, sampled every {fmt_g(tr.get('dt_out'))} s "
            f"up to {fmt_g(tr.get('t_end'))} s. "
            f"The reference is {tr.get('reference')}; the error is the largest coordinate's distance to it, "
            f"judged against the trajectory threshold {sci(thr)} rad."
        )
        doc.table(
            f"Trajectory runs of {name}",
            ("source", "method", "cost", "max error vs reference", "first above threshold", "energy drift", "verdict"),
            [
                (
                    run_label(r),
                    r.get("method"),
                    fmt_stats(r.get("stats")),
                    Num(r.get("max_error_vs_hand"), unit="rad"),
                    fmt_time(r.get("first_exceeds_threshold")),
                    Num(r.get("energy_drift"), unit="J"),
                    run_verdict(r),
                )
                for r in tr["runs"]
            ],
        )
        if tr.get("judged_until") is not None:
            doc.p(f"Runs are judged until {fmt_g(tr['judged_until'])} s, not beyond: {tr.get('judged_because')}.")
        for why in sorted({r["why_not_counted"] for r in tr["runs"] if r.get("why_not_counted")}):
            doc.p(f"Not part of the verdict: {why}.", "note")
        runs = tr["runs"]
        doc.figure(
            f"img/{name}_trajectories.png",
            trajectory_figure(name, s.get("coordinates", []), t, runs),
            f"Coordinates of {name} against time for every source",
            "Coordinates against time: the sources overlay each other while they agree.",
        )
        doc.figure(
            f"img/{name}_error.png",
            error_figure(name, t, runs, thr, str(tr.get("reference"))),
            f"log10 of the distance of each source to the reference trajectory of {name}",
            "Distance to the reference trajectory on a log10 scale; dashed red: the threshold; a dotted "
            "vertical line marks where a source first passes it. Sources identical to the reference "
            "are not drawn.",
        )
        doc.figure(
            f"img/{name}_energy.png",
            energy_figure(name, t, runs),
            f"Energy of {name} against time for every source",
            f"Total energy T + V by the hand equations along each source's trajectory, relative to "
            f"E(0) = {sci(series(runs[0]['energy'])[0], 6)} J; a conservative system should stay at 0.",
        )

    system_equivalence(doc, name, s)
    doc.h(3, "Chaos", f"{slug(name)}-chaos")
    system_chaos(doc, name, s)
    doc.h(3, "Experiments", f"{slug(name)}-experiments")
    system_experiments(doc, name, s)
    system_skipped(doc, name, s)


def run_verdict(run: dict[str, Any]) -> Any:
    """A trajectory run's verdict as the table shows it: judged up to a time, or information only."""
    if not run.get("counts", True):
        return "information only"
    if "passed" not in run:
        return "–"
    mark = pass_mark(run["passed"])
    return Mark(mark.state, f"{mark.text} (until {fmt_g(run.get('judged_until'))} s)")


def fmt_stats(stats: Any) -> str:
    if not isinstance(stats, dict) or not stats:
        return "–"
    names = {"nfev": "evaluations", "steps": "steps"}
    return ", ".join(f"{v} {names.get(k, k)}" for k, v in sorted(stats.items()) if k != "label") or "–"


def fmt_g(x: Any) -> str:
    """A setting (a time step, a duration) as written: 0.01, 10."""
    return f"{x:g}" if is_number(x) else sci(x)


def shorten(x: Any, n: int = 60) -> str:
    text = vec(x) if isinstance(x, list) else cell_text(x)
    return text if len(text) <= n else text[: n - 1] + "…"

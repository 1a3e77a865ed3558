"""The section of one system: model, model checks, pointwise agreement, the derivation's terms,
printed forms, trajectories, chaos and experiments; a pure function of that system's results.
"""

from __future__ import annotations

from typing import Any

from ..results.schema import SCALED_DEFINITION
from .audit import audit_section
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
from .findings import chaos_facts, derivation_label, is_damped, is_driven, system_headline
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
    doc.p(f"Verdict: {cell_text(mark)}: {system_headline(s)[1]}.", {"ok": "pass", "bad": "finding"}.get(mark.state, ""))

    # Model
    doc.h(3, "Model", f"{slug(name)}-model")
    doc.p(
        f"{str(s.get('model_format', 'mjcf')).upper()} `{s.get('mjcf', '?')}`; "
        f"{derivation_label(s)} `{s.get('equations', '?')}`; the scene uses "
        f"{', '.join(s.get('uses', [])) or 'nothing beyond the chain'}; MuJoCo timestep "
        f"{sci(s.get('timestep'))} s."
    )
    params = s.get("parameters", {})
    keys = s.get("parameter_keys") or {}
    doc.table(
        f"Parameters of {name}'s derivation, read from the compiled model",
        ("parameter", "value", "unit", "model keys it sets"),
        [
            (
                k,
                Num(v, short=True),
                (keys.get(k) or {}).get("unit") or "–",
                ", ".join((keys.get(k) or {}).get("keys") or []) or "–",
            )
            for k, v in sorted(params.items(), key=lambda kv: (kv[0].lower(), kv[0]))
        ],
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
                "What the harness aligned between the engines' readings before comparing them (a URDF is read "
                "by each engine's own parser; Drake's lines start 'Drake'):"
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
    audit_section(doc, slug(name), s)

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
            f"symbolically (`symbolic`). `max abs` is the largest `|a - b|`, `scale` the largest magnitude; "
            f"{SCALED_DEFINITION}; a row passes when scaled ≤ tolerance."
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
        section_trajectories(doc, name, s, tr)

    system_equivalence(doc, name, s)
    facts = chaos_facts(s)
    chaotic = bool(facts and facts["chaotic"])
    doc.h(3, "Chaos" if chaotic or not facts else "Error growth", f"{slug(name)}-chaos")
    system_chaos(doc, name, s)
    doc.h(3, "Experiments", f"{slug(name)}-experiments")
    system_experiments(doc, name, s)
    system_skipped(doc, name, s)


def section_trajectories(doc: Document, name: str, s: dict[str, Any], tr: dict[str, Any]) -> None:
    t = series(tr.get("t", []))
    thr = as_float(tr.get("threshold"))
    runs = tr["runs"]
    damped = is_damped(s)
    doc.p(
        f"Free motion from q0 = {vec(tr.get('q0', []))} rad, v0 = {vec(tr.get('v0', []))} rad/s, "
        f"tau = {vec(tr.get('tau', []))}, sampled every {fmt_g(tr.get('dt_out'))} s "
        f"up to {fmt_g(tr.get('t_end'))} s. "
        f"The reference is {tr.get('reference')}; the error is the largest coordinate's distance to it, "
        f"judged against the trajectory threshold {sci(thr)} rad."
    )
    energy_column = "energy change (friction)" if damped else "energy drift"
    doc.table(
        f"Trajectory runs of {name}",
        ("source", "method", "cost", "max error vs reference", "first above threshold", energy_column, "verdict"),
        [
            (
                run_label(r),
                r.get("method"),
                fmt_stats(r.get("stats")),
                Num(r.get("max_error_vs_hand"), unit="rad"),
                first_above(r, tr),
                Num(r.get("energy_drift"), unit="J"),
                run_verdict(r, tr.get("t_end")),
            )
            for r in runs
        ],
    )
    if tr.get("judged_until") is not None:
        doc.p(f"Runs are judged until {fmt_g(tr['judged_until'])} s, not beyond: {tr.get('judged_because')}.")
    for why in sorted({r["why_not_counted"] for r in runs if r.get("why_not_counted")}):
        doc.p(f"Not part of the verdict: {why}.", "note")
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
        "vertical line marks where a source first passes it (a run from another start passes it at once). "
        "Sources identical to the reference are not drawn.",
    )
    if damped:
        energy_text = (
            "the joints' viscous friction dissipates energy, so E falls; every source should fall along the same curve"
            + (" (the inputs also do work)" if is_driven(s) else "")
            + "."
        )
    elif is_driven(s):
        energy_text = "the inputs do work, so E changes; every source should change along the same curve."
    else:
        energy_text = "the system is conservative, so each curve is that source's drift and should stay near 0."
    doc.figure(
        f"img/{name}_energy.png",
        energy_figure(name, t, runs),
        f"Energy of {name} against time for every source",
        f"Total energy T + V by the hand equations along each source's trajectory, relative to "
        f"E(0) = {sci(series(runs[0]['energy'])[0], 6)} J; {energy_text}",
    )


def first_above(run: dict[str, Any], tr: dict[str, Any]) -> str:
    """When a run first passes the threshold, and why where it is expected."""
    first = run.get("first_exceeds_threshold")
    if first is None:
        return "never"
    when = fmt_time(first)
    if run.get("label"):
        return f"{when} (starts elsewhere: {run['label']})"
    if not run.get("counts", True):
        return f"{when} (information only)"
    if run.get("passed") is False:
        return f"{when} (fails)"
    judged = run.get("judged_until", tr.get("judged_until"))
    if judged is not None and as_float(first) > as_float(judged):
        return f"{when} (after {fmt_g(judged)} s, beyond the judged interval)"
    return when


def run_verdict(run: dict[str, Any], t_end: Any = None) -> Any:
    """A trajectory run's verdict as the table shows it: what interval was judged, or information only."""
    if not run.get("counts", True):
        return "information only"
    if "passed" not in run:
        return "–"
    judged = run.get("judged_until")
    if run["passed"] is False:
        first = run.get("first_exceeds_threshold")
        return Mark("bad", "FAIL" + (f": above the threshold from {fmt_g(first)} s" if first is not None else ""))
    if run["passed"] is True:
        if judged is not None and t_end is not None and as_float(judged) < as_float(t_end):
            return Mark("ok", f"pass until {fmt_g(judged)} s, not judged beyond")
        return Mark("ok", f"pass over the whole run ({fmt_g(judged if judged is not None else t_end)} s)")
    return pass_mark(run["passed"])


def fmt_stats(stats: Any) -> str:
    """The cost of a run: its function evaluations and steps (the integrator's status is not a cost)."""
    if not isinstance(stats, dict) or not stats:
        return "–"
    names = {"nfev": "evaluations", "steps": "steps", "njev": "Jacobians"}
    return ", ".join(f"{v} {names[k]}" for k, v in sorted(stats.items()) if k in names and is_number(v)) or "–"


def fmt_g(x: Any) -> str:
    """A setting (a time step, a duration) as written: 0.01, 10."""
    return f"{x:g}" if is_number(x) else sci(x)


def shorten(x: Any, n: int = 60) -> str:
    text = vec(x) if isinstance(x, list) else cell_text(x)
    return text if len(text) <= n else text[: n - 1] + "…"

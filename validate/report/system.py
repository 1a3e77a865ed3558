"""The section of one system: model, model checks, pointwise agreement, the derivation's terms,
printed forms, trajectories, chaos and experiments; a pure function of that system's results.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import TYPE_CHECKING

from ..results.schema import SCALED_DEFINITION, ComparisonRow, FreeRun, Reproducer, SystemResult, Trajectories
from .audit import audit_section
from .document import (
    NOT_RUN,
    Cell,
    Document,
    Items,
    Link,
    Mark,
    Num,
    as_float,
    cell_text,
    fmt_time,
    is_number,
    pass_mark,
    ratio,
    sci,
    slug,
    vec,
)
from .figures import energy_figure, error_figure, pointwise_figure, run_label, series, trajectory_figure
from .findings import (
    and_join,
    chaos_facts,
    compared_sources,
    derivation_label,
    has_actuators,
    has_derivation,
    is_damped,
    is_driven,
    sources_text,
    system_headline,
)
from .runs import fmt_g, run_verdict
from .system_parts import (
    system_chaos,
    system_derivation,
    system_derived,
    system_equivalence,
    system_experiments,
    system_skipped,
)
from .trust import trust_section

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt


def section_system(doc: Document, name: str, s: SystemResult) -> None:
    """The system's heading and verdict, then its details folded (closed by default)."""
    doc.h(2, f"System {name}", f"system-{slug(name)}")
    mark = pass_mark(s.get("passed"))
    described = str(s.get("description") or "").rstrip(".")
    doc.p(
        (f"{described[:1].upper()}{described[1:]}. " if described else "")
        + f"Verdict: {cell_text(mark)}: {system_headline(s)[1]}.",
        {"ok": "pass", "bad": "finding"}.get(mark.state, ""),
    )
    inner = Document()
    system_details(inner, name, s)
    doc.fold(f"Details of {name}: {', '.join(detail_parts(s))}", inner)


def detail_parts(s: SystemResult) -> list[str]:
    parts = ["model", "model checks"]
    parts += ["the derivation's terms"] if has_derivation(s) else []
    parts += ["derived equations"] if s.get("derived") else []
    parts += ["pointwise agreement", "trajectories"]
    parts += ["error growth"] if s.get("chaos") else []
    parts += ["experiments"] if s.get("experiments") else []
    return parts


def system_details(doc: Document, name: str, s: SystemResult) -> None:
    section_model(doc, name, s)
    section_model_checks(doc, name, s)
    system_derived(doc, name, s)
    if has_derivation(s):
        doc.h(3, "Derivation verdict", f"{slug(name)}-derivation")
        system_derivation(doc, name, s)
    section_pointwise(doc, name, s)
    tr = s.get("trajectories")
    doc.h(3, "Trajectories", f"{slug(name)}-trajectories")
    if not tr or not tr.get("runs"):
        doc.p(f"Trajectories: {NOT_RUN}.", "missing")
    else:
        section_trajectories(doc, name, s, tr)
    system_equivalence(doc, name, s)
    facts = chaos_facts(s)
    chaotic = bool(facts and facts["chaotic"])
    if s.get("chaos") or has_derivation(s):
        doc.h(3, "Chaos" if chaotic or not facts else "Error growth", f"{slug(name)}-chaos")
        system_chaos(doc, name, s)
    if s.get("experiments") or has_derivation(s):
        doc.h(3, "Experiments", f"{slug(name)}-experiments")
        system_experiments(doc, name, s)
    system_skipped(doc, name, s)


def section_model(doc: Document, name: str, s: SystemResult) -> None:
    doc.h(3, "Model", f"{slug(name)}-model")
    equations = f"{derivation_label(s)} `{s.get('equations')}`; " if has_derivation(s) and s.get("equations") else ""
    doc.p(
        f"{str(s.get('model_format', 'mjcf')).upper()} `{s.get('mjcf', '?')}`; {equations}the scene uses "
        f"{', '.join(s.get('uses', [])) or 'nothing beyond the chain'}; MuJoCo timestep "
        f"{sci(s.get('timestep'))} s." + ("" if has_derivation(s) else " No derivation was given.")
    )
    params = s.get("parameters", {})
    keys = s.get("parameter_keys") or {}
    if params:
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


def section_model_checks(doc: Document, name: str, s: SystemResult) -> None:
    mc = s.get("model_checks")
    doc.h(3, "Model checks", f"{slug(name)}-model-checks")
    if not mc:
        doc.p(f"Model checks: {NOT_RUN}.", "missing")
        return
    mism = mc.get("mismatches", [])
    by_check: dict[str, int] = {}
    for m in mism:
        by_check[m.get("check", "?")] = by_check.get(m.get("check", "?"), 0) + 1
    given = has_derivation(s)
    doc.p(
        "Before any dynamics: "
        + (
            "every key of the compiled model against what the derivation states it assumes (equations~mjcf), and "
            if given
            else ""
        )
        + "every compared body's mass, centre of mass and inertia, and every compared joint's anchor and axis, as "
        "Pinocchio and MuJoCo read them (pinocchio~mujoco)."
    )
    if mc.get("defects"):
        doc.p("Defects of the file, each a finding (model/inertia.py says how each was repaired and for whom):")
        doc.blocks.append(Items(tuple(mc["defects"])))
    if mc.get("left_out"):
        doc.p(
            "Left out of every comparison: the model's constraints, which add forces on top of the equations of "
            "motion that no Lagrangian derivation of the chain contains (switched off in MuJoCo, absent from "
            "Pinocchio's and Drake's smooth dynamics), and the passive forces MuJoCo alone computes:"
        )
        doc.blocks.append(Items(tuple(mc["left_out"])))
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
            (
                "equations~mjcf and pinocchio~mujoco" if given else "pinocchio~mujoco",
                mc.get("n_checked"),
                len(mism),
                pass_mark(mc.get("passed")),
            ),
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


POINTWISE_COLUMNS = ("quantity", "pair", "tier", "max abs", "scale", "scaled", "tolerance", "verdict")


def pointwise_row(r: ComparisonRow) -> tuple[Cell, ...]:
    return (
        r.get("quantity"),
        r.get("pair"),
        r.get("tier"),
        Num(r.get("max_abs")),
        Num(r.get("scale")),
        Num(r.get("scaled")),
        Num(r.get("tolerance"), short=True),
        pass_mark(r.get("passed")),
    )


def worst_per_quantity(rows: list[ComparisonRow]) -> list[tuple[Cell, ...]]:
    """One line per quantity: how many pairs agree, and the pair closest to (or furthest past) its tolerance."""
    by: dict[str, list[ComparisonRow]] = {}
    for r in rows:
        by.setdefault(str(r.get("quantity")), []).append(r)
    out: list[tuple[Cell, ...]] = []
    for q, rs in by.items():
        w = max(rs, key=ratio)
        bad = sum(1 for r in rs if r.get("passed") is False)
        out.append(
            (
                q,
                f"{len(rs) - bad} of {len(rs)}",
                w.get("pair"),
                Num(w.get("scaled")),
                Num(w.get("tolerance"), short=True),
                pass_mark(not bad if all(r.get("passed") is not None for r in rs) else None),
            )
        )
    return out


def reproducer_row(r: Reproducer) -> tuple[Cell, ...]:
    """A disagreement with its reproducer: the pair, the state, both numbers and the script (or why none)."""
    numbers = r.get("numbers", {})
    entry = "".join(f"[{i}]" for i in r.get("entry", []))
    shown = ", ".join(f"{k} {sci(x)}" for k, x in numbers.items())
    where: Cell = Link(r["file"], r["path"]) if "path" in r else f"not written: {r.get('skipped', '')}"
    return (f"{r.get('quantity')}{entry}", r.get("pair"), r.get("state_index"), shown, where)


def section_reproducers(doc: Document, name: str, s: SystemResult) -> None:
    """Each disagreeing pair of sources (readers set aside included) with its standalone reproducer: a
    script of the libraries' own calls that exits 1 where the disagreement shows (verdict/reproduce.py)."""
    proofs = s.get("reproducers") or []
    if not proofs:
        return
    doc.p(
        "Each disagreement with its proof: a standalone Python script of the libraries' own calls (the model "
        "read from its path, the joints by name, the harness's alignments commented) that prints both numbers "
        "and exits 1 where the disagreement shows, 0 where it does not (then the FAIL is the harness's own)."
    )
    doc.table(
        f"Reproducers of {name}'s disagreements",
        ("quantity", "pair", "state", "the harness's numbers", "reproducer"),
        [reproducer_row(r) for r in proofs],
    )


def section_pointwise(doc: Document, name: str, s: SystemResult) -> None:
    pw = s.get("pointwise")
    doc.h(3, "Pointwise agreement", f"{slug(name)}-pointwise")
    if not pw:
        doc.p(f"Pointwise agreement: {NOT_RUN}.", "missing")
        return
    rows = pw.get("rows", [])
    doc.p(
        f"Every quantity of every pair of sources at {pw.get('n_states')} random states (seed {pw.get('seed')}): "
        f"{sources_text(s)}"
        + (" (`symbolic`: the model's own equations derived symbolically)" if "symbolic" in compared_sources(s) else "")
        + f". {SCALED_DEFINITION}; a row passes when scaled ≤ tolerance."
    )
    for bug in pw.get("harness_bugs", []):
        doc.p(f"✗ Harness bug: {bug}.", "fail")
    doc.table(
        f"Pointwise agreement of {name}, one line per quantity: its worst pair of sources",
        ("quantity", "pairs that agree", "worst pair", "scaled", "tolerance", "verdict"),
        worst_per_quantity(rows),
    )
    every = Document()
    every.p("`max abs` is the largest `|a - b|`, `scale` the largest magnitude.")
    every.table(
        f"Pointwise agreement of {name} at {pw.get('n_states')} random states (seed {pw.get('seed')})",
        POINTWISE_COLUMNS,
        [pointwise_row(r) for r in rows],
    )
    doc.fold(f"All {len(rows)} rows (every quantity and pair of sources)", every)
    failing = [r for r in rows if r.get("passed") is False and r.get("worst_state")]
    if failing:
        doc.table(
            f"States where {name}'s failing quantities disagree most",
            ("quantity", "pair", "q", "v", "tau"),
            [
                (
                    r["quantity"],
                    r["pair"],
                    vec(w.get("q", [])),
                    vec(w.get("v", [])),
                    vec(w.get("tau", [])),
                )
                for r in failing
                if (w := r["worst_state"])
            ],
        )
    section_reproducers(doc, name, s)
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


def reference_text(s: SystemResult, tr: Trajectories) -> str:
    """The reference of the trajectory runs and why it is that one, from the system's facts."""
    ref = re.sub(r" \((the hand derivation|your derivation)[^()]*\)$", "", str(tr.get("reference")))
    if not has_derivation(s):
        return f"{ref} (no derivation given: MuJoCo's own run is the reference, and every run is information only)"
    if (s.get("derivation") or {}).get("verdict") == "disagrees":
        return f"{ref} ({derivation_label(s)} disagrees with the engines, so it is not the reference)"
    return ref


def section_trajectories(doc: Document, name: str, s: SystemResult, tr: Trajectories) -> None:
    t = series(tr.get("t", []))
    thr = as_float(tr.get("threshold"))
    trajectory_intro(doc, s, tr, thr)
    trajectory_runs_table(doc, name, s, tr)
    judged_notes(doc, name, tr, t)
    trust_section(doc, tr)
    uncounted_notes(doc, s, tr)
    trajectory_figures(doc, name, s, tr, t, thr)


def trajectory_intro(doc: Document, s: SystemResult, tr: Trajectories, thr: float) -> None:
    """The start, sampling and reference of the free motion, and what the error is judged against."""
    runs = tr["runs"]
    doc.p(
        f"Free motion from q0 = {vec(tr.get('q0', []))} rad, v0 = {vec(tr.get('v0', []))} rad/s, "
        f"tau = {vec(tr.get('tau', []))}, sampled every {fmt_g(tr.get('dt_out'))} s "
        f"up to {fmt_g(tr.get('t_end'))} s. "
        f"The reference is {reference_text(s, tr)}; the error is the largest coordinate's distance to it, "
        + (
            (
                f"judged against {tr['threshold_rule']}."
                if tr.get("threshold_rule")
                else f"judged against the trajectory threshold {sci(thr)} rad."
            )
            if any(r.get("counts", True) for r in runs)
            else f"shown beside the trajectory threshold {sci(thr)} rad, not judged."
        )
    )


def trajectory_runs_table(doc: Document, name: str, s: SystemResult, tr: Trajectories) -> None:
    """One row per run: its cost, error against the reference, energy change and verdict."""
    energy_column = "energy change (friction)" if is_damped(s) else "energy drift"
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
                r["energy_missing"] if r.get("energy_missing") else Num(r.get("energy_drift"), unit="J"),
                run_verdict(r, tr),
            )
            for r in tr["runs"]
        ],
    )


def judged_notes(doc: Document, name: str, tr: Trajectories, t: npt.NDArray[np.float64]) -> None:
    """How long the runs are judged and why: the common interval, each run's own error estimate and
    threshold, and the runs judged over a shorter interval of their own."""
    runs = tr["runs"]
    if tr.get("judged_until") is not None:
        whole = as_float(tr["judged_until"]) >= as_float(tr.get("t_end"))
        doc.p(
            f"Runs are judged over the whole run ({fmt_g(tr['judged_until'])} s): {tr.get('judged_because')}."
            if whole
            else f"Runs are judged until {fmt_g(tr['judged_until'])} s, not beyond: {tr.get('judged_because')}."
        )
    estimated = [r for r in runs if r.get("estimate_how")]
    if estimated:
        doc.table(
            f"Each run's own error estimate and threshold, {name}",
            ("source", "estimate from", "largest estimate judged", "threshold at the judged end"),
            [
                (
                    run_label(r),
                    r["estimate_how"],
                    Num(judged_max(r.get("error_estimate"), t, r.get("judged_until")), unit="rad"),
                    Num(r.get("threshold_at_judged_end"), unit="rad"),
                )
                for r in estimated
            ],
        )
    for r in runs:
        if r.get("judged_because"):
            doc.p(f"{run_label(r)} is judged until {fmt_g(r.get('judged_until'))} s: {r['judged_because']}.")


def uncounted_notes(doc: Document, s: SystemResult, tr: Trajectories) -> None:
    """Why runs are not part of the verdict: no derivation given, or each run's own reason."""
    runs = tr["runs"]
    if not has_derivation(s):
        shown = and_join(sorted({run_label(r) for r in runs if r.get("source") != "mujoco" or tr.get("trust")}))
        against = "the reference" if tr.get("trust") else "MuJoCo's run"
        doc.p(f"Not part of the verdict: no derivation given; {shown or 'no run'} shown against {against}.", "note")
    else:
        for why in sorted({r["why_not_counted"] for r in runs if r.get("why_not_counted")}):
            doc.p(f"Not part of the verdict: {why}.", "note")


def trajectory_figures(
    doc: Document, name: str, s: SystemResult, tr: Trajectories, t: npt.NDArray[np.float64], thr: float
) -> None:
    """The coordinates, the error against the reference and the energy of every run, against time."""
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
        "vertical line marks where a source first passes it (a run from another start passes it at once). "
        "Sources identical to the reference are not drawn.",
    )
    doc.figure(
        f"img/{name}_energy.png",
        energy_figure(name, t, runs),
        f"Energy of {name} against time for every source",
        f"Total energy T + V by {energy_source(s)} along each source's trajectory, relative to "
        f"E(0) = {sci(series(runs[0]['energy'])[0], 6)} J; {energy_text(s)}",
    )


def judged_max(values: Iterable[object] | None, t: Iterable[object], until: float | str | None) -> float | None:
    """The largest of a run's per-sample values up to the judged end (all, without one)."""
    x = series(values if values is not None else [])
    if until is not None and len(x) == len(series(t)):
        x = x[series(t) <= as_float(until) + 1e-12]
    return float(x.max()) if len(x) else None


def energy_source(s: SystemResult) -> str:
    """Whose T + V the runs' energies are (the pipeline's order: the derivation, the derived equations, MuJoCo)."""
    if has_derivation(s):
        return derivation_label(s)
    return "the derived equations" if "symbolic" in compared_sources(s) else "MuJoCo"


def energy_text(s: SystemResult) -> str:
    if is_damped(s):
        return (
            "the joints' viscous friction dissipates energy, so E falls; every source should fall along the same curve"
            + (" (the inputs also do work)" if is_driven(s) else "")
            + "."
        )
    if is_driven(s):
        return "the inputs do work, so E changes; every source should change along the same curve."
    inputs = "no friction, and the inputs are zero along these runs" if has_actuators(s) else "no friction, no inputs"
    return f"the system is conservative ({inputs}), so each curve is that source's drift and should stay near 0."


def first_above(run: FreeRun, tr: Trajectories) -> str:
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


def fmt_stats(stats: object) -> str:
    """The cost of a run: its function evaluations and steps (the integrator's status is not a cost)."""
    if not isinstance(stats, dict) or not stats:
        return "–"
    names = {"nfev": "evaluations", "steps": "steps", "njev": "Jacobians"}
    return ", ".join(f"{v} {names[k]}" for k, v in sorted(stats.items()) if k in names and is_number(v)) or "–"


def shorten(x: Cell | list[float | str], n: int = 60) -> str:
    text = vec(x) if isinstance(x, list) else cell_text(x)
    return text if len(text) <= n else text[: n - 1] + "…"

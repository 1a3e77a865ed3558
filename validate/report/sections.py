"""The report's other sections (provenance, summary, errata, tolerance tiers, limitations, how to
replay) and `build`, which puts every section in order.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

from ..results.schema import (
    SCALED_DEFINITION,
    Derivation,
    ReportInput,
    RunResults,
    SystemResult,
    WorstTerm,
)
from .chains import section_chains
from .document import (
    BENCHMARK,
    ERRATA,
    LIMITATIONS,
    NOT_RUN,
    PROVENANCE,
    REPLAY,
    STRESS,
    SUMMARY,
    TOLERANCE_TIERS,
    Cell,
    Code,
    Document,
    Items,
    Mark,
    Num,
    as_float,
    is_number,
    pass_mark,
    ratio,
    sci,
    slug,
    to_plain,
    verdict_mark,
)
from .errata import section_errata
from .findings import (
    MODEL_ONLY,
    SOURCE_NAMES,
    Cells,
    Finding,
    agreeing_forms,
    and_join,
    compared_sources,
    derivation_label,
    form_term,
    forms_tally,
    has_derivation,
    is_chaotic,
    is_user,
    pair_cells,
    pointwise_rows,
    system_headline,
    term_cells,
    wrong_forms,
)
from .runs import fmt_g
from .studies import section_bench, section_stress
from .system import section_system, shorten
from .timing import section_timing


def variant_worst(v: Derivation) -> WorstTerm | None:
    if v.get("worst_term"):
        return v["worst_term"]
    terms = v.get("terms") or []
    if not terms:
        return None
    w = max(terms, key=ratio)
    keys = ("term", "engine", "parameters", "max_abs", "scaled", "tolerance", "pair")
    return cast(WorstTerm, {k: w.get(k) for k in keys})  # absent ones as None


def variant_tolerance(v: Derivation, worst: WorstTerm | None) -> float | None:
    if worst is None:
        return None
    if worst.get("tolerance") is not None:
        return worst["tolerance"]
    for t in v.get("terms") or []:
        if t.get("term") == worst.get("term") and t.get("engine") == worst.get("engine"):
            return t.get("tolerance")
    return None


def counts(results: RunResults) -> dict[str, int]:
    systems = results.get("systems", {})
    variants = [v for s in systems.values() for v in s.get("variants", [])]
    return {
        "systems": len(systems),
        "failed": sum(1 for s in systems.values() if s.get("passed") is not True),
        "forms": len(variants),
        "disagree": sum(1 for v in variants if v.get("verdict") == "disagrees"),
        "not_applicable": sum(1 for v in variants if v.get("verdict") not in ("agrees", "disagrees")),
    }


HIDDEN = "the notes' parameter values hide it; a probe shows it"


def verdict_line(results: RunResults) -> tuple[bool, str, str]:
    """(passed, headline, detail) for the top of the report: the derivations' verdict first, then the
    printed forms; a failing system is named with its failing term and pair."""
    c = counts(results)
    systems = results.get("systems", {})
    passed = results.get("passed") is True and c["failed"] == 0
    given = [n for n, s in systems.items() if has_derivation(s)]
    users = [n for n in given if is_user(systems[n])]
    alone = c["systems"] - len(given)
    if c["systems"] == 0:
        return False, "no system was run", ""
    if passed:
        if not given:
            head = f"{MODEL_ONLY}; they agree"
        elif len(given) == 1:
            head = f"{derivation_label(systems[given[0]])} agrees with the engines"
        elif len(users) == len(given):
            head = f"all {len(given)} of your derivations agree with the engines"
        else:
            head = f"all {len(given)} derivations agree with the engines"
        if given and alone:
            head += f"; {alone} model{'s' if alone > 1 else ''} without a derivation: the engines agree"
    else:
        failing = sorted(n for n, s in systems.items() if s.get("passed") is not True)
        first = failing[0]
        head = (
            f"{first} fails: {system_headline(systems[first])[1]}"
            if len(failing) == 1
            else f"{len(failing)} of {c['systems']} systems fail; {first}: {system_headline(systems[first])[1]}"
        )
    if c["forms"]:
        detail = (
            f"{c['disagree']} of the {c['forms']} printed forms of the notes are wrong (listed below, each with its "
            f"term and reason; details in {ERRATA})"
            if c["disagree"]
            else f"All {c['forms']} printed forms of the notes agree with the engines"
        )
        if c["not_applicable"]:
            detail += f"; {c['not_applicable']} could not be judged"
    elif not given:
        names = sorted({x for s in systems.values() for x in compared_sources(s)})
        detail = "Compared quantity by quantity at random states: " + and_join(
            [SOURCE_NAMES[n] for n in names if n in SOURCE_NAMES]
        )
    else:
        probed = any((s.get("derivation") or {}).get("checked", {}).get("probes") for s in systems.values())
        detail = (
            "Judged term by term against the engines (MuJoCo, Pinocchio, Drake where installed) at the model's "
            "parameters" + (" and at probe parameter sets" if probed else " only (no probe parameter sets)")
        )
    return passed, (head if not passed else head[0].upper() + head[1:]), detail + "."


def system_statuses(results: RunResults) -> list[tuple[str, str, Mark, str]]:
    """(name, anchor, verdict mark, one-line detail) of every system, for the top of the report."""
    out = []
    for name, s in sorted(results.get("systems", {}).items()):
        ok, text = system_headline(s)
        variants = s.get("variants", [])
        wrong = sum(1 for v in variants if v.get("verdict") == "disagrees")
        if variants:
            text += f"; {wrong} of {len(variants)} printed forms wrong"
        out.append((name, f"system-{slug(name)}", pass_mark(s.get("passed")), text))
    return out


@dataclass(frozen=True)
class Header:
    """What the first screen says, in order: the verdict, each derivation, every wrong printed form
    with its term and reason, and the forms that agree (folded)."""

    state: str  # "ok", "warn" (every derivation agrees, some printed forms are wrong) or "bad"
    headline: str
    detail: str
    statuses: list[tuple[str, str, Mark, str]]
    wrong: list[Finding]
    wrong_title: str
    agreeing: list[tuple[str, str, str]]
    agreeing_title: str
    statuses_title: str = "Derivations, each judged term by term against the engines"


def header(results: RunResults) -> Header:
    passed, head, detail = verdict_line(results)
    n, wrong, _ = forms_tally(results)
    agreeing = agreeing_forms(results)
    agree = sum(1 for *_, v in agreeing if v == "agrees")
    return Header(
        state="bad" if not passed else "warn" if wrong else "ok",
        headline=head,
        detail=detail,
        statuses=system_statuses(results),
        wrong=wrong_forms(results),
        wrong_title=f"Wrong printed forms of the notes ({wrong} of {n}): the term that disagrees and why",
        agreeing=agreeing,
        agreeing_title=f"{agree} printed forms agree with the engines"
        + (f", {len(agreeing) - agree} not judged" if len(agreeing) > agree else ""),
        statuses_title=statuses_title(results),
    )


def statuses_title(results: RunResults) -> str:
    systems = results.get("systems", {}).values()
    given = sum(1 for s in systems if has_derivation(s))
    if given == len(systems):
        return "Derivations, each judged term by term against the engines"
    if not given:
        return "Models alone (no derivation given), each engine's reading and dynamics compared with the others'"
    return "Systems: each derivation judged term by term against the engines; each model alone, its engines compared"


def cached_line(results: RunResults) -> str:
    """Which results were loaded from the cache (validate/core/cache.py) rather than computed in this run."""
    hits = []
    for name, s in sorted(results.get("systems", {}).items()):
        chaos = s.get("chaos") or {}
        kinds = [
            kind
            for kind, info in (
                ("reference solution", (s.get("trajectories") or {}).get("reference_info")),
                ("chaos summary", chaos.get("chaos")),
                ("chaos and mirrors", chaos),
                ("experiments", s.get("experiments")),
            )
            if isinstance(info, dict) and info.get("cache") == "hit"
        ]
        if kinds:
            hits.append(f"{name} ({', '.join(kinds)})")
    return "; ".join(hits) if hits else "nothing: every result computed in this run"


def section_provenance(doc: Document, results: RunResults) -> None:
    meta = results.get("meta", {})
    doc.h(2, PROVENANCE)
    doc.p(
        "Where and how these results were produced. These lines, and only these, differ between two runs "
        "with the same seed.",
        "note",
    )
    rows = [
        (label, str(meta.get(key, "unknown")))
        for label, key in (
            ("harness version", "harness_version"),
            ("git commit", "git_commit"),
            ("date (UTC)", "date"),
            ("command line", "command"),
            ("CPU", "cpu"),
            ("Python", "python"),
            ("platform", "platform"),
            ("seed", "seed"),
        )
    ]
    rows.append(("from the cache", cached_line(results)))
    doc.table("Run", ("item", "value"), rows)
    versions = meta.get("versions", {})
    doc.table("Package versions", ("package", "version"), [(k, str(v)) for k, v in sorted(versions.items())])


def derivation_row(name: str, s: SystemResult) -> tuple[Cell, ...]:
    """One system's row: the term (or pointwise pair) that fails, with its numbers; where none fails
    but the system does (a model check, a stage after the verdict), that failure in words and no
    numbers; where all pass, the term closest to its tolerance. The mark is the row's own."""
    label = derivation_label(s).removeprefix("the ") if has_derivation(s) else "the model alone"
    kind = "hand" if has_derivation(s) else "engines"
    summary = (s.get("derivation") or {}).get("summary") or []
    prow = pointwise_rows(s)
    failing = [r for r in summary if r.get("passed") is False]
    bad = [r for r in prow if r.get("passed") is False]
    ok: bool | None = s.get("passed")
    cells: Cells = (None, None, None, None)
    if failing:
        cells, ok = term_cells(failing[0]), False
    elif bad:
        cells, ok = pair_cells(max(bad, key=ratio)), False
    elif ok is False:
        cells = (_failure_words(s), None, None, None)
    elif summary:
        cells = term_cells(
            max(summary, key=lambda r: as_float(r.get("worst_scaled")) / max(as_float(r.get("tolerance")), 1e-300))
        )
    elif prow:
        cells = pair_cells(max(prow, key=ratio))
    term, pair, err, tol = cells
    return (name, label, kind, pass_mark(ok), term, pair, Num(err), Num(tol, short=True))


def _failure_words(s: SystemResult) -> str:
    """What failed where no term and no pointwise pair does: the first phrase of `failed`."""
    failed = list(s.get("failed") or [])
    return str(failed[0]) if failed else "see its section"


def form_row(name: str, v: Derivation) -> tuple[Cell, ...]:
    w = variant_worst(v)
    engine = (w or {}).get("engine")
    wrong = v.get("verdict") == "disagrees"
    return (
        name,
        v.get("name"),
        v.get("kind"),
        verdict_mark(v.get("verdict", "")),
        form_term(v) if wrong else (w or {}).get("term"),
        f"printed~{engine}" if engine else None,
        Num((w or {}).get("scaled")),
        Num(variant_tolerance(v, w), short=True),
    )


SUMMARY_COLUMNS = ("system", "form", "kind", "verdict", "term (worst)", "pair", "scaled error", "tolerance")


def section_summary(doc: Document, results: RunResults) -> None:
    doc.h(2, SUMMARY)
    forms = any(s.get("variants") for s in results.get("systems", {}).values())
    systems = results.get("systems", {}).values()
    alone = any(not has_derivation(s) for s in systems)
    given = any(has_derivation(s) for s in systems)
    if alone and given:
        lead = (
            "One row per system (a derivation judged on every term against the engines and on the model checks; "
            "a model alone, its engines compared quantity by quantity and on the model checks)"
        )
    elif alone:
        lead = (
            "One row per model (no derivation given: its engines compared quantity by quantity and on the model checks)"
        )
    else:
        lead = "One row per derivation (judged on every term against the engines, and on the model checks)"
    doc.p(
        lead
        + (
            ", then one per wrong printed form of the notes; the printed forms that agree are folded below"
            if forms
            else ""
        )
        + f". {SCALED_DEFINITION}; the row shows the term closest to (or furthest past) its tolerance."
    )
    rows: list[tuple[Cell, ...]] = []
    passing: list[tuple[Cell, ...]] = []
    for name, s in sorted(results.get("systems", {}).items()):
        rows.append(derivation_row(name, s))
        for v in s.get("variants", []):
            (rows if v.get("verdict") == "disagrees" else passing).append(form_row(name, v))
    what = "derivation" if given and not alone else "system"
    doc.table(
        f"Verdict of every {what}" + (" and wrong printed form" if forms else ""), SUMMARY_COLUMNS, rows, group=True
    )
    if passing:
        inner = Document()
        inner.table("Printed forms that agree with the engines", SUMMARY_COLUMNS, passing, group=True)
        doc.fold(f"{len(passing)} printed forms agree with the engines or were not judged", inner)


def section_tolerances(doc: Document, results: RunResults) -> None:
    doc.h(2, TOLERANCE_TIERS)
    tiers = results.get("tolerances") or {}
    used: dict[str, set[str]] = {}
    for s in results.get("systems", {}).values():
        for r in s.get("pointwise", {}).get("rows", []):
            used.setdefault(r.get("tier", "?"), set()).add(r.get("quantity", "?"))
        if any(r.get("counts", True) for r in (s.get("trajectories") or {}).get("runs", [])):
            used.setdefault("trajectory", set()).add("trajectories")
    doc.p(
        "Every comparison is judged with one named tier: a bound on `scaled` (the largest `|a - b|` over the states "
        "divided by the largest magnitude the quantity takes over them) or, for trajectories, a distance in rad. "
        "Each tier says why it is what it is."
    )
    doc.table(
        "Tolerance tiers, what each judges and why",
        ("tier", "rtol", "judges", "reason"),
        [
            (
                k,
                Num(t.get("rtol"), short=True),
                ", ".join(sorted(used.get(k, []))) or "–",
                trajectory_reason(results) if k == "trajectory" else t.get("reason", ""),
            )
            for k, t in sorted(tiers.items())
        ],
    )


def trajectory_reason(results: RunResults) -> str:
    """Why the trajectory threshold is what it is, from the runs these results hold: their integrators,
    duration, judged interval and largest error (nothing hard-coded)."""
    trs = {n: tr for n, s in sorted(results.get("systems", {}).items()) if (tr := s.get("trajectories"))}
    runs = [r for tr in trs.values() for r in tr.get("runs", []) if r.get("counts", True) and not r.get("label")]
    if not runs:
        return "Not used in these results: no trajectory run was judged."
    thr = sorted({sci(tr.get("threshold")) for tr in trs.values()})
    ends = sorted({fmt_g(tr.get("t_end")) for tr in trs.values()})
    methods = sorted({str(r.get("method")) for r in runs})
    judged = [
        f"{n} until {fmt_g(tr['judged_until'])} s"
        for n, tr in trs.items()
        if tr.get("judged_until") is not None and as_float(tr["judged_until"]) < as_float(tr.get("t_end"))
    ] or ["here every run is judged over its whole length"]
    worst = max(runs, key=lambda r: as_float(r.get("max_error_vs_hand")))
    error, limit = as_float(worst.get("max_error_vs_hand")), max(as_float(tr.get("threshold")) for tr in trs.values())
    margin = (
        f"{' or '.join(thr)} rad is {limit / error:.0f} times that"
        if 0 < error <= limit
        else f"{' or '.join(thr)} rad"
        + (" is not passed" if error <= limit else " is passed after the judged interval")
    )
    return (
        f"Free-running trajectories over {' or '.join(ends)} s, by {', '.join(methods)}. A run is judged only up to "
        "where the dynamics amplify errors so much that the integrators' own error could pass the threshold"
        + (f" ({'; '.join(judged)})" if judged else "")
        + f". The largest whole-run error of a judged run here is {sci(error)} rad ({worst.get('method')}); "
        f"the threshold {margin}."
    )


def section_limitations(doc: Document, results: ReportInput) -> None:
    doc.h(2, LIMITATIONS)
    doc.p("What these results do not show:")
    systems = results.get("systems", {})
    placeholders = {
        name: sorted(k for k, v in s.get("parameters", {}).items() if is_number(v) and 0 < abs(v) <= 1e-12)
        for name, s in sorted(systems.items())
    }
    items = placeholder_items(placeholders) + coverage_items(systems) + chaos_items(systems)
    items += [
        "Contacts, joint limits, constraints and closed chains are not part of any system and are not checked.",
        "This report only presents results.json; it recomputes nothing. A number here is only as recent as "
        "that file (see Provenance).",
    ]
    items += system_limitation_items(systems, placeholders) + not_run_items(results)
    doc.blocks.append(Items(tuple(items)))


def placeholder_items(placeholders: dict[str, list[str]]) -> list[str]:
    """The note on the placeholder inertias, when a system has any."""
    with_placeholders = [n for n, keys in placeholders.items() if keys]
    if not with_placeholders:
        return []
    return [
        f"{', '.join(with_placeholders)}: bodies the derivation treats as point masses are given a rotational "
        "inertia of order 1e-14 kg m^2 in the model, because MuJoCo refuses a moving body without one; the "
        "derivations include it exactly, the printed forms that omit it are off by about 1e-14 relative, far "
        "below the algebraic tier, so it cannot flip a verdict."
    ]


def coverage_items(systems: dict[str, SystemResult]) -> list[str]:
    """What the sampled states and the parameter sets of the printed forms leave out."""
    items = [
        "Pointwise results keep only the largest error over the random states (and the state where it "
        "occurred), not each state's error: the per-quantity charts show those maxima, not a distribution.",
        "The random states cover a box of angles and velocities; states outside it (very fast motion) are "
        "not sampled. Engines are compared on the quantities listed in each pointwise table; the Coriolis "
        "matrix itself is only compared through C(q, v) v inside the bias.",
    ]
    sets = sorted({len(v.get("probes") or []) for s in systems.values() for v in s.get("variants", [])} - {0})
    if sets:
        counted = " or ".join(str(n) for n in sets)
        items.append(
            f"A printed form is judged at {counted} parameter sets (the model's and its probes); a slip that happens "
            "to vanish at every one of them would not show."
        )
    return items


def chaos_items(systems: dict[str, SystemResult]) -> list[str]:
    """What one initial state per trajectory says, for the chaotic systems and the regular ones."""
    items = []
    chaotic = [n for n, s in sorted(systems.items()) if is_chaotic(s)]
    regular = [n for n, s in sorted(systems.items()) if s.get("chaos") and not is_chaotic(s)]
    if chaotic:
        items.append(
            f"Each trajectory starts from one initial state. From theirs, {', '.join(chaotic)} move chaotically: "
            "beyond the predictability horizon the sources drift apart by integrator error alone, so the trajectory "
            "threshold judges the interval before it, not the equations."
        )
    if regular:
        items.append(
            f"{', '.join(regular)}: not chaotic from the initial state run (see their error-growth tables); one "
            "start says nothing of motion elsewhere in the state space."
        )
    return items


def system_limitation_items(systems: dict[str, SystemResult], placeholders: dict[str, list[str]]) -> list[str]:
    """Per system: its placeholder parameters, the printed forms not judged, the parts not run; then what
    was skipped, grouped by reason."""
    items = []
    skips: dict[str, list[str]] = {}
    for name, s in sorted(systems.items()):
        if placeholders[name]:
            items.append(
                f"{name}: parameters {', '.join(placeholders[name])} are placeholders of order 1e-14 (see above), "
                "not physical values."
            )
        for v in s.get("variants", []):
            if v.get("verdict") not in ("agrees", "disagrees"):
                items.append(
                    f"{name}, printed form {v.get('name')}: not judged ({v.get('verdict')}"
                    + (f": {v['reason']}" if v.get("reason") else "")
                    + ")."
                )
        for key in ("model_checks", "pointwise", "trajectories"):
            if not s.get(key):
                items.append(f"{name}: {key.replace('_', ' ')} {NOT_RUN}.")
        skipped = s.get("skipped")
        for what in skipped if isinstance(skipped, list) else [skipped] if skipped else []:
            skips.setdefault(str(what).rstrip("."), []).append(name)
    for what, names in sorted(skips.items()):
        items.append(f"Skipped for {', '.join(names)}: {what}.")
    return items


def not_run_items(results: ReportInput) -> list[str]:
    """The studies and per-system parts these results lack, and what the run skipped."""
    systems = results.get("systems", {})
    items = []
    missing = [label for key, label in (("bench", "benchmark"), ("stress", "stress tests")) if not results.get(key)]
    missing += [
        f"{label} of {name}"
        for name, s in sorted(systems.items())
        for key, label in (("chaos", "chaos"), ("experiments", "experiments"))
        if not s.get(key)
    ]
    if missing:
        items.append(f"Not run in these results: {', '.join(missing)}.")
    if results.get("skipped"):
        items.append(f"Skipped: {shorten(results['skipped'], 200)}.")
    return items


@dataclass(frozen=True)
class ReplayHint:
    """Where `run` wrote the recordings and the viewer command that opens them on this machine."""

    out: str = "reports"  # the reports folder, as the recordings' paths are written
    viewer: str = ".venv/bin/rerun"  # after the README's set-up, from the checkout
    written: bool = True  # False: run with --no-replay


def section_replay(doc: Document, results: RunResults, hint: ReplayHint | None = None) -> None:
    hint = hint or ReplayHint()
    doc.h(2, REPLAY)
    names = sorted(n for n, s in results.get("systems", {}).items() if s.get("trajectories"))
    if not hint.written:
        doc.p(
            f"This run was made with `--no-replay`: no recording was written. `lagrange-xval replay SYSTEM --results "
            f"{hint.out}/results.json --save FILE.rrd` draws one from these results.",
            "missing",
        )
        return
    if not names:
        doc.p("No system has trajectories, so no recording was written.", "missing")
        return
    doc.p(
        f"`lagrange-xval run` wrote each system's trajectories for the rerun viewer beside this report, in "
        f"`{hint.out}/`"
        + (
            "; the runs of the wrong printed forms from the same start are in the same recording, beside the engines'"
            if any(
                v.get("verdict") == "disagrees"
                for s in results.get("systems", {}).values()
                for v in s.get("variants", [])
            )
            else ""
        )
        + f". Open one in the native viewer (`{hint.viewer}` is the viewer installed with lagrange-xval), or in the "
        "web viewer served on this machine only:"
    )
    lines = []
    for name in names:
        path = f"{hint.out}/{name}.rrd"
        lines += [f"{hint.viewer} {path}", f"{hint.viewer} --web-viewer --bind 127.0.0.1 {path}"]
    doc.blocks.append(Code("\n".join(lines)))
    doc.p(
        f"`lagrange-xval replay SYSTEM --results {hint.out}/results.json` opens one system's recording, drawn again "
        "from the results (nothing is recomputed); `lagrange-xval report` re-renders this report from the same file."
    )


def system_section(name: str, s: SystemResult) -> Document:
    """One system's section alone (blocks and images): a pure function of that system's results, so
    it can be rendered in the worker that computed them while others still run."""
    doc = Document()
    section_system(doc, name, to_plain(s))
    return doc


def build(
    results: ReportInput, sections: dict[str, Document] | None = None, hint: ReplayHint | None = None
) -> Document:
    """The whole report as blocks and images (the results must already be plain: see `to_plain`);
    `sections`: systems' sections already rendered from these results (`system_section`). The
    findings first (summary, errata), then each system, then the reference sections."""
    doc = Document()
    section_summary(doc, results)
    if any(s.get("variants") or (not is_user(s) and has_derivation(s)) for s in results.get("systems", {}).values()):
        section_errata(doc, results)  # a run of the user's own systems alone has no errata of the notes
    for name, s in sorted(results.get("systems", {}).items()):
        done = (sections or {}).get(name)
        if done is None:
            section_system(doc, name, s)
        else:
            doc.blocks += done.blocks
            doc.images.update(done.images)
    section_timing(doc, results)
    section_tolerances(doc, results)

    doc.h(2, BENCHMARK)
    section_bench(doc, results.get("bench"))
    doc.h(2, STRESS)
    section_stress(doc, results.get("stress"))
    section_chains(doc, results.get("chains"))
    section_limitations(doc, results)
    section_replay(doc, results, hint)
    section_provenance(doc, results)
    return doc

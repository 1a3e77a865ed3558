"""The report's other sections (provenance, summary, errata, tolerance tiers, limitations, how to
replay) and `build`, which puts every section in order.
"""

from __future__ import annotations

from typing import Any

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
    Code,
    Document,
    Items,
    Mark,
    Num,
    as_float,
    is_number,
    pass_mark,
    ratio,
    slug,
    to_plain,
    verdict_mark,
)
from .studies import section_bench, section_stress
from .system import section_system, shorten


def variant_worst(v: dict[str, Any]) -> dict[str, Any] | None:
    if v.get("worst_term"):
        return v["worst_term"]
    terms = v.get("terms") or []
    if not terms:
        return None
    w = max(terms, key=ratio)
    return {k: w.get(k) for k in ("term", "engine", "parameters", "max_abs", "scaled", "tolerance", "pair")}


def variant_tolerance(v: dict[str, Any], worst: dict[str, Any] | None) -> Any:
    if worst is None:
        return None
    if worst.get("tolerance") is not None:
        return worst["tolerance"]
    for t in v.get("terms") or []:
        if t.get("term") == worst.get("term") and t.get("engine") == worst.get("engine"):
            return t.get("tolerance")
    return None


def counts(results: dict[str, Any]) -> dict[str, int]:
    systems = results.get("systems", {})
    variants = [v for s in systems.values() for v in s.get("variants", [])]
    return {
        "systems": len(systems),
        "failed": sum(1 for s in systems.values() if s.get("passed") is not True),
        "forms": len(variants),
        "disagree": sum(1 for v in variants if v.get("verdict") == "disagrees"),
        "not_applicable": sum(1 for v in variants if v.get("verdict") not in ("agrees", "disagrees")),
    }


def verdict_line(results: dict[str, Any]) -> tuple[bool, str, str]:
    """(passed, headline, detail) for the top of the report."""
    c = counts(results)
    passed = results.get("passed") is True and c["failed"] == 0
    if c["systems"] == 0:
        head = "no system was run"
        passed = False
    elif passed:
        head = f"all {c['systems']} systems pass" if c["systems"] > 1 else "the system passes"
    else:
        head = f"{c['failed']} of {c['systems']} systems fail"
    detail = (
        f"{c['forms']} printed forms of the notes judged: {c['forms'] - c['disagree'] - c['not_applicable']} agree "
        f"with the engines, {c['disagree']} disagree (see {ERRATA})"
    )
    if c["not_applicable"]:
        detail += f", {c['not_applicable']} could not be judged"
    return passed, head, detail + "."


def system_statuses(results: dict[str, Any]) -> list[tuple[str, str, Mark, str]]:
    """(name, anchor, verdict mark, one-line detail) of every system, for the top of the report."""
    out = []
    for name, s in sorted(results.get("systems", {}).items()):
        variants = s.get("variants", [])
        wrong = sum(1 for v in variants if v.get("verdict") == "disagrees")
        forms = f"{len(variants)} printed form" + ("s" if len(variants) != 1 else "")
        detail = f"{forms}, {wrong} disagree" if variants else "no printed form"
        d = s.get("derivation") or {}
        if d.get("verdict") == "disagrees":
            detail = f"hand derivation: {d.get('statement')}; {detail}"
        out.append((name, f"system-{slug(name)}", pass_mark(s.get("passed")), detail))
    return out


def cached_line(results: dict[str, Any]) -> str:
    """Which results were loaded from the cache (validate/cache.py) rather than computed in this run."""
    hits = []
    for name, s in sorted(results.get("systems", {}).items()):
        chaos = s.get("chaos") or {}
        kinds = [
            kind
            for kind, info in (
                ("reference solution", (s.get("trajectories") or {}).get("reference_info")),
                ("chaos summary", chaos.get("chaos")),
            )
            if isinstance(info, dict) and info.get("cache") == "hit"
        ]
        if kinds:
            hits.append(f"{name} ({', '.join(kinds)})")
    return "; ".join(hits) if hits else "nothing: every result computed in this run"


def section_provenance(doc: Document, results: dict[str, Any]) -> None:
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


def section_summary(doc: Document, results: dict[str, Any]) -> None:
    doc.h(2, SUMMARY)
    doc.p(
        "One row per system and per form of its equations: first the hand derivation (judged on every "
        "quantity against both engines, and on the model checks), then each form printed in the notes. "
        "The error is the largest `|a - b|` over the random states divided by the quantity's range; "
        "the worst row is the one closest to (or furthest past) its tolerance."
    )
    rows: list[tuple[Any, ...]] = []
    for name, s in sorted(results.get("systems", {}).items()):
        prow = s.get("pointwise", {}).get("rows", [])
        d = s.get("derivation") or {}
        if d.get("summary"):
            failing = [r for r in d["summary"] if not r.get("passed")]
            w = (
                failing[0]
                if failing
                else max(
                    d["summary"],
                    key=lambda r: as_float(r.get("worst_scaled")) / max(as_float(r.get("tolerance")), 1e-300),
                )
            )
            rows.append(
                (
                    name,
                    "hand derivation",
                    "hand",
                    pass_mark(s.get("passed")),
                    w.get("term"),
                    f"hand~{w.get('engine')}",
                    Num(w.get("worst_scaled")),
                    Num(w.get("tolerance"), short=True),
                )
            )
        elif prow:
            w = max(prow, key=ratio)
            rows.append(
                (
                    name,
                    "hand derivation",
                    "hand",
                    pass_mark(s.get("passed")),
                    w.get("quantity"),
                    w.get("pair"),
                    Num(w.get("scaled")),
                    Num(w.get("tolerance"), short=True),
                )
            )
        else:
            rows.append((name, "hand derivation", "hand", pass_mark(s.get("passed")), None, None, Num(None), Num(None)))
        for v in s.get("variants", []):
            w = variant_worst(v)
            engine = (w or {}).get("engine")
            rows.append(
                (
                    name,
                    v.get("name"),
                    v.get("kind"),
                    verdict_mark(v.get("verdict", "")),
                    (w or {}).get("term"),
                    f"printed~{engine}" if engine else None,
                    Num((w or {}).get("scaled")),
                    Num(variant_tolerance(v, w), short=True),
                )
            )
    doc.table(
        "Verdict of every system and printed form",
        ("system", "form", "kind", "verdict", "worst quantity", "pair", "scaled error", "tolerance"),
        rows,
        group=True,
    )


def section_errata(doc: Document, results: dict[str, Any]) -> None:
    doc.h(2, ERRATA)
    doc.p(
        "Every form of the equations printed in the notes, transcribed as printed and judged term by term "
        "against both engines, with the notes' parameters and at probe parameter sets in which every parameter "
        "moves by its own factor, keeping only the equalities the printed forms assume (so a slip such as a "
        "missing factor l shows even where l = 1). `first disagreeing term` is the first term, in the order mass "
        "matrix, gravity, velocity, friction, actuation, that disagrees; `worst term` is the largest error; "
        "`disagrees at` says whether the model's own parameters already show it or only a probe does."
    )
    assumed = sorted(
        {
            (name, v["assumes"])
            for name, s in results.get("systems", {}).items()
            for v in s.get("variants", [])
            if v.get("assumes")
        }
    )
    for name, text in assumed:
        doc.p(f"The printed forms of {name} assume {text}; their probes keep these equalities.", "note")
    rows, notes, explained = [], [], []
    for name, s in sorted(results.get("systems", {}).items()):
        for v in s.get("variants", []):
            for e in v.get("explanations", []):
                explained.append(
                    (
                        name,
                        v.get("name"),
                        e.get("entry"),
                        e.get("statement") if e.get("explained") else f"(not explained) {e.get('statement')}",
                    )
                )
            w = v.get("worst_term") if v.get("verdict") == "disagrees" else None
            rows.append(
                (
                    name,
                    v.get("name"),
                    ", ".join(v.get("notes_equations", [])),
                    v.get("kind"),
                    verdict_mark(v.get("verdict", "")),
                    v.get("first_disagreeing_term"),
                    (w or {}).get("term"),
                    (w or {}).get("engine"),
                    Num((w or {}).get("scaled")),
                    v.get("disagrees_at"),
                )
            )
            extra = v.get("note") or ""
            if v.get("reason"):
                extra = (extra + " " if extra else "") + f"Not judged: {v['reason']}"
            if extra:
                notes.append(f"{name}, {v.get('name')}: {extra}")
    if not rows:
        doc.p("No printed form was judged in these results.", "missing")
        return
    doc.table(
        "Printed forms of the notes and their verdicts",
        (
            "system",
            "printed form",
            "notes eqs",
            "kind",
            "verdict",
            "first disagreeing term",
            "worst term",
            "engine",
            "scaled error",
            "disagrees at",
        ),
        rows,
        group=True,
    )
    if explained:
        doc.p(
            "What each wrong printed form lacks, against the model's own equations derived symbolically: the "
            "difference in each disagreeing entry fitted onto one slip (or two) and kept only where it reproduces the "
            "printed form's numbers at states held back from the fit, at the probes that keep the printed form's "
            "equalities (parameters it assumes equal cannot be told apart). An explicit form is compared through its "
            "numerator, det(M) times the acceleration."
        )
        doc.table(
            "Symbolic differences of the wrong printed forms",
            ("system", "printed form", "entry", "difference"),
            explained,
        )
    if notes:
        doc.p("Notes on the transcription:")
        doc.blocks.append(Items(tuple(notes)))


def section_tolerances(doc: Document, results: dict[str, Any]) -> None:
    doc.h(2, TOLERANCE_TIERS)
    tiers = results.get("tolerances") or {}
    used: dict[str, set[str]] = {}
    for s in results.get("systems", {}).values():
        for r in s.get("pointwise", {}).get("rows", []):
            used.setdefault(r.get("tier", "?"), set()).add(r.get("quantity", "?"))
        if s.get("trajectories"):
            used.setdefault("trajectory", set()).add("trajectories")
    doc.p(
        "Every comparison is judged with one named tier: a fraction of the quantity's range over the states "
        "(or, for trajectories, a distance in rad). Each tier says why it is what it is."
    )
    doc.table(
        "Tolerance tiers, what each judges and why",
        ("tier", "rtol", "judges", "reason"),
        [
            (k, Num(t.get("rtol"), short=True), ", ".join(sorted(used.get(k, []))) or "–", t.get("reason", ""))
            for k, t in sorted(tiers.items())
        ],
    )


def section_limitations(doc: Document, results: dict[str, Any]) -> None:
    doc.h(2, LIMITATIONS)
    doc.p("What these results do not show:")
    items = [
        "Point-mass bobs are given a rotational inertia of 1e-14 kg m^2 in the MJCF, because MuJoCo refuses a "
        "moving body without one. The hand derivations include it exactly; the notes' printed forms omit it, an "
        "error of about 1e-14 relative in M, far below the algebraic tier, so it cannot flip a verdict.",
        "Pointwise results keep only the largest error over the random states (and the state where it "
        "occurred), not each state's error: the per-quantity charts show those maxima, not a distribution.",
        "The random states cover a box of angles and velocities; states outside it (very fast motion) are "
        "not sampled. Engines are compared on the quantities listed in each pointwise table; the Coriolis "
        "matrix itself is only compared through C(q, v) v inside the bias.",
        "A printed form is judged at two parameter sets (the notes' and one probe); a slip that happens to "
        "vanish at both would not show.",
        "Each trajectory starts from one initial state. The motion is chaotic, so after the predictability "
        "horizon the sources drift apart by integrator error alone; the trajectory threshold judges the "
        "interval before that, not the equations.",
        "Contacts, joint limits, constraints and closed chains are not part of any system and are not checked.",
        "This report only presents results.json; it recomputes nothing. A number here is only as recent as "
        "that file (see Provenance).",
    ]
    systems = results.get("systems", {})
    skips: dict[str, list[str]] = {}
    for name, s in sorted(systems.items()):
        tiny = sorted(k for k, v in s.get("parameters", {}).items() if is_number(v) and 0 < abs(v) <= 1e-12)
        if tiny:
            items.append(
                f"{name}: parameters {', '.join(tiny)} are placeholders of order 1e-14 (see above), "
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
    doc.blocks.append(Items(tuple(items)))


def section_replay(doc: Document, results: dict[str, Any]) -> None:
    doc.h(2, REPLAY)
    doc.p(
        "`lagrange-xval run` records every system's trajectories for the rerun viewer next to this report "
        "(`reports/<system>.rrd`, unless run with `--no-replay`). Open one in the native viewer, or in the "
        "web viewer served on this machine only:"
    )
    lines = []
    for name in sorted(results.get("systems", {})):
        lines += [f"rerun reports/{name}.rrd", f"rerun --web-viewer --bind 127.0.0.1 reports/{name}.rrd"]
    doc.blocks.append(Code("\n".join(lines) if lines else "rerun reports/<system>.rrd"))
    doc.p(
        "`lagrange-xval replay SYSTEM` opens one system's recording, drawn again from `reports/results.json` "
        "(nothing is recomputed); `lagrange-xval report` re-renders this report from the same file."
    )


def system_section(name: str, s: dict[str, Any]) -> Document:
    """One system's section alone (blocks and images): a pure function of that system's results, so
    it can be rendered in the worker that computed them while others still run."""
    doc = Document()
    section_system(doc, name, to_plain(s), {})
    return doc


def build(results: dict[str, Any], sections: dict[str, Document] | None = None) -> Document:
    """The whole report as blocks and images (the results must already be plain: see `to_plain`);
    `sections`: systems' sections already rendered from these results (`system_section`)."""
    doc = Document()
    section_provenance(doc, results)
    section_summary(doc, results)
    for name, s in sorted(results.get("systems", {}).items()):
        done = (sections or {}).get(name)
        if done is None:
            section_system(doc, name, s, results)
        else:
            doc.blocks += done.blocks
            doc.images.update(done.images)
    section_errata(doc, results)
    section_tolerances(doc, results)

    doc.h(2, BENCHMARK)
    section_bench(doc, results.get("bench"))
    doc.h(2, STRESS)
    section_stress(doc, results.get("stress"))
    section_limitations(doc, results)
    section_replay(doc, results)
    return doc

"""The errata of the notes: every wrong printed form with its term, where it is worst, its reason and
its symbolic differences, each under its own anchor (the first screen links here); the forms that
agree folded in one table.
"""

from __future__ import annotations

from ..results.schema import Derivation, Explanation, RunResults
from .document import ERRATA, Cell, Document, Num, verdict_mark
from .findings import form_anchor, form_reason, form_term, where_worst, whose


def variant_row(name: str, v: Derivation) -> tuple[Cell, ...]:
    w = v.get("worst_term") if v.get("verdict") == "disagrees" else None
    return (
        name,
        v.get("name"),
        ", ".join(v.get("notes_equations", [])),
        v.get("kind"),
        verdict_mark(v.get("verdict", "")),
        form_term(v) if v.get("verdict") == "disagrees" else None,
        (w or {}).get("engine"),
        Num((w or {}).get("scaled")),
        v.get("disagrees_at"),
    )


COLUMNS = ("system", "printed form", "notes eqs", "kind", "verdict", "term", "worst against", "scaled error", "at")


def section_errata(doc: Document, results: RunResults) -> None:
    doc.h(2, ERRATA)
    systems = results.get("systems", {})
    forms = [(name, v) for name, s in sorted(systems.items()) for v in s.get("variants", [])]
    if not forms:
        doc.p("No printed form was judged in these results.", "missing")
        return
    wrong = [(n, v) for n, v in forms if v.get("verdict") == "disagrees"]
    rest = [(n, v) for n, v in forms if v.get("verdict") != "disagrees"]
    doc.p(
        f"{len(forms)} forms of the equations printed in the notes, transcribed as printed and judged term by term "
        f"against the engines at the notes' parameters and at probe parameter sets that keep only the equalities the "
        f"printed forms assume (so a slip such as a missing factor l shows even where l = 1): {len(wrong)} are wrong. "
        "`term` is the first term, in the order mass matrix, gravity, velocity, friction, actuation, that disagrees "
        "(for a derivation step, the quantity and the entry it computes); `at` is the first parameter set that "
        "shows it."
    )
    for name, text in sorted({(n, v["assumes"]) for n, v in forms if v.get("assumes")}):
        doc.p(f"The printed forms of {name} assume {text}; their probes keep these equalities.", "note")
    if wrong:
        doc.table("The wrong printed forms", COLUMNS, [variant_row(n, v) for n, v in wrong], group=True)
    if rest:
        inner = Document()
        inner.table("Printed forms that agree with the engines", COLUMNS, [variant_row(n, v) for n, v in rest])
        notes = [
            f"{n}, {v.get('name')}: {v.get('note') or ''}" + (f" Not judged: {v['reason']}" if v.get("reason") else "")
            for n, v in rest
            if v.get("note") or v.get("reason")
        ]
        if notes:
            inner.p("Notes on their transcription:")
            inner.items(notes)
        agree = sum(1 for _, v in rest if v.get("verdict") == "agrees")
        label = f"{agree} printed forms agree with the engines" + (
            f", {len(rest) - agree} could not be judged" if len(rest) > agree else ""
        )
        doc.fold(label, inner)
    for name, v in wrong:
        form_details(doc, name, v)


def form_details(doc: Document, name: str, v: Derivation) -> None:
    """One wrong printed form: its term, where it is worst, its reason, the transcription note and
    every symbolic difference."""
    form = str(v.get("name"))
    doc.h(3, f"{name}: {form}", form_anchor(name, form))
    eqs = ", ".join(v.get("notes_equations", []))
    where = where_worst(v)
    hidden = (
        f" The notes' own parameters hide it; it shows at {v.get('disagrees_at')}"
        + (f" ({v['disagrees_where']})" if v.get("disagrees_where") else "")
        + "."
        if v.get("hidden_by_model_values")
        else ""
    )
    doc.p(
        f"✗ {v.get('kind')} form, notes equation(s) {eqs or '–'}: the term `{form_term(v)}` disagrees"
        + (f" ({where})" if where else "")
        + f". Why: {form_reason(v)}.{hidden}",
        "finding",
    )
    if v.get("note"):
        doc.p(f"Transcription note: {v['note']}", "note")
    explained = v.get("explanations") or []
    if explained:
        inner = Document()
        differences(inner, name, form, explained)
        doc.fold(f"Symbolic differences from the model's own equations ({len(explained)} entries)", inner)


def differences(doc: Document, name: str, form: str, explained: list[Explanation]) -> None:
    """The symbolic differences of a wrong printed form and the symbols they use."""
    owner = "the notes' form"
    doc.table(
        f"Symbolic differences of {name}'s {form} from the model's own equations",
        ("entry", "difference", "expected (the model's equations)"),
        [
            (
                e.get("entry"),
                whose(e.get("statement") if e.get("explained") else f"(not explained) {e.get('statement')}", owner),
                e.get("expected", ""),
            )
            for e in explained
        ],
    )
    symbols = sorted({(k, d) for e in explained for k, d in (e.get("symbols") or {}).items()})
    if symbols:
        doc.p("Symbols: " + "; ".join(symbol_text(k, d) for k, d in symbols) + ".", "note")


def symbol_text(symbol: str, meaning: str) -> str:
    """The errata's "`c_link1 = -body/link1/com[1]` (m)" from the results' "-body/link1/com[1], m"."""
    reading, _, unit = str(meaning).rpartition(", ")
    return f"`{symbol} = {reading}` ({unit})" if reading else f"`{symbol}` {meaning}"

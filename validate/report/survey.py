"""The survey's page (`lagrange-xval survey DIR`): one table of every model by outcome (FAIL, crash,
refused, pass: what needs a look first), each model's details folded below it (the verdict's sentence,
the audit's findings, the reproducers, linked), the pairs of files of one robot, the refusals by
reason. Rendered from the survey's results (results/schema.py `SurveyResults`) as markdown and as one
self-contained HTML page (the report's style and blocks: no scripts, no external resources)."""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Iterable
from urllib.parse import quote

from ..results.schema import SurveyResults, SurveyRow
from .document import MARK_SIGN, Document, Link, Mark
from .render import environment, markdown_blocks

OUTCOMES = ("FAIL", "crash", "refused", "pass")
STATE = {"pass": "ok", "FAIL": "bad", "crash": "bad", "refused": "na", "same robot": "ok", "differ": "bad"}
TITLE = "lagrange-xval survey"


def _mark(outcome: str) -> Mark:
    return Mark(STATE.get(outcome, "na"), outcome)


def _order(row: SurveyRow) -> tuple[int, str]:
    return (OUTCOMES.index(row["outcome"]) if row["outcome"] in OUTCOMES else 0, row["model"])


def _details(row: SurveyRow) -> Document:
    inner = Document()
    fmt, robot = row["format"].upper() or "not read", row["robot"] or "unnamed"
    inner.p(f"`{row['model']}` ({fmt}; robot {robot}): {row['why']}")
    inner.p(f"audit: {row['audit']}")
    if row["findings"]:
        inner.items(row["findings"])
    if row["reproducers"]:
        inner.p("reproducers (each a script of the libraries' own calls; run it with python):")
        inner.table("reproducers", ("script",), [(Link(r, quote(r)),) for r in row["reproducers"]])
    return inner


def survey_document(result: SurveyResults) -> Document:
    """The page as a Document (module docstring)."""
    doc = Document()
    doc.p(f"{result['folder']}: {summary_line(result)}; run on {result['executor']}.")
    rows = sorted(result["rows"], key=_order)
    doc.h(2, "Models, by outcome")
    table = [
        (_mark(r["outcome"]), r["model"], r["format"], f"{r['seconds']:.1f} s", len(r["reproducers"]), r["audit"])
        for r in rows
    ]
    doc.table("every model", ("outcome", "model", "format", "time", "reproducers", "audit"), table)
    for r in rows:
        doc.fold(f"{r['outcome']}: {r['model']}: {r['why'][:160]}", _details(r))
    if result["pairs"]:
        doc.h(2, "Files of one robot")
        pairs = [(_mark(p["outcome"]), p["a"], p["b"], p["robot"], p["why"][:200]) for p in result["pairs"]]
        doc.table("each pair, by the two-file audit", ("outcome", "A", "B", "robot", "why"), pairs)
    reasons = refusal_reasons(rows)
    if reasons:
        doc.h(2, "Refused, by reason")
        doc.table("refusals", ("models", "reason"), [(n, why) for why, n in reasons])
    return doc


def render_survey(result: SurveyResults) -> dict[str, bytes]:
    """{"survey.md": ..., "survey.html": ...}."""
    doc = survey_document(result)
    markdown = "\n".join([f"# {TITLE}", "", *markdown_blocks(doc.blocks)]).rstrip("\n") + "\n"
    html = (
        environment()
        .get_template("survey.html.j2")
        .render(title=TITLE, blocks=doc.blocks, images={}, mark_sign=MARK_SIGN)
    )
    return {"survey.md": markdown.encode(), "survey.html": str(html).encode()}


def summary_line(result: SurveyResults) -> str:
    """ "108 models in 312 s: 52 pass, 16 FAIL (16 with reproducers), 40 refused, 0 crash; 3 pairs: ..."."""
    rows, n = result["rows"], result["counts"]
    proved = sum(1 for r in rows if r["outcome"] == "FAIL" and r["reproducers"])
    text = (
        f"{len(rows)} models in {result['seconds']:.0f} s: {n['pass']} pass, {n['FAIL']} FAIL ({proved} with "
        f"reproducers), {n['refused']} refused, {n['crash']} crash"
    )
    if result["pairs"]:
        by = Counter(p["outcome"] for p in result["pairs"])
        text += f"; {len(result['pairs'])} pairs of files: " + ", ".join(f"{v} {k}" for k, v in sorted(by.items()))
    return text


def sorted_rows(rows: Iterable[SurveyRow]) -> list[SurveyRow]:
    """The rows by outcome (FAIL, crash, refused, pass), then by model."""
    return sorted(rows, key=lambda r: _order(r))


def refusal_reasons(rows: Iterable[SurveyRow]) -> list[tuple[str, int]]:
    """The refusals' reasons as classes (names, quotes and numbers left out), most frequent first."""

    def reason(why: str) -> str:
        text = re.sub(r"^[^:]+\.(xml|urdf|mjcf): ", "", why)
        text = re.sub(r"'[^'\s]*'", "'…'", text)  # a quoted name, not an apostrophe's text
        return re.sub(r"\d[\d.e+-]*", "N", text)[:100]

    return Counter(reason(r["why"]) for r in rows if r["outcome"] == "refused").most_common()


def table_lines(result: SurveyResults, width: int = 110) -> list[str]:
    """The console's table: a line per model, by outcome, then the pairs, the refusals' reasons and the
    summary line."""
    out = [f"{'outcome':8} {'s':>6}  model: why"]
    for r in sorted_rows(result["rows"]):
        proof = f" [{len(r['reproducers'])} reproducer(s)]" if r["reproducers"] else ""
        out.append(f"{r['outcome']:8} {r['seconds']:6.1f}  {r['model']}: {r['why'][:width]}{proof}")
    for p in result["pairs"]:
        out.append(f"pair     {p['seconds']:6.1f}  {p['a']} ~ {p['b']}: {p['outcome']}: {p['why'][:width]}")
    out += [f"  refused {n:3}: {why}" for why, n in refusal_reasons(result["rows"])]
    return [*out, summary_line(result)]

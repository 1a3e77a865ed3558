"""Where each system's time went: every stage's wall seconds from results.json's `stages`, one folded table."""

from __future__ import annotations

from ..results.schema import RunResults
from ..results.stages import ordered, seconds_of
from .document import Document

TIMING = "Where the time went"
# A stage named as the module names it: the table spans every system, and a system without printed
# forms must read no sentence about them (tests/unit/report/test_findings.py).
SHOWN = {"printed forms": "VARIANTS"}


def section_timing(doc: Document, results: RunResults) -> None:
    """One row per stage (in the order the stages ran), one column per system, wall seconds; folded.
    Nothing when no system recorded its stages' seconds (results written before they did)."""
    systems = sorted(results.get("systems", {}).items())
    seconds = {name: {k: seconds_of(v) for k, v in (s.get("stages") or {}).items()} for name, s in systems}
    stages = ordered(k for timed in seconds.values() for k, v in timed.items() if v is not None)
    if not stages:
        return
    names = [name for name, _ in systems]
    rows = [(SHOWN.get(stage, stage), *(_cell(seconds[n].get(stage)) for n in names)) for stage in stages]
    totals = [sum(v for v in seconds[n].values() if v is not None) for n in names]
    rows.append(("total", *(f"{t:.2f}" for t in totals)))
    inner = Document()
    inner.p(
        "Each stage's wall seconds per system, as `run` measured them in its worker (a warm cache makes the "
        "reference, chaos and explanations cheap; `bench --run-time` measures a fresh and a warm run); "
        "blank: the stage was not run for that system."
    )
    inner.table("Wall seconds of each stage, per system", ("stage", *names), rows)
    doc.fold(f"{TIMING}: {sum(totals):.1f} s of stages over {len(names)} systems", inner)


def _cell(value: float | None) -> str:
    return "" if value is None else f"{value:.2f}"

"""What `lagrange-xval check` prints: the pointwise table, the terms, and the verdict line last; or
one JSON object (README, "check --json schema")."""

from __future__ import annotations

from typing import TypedDict

import numpy as np

from ..core.arrays import JsonObject
from ..results import to_jsonable
from ..results.schema import AsIf, ComparisonRow, Mismatch, StructureFinding
from ..systems import System
from ..verdict.decide import Decision, left_out_line
from ..verdict.pointwise import States
from ..verdict.reproduce import Reproducer

QUANTITIES = ("M", "bias", "qacc", "tau_inverse", "T", "V")  # each state's quantities in the JSON


def mismatches(decision: Decision) -> list[Mismatch]:
    """The model checks' mismatches (none when the derivation could not read its model)."""
    return [] if decision.model_checks is None else decision.model_checks["mismatches"]


def verdict_line(decision: Decision) -> str:
    """The last line of `check`: the system, pass or FAIL, and the statement."""
    return f"verdict: {decision.system.name}: {'pass' if decision.passed else 'FAIL'}: {decision.statement}"


class TermLine(TypedDict):
    """One term of the verdict in `check --json` (a TermSummary's fields)."""

    term: str | None
    passed: bool | None
    worst_scaled: float | None
    tolerance: float | None
    engine: str | None
    probe: int | None


class VerdictData(TypedDict):
    """The verdict in `check --json` (README, "check --json schema")."""

    passed: bool
    statement: str
    derivation: str
    first_disagreeing_term: str | None
    hidden_by_model_values: bool
    model_mismatches: list[str]
    excluded: dict[str, str]
    probes: dict[str, int]  # asked for, built
    not_looked_for: str  # "" unless probes asked for were not built (or none was asked for): what that leaves out
    left_out: list[str]  # what every comparison of the model leaves out (contacts, ranges, ...): once, not per line
    structure: list[StructureFinding]  # the properties of a derivation its own functions break (verdict/structure.py)
    terms: list[TermLine]
    as_if: AsIf | None  # the other chain a wrong derivation is the right derivation of (verdict/asif.py)


def verdict_data(decision: Decision) -> VerdictData:
    """The verdict in the JSON object: what `lagrange_xval.check` and `run` decide, term by term."""
    d = decision.derivation
    return {
        "passed": decision.passed,
        "statement": decision.statement,
        "derivation": d.get("verdict", ""),
        "first_disagreeing_term": d.get("first_disagreeing_term"),
        "hidden_by_model_values": d.get("hidden_by_model_values", False),
        "model_mismatches": [m["key"] for m in mismatches(decision)],
        "excluded": dict(decision.excluded or {}),
        "probes": {
            "asked": int(d.get("checked", {}).get("probes_asked", 0)),
            "built": int(d.get("checked", {}).get("probes", 0)),
        },
        "not_looked_for": str(d.get("not_looked_for", "")),
        "left_out": list(decision.model_checks.get("left_out", [])) if decision.model_checks is not None else [],
        "structure": list(d.get("structure", [])),
        "terms": [
            {
                "term": t.get("term"),
                "passed": t.get("passed"),
                "worst_scaled": t.get("worst_scaled"),
                "tolerance": t.get("tolerance"),
                "engine": t.get("engine"),
                "probe": t.get("probe"),
            }
            for t in d.get("summary", [])
        ],
        "as_if": d.get("as_if"),
    }


def json_document(
    system: System,
    states: States | None,
    values: dict[str, dict[str, np.ndarray]],
    rows: list[ComparisonRow],
    passed: bool,
    verdict: VerdictData | None = None,
) -> JsonObject:
    """`check --json`: the states, every source's quantities at each, the largest disagreement of
    each quantity and pair, `passed`, and the `verdict` (absent with --pointwise-only)."""
    disagreement: dict[str, dict[str, dict[str, float | bool]]] = {}
    for r in rows:
        entry: dict[str, float | bool] = {k: r[k] for k in ("max_abs", "scaled", "tolerance", "passed")}
        if "constant" in r:  # V: the constant it was compared up to (results.schema.SCALED_DEFINITION)
            entry["constant"] = r["constant"]
        disagreement.setdefault(r["quantity"], {})[r["pair"]] = entry
    out: dict[str, object] = {
        "system": system.name,
        "coordinates": list(system.coordinates),
        "states": [
            {
                **states.state(i),
                "sources": {s: {k: values[s][k][i] for k in QUANTITIES if k in values[s]} for s in values},
            }
            for i in range(len(states))
        ]
        if states is not None
        else [],
        "max_disagreement": disagreement,
        "passed": passed,
    }
    if verdict is not None:
        out["verdict"] = verdict
    return dict(to_jsonable(out))


def decision_json(decision: Decision) -> JsonObject:
    """`check --json` of a verdict: `passed` is the verdict's."""
    rows = decision.pointwise["rows"] if decision.pointwise is not None else []
    values = decision.values or {}
    return json_document(decision.system, decision.states, values, rows, decision.passed, verdict_data(decision))


def reproducer_lines(proofs: list[Reproducer]) -> list[str]:
    """One line per disagreement's reproducer: the file written, or the pair and why none was; none
    when nothing was written (without --reproduce, `check --json` lists them)."""
    lines = []
    for r in proofs:
        if "path" in r:
            lines.append(f"reproducer: {r['quantity']} {r['pair']}: {r['path']}")
        elif "skipped" in r:
            lines.append(f"reproducer: {r['quantity']} {r['pair']}: not written: {r['skipped']}")
    return lines


def table_lines(rows: list[ComparisonRow], title: str) -> list[str]:
    """The pointwise rows as a table under a one-line title."""
    lines = [title, f"{'quantity':15s} {'pair':20s} {'max abs':>10s} {'scaled':>10s} {'tolerance':>10s}  verdict"]
    lines += [
        f"{r['quantity']:15s} {r['pair']:20s} {r['max_abs']:10.2e} {r['scaled']:10.2e} "
        f"{r['tolerance']:10.0e}  {'pass' if r['passed'] else 'FAIL'}"
        for r in rows
    ]
    return lines + constant_lines(rows)


def constant_lines(rows: list[ComparisonRow]) -> list[str]:
    """One line per row compared up to a constant that is not rounding (V of a pedestal counted by one
    reader only): information, not a disagreement, as no equation of motion contains it."""
    out = []
    for r in rows:
        c = r.get("constant", 0.0)
        if abs(c) > r["tolerance"] * r["scale"]:
            out.append(
                f"{r['quantity']} {r['pair']}: compared up to a constant of {c:.6g} J (the zero of the potential "
                "energy, or bodies welded to the world that one reader counts and the other does not; it changes "
                "no equation of motion)"
            )
    return out


def term_lines(decision: Decision) -> list[str]:
    """The derivation's terms, each with its worst scaled error, where (engine, probe) and its tier."""
    summary = decision.derivation.get("summary", [])
    if not summary:
        return []
    lines = ["terms of the derivation, at the model's parameters (probe 0) and at the probe parameter sets:"]
    lines.append(f"{'term':17s} {'worst scaled':>12s} {'tolerance':>10s}  {'engine':10s} {'probe':>5s}  verdict")
    for t in summary:
        lines.append(
            f"{t['term']:17s} {t['worst_scaled']:12.2e} {t['tolerance']:10.0e}  {t['engine']:10s} "
            f"{t['probe'] if t['probe'] is not None else '-':>5}  {'pass' if t['passed'] else 'FAIL'}"
        )
    return lines


def text_lines(decision: Decision) -> list[str]:
    """`check`'s table: the pointwise rows, the terms, the model mismatches, and the verdict line last."""
    lines = []
    if decision.states is not None and decision.pointwise is not None:
        coordinates = ", ".join(decision.system.coordinates)
        title = f"{decision.system.name}: {len(decision.states)} states, coordinates ({coordinates})"
        lines += table_lines(decision.pointwise["rows"], title)
    for m in mismatches(decision):
        lines.append(f"model: {m['key']} ({m['check']}): {m['why']}")
    lines += term_lines(decision)
    left = left_out_line(decision.model_checks)  # true of every verdict of the model: said once, above it
    return [*lines, *([left] if left else []), verdict_line(decision)]

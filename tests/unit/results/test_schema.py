"""The results follow their typed schema (validate/results/schema.py): every key a producer writes
is declared there, and every required key is written, for a passing and for a failing derivation."""

from __future__ import annotations

from typing import Any

import pytest
from lagrange_xval import systems
from lagrange_xval.results import provenance
from lagrange_xval.results.schema import (
    ComparisonRow,
    Derivation,
    Mismatch,
    ModelChecks,
    Pointwise,
    Provenance,
    SystemResult,
    TermRow,
)
from lagrange_xval.stages import pipeline

from ...mutations import MUTATIONS, load_mutated


def _keys_match(kind: Any, value: dict[str, Any], where: str) -> list[str]:
    declared = kind.__required_keys__ | kind.__optional_keys__
    problems = [f"{where}: undeclared key {k!r}" for k in value if k not in declared]
    problems += [f"{where}: missing required key {k!r}" for k in kind.__required_keys__ if k not in value]
    return problems


def _check(result: dict[str, Any]) -> list[str]:
    out = _keys_match(SystemResult, result, "system")
    out += _keys_match(ModelChecks, result["model_checks"], "model_checks")
    for m in result["model_checks"]["mismatches"]:
        out += _keys_match(Mismatch, m, "mismatch")
    out += _keys_match(Pointwise, result["pointwise"], "pointwise")
    for r in result["pointwise"]["rows"]:
        out += _keys_match(ComparisonRow, r, "pointwise row")
    out += _keys_match(Derivation, result["derivation"], "derivation")
    for r in result["derivation"]["terms"]:
        out += _keys_match(TermRow, r, "term row")
    return out


@pytest.fixture(scope="module")
def simple():
    return pipeline.run_system(systems.load("simple_pendulum"), n_states=50, seed=0, n_probes=1)


def test_a_passing_system_follows_the_schema(simple):
    assert simple["passed"]
    assert not _check(simple), "\n".join(_check(simple))


def test_a_failing_derivation_follows_the_schema():
    m = next(m for m in MUTATIONS if m.system == "simple_pendulum" and "gravity sign" in m.kinds)
    system = systems.load(m.system).derive(equations=load_mutated(m))
    result = pipeline.run_system(system, n_states=50, seed=0, n_probes=1)
    assert not result["passed"] and result["derivation"]["verdict"] == "disagrees"
    assert not _check(result), "\n".join(_check(result))


def test_provenance_is_one_block():
    assert not _keys_match(Provenance, dict(provenance(3)), "meta")


def test_the_check_can_fail():
    """A producer that writes an undeclared key is caught."""
    assert _keys_match(Pointwise, {"passed": True, "n_states": 1, "seed": 0, "rows": [], "extra": 1}, "p") == [
        "p: undeclared key 'extra'"
    ]

"""The scaling study of generated n-link chains (issue 14): every source agrees within the tiers at
small n, planar and spatial; the symbolic derivation's size grows much faster than the chain (an
operation count, not a clock); the study stops the symbolic source where its derivation would
exceed the budget and says so; the generated models are valid and removed afterwards."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest
from lagrange_xval.studies import chains
from lagrange_xval.systems import System


@pytest.fixture(scope="module")
def small():
    return chains.run_chains(ns=(2, 3, 4), n_states=50, repeats=1)


def test_every_source_agrees_on_small_chains(small):
    assert [(r["kind"], r["n"]) for r in small["rows"]] == [(k, n) for k in ("planar", "spatial") for n in (2, 3, 4)]
    for row in small["rows"]:
        assert row["all_within_tiers"], {k: v for k, v in row["worst_scaled"].items()}
        assert set(row["per_state_s"]) == {"mujoco", "pinocchio", "symbolic"}
        assert all(t > 0 for src in row["per_state_s"].values() for t in src.values())
        assert any(k.endswith("pinocchio~symbolic") for k in row["worst_scaled"])


def test_the_symbolic_size_grows_faster_than_the_square_of_the_chain(small):
    for kind in ("planar", "spatial"):
        ops = {r["n"]: r["symbolic"]["ops_M_Cv"] for r in small["rows"] if r["kind"] == kind}
        assert ops[4] / ops[2] > 4**2 / 2**2, ops  # the engines' algorithms are O(n); the closed form is not


def test_the_symbolic_source_stops_where_the_budget_would_be_exceeded(monkeypatch):
    monkeypatch.setitem(chains.SYMBOLIC_BUDGET, "quick", 0.05)
    result = chains.run_chains(quick=True, ns=(2, 6), n_states=10, repeats=1)
    for kind in ("planar", "spatial"):
        assert result["symbolic_stopped_at"][kind]["n"] in (2, 6)
        assert "budget" in result["symbolic_stopped_at"][kind]["why"]
    last = [r for r in result["rows"] if r["n"] == 6]
    assert all("symbolic" not in r["per_state_s"] for r in last)
    assert all(r["all_within_tiers"] for r in result["rows"])


@pytest.mark.parametrize("kind", ["planar", "spatial"])
def test_generated_chains_are_valid_models(kind):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "c.xml"
        path.write_text(chains.chain_mjcf(30, kind))
        system = System.model_only(path)
        assert system.nv == 30 and len(system.bodies) == 30


def test_the_report_shows_the_study(small):
    """Rendered from the study's own results: the plots, the slopes, where the symbolic source runs."""
    from lagrange_xval.report.chains import section_chains
    from lagrange_xval.report.document import Document

    doc = Document()
    section_chains(doc, small)
    assert set(doc.images) == {"img/chains_planar.png", "img/chains_spatial.png"}
    assert all(png.startswith(b"\x89PNG") for png in doc.images.values())
    text = repr(doc.blocks)
    assert "Every source agrees within the tiers at every n." in text
    assert "The symbolic derivation's cost" in text
    empty = Document()
    section_chains(empty, None)
    assert "bench --chains" in repr(empty.blocks)

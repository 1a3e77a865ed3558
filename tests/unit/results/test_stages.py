"""Every stage's cost on record: results.json's per-system `stages` holds each stage's wall seconds
(the verdict's model checks, pointwise, probes and terms; the printed forms, equivalence, derived
equations; each source's trajectory, the reference and the error estimates; experiments, chaos, the
audit), a stage not run says why, and the report folds them into one table."""

from __future__ import annotations

import pytest
from lagrange_xval.report.document import Document, to_plain
from lagrange_xval.report.render import render_markdown
from lagrange_xval.report.timing import TIMING, section_timing
from lagrange_xval.results.stages import Clock, outcome, records, seconds_of, stage_line
from lagrange_xval.stages import pipeline
from lagrange_xval.systems import load

VERDICT = ("model checks", "pointwise", "probes", "terms")
AFTER = ("equivalence", "derived equations", "experiments", "chaos", "audit", "estimates")
RUNS = ("trajectories: reference", "trajectories: hand", "trajectories: mujoco", "trajectories: pinocchio")


@pytest.fixture(scope="module")
def result():
    return pipeline.run_system(load("simple_pendulum"), n_states=50, seed=0, n_probes=1, t_end=1.0, dt_out=0.01)


def test_every_stage_of_a_run_has_its_wall_seconds(result):
    stages = result["stages"]
    missing = [name for name in (*VERDICT, *AFTER, *RUNS) if name not in stages]
    assert not missing, f"stages without a record: {missing}; recorded: {list(stages)}"
    timed = {name: seconds_of(stage) for name, stage in stages.items()}
    assert all(s is not None and s > 0 for s in timed.values()), timed
    assert not [name for name, stage in stages.items() if outcome(stage)], "every stage ran"
    assert list(stages)[:4] == list(VERDICT), "in the order they ran, the verdict first"


def test_a_stage_not_run_says_why_and_has_no_seconds():
    stages = records({"model checks": 0.5}, {"chaos and mirrors": "not run: the derivation disagrees"})
    assert stages == {
        "model checks": {"seconds": 0.5},
        "chaos and mirrors": {"outcome": "not run: the derivation disagrees"},
    }
    assert seconds_of(stages["chaos and mirrors"]) is None and outcome(stages["model checks"]) == ""
    assert outcome("failed: ValueError: x") == "failed: ValueError: x", "results written before stages had seconds"
    assert seconds_of("failed: ValueError: x") is None
    assert stage_line(stages) == "0.50 s: model checks 0.50"


def test_the_clock_adds_a_stage_lapped_twice():
    clock = Clock()
    clock.lap("a")
    clock.lap("b")
    clock.lap("a")
    assert list(clock.seconds) == ["a", "b"] and clock.total == pytest.approx(sum(clock.seconds.values()))


def test_the_report_folds_every_stages_seconds_into_one_table(result):
    results = to_plain({"systems": {"simple_pendulum": result}, "meta": {}, "passed": result["passed"]})
    doc = Document()
    section_timing(doc, results)
    text = render_markdown(doc, results)
    assert text.count("<details>") == 1 and TIMING in text, text[:400]
    rows = {line.split("|")[1].strip(): line for line in text.splitlines() if line.startswith("| ")}
    for stage in (*VERDICT, *RUNS, "audit", "total"):
        assert stage in rows, f"no row for {stage}: {list(rows)}"
    seconds = float(rows["chaos"].split("|")[2])
    assert seconds == pytest.approx(result["stages"]["chaos"]["seconds"], abs=0.006)


def test_results_without_seconds_have_no_timing_table():
    doc = Document()
    section_timing(doc, {"systems": {"old": {"stages": {"chaos": "not run: old results"}}}})
    assert not doc.blocks


def test_the_stages_are_shown_in_the_order_they_run_whatever_the_order_of_the_keys(result):
    """results.json sorts its keys: the table and `run --verbose` put the stages back in running order."""
    shuffled = dict(sorted(result["stages"].items()))
    line = stage_line(shuffled)
    at = [line.index(name) for name in ("model checks", "terms", "trajectories: reference", "audit")]
    assert at == sorted(at), line


def test_bench_run_time_sums_each_stage_over_the_systems_and_takes_the_median(tmp_path):
    """`bench --run-time`'s split: a run's results.json summed per stage over its systems, then the
    median over the repeats (a run without the stage counts 0; results without seconds give none)."""
    import json

    from lagrange_xval.studies.bench.ratios import median_stages, stage_seconds

    path = tmp_path / "results.json"
    path.write_text(
        json.dumps(
            {
                "systems": {
                    "a": {"stages": {"chaos": {"seconds": 1.0}, "terms": {"seconds": 0.5}}},
                    "b": {"stages": {"chaos": {"seconds": 2.0}, "printed forms": {"outcome": "not run: x"}}},
                    "old": {"stages": {"chaos": "failed: ValueError"}},
                }
            }
        )
    )
    assert stage_seconds(path) == {"chaos": 3.0, "terms": 0.5}
    assert stage_seconds(tmp_path / "none.json") == {}
    assert median_stages([{"chaos": 3.0, "terms": 0.5}, {"chaos": 1.0}, {"chaos": 2.0, "terms": 0.1}]) == {
        "chaos": 2.0,
        "terms": 0.1,
    }


def test_a_stored_references_window_check_runs_the_checked_trace_and_agrees_with_the_module():
    """Reading a cached reference re-integrates every window with the hand equations' traced code (checked
    against the module first): it gives the module's accelerations, to rounding."""
    import numpy as np
    from lagrange_xval.dynamics import reference
    from lagrange_xval.sources.hand import HandSource
    from lagrange_xval.verdict.pointwise import random_states

    system = load("double_pendulum_point")
    states = random_states(system, n=200, seed=3)
    u = np.zeros_like(states.q)
    f = reference._window_rhs(system, u)
    assert f.__name__ == "compiled"
    y = np.hstack([states.q, states.v])
    module = HandSource(system).forward(states.q, states.v, u)
    assert np.allclose(f(y)[:, system.nv :], module, rtol=1e-12, atol=1e-12)
    assert np.array_equal(f(y)[:, : system.nv], states.v)

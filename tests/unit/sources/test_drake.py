"""Drake as a fifth source (issue 29): a third, independent reader of every model (its own MJCF or URDF
parser), within the tolerance tiers of MuJoCo and Pinocchio on every repository system and example;
what Drake reads differently is listed as an alignment; a missing pydrake is a stated skip."""

from __future__ import annotations

import importlib.util
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from lagrange_xval.cli import parser as cli_parser
from lagrange_xval.dynamics import drakerun, estimate, fast, freeruns, integrate
from lagrange_xval.dynamics.reference import reference_trajectory
from lagrange_xval.model.start import Start
from lagrange_xval.sources import drake as drake_engine
from lagrange_xval.sources import make_sources
from lagrange_xval.studies.bench import runners
from lagrange_xval.studies.bench.plan import CONTENDER_DRIVERS, FULL, GRID_DRIVERS, QUICK
from lagrange_xval.systems import System, load, system_names
from lagrange_xval.verdict import pointwise
from lagrange_xval.verdict.decide import decide

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = sorted(ROOT.glob("examples/*.xml"))
HAS_DRAKE = importlib.util.find_spec("pydrake") is not None
needs_drake = pytest.mark.skipif(not HAS_DRAKE and os.environ.get("CI") != "true", reason="pydrake not installed")


def _systems() -> list[System]:
    return (
        [load(n) for n in system_names()]
        + [System.from_files(p, p.with_suffix(".py")) for p in EXAMPLES]
        + [System.from_files(ROOT / "examples/urdf/spatial_arm.urdf", ROOT / "examples/spatial_arm.py")]
    )


def test_pydrake_is_importable_under_ci():
    """CI installs requirements.lock, which pins drake: there the source must exist, never be skipped."""
    if os.environ.get("CI") == "true":
        assert HAS_DRAKE, "pydrake is not importable under CI (requirements.lock pins drake==1.51.1)"


def test_a_missing_pydrake_is_a_stated_skip(monkeypatch):
    """Without pydrake the other sources run and the model checks say why Drake is absent."""
    monkeypatch.setattr(drake_engine, "unavailable", lambda: "pydrake is not installed (test)")
    system = load("simple_pendulum")
    sources = make_sources(system)
    assert "drake" not in sources and "pydrake is not installed" in sources.skipped["drake"]
    decision = decide(system, n_states=20, seed=0, probes=0)
    assert any(a.startswith("Drake left out: ") for a in decision.model_checks["alignments"])


@needs_drake
@pytest.mark.parametrize("system", _systems(), ids=lambda s: f"{s.name}-{s.model_format}")
def test_drake_agrees_with_mujoco_and_pinocchio_on_every_system(system):
    """Every pair with Drake within its tier at 200 seeded states, every quantity."""
    sources = make_sources(system)
    assert "drake" in sources, sources.skipped
    result = pointwise.pointwise(system, n=200, seed=0, sources=sources)
    rows = [r for r in result["rows"] if "drake" in r["pair"]]
    assert {r["pair"] for r in rows} >= {"drake~mujoco", "drake~pinocchio"}
    bad = [(r["quantity"], r["pair"], r["scaled"], r["tolerance"]) for r in rows if not r["passed"]]
    assert not bad, bad


@needs_drake
def test_the_term_judge_judges_against_drake():
    """The derivation's terms are judged against Drake too (the verdict's hand~drake rows)."""
    decision = decide(load("double_pendulum_point"), n_states=100, seed=0, probes=1)
    rows = [t for t in decision.derivation["terms"] if t["engine"] == "drake"]
    assert {t["term"] for t in rows} >= {"mass matrix", "gravity", "velocity", "kinetic energy", "body positions"}
    assert all(t["passed"] for t in rows) and decision.passed


@needs_drake
def test_what_drake_reads_differently_is_listed():
    """Gravity disabled by an MJCF flag Drake ignores, a URDF's floating root, both named."""
    gimbal = make_sources(load("gimbal"))["drake"].alignments
    assert any("gravity" in a and "set to MuJoCo's" in a for a in gimbal)
    assert any("'flag'" in a for a in gimbal)
    arm = make_sources(System.from_files(ROOT / "examples/urdf/spatial_arm.urdf", ROOT / "examples/spatial_arm.py"))
    text = "\n".join(arm["drake"].alignments)
    assert "root link 'base' welded to the world" in text and "URDF states no gravity" in text


@needs_drake
def test_coordinates_are_mapped_by_joint_name():
    """Drake's q index of each joint is its own position_start, whatever order the file declares."""
    system = System.from_files(ROOT / "examples/spatial_arm.xml", ROOT / "examples/spatial_arm.py")
    source = make_sources(system)["drake"]
    for j, i in zip(system.joints, source.qidx, strict=True):
        assert source.plant.GetJointByName(j).position_start() == i


@needs_drake
@pytest.mark.parametrize("name", ["simple_pendulum", "double_pendulum_point"])
def test_drakes_free_run_agrees_with_the_reference_within_its_own_threshold(name):
    """Drake's own integrator (RK3 at DRAKE_DEFAULT's accuracy) on its continuous plant, 10 s, against the
    long-double reference, within max(1e-6, 10 x its own estimate) at every sample."""
    system = load(name)
    sources = make_sources(system)
    q0, v0 = integrate.initial_state(system)
    tau, t = np.zeros(system.nv), integrate.time_grid(10.0, 0.01)
    ref, _ = reference_trajectory(system, Start.of(q0, v0, tau), t, cache_dir=None)
    run = drakerun.drake_trajectory(system, sources["drake"], Start.of(q0, v0, tau), t)
    assert run.source == "drake" and run.method == "Drake runge_kutta3 accuracy 1e-08" and run.stats["status"] == "ok"
    est, how = estimate.run_estimate(system, sources, run, Start.of(q0, v0, tau))
    assert "against 1e-09" in how
    err = np.abs(run.q - ref.q).max(axis=1)
    assert np.all(err <= estimate.threshold(est)), float(err.max())
    assert 1e-12 < err.max() < 1e-6  # a real integration, and accurate


@needs_drake
def test_drakes_information_only_run_is_made_only_on_request():
    """`run --drake-run` asks for Drake's free run (not judged, so not computed unless asked): without it the
    free runs are the judged ones alone, and no estimate is computed for a run that is not there."""
    system = load("simple_pendulum")
    traj = freeruns.trajectory_results(system, make_sources(system), t_end=0.5, dt_out=0.01)
    assert "drake" not in {r["source"] for r in traj["runs"]}
    assert {"hand", "mujoco", "pinocchio"} <= {r["source"] for r in traj["runs"]}
    args = cli_parser.build_parser().parse_args(["run", "--drake-run"])
    assert args.drake_run and not cli_parser.build_parser().parse_args(["run"]).drake_run


@needs_drake
def test_drakes_run_is_among_runs_free_runs():
    """`run --drake-run`'s free runs hold Drake's, measured against the reference and within its own threshold here, but
    shown as information (its error-controlled integrator's estimate is not a bound: freeruns.DRAKE_NOT_JUDGED)."""
    system = load("double_pendulum_point")
    traj = freeruns.trajectory_results(system, make_sources(system), t_end=2.0, dt_out=0.01, drake_run=True)
    freeruns.judge_trajectories(traj, None)
    drake = [r for r in traj["runs"] if r["source"] == "drake"]
    assert len(drake) == 1 and not drake[0]["counts"] and drake[0]["why_not_counted"] == freeruns.DRAKE_NOT_JUDGED
    assert drake[0]["estimate_how"].startswith("Drake runge_kutta3")
    assert drake[0]["first_exceeds_threshold"] is None and drake[0]["max_error_vs_hand"] < 1e-6


def test_no_drake_run_without_the_drake_source(monkeypatch):
    monkeypatch.setattr(drake_engine, "unavailable", lambda: "pydrake is not installed (test)")
    system = load("simple_pendulum")
    runs = fast.run_trajectories(system, make_sources(system), t_end=0.1, dt_out=0.01)
    assert "drake" not in {r.source for r in runs}


@needs_drake
def test_bench_times_drakes_integrators():
    """Drake's integrators are contenders of the quick sweep; one runs, timed, with its samples."""
    specs = [s for s in QUICK.specs() if s["engine"] == "drake"]
    assert {s["scheme"] for s in specs} == {"runge_kutta3", "runge_kutta2", "explicit_euler"}
    assert "drake" in CONTENDER_DRIVERS and "drake" in GRID_DRIVERS
    case = runners.case_for(load("simple_pendulum"), FULL)
    spec = next(s for s in specs if s["scheme"] == "runge_kutta3" and s["value"] == 1e-8)
    row = runners.execute(spec, case, plan=replace(FULL, budget=5.0, min_timed=0.0))
    assert row["status"] == "ok" and row["cpu_s"] > 0 and row["steps"] > 1000
    ref, _ = reference_trajectory(
        load("simple_pendulum"), Start.of(case["q0"], case["v0"], case["tau"]), row["t"], cache_dir=None
    )
    assert np.abs(row["q"] - ref.q).max() < 1e-6
    fixed = next(s for s in specs if s["scheme"] == "runge_kutta2" and s["value"] == 1e-3)
    assert (
        10_000 <= runners.execute(fixed, case, plan=replace(FULL, budget=5.0, min_timed=0.0))["steps"] <= 11_000
    )  # + end-of-sample steps

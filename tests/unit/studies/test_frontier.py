"""The benchmark's frontier contenders (heyoka's Taylor integrator in double precision, the compiled
right-hand side and compiled RK4 steps, MuJoCo's rollout) compute what they claim, and the ratio of
the default path to the fastest method picks the right runs. No assertion here is about time."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.dynamics import compiled
from lagrange_xval.dynamics.integrate import time_grid
from lagrange_xval.dynamics.mirror import mirror_trajectory
from lagrange_xval.model.start import Start
from lagrange_xval.sources.fastpath import scalar_rhs
from lagrange_xval.studies import bench
from lagrange_xval.studies.bench import FULL, QUICK
from lagrange_xval.studies.bench.analysis import errors_against

DP = "double_pendulum_point"


@pytest.fixture(scope="module")
def prepared():
    return bench.prepare(DP, FULL)


def _errors(res, ref):
    assert res["status"] == "ok", res
    return errors_against(
        res["t"], res["q"], ref["t"], ref["q"], window=ref["horizon_window_s"], tolerance=FULL.horizon_tolerance
    )


def test_taylor_in_double_meets_its_tolerance_and_a_tighter_one_errs_less(prepared):
    """Against the long-double reference: tol 1e-12 is within 1e-10 rad at 2 s and 10 s, tol 1e-6
    errs more than tol 1e-12 at both times (the tolerance governs the error)."""
    case = prepared["case"]
    loose = _errors(
        bench.execute(bench.taylor_spec(1e-6), case, plan=replace(FULL, budget=30.0, min_timed=0.0)), prepared
    )
    tight = _errors(
        bench.execute(bench.taylor_spec(1e-12), case, plan=replace(FULL, budget=30.0, min_timed=0.0)), prepared
    )
    assert tight["error_2s"] < 1e-10 and tight["error_10s"] < 1e-10, tight
    assert loose["error_2s"] > 10 * tight["error_2s"] and loose["error_10s"] > 10 * tight["error_10s"]


def test_taylor_stopped_by_its_step_budget_is_not_ok():
    """A step budget too small for the grid ends as "failed" with heyoka's word, never as samples."""
    system = systems.load(DP)
    ta = compiled.taylor_integrator(system, 1e-9)
    outcome, states, steps = compiled.taylor_grid(
        ta, Start.of([3.0, 0.0], [0.0, 0.0], [0.0, 0.0]), time_grid(10.0, 0.01), max_steps=5
    )
    assert outcome != "ok" and steps <= 5
    assert np.isnan(states[-1]).all()


def test_the_compiled_rhs_is_the_hand_equations():
    """heyoka's cfunc of the traced equations equals the generated `math` fast path at random states."""
    system = systems.load(DP)
    cf, fast = compiled.compiled_rhs(system), scalar_rhs(system)
    rng = np.random.default_rng(1)
    for _ in range(50):
        y, tau = rng.uniform(-3, 3, 4), rng.uniform(-1, 1, 2)
        a, b = np.asarray(cf(0.0, y, tau)), np.asarray(fast(0.0, y, list(tau)))
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)


def test_compiled_rk4_is_the_rk4_mirror_up_to_rounding():
    """The compiled RK4 steps (10 per call) and the Python RK4 mirror on the hand equations take the
    same steps: over 1 s at 1 ms they agree to 1e-11 rad, far below RK4's own error there."""
    system, sources = bench.resources(DP)
    t = time_grid(1.0, 0.01)
    q0, v0, tau = np.array([3.0, 0.0]), np.zeros(2), np.zeros(2)
    per_call, calls = compiled.rk4_plan(0.01, 1e-3)
    assert (per_call, calls) == (10, 1)
    status, states = compiled.rk4_grid(
        compiled.compiled_rk4(system, per_call), calls, Start.of(q0, v0, tau), t, timestep=1e-3
    )
    mirror = mirror_trajectory(system, sources["hand"], Start.of(q0, v0, tau), t, integrator="RK4", timestep=1e-3)
    assert status == "ok"
    assert np.abs(states[:, :2] - mirror.q).max() < 1e-11
    coarse = compiled.rk4_grid(compiled.compiled_rk4(system, 1), 1, Start.of(q0, v0, tau), t, timestep=1e-2)[1]
    assert np.abs(coarse[:, :2] - mirror.q).max() > 1e-8  # the comparison can tell another timestep


def test_compiled_rk4_stops_at_its_deadline_and_on_blow_up():
    system = systems.load(DP)
    cf = compiled.compiled_rk4(system, 1)
    t = time_grid(10.0, 0.01)
    zero = np.zeros(2)
    assert (
        compiled.rk4_grid(cf, 10, Start.of([3.0, 0.0], zero, zero), t, timestep=1e-3, deadline=time.perf_counter())[0]
        == "timeout"
    )
    assert compiled.rk4_grid(cf, 1, Start.of([3.0, 0.0], [1e200, 0.0], zero), t, timestep=1e-2)[0] == "diverged"


@pytest.mark.parametrize("batch", [1, 3])
def test_rollout_gives_the_stepping_loop_bit_for_bit(batch):
    """MuJoCo's rollout (one or a batch of copies) and the mj_step loop of `run_mujoco` give the same bits."""
    system, _ = bench.resources(DP)
    case = dict(bench.case_for(system, FULL), t_end=1.0)
    loop = bench.execute(
        bench.step_spec("mujoco", "mujoco", "RK4", 1e-3), case, plan=replace(FULL, budget=30.0, min_timed=0.0)
    )
    driver = "rollout" if batch == 1 else "rollout_batch"
    rolled = bench.execute(
        bench.step_spec("mujoco", driver, "RK4", 1e-3, batch=batch if batch > 1 else None),
        case,
        plan=replace(FULL, budget=30.0, min_timed=0.0),
    )
    assert rolled["status"] == loop["status"] == "ok", rolled
    assert rolled["digest"] == loop["digest"]
    assert np.array_equal(rolled["q"], loop["q"])


def test_every_contender_is_in_both_plans_and_named():
    for plan in (QUICK, FULL):
        drivers = {s["driver"] for s in plan.specs()}
        assert {"taylor", "compiled_rk4", "rollout", "rollout_batch", "odeint", "default"} <= drivers, plan.quick
        engines = {s["engine"] for s in plan.specs()}
        assert "hand-cfunc" in engines
    full = FULL.specs()
    for engine in ("hand", "symbolic"):
        tols = sorted(s["value"] for s in full if s["driver"] == "taylor" and s["engine"] == engine)
        assert tols[0] == pytest.approx(1e-16, rel=1e-9) and tols[-1] == pytest.approx(1e-6, rel=1e-9), engine
        assert len(tols) == 11, engine
    assert len({s["method"] for s in full}) == len({(s["engine"], s["driver"], s["scheme"]) for s in full})


def _row(method, driver, engine, value, cpu, err, status="ok"):
    return {
        "system": "s", "method": method, "engine": engine, "driver": driver, "setting": "rtol", "value": value,
        "status": status, "cpu_s": cpu, "wall_s": cpu, "error_2s": err, "error_10s": err,
    }  # fmt: skip


def test_frontier_ratio_compares_the_default_path_with_the_fastest_at_equal_error():
    rows = [
        _row("hand odeint", "odeint", "hand", 1e-6, 2.0, 5e-7),
        _row("hand odeint", "odeint", "hand", 1e-9, 4.0, 5e-10),
        _row("hand default", "default", "hand", 1e-11, 5.0, 2e-11),
        _row("taylor", "taylor", "hand", 1e-9, 0.5, 1e-10),
        _row("taylor", "taylor", "hand", 1e-12, 1.0, 1e-13),
        _row("ode 2 outputs", "ode_endpoints", "hand", 1e-3, 0.01, 1e-14),  # not the whole grid
        _row("rk4", "compiled_rk4", "hand", 1e-3, 0.1, 1e-7, status="diverged"),  # failed runs never count
    ]
    out = bench.frontier_ratios(rows, (1e-6, 1e-9, 1e-12))["per_system"]["s"]
    by_eps = {e["epsilon"]: e for e in out}
    assert by_eps[1e-6]["default_path"]["value"] == 1e-6 and by_eps[1e-6]["fastest"]["method"] == "taylor"
    assert by_eps[1e-6]["ratio"] == pytest.approx(4.0)
    assert by_eps[1e-9]["ratio"] == pytest.approx(8.0)
    assert by_eps[1e-9]["fastest_contender"]["value"] == 1e-9
    assert by_eps[1e-12]["default_path"] is None and by_eps[1e-12]["ratio"] is None
    assert by_eps[1e-12]["fastest"]["value"] == 1e-12


def test_the_report_names_the_fastest_method_at_each_eps():
    from lagrange_xval.report.document import Document
    from lagrange_xval.report.studies import frontier_section

    rows = [
        _row("hand odeint", "odeint", "hand", 1e-9, 4.0, 5e-10),
        _row("hand heyoka Taylor (double)", "taylor", "hand", 1e-9, 0.5, 1e-10),
    ]
    doc = Document()
    frontier_section(doc, bench.frontier_ratios(rows, (1e-9, 1e-12)))
    (table,) = doc.blocks
    assert [r[:2] for r in table.rows] == [("s", "1e-9"), ("s", "1e-12")]
    assert table.rows[0][2].startswith("hand heyoka Taylor (double)") and table.rows[0][4] == "8.0x"
    assert table.rows[1][2] == "not reached" and table.rows[1][4] == "no run reaches eps"


@pytest.mark.parametrize("name", [DP, "double_pendulum_absolute"])
def test_taylor_on_the_derived_equations_follows_the_hand_reference(name):
    """heyoka's Taylor method on the symbolic source (joint coordinates; the absolute-angle pendulum's
    JOINT_MAP applied on the way in and out) stays within 1e-9 rad of the hand equations' reference at
    2 s; with a wrong JOINT_MAP handling the coordinates would differ by radians."""
    ref = bench.prepare(name, FULL)
    res = bench.execute(
        bench.taylor_spec(1e-12, "symbolic"), ref["case"], plan=replace(FULL, budget=30.0, min_timed=0.0)
    )
    assert res["status"] == "ok", res
    err = errors_against(
        res["t"], res["q"], ref["t"], ref["q"], window=ref["horizon_window_s"], tolerance=FULL.horizon_tolerance
    )
    assert err["error_2s"] < 1e-9, err

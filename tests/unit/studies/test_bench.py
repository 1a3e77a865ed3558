"""The benchmark's data: work-precision rows, statuses for runs that fail, Pareto fronts, time to eps,
the hand-written comparison formulas, and bench.json. No assertion here is about how long anything takes."""

from __future__ import annotations

import json
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from dataclasses import replace

import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.sources import make_sources
from lagrange_xval.sources.fastpath import scalar_rhs
from lagrange_xval.studies import bench
from lagrange_xval.studies.bench import FULL, QUICK
from lagrange_xval.verdict import pointwise as compare

ROW_KEYS = {
    "system", "method", "engine", "driver", "scheme", "setting", "value", "atol", "status", "message", "error_2s",
    "error_10s", "error_horizon", "t_exceeds_tolerance", "cpu_s", "wall_s", "cpu_s_repeats", "wall_s_repeats",
    "executions", "nfev", "steps", "deterministic",
}  # fmt: skip
DP = "double_pendulum_point"


def _specs(methods, rtols):
    specs = [bench.scipy_spec("hand", "solve_ivp", m, r, atol_factor=FULL.atol_factor) for m in methods for r in rtols]
    for s in specs:
        s["method"] = bench.method_name(s)
    return specs


def _dominates(a, b, error):
    return a["cpu_s"] <= b["cpu_s"] and a[error] <= b[error] and (a["cpu_s"] < b["cpu_s"] or a[error] < b[error])


@pytest.fixture(scope="module")
def tiny():
    """One system, two methods, two tolerances, two repeats, in a two-process pool."""
    prepared = {DP: bench.prepare(DP, FULL)}
    with ProcessPoolExecutor(max_workers=2) as pool:
        plan = replace(FULL, repeats=2, budget=60.0, min_timed=0.0)
        rows, _ = bench.sweep(prepared, _specs(("DOP853", "RK45"), (1e-4, 1e-8)), plan=plan, executor=pool)
    return rows


def test_tiny_sweep_rows_are_long_format_sorted_and_complete(tiny):
    """Every (method, rtol) has one row with the expected keys, status ok, a median of both repeats."""
    assert len(tiny) == 4
    assert tiny == sorted(tiny, key=bench.sort_key)
    for r in tiny:
        assert set(r) == ROW_KEYS, set(r) ^ ROW_KEYS
        assert r["status"] == "ok", r
        assert r["deterministic"], f"{r['method']} {r['value']}: repeats gave different samples"
        assert len(r["cpu_s_repeats"]) == 2 and r["cpu_s"] == np.median(r["cpu_s_repeats"])
        assert r["atol"] == r["value"] * FULL.atol_factor
        assert r["error_horizon"] >= max(r["error_2s"], r["error_10s"])


def test_tiny_sweep_tighter_rtol_costs_more_and_errs_less(tiny):
    """Per method, the tighter tolerance has smaller errors at 2 s and 10 s and more evaluations."""
    for method in {r["method"] for r in tiny}:
        loose, tight = sorted((r for r in tiny if r["method"] == method), key=lambda r: -r["value"])
        assert tight["error_2s"] < loose["error_2s"], method
        assert tight["error_10s"] < loose["error_10s"], method
        assert tight["nfev"] > loose["nfev"], method


def test_tiny_sweep_pareto_front_is_a_non_dominated_subset(tiny):
    """Each front point is a row, no row dominates it, and every row off the front is dominated by one on it."""
    for error in ("error_2s", "error_10s"):
        front = bench.pareto_front(tiny, error)
        assert front
        keyed = {(r["method"], r["value"]): r for r in tiny}
        for p in front:
            row = keyed[(p["method"], p["value"])]
            assert (p["cpu_s"], p[error]) == (row["cpu_s"], row[error])
            assert not any(_dominates(r, row, error) for r in tiny), (error, p)
        on = {(p["method"], p["value"]) for p in front}
        for r in tiny:
            if (r["method"], r["value"]) not in on:
                assert any(_dominates(keyed[k], r, error) or keyed[k][error] == r[error] for k in on), r


def test_tiny_sweep_time_to_epsilon_matches_the_rows(tiny):
    """The cheapest run of each method reaching eps at 2 s, or "not reached" when none does."""
    table = bench.time_to_epsilon(tiny, FULL.epsilons)
    assert len(table) == 2 * len(FULL.epsilons)
    for e in table:
        runs = [r for r in tiny if r["method"] == e["method"]]
        good = [r for r in runs if r["error_2s"] <= e["epsilon"]]
        if not good:
            assert e["result"] == "not reached" and e["cpu_s"] is None
        else:
            assert e["result"] == "reached"
            assert e["cpu_s"] == min(r["cpu_s"] for r in good)
            assert e["error"] <= e["epsilon"]


def test_pareto_and_epsilon_ignore_runs_that_failed():
    """Rows that diverged or timed out never enter a front or reach an epsilon."""
    rows = [
        {"system": "s", "method": "a", "setting": "rtol", "value": 1e-3, "status": "ok", "cpu_s": 1.0,
         "wall_s": 1.0, "error_2s": 1e-4},
        {"system": "s", "method": "a", "setting": "rtol", "value": 1e-6, "status": "timeout", "cpu_s": 0.1,
         "wall_s": 0.1, "error_2s": None},
        {"system": "s", "method": "b", "setting": "rtol", "value": 1e-6, "status": "diverged", "cpu_s": 0.01,
         "wall_s": 0.01, "error_2s": 1e-12},
        {"system": "s", "method": "b", "setting": "rtol", "value": 1e-3, "status": "ok", "cpu_s": 2.0,
         "wall_s": 2.0, "error_2s": 1e-2},
    ]  # fmt: skip
    assert [(p["method"], p["value"]) for p in bench.pareto_front(rows, "error_2s")] == [("a", 1e-3)]
    reached = {(e["method"], e["epsilon"]): e["result"] for e in bench.time_to_epsilon(rows, FULL.epsilons)}
    assert reached[("a", 1e-3)] == "reached" and reached[("a", 1e-6)] == "not reached"
    assert reached[("b", 1e-3)] == "not reached"


# ----------------------------------------------------------------------------------------------
# Runs that go wrong are recorded, not dropped


def test_mujoco_euler_at_a_huge_timestep_is_diverged():
    """Euler at 0.5 s from 20 rad/s: MuJoCo warns about qacc and resets the state; the run is "diverged"."""
    case = dict(bench.case_for(systems.load(DP), FULL), v0=[20.0, -20.0], dt_out=0.5)
    spec = bench.step_spec("mujoco", "mujoco", "Euler", 0.5)
    res = bench.execute(spec, case, plan=replace(FULL, budget=30.0, min_timed=0.0))
    assert res["status"] == "diverged", res["message"]
    assert "BADQACC" in res["message"]


@pytest.mark.parametrize("driver", ["solve_ivp", "ode", "odeint"])
def test_a_rhs_returning_nan_is_diverged(driver):
    """A right-hand side that returns NaN ends as "diverged" (solve_ivp's RK45 would otherwise loop forever)."""
    t = np.linspace(0.0, 1.0, 11)
    res = bench.run_scipy(
        driver, "RK45", lambda t, y: [math.nan, math.nan], np.array([1.0, 0.0]), t, rtol=1e-6, atol=1e-9,
        deadline=time.perf_counter() + 60.0,
    )  # fmt: skip
    assert res["status"] == "diverged", res


@pytest.mark.parametrize("driver", ["solve_ivp", "ode", "ode_endpoints", "odeint"])
def test_a_run_past_its_budget_is_stopped_as_timeout(driver):
    """The rhs stops the integration once past the deadline (for `ode` by returning NaN, since an
    exception inside its compiled driver crashes the process)."""

    def slow(t, y):
        time.sleep(2e-5)
        return [y[1], -y[0]]

    t = np.linspace(0.0, 10.0, 1001)
    start = time.perf_counter()
    res = bench.run_scipy(
        driver, "DOP853", slow, np.array([1.0, 0.0]), t, rtol=1e-13, atol=1e-16, deadline=start + 0.05
    )
    assert res["status"] == "timeout", res
    assert res["nfev"] < 1e5, "the run went on long after its deadline"


@pytest.mark.parametrize(
    "spec", [bench.step_spec("mujoco", "mujoco", "RK4", 1e-5), bench.step_spec("pinocchio", "mirror", "RK4", 1e-5)]
)
def test_stepping_runs_past_their_budget_are_timeouts(spec):
    res = bench.execute(spec, bench.case_for(systems.load(DP), FULL), plan=replace(FULL, budget=0.02, min_timed=0.0))
    assert res["status"] == "timeout", res


def test_a_timeout_is_kept_and_tighter_settings_are_skipped_not_dropped():
    """With a budget nothing meets, every planned row is still there: timed out or skipped as costlier."""
    prepared = {DP: bench.prepare(DP, FULL)}
    specs = _specs(("Radau",), (1e-9, 1e-10, 1e-11, 1e-12))
    with ThreadPoolExecutor(max_workers=1) as pool:
        rows, _ = bench.sweep(
            prepared,
            specs,
            plan=replace(FULL, repeats=2, budget=0.01, min_timed=0.0),
            executor=pool,
        )
    assert [r["value"] for r in rows] == [1e-9, 1e-10, 1e-11, 1e-12]
    assert rows[0]["status"] == "timeout"
    assert {r["status"] for r in rows} <= {"timeout", "skipped"}
    assert all(r["error_2s"] is None for r in rows)


def test_the_mujoco_model_options_are_restored():
    """A MuJoCo run sets the integrator and timestep it is asked for and puts the model's back."""
    system, sources = bench.resources(DP)
    m = sources["mujoco"].m
    before = (m.opt.integrator, m.opt.timestep)
    bench.execute(
        bench.step_spec("mujoco", "mujoco", "Euler", 1e-2),
        bench.case_for(system, FULL),
        plan=replace(FULL, budget=30.0),
    )
    assert (m.opt.integrator, m.opt.timestep) == before


# ----------------------------------------------------------------------------------------------
# The ratios compare like with like


def test_hand_math_rhs_equals_the_fast_path():
    """The hand-written scalar formula (eqs 33-34 with I1, I2, Cramer's rule) is the fast path's formula."""
    system = systems.load(DP)
    fast, hand = scalar_rhs(system), bench.hand_math_rhs(system.params)
    numpy_rhs = bench.numpy_solve_rhs(system.params)
    rng = np.random.default_rng(3)
    for _ in range(1000):
        y = np.concatenate([rng.uniform(-np.pi, np.pi, 2), rng.uniform(-10, 10, 2)])
        a, b, c = np.array(fast(0.0, y, [0.0, 0.0])), np.array(hand(0.0, y)), numpy_rhs(0.0, y)
        scale = np.abs(a).max()
        assert np.abs(a - b).max() <= 1e-13 * scale, (y, a, b)
        assert np.abs(a - c).max() <= 1e-13 * scale, (y, a, c)


def test_hand_math_rhs_keeps_every_parameter():
    """At unequal masses and lengths and large bob inertias (where dropping I1, I2 or assuming m1 == m2
    shows), the hand-written formula equals the equations module's numpy solve."""
    import dataclasses

    system = systems.load(DP)
    p = dataclasses.replace(system.params, m1=1.3, m2=0.7, l1=0.9, l2=1.2, g=9.7, I1=0.3, I2=0.2)
    hand, eq = bench.hand_math_rhs(p), system.equations
    rng = np.random.default_rng(6)
    q, v = rng.uniform(-np.pi, np.pi, (200, 2)), rng.uniform(-10, 10, (200, 2))
    expected = np.linalg.solve(eq.mass_matrix(p, q), -eq.bias(p, q, v)[..., None])[..., 0]
    got = np.array([hand(0.0, np.concatenate([q[i], v[i]]))[2:] for i in range(200)])
    assert np.abs(got - expected).max() <= 1e-13 * np.abs(expected).max()


def test_raw_pointwise_loops_give_the_harness_values_bit_for_bit(system):
    """The raw engine loops the pointwise ratio is measured against compute exactly what the harness does."""
    sources = make_sources(system)
    states = compare.random_states(system, n=20, seed=4)
    harness, raw = compare.evaluate(sources, states), bench.raw_pointwise(system, sources, states)
    for src in ("hand", "mujoco", "pinocchio"):
        for key, value in harness[src].items():
            mine = raw[src][key]
            if isinstance(mine, dict):  # the equations module's per-body dicts, as the harness stacks them
                mine = np.stack([mine[b] for b in system.bodies], axis=-2 if key == "body_positions" else -3)
            assert np.array_equal(np.asarray(value), np.asarray(mine)), f"{system.name} {src} {key}"


def test_default_ratio_names_the_runs_that_would_pass():
    rows = [
        {"system": DP, "method": "hand default scipy_trajectory", "engine": "hand", "driver": "default",
         "value": 1e-12, "atol": 1e-12, "status": "ok", "cpu_s": 3.0, "error_2s": 1e-11},
        {"system": DP, "method": "hand odeint", "engine": "hand", "driver": "odeint", "value": 1e-11,
         "atol": 1e-14, "status": "ok", "cpu_s": 1.0, "error_2s": 5e-10},
        {"system": DP, "method": "hand solve_ivp DOP853", "engine": "hand", "driver": "solve_ivp", "value": 1e-10,
         "atol": 1e-13, "status": "ok", "cpu_s": 1.4, "error_2s": 8e-10},
        {"system": DP, "method": "hand solve_ivp RK45", "engine": "hand", "driver": "solve_ivp", "value": 1e-6,
         "atol": 1e-9, "status": "ok", "cpu_s": 0.1, "error_2s": 1e-6},
    ]  # fmt: skip
    out = bench.default_ratio(rows, FULL)
    assert out["value"] == 3.0 and out["passed"] is False
    assert [w["method"] for w in out["would_pass"]] == ["hand odeint", "hand solve_ivp DOP853"]


# ----------------------------------------------------------------------------------------------
# bench.json


def test_bench_json_is_valid_json_and_written_atomically(tmp_path, monkeypatch):
    """bench.json is strict JSON (inf/nan as strings); a failed write leaves the previous file whole."""
    results = {"rows": [{"cpu_s": 0.5, "error_2s": float("inf")}], "ratios": {}, "n": np.int64(3)}
    path = bench.write_bench(results, tmp_path)
    assert json.loads(path.read_text()) == {"rows": [{"cpu_s": 0.5, "error_2s": "inf"}], "ratios": {}, "n": 3}
    before = path.read_text()

    def fail(src, dst, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(HarnessError, match="bench.json: No space left on device"):
        bench.write_bench({"rows": [1, 2, 3]}, tmp_path)
    monkeypatch.undo()
    assert path.read_text() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bench.json"], "a temporary file was left behind"
    with pytest.raises(TypeError):  # not serialisable: fails before anything is written
        bench.write_bench({"rows": [object()]}, tmp_path)
    assert path.read_text() == before


def test_unknown_system_and_bad_repeats_are_one_line_errors():
    with pytest.raises(HarnessError, match="Did you mean 'double_pendulum_point'"):
        bench.run_bench(["double_pendulum_pointt"], plan=QUICK)
    with pytest.raises(HarnessError, match="repeats"):
        bench.run_bench([DP], plan=replace(QUICK, repeats=0))


def test_run_time_is_judged_on_the_warm_median_and_states_fresh_beside_it(monkeypatch, capsys):
    """`bench --run-time` passes or fails on the warm cache's median against the 5 s target alone, and
    prints the fresh machine's and the cold cache's medians beside it with each condition's stages."""
    from lagrange_xval.studies.bench import output

    def fake(warm: float) -> dict:
        medians = {"fresh machine": 30.0, "cold cache": 12.0, "warm cache": warm}
        return {
            "target": FULL.run_warm_target_s,
            "passed": warm <= FULL.run_warm_target_s,
            "median_s": medians,
            "wall_s_all": {c: [m] for c, m in medians.items()},
            "cpu_s_all": {c: [m] for c, m in medians.items()},
            "stages_s": {c: {"chaos": 1.0, "pointwise": 0.5} for c in medians},
            "exit_codes": [0, 0, 0],
        }

    assert FULL.run_warm_target_s == 5.0
    monkeypatch.setattr(output, "run_wall_times", lambda plan: fake(4.0))
    assert output.run_time_command(FULL) == 0
    text = capsys.readouterr().out
    assert "meets the target (warm <= 5 s): warm 4.0 s (fresh machine 30.0 s, cold cache 12.0 s" in text
    assert "stages, s summed over the systems: chaos 1.0, pointwise 0.5" in text
    monkeypatch.setattr(output, "run_wall_times", lambda plan: fake(5.5))
    assert output.run_time_command(FULL) == 1
    assert "MISSES the target (warm <= 5 s): warm 5.5 s" in capsys.readouterr().out

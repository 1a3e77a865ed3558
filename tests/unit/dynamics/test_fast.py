"""The harness's own fast trajectories (dynamics/fast.py, the compiled mirror of RK4) and the bench's
comparison of its checks with the fastest run at their error (studies/bench/checks.py). Nothing here
asserts on time: the ratios are measured by `lagrange-xval bench`."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.dynamics import compiled, fast, integrate, mirror
from lagrange_xval.dynamics.reference import reference_trajectory
from lagrange_xval.model.start import Scheme, Start
from lagrange_xval.sources import make_source, make_sources
from lagrange_xval.sources.hand import HandSource
from lagrange_xval.studies.bench import FULL, checks

from tests.unit.dynamics.test_budgets import FRICTION_SIGN, assert_kept_until_stop, mutated, start


@pytest.mark.parametrize("name", ["double_pendulum_point", "double_pendulum_absolute", "gimbal"])
def test_taylor_trajectories_of_hand_and_derived_equations_follow_the_reference(name):
    """Over 10 s from the notes' start (chaotic for the double pendulums), both fast runs stay within
    1e-11 rad of the long-double reference; the derived one integrates in joint coordinates and comes
    back in the equations' (JOINT_MAP), so a wrong mapping would show as an O(1) error."""
    s = systems.load(name)
    q0, v0, tau = start(s)
    t = integrate.time_grid(10.0, 0.01)
    ref, _ = reference_trajectory(s, Start.of(q0, v0, tau), t)
    sources = make_sources(s)
    for src in ("hand", "symbolic"):
        tr = fast.accurate_trajectory(s, sources[src], Start.of(q0, v0, tau), t)
        assert tr.method.startswith("heyoka Taylor (double)") and tr.source == src, tr.method
        assert tr.stats["status"] == "ok" and tr.stats["stopped_at"] == t[-1], tr.stats
        assert np.abs(tr.q - ref.q).max() < 1e-11 and np.abs(tr.v - ref.v).max() < 1e-10, (src, tr.stats)


def test_a_run_away_derivation_ends_as_a_finding_with_its_samples_kept():
    """The gimbal with friction of the wrong sign speeds up without bound: the Taylor run stops with a
    status and reason (never raises, never hangs), finite up to the stop and NaN after."""
    s = mutated(*FRICTION_SIGN)
    q0, v0, tau = start(s)
    tr = fast.taylor_trajectory(s, "hand", Start.of(q0, v0, tau), integrate.time_grid(10.0, 0.01))
    assert tr.stats["status"] in ("diverged", "stopped: budget"), tr.stats
    assert tr.stats["reason"] and 0 < tr.stats["stopped_at"] < 10.0, tr.stats
    assert_kept_until_stop(tr)


def test_a_smaller_bound_stops_the_run_where_the_state_passes_it():
    s = systems.load("double_pendulum_point")
    q0, v0, tau = start(s)
    t = integrate.time_grid(10.0, 0.01)
    tight = integrate.Budget(max_abs_state=4.0)
    tr = fast.taylor_trajectory(s, "hand", Start.of(q0, v0, tau), t, budget=tight)
    full = fast.taylor_trajectory(s, "hand", Start.of(q0, v0, tau), t)
    k = int(np.argmax((np.abs(np.concatenate([full.q, full.v], axis=1)) > 4.0).any(axis=1)))
    assert 0 < k < len(t) and tr.stats["status"] == "diverged", tr.stats
    assert np.array_equal(tr.q[:k], full.q[:k]) and np.isnan(tr.q[k:]).all()


def test_equations_heyoka_cannot_take_fall_back_to_scipy_and_say_so(monkeypatch):
    def refuse(*args, **kwargs):
        raise TypeError("cannot trace")

    monkeypatch.setattr(fast, "taylor_integrator", refuse)
    s = systems.load("simple_pendulum")
    q0, v0, tau = start(s)
    tr = fast.accurate_trajectory(s, make_source(s, "hand"), Start.of(q0, v0, tau), integrate.time_grid(1.0, 0.01))
    assert tr.method.startswith("scipy odeint") and "cannot trace" in tr.stats["fast_path"], tr.stats
    with pytest.raises(Exception, match="no Taylor trajectory of the 'pinocchio' source"):
        fast.taylor_trajectory(s, "pinocchio", Start.of(q0, v0, tau), integrate.time_grid(1.0, 0.01))


class PlainHand(HandSource):
    """The hand equations through the Python scheme: a subclass is never handed to the compiled steps."""


@pytest.mark.parametrize("name", ["double_pendulum_point", "gimbal"])
def test_the_compiled_mirror_of_rk4_rounds_as_the_python_scheme_does(name):
    """Free run and batched windows: the compiled RK4 (MuJoCo's operation order) against the generated
    Python scheme on the same equations, to a few ulps per window and to chaos-amplified round-off
    over 2 s; and within ROUND_OFF_ULPS of MuJoCo's own windows."""
    s = systems.load(name)
    q0, v0, tau = start(s)
    t = integrate.time_grid(2.0, 0.01)
    hand, plain = make_source(s, "hand"), PlainHand(s)
    a = mirror.mirror_trajectory(s, hand, Start.of(q0, v0, tau), t, integrator="RK4")
    b = mirror.mirror_trajectory(s, plain, Start.of(q0, v0, tau), t, integrator="RK4")
    assert a.method.endswith("(compiled)") and not b.method.endswith("(compiled)")
    assert a.stats["status"] == b.stats["status"] == "ok"
    assert np.abs(a.q - b.q).max() < 1e-11, np.abs(a.q - b.q).max()
    ref, _ = reference_trajectory(s, Start.of(q0, v0, tau), t)
    ulp = np.spacing(np.abs(np.concatenate([ref.q, ref.v], axis=1)).max())
    qa, va = mirror.mirror_steps(s, hand, ref.q[:-1], ref.v[:-1], tau, Scheme("RK4", 1e-3), steps=10)
    qb, vb = mirror.mirror_steps(s, plain, ref.q[:-1], ref.v[:-1], tau, Scheme("RK4", 1e-3), steps=10)
    qm, vm = mirror.mujoco_steps(make_source(s, "mujoco"), ref.q[:-1], ref.v[:-1], tau, Scheme("RK4", 1e-3), steps=10)
    assert max(np.abs(qa - qb).max(), np.abs(va - vb).max()) <= 4 * ulp
    assert max(np.abs(qa - qm).max(), np.abs(va - vm).max()) <= 16 * ulp


def test_the_compiled_mirror_of_a_run_away_derivation_is_diverged_and_kept_up_to_there():
    s = mutated(*FRICTION_SIGN)
    q0, v0, tau = start(s)
    tr = mirror.mirror_trajectory(
        s, make_source(s, "hand"), Start.of(q0, v0, tau), integrate.time_grid(10.0, 0.01), integrator="RK4"
    )
    assert tr.method.endswith("(compiled)"), tr.method
    assert tr.stats["status"] == "diverged" and tr.stats["reason"].startswith("diverged at t ="), tr.stats
    assert_kept_until_stop(tr)


def test_the_compiled_steps_are_refused_for_other_sources_and_integrators():
    s = systems.load("gimbal")
    hand = make_source(s, "hand")
    assert mirror.compiled_steps(hand, "RK4", 10) is not None
    assert mirror.compiled_steps(hand, "Euler", 10) is None
    assert mirror.compiled_steps(PlainHand(s), "RK4", 10) is None
    assert mirror.compiled_steps(make_source(s, "pinocchio"), "RK4", 10) is None
    assert compiled.RK4_B == (1 / 6, 1 / 3, 1 / 3, 1 / 6)


# ----------------------------------------------------------------------------------------------
# The bench's comparison (pure functions on rows; the timing itself is the bench's)


def row(method, engine, driver, setting, value, cpu, err, scheme=None):
    return {
        "system": "s",
        "method": method,
        "engine": engine,
        "driver": driver,
        "scheme": scheme,
        "setting": setting,
        "value": value,
        "cpu_s": cpu,
        "error_2s": err,
        "status": "ok",
    }


ROWS = [
    row("hand heyoka Taylor (double)", "hand", "taylor", "tol", 1e-15, 1e-3, 1e-15),
    row("hand heyoka Taylor (double)", "hand", "taylor", "tol", 1e-9, 2e-4, 1e-10),
    row("symbolic heyoka Taylor (double)", "symbolic", "taylor", "tol", 1e-15, 5e-3, 1e-15),
    row("hand compiled RK4", "hand", "compiled_rk4", "timestep", 1e-3, 4e-3, 1e-10, "RK4"),
    row("mujoco RK4", "mujoco", "mujoco", "timestep", 1e-3, 1e-4, 1e-10, "RK4"),  # other equations: never chosen
    row("mujoco RK4", "mujoco", "mujoco", "timestep", 1e-2, 5e-3, 1e-6, "RK4"),
    row("pinocchio odeint", "pinocchio", "odeint", "rtol", 1e-12, 2e-2, 1e-10),
]


def check(label, engine, kind, cpu, err, timestep=None):
    return {
        "system": "s",
        "check": label,
        "engine": engine,
        "kind": kind,
        "method": label,
        "cpu_s": cpu,
        "error_2s": err,
        "timestep": timestep,
    }


def test_each_check_is_set_against_the_fastest_run_computing_the_same_at_its_error():
    measured = [
        {
            "rows": [
                check("hand accurate", "hand", "accurate", 1.2e-3, 2e-15),  # only Taylor 1e-15 is as accurate
                check("symbolic accurate", "symbolic", "accurate", 6e-3, 2e-15),  # hand rows do not count
                check("mirror", "hand", "scheme", 8e-3, 1e-10, 1e-3),  # RK4 at 1e-3 on the hand equations only
                check("pinocchio", "pinocchio", "accurate", 1e-1, 1e-10),  # 5x: beyond the target
                check("user", "hand", "user", 1e-2, 1e-10),
                check("nothing", "pinocchio", "accurate", 1e-2, 1e-14),  # no Pinocchio run is that accurate
            ]
        }
    ]
    out = checks.checks_ratios(measured, ROWS, target=FULL.checks_target)
    by = {e["check"]: e for e in out["rows"]}
    assert by["hand accurate"]["fastest"]["value"] == 1e-15 and by["hand accurate"]["ratio"] == pytest.approx(1.2)
    assert by["symbolic accurate"]["fastest"]["method"].startswith("symbolic")
    assert by["mirror"]["fastest"]["method"] == "hand compiled RK4" and by["mirror"]["ratio"] == pytest.approx(2.0)
    assert by["pinocchio"]["passed"] is False and by["pinocchio"]["ratio"] == pytest.approx(5.0)
    assert by["user"]["target"] is None and by["user"]["passed"] is None and by["user"]["ratio"] == pytest.approx(50)
    assert by["nothing"]["fastest"] is None and by["nothing"]["why"]
    assert out["passed"] is False and out["value"] == pytest.approx(5.0)  # the worst targeted ratio


def test_a_check_timed_again_beside_its_fastest_run_takes_the_ratio_of_the_pair():
    """Two timings minutes apart carry what else the machine did: the side-by-side pair decides."""
    measured = [{"rows": [check("hand accurate", "hand", "accurate", 3e-3, 2e-15), check("u", "hand", "user", 1, 1)]}]
    first = checks.checks_ratios(measured, ROWS, target=FULL.checks_target)
    assert first["rows"][0]["ratio"] == pytest.approx(3.0) and first["passed"] is False
    pairs = checks.pairs_to_time(first)
    assert list(pairs) == ["s"] and [label for label, _ in pairs["s"]] == ["hand accurate"]  # the user's path: none
    spec = pairs["s"][0][1]
    assert (spec["driver"], spec["engine"], spec["value"]) == ("taylor", "hand", 1e-15)
    again = checks.checks_ratios(
        measured, ROWS, {"s": {"hand accurate": {"cpu_s": 1.1e-3, "fastest_cpu_s": 1e-3}}}, target=FULL.checks_target
    )
    entry = again["rows"][0]
    assert entry["ratio"] == pytest.approx(1.1) and entry["sweep_ratio"] == pytest.approx(3.0)
    assert again["passed"] is True and again["value"] == pytest.approx(1.1)


def test_paired_timings_time_the_check_and_the_sweeps_run_in_one_task():
    from lagrange_xval.studies import bench

    spec = {**bench.taylor_spec(1e-15), "method": "hand heyoka Taylor (double)"}
    out = checks.paired_timings(
        "simple_pendulum", [("hand accurate run", spec)], plan=replace(FULL, budget=60.0), reps=2
    )
    assert set(out) == {"hand accurate run"}
    assert out["hand accurate run"]["cpu_s"] > 0 and out["hand accurate run"]["fastest_cpu_s"] > 0


def test_measure_checks_times_what_run_does_and_measures_its_errors():
    out = checks.measure_checks("gimbal", plan=FULL, reps=1)
    by = {r["check"]: r for r in out["rows"]}
    expected = {"hand accurate run", "hand scipy run (the user's path)", "hand mirror RK4", "pinocchio mirror RK4"}
    assert expected | {"pinocchio scipy run", "symbolic accurate run", "hand mirror RK4 windows"} <= set(by)
    assert all(r["cpu_s"] > 0 and r["status"] == "ok" for r in out["rows"]), out
    assert by["hand accurate run"]["error_2s"] < 1e-13 and by["hand mirror RK4"]["method"].endswith("(compiled)")
    assert by["hand mirror RK4 windows"]["windows_ulps_vs_mujoco"] <= 16

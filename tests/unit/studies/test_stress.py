"""Stress tests of numerical stability: bisection, energy classification, conditioning, stress.json."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.dynamics.integrate import initial_state, mujoco_trajectory
from lagrange_xval.dynamics.mirror import mirror_trajectory
from lagrange_xval.model.start import Scheme, Start
from lagrange_xval.sources import make_sources
from lagrange_xval.studies import stress

EPS = np.finfo(float).eps
_cache: dict[str, tuple] = {}


def loaded(name):
    """(system, sources, V_min), built once per session."""
    if name not in _cache:
        system = systems.load(name)
        sources = make_sources(system)
        _cache[name] = (system, sources, stress.minimum_potential(system, sources["hand"]))
    return _cache[name]


@pytest.fixture(autouse=True)
def _quiet():
    with stress.quiet_mujoco_warnings():
        yield


# ----------------------------------------------------------------------------------------------
# Runs


@pytest.mark.parametrize("integrator", ["RK4", "Euler"])
def test_mirror_runs_in_chunks_equal_one_run(integrator):
    """A mirror run checked sample by sample is bit for bit the mirror run in one piece."""
    system, sources, _ = loaded("double_pendulum_point")
    q0, v0 = initial_state(system)
    run = stress.simulate(
        system, sources, "mirror", Start.of(q0, v0, np.zeros(2)), Scheme(integrator, 1e-3), t_end=0.5, sample_steps=50
    )
    whole = mirror_trajectory(
        system, sources["hand"], Start.of(q0, v0, np.zeros(2)), run.t, integrator=integrator, timestep=1e-3
    )
    assert run.failure is None
    assert np.array_equal(run.q, whole.q) and np.array_equal(run.v, whole.v)


@pytest.mark.parametrize("integrator", stress.MUJOCO_INTEGRATORS)
def test_mujoco_runs_equal_mujoco_trajectory(integrator):
    """`simulate` steps MuJoCo exactly as integrate.mujoco_trajectory does (bitwise equal samples)."""
    system, sources, _ = loaded("double_pendulum_point")
    q0, v0 = initial_state(system)
    run = stress.simulate(
        system, sources, "mujoco", Start.of(q0, v0, np.zeros(2)), Scheme(integrator, 1e-3), t_end=0.5, sample_steps=10
    )
    ref = mujoco_trajectory(
        system, sources["mujoco"], Start.of(q0, v0, np.zeros(2)), run.t, integrator=integrator, timestep=1e-3
    )
    assert np.array_equal(run.q, ref.q) and np.array_equal(run.v, ref.v)


def test_mujoco_warning_stops_a_run():
    """A blow-up is caught from MuJoCo's own warning, not from the state it resets to."""
    system, sources, _ = loaded("double_pendulum_point")
    q0, _ = initial_state(system)
    run = stress.simulate(
        system,
        sources,
        "mujoco",
        Start.of(q0, np.full(2, 50.0), np.zeros(2)),
        Scheme("Euler", 0.05),
        t_end=10.0,
        sample_steps=1,
    )
    assert run.failure is not None and "mjWARN_BADQACC" in run.failure, run.failure
    assert run.t_fail is not None and run.t_fail < 10.0
    assert np.all(np.isfinite(run.q)) and run.t[-1] < run.t_fail


# ----------------------------------------------------------------------------------------------
# Bisection


def test_bisection_brackets_a_known_threshold():
    """On a trial stable exactly below 3.17e-3 s the bisection returns a bracket around it within the ratio."""
    threshold = 3.17e-3
    calls = []

    def trial(dt):
        calls.append(dt)
        return {"stable": dt < threshold, "reason": None if dt < threshold else "synthetic"}

    found = stress.max_stable_timestep(trial)
    assert found["max_stable"] < threshold <= found["min_unstable"]
    assert found["min_unstable"] / found["max_stable"] <= stress.BISECTION_RATIO
    assert len(calls) <= 10, calls  # log2(ln(1e4) / ln(1.1)) = 6.6 halvings plus the top
    assert stress.max_stable_timestep(lambda dt: {"stable": True})["min_unstable"] is None
    low = stress.max_stable_timestep(lambda dt: {"stable": False, "reason": "always"})
    assert low["max_stable"] is None and low["min_unstable"] == stress.DT_RANGE[0]


def test_bisection_finds_the_boundary_of_euler_on_the_fast_simple_pendulum():
    """MuJoCo Euler on simple_pendulum at 50 rad/s is stable at the returned timestep and unstable at twice it.

    The simple pendulum's boundary lies beyond the stress table's 0.1 s (Euler there is the standard map
    with K = h^2 g / l, whose momentum diffuses without bound from K ~ 1, h ~ 0.4 s) and needs many
    steps to show, so this bisection runs over 100 s on [1e-2, 2] s.
    """
    system, sources, V_min = loaded("simple_pendulum")
    q0, _ = initial_state(system)
    v0, tau = np.array([50.0]), np.zeros(1)

    def trial(dt):
        return stress.stability_trial(
            system, sources, "mujoco", Start.of(q0, v0, tau), Scheme("Euler", dt), t_end=100.0, V_min=V_min
        )

    found = stress.max_stable_timestep(trial, dt_range=(1e-2, 2.0))
    dt = found["max_stable"]
    assert dt is not None and found["min_unstable"] is not None, found
    assert trial(dt)["stable"]
    twice = trial(2 * dt)
    assert not twice["stable"] and twice["reason"], twice
    assert 0.2 < dt < 1.0, f"boundary at {dt} s; the standard map's K = 1 lies at sqrt(l / g) = 0.32 s"


# ----------------------------------------------------------------------------------------------
# Energy classification


def _energy(integrator, dt, t_end=20.0):
    system, sources, V_min = loaded("simple_pendulum")
    q0, v0 = initial_state(system)
    run = stress.simulate(
        system,
        sources,
        "mujoco",
        Start.of(q0, v0, np.zeros(1)),
        Scheme(integrator, dt),
        t_end=t_end,
        sample_steps=max(1, round(0.1 / dt)),
    )
    return stress.classify_energy(run.t, stress.run_energy(sources["hand"], run), V_min=V_min)


def test_semi_implicit_euler_energy_is_bounded():
    """Semi-implicit Euler on the simple pendulum (constant M: symplectic) keeps its energy error bounded."""
    c = _energy("Euler", 0.01)
    assert c["class"] == "bounded oscillation", c
    assert c["late_envelope"] <= 1.05 * c["early_envelope"] and c["relative_max"] < 0.05, c


def test_rk4_loses_energy_like_h_to_the_fifth():
    """RK4 on the simple pendulum drifts downward: per step its stability polynomial loses (w h)^6 / 72 of
    an oscillator's energy, so over a fixed time the loss scales like h^5 (measured exponent 4.95-5.0)."""
    coarse, fine = _energy("RK4", 0.05), _energy("RK4", 0.02)
    for c in (coarse, fine):
        assert c["class"] == "secular drift" and c["direction"] == "loss" and c["relative_final"] < 0, c
    exponent = math.log(coarse["relative_final"] / fine["relative_final"]) / math.log(0.05 / 0.02)
    assert 4.5 < exponent < 5.5, exponent
    # the small-amplitude estimate: 400 steps x (w h)^6 / 72, w = sqrt(g / l); 2 rad of amplitude lowers w
    estimate = 400 * (math.sqrt(9.81) * 0.05) ** 6 / 72
    assert 0.1 * estimate < -coarse["relative_final"] < estimate, (coarse["relative_final"], estimate)


def test_non_finite_and_growing_energy_are_unstable():
    """NaN energy, a reported failure, or an energy gain beyond GROWTH x (E0 - V_min) classify as unstable."""
    t = np.linspace(0.0, 10.0, 101)
    calm = 1.0 + 1e-3 * np.sin(t)
    assert stress.classify_energy(t, calm, V_min=0.0)["class"] == "bounded oscillation"
    nan = calm.copy()
    nan[50:] = np.nan
    assert stress.classify_energy(t, nan, V_min=0.0)["class"] == "unstable"
    assert stress.classify_energy(t, calm, V_min=0.0, failure="mjWARN_BADQACC")["class"] == "unstable"
    growing = 1.0 + 0.5 * np.exp(t - 5.0)
    c = stress.classify_energy(t, growing, V_min=0.0)
    assert c["class"] == "unstable" and "energy gain" in c["reason"], c
    assert stress.classify_energy(t, 1.0 + 1e-14 * np.sin(t), V_min=0.0)["class"] == "round-off"


def test_downsampled_series_keep_the_envelope():
    """At most SERIES_POINTS points, the first sample kept, and the largest |y| survives."""
    t = np.linspace(0.0, 1000.0, 10001)
    y = np.sin(t) * 1e-3
    y[7777] = -5.0
    d = stress.downsample(t, y)
    assert len(d["t"]) <= stress.SERIES_POINTS and d["t"][0] == 0.0
    assert min(d["y"]) == -5.0 and t[7777] in d["t"]


# ----------------------------------------------------------------------------------------------
# Conditioning


def test_disagreement_grows_like_cond_times_eps():
    """With a heavy distal bob (light elbow) the sources' q'' disagreement grows with cond(M): log-log slope
    1 +- 0.3, increasing at every point, below 1e3 cond(M) eps."""
    system, sources, _ = loaded("double_pendulum_point")
    sweep = next(s for s in stress.conditioning_sweeps(system, sources["hand"]) if s.heavy == "link2")
    cond, err = [], []
    for ratio in (1e2, 1e4, 1e6, 1e8):
        point = stress.conditioning_point(
            systems.load(system.name, overrides=stress.sweep_overrides(system, sweep, ratio)), n_states=100, seed=0
        )
        worst = max(r["scaled"] for r in point["rows"] if r["quantity"] == "qacc")
        cond.append(point["cond_max"])
        err.append(worst)
        assert worst <= 1e3 * point["cond_max"] * EPS, (ratio, worst, point["cond_max"])
    assert np.all(np.diff(np.log10(cond)) > 1.0), cond
    assert np.all(np.diff(err) > 0), err
    slope = np.polyfit(np.log10(cond), np.log10(err), 1)[0]
    assert 0.7 < slope < 1.3, (slope, cond, err)


def test_diagonal_scaling_leaves_the_disagreement_at_round_off():
    """A gimbal with the outer inertia 1e8 times the inner one has cond(M) ~ 1e7 and M diagonal: the
    sources still agree to ~1e-15, which is why cond(M) alone overstates the expected error."""
    system, sources, _ = loaded("gimbal")
    sweep = next(s for s in stress.conditioning_sweeps(system, sources["hand"]) if s.heavy == "outer")
    assert sweep.kind == "inertia"  # the gimbal's masses do not enter M
    point = stress.conditioning_point(
        systems.load(system.name, overrides=stress.sweep_overrides(system, sweep, 1e8)), n_states=100, seed=0
    )
    assert point["cond_max"] > 1e6 and point["cond_eq_max"] < 2.0, point
    assert max(r["scaled"] for r in point["rows"]) < 1e-14


def test_every_sweep_point_compiles():
    """The light body keeps its inertia, so no sweep point falls below MuJoCo's mjMINVAL."""
    for name in systems.system_names():
        system, sources, _ = loaded(name)
        for sweep in stress.conditioning_sweeps(system, sources["hand"]):
            for ratio in (stress.FULL.ratios[0], stress.FULL.ratios[-1]):
                systems.load(name, overrides=stress.sweep_overrides(system, sweep, ratio)).mujoco_model()


# ----------------------------------------------------------------------------------------------
# stress.json and bad input

TINY = replace(
    stress.QUICK, drift_horizons=(5.0,), speeds=(50.0,), stability_t_end=1.0, sections=("drift", "stability")
)


def test_stress_json_is_written_atomically(tmp_path):
    """stress.json is valid JSON with sorted rows and short series; a failed write leaves the old file."""
    results = stress.run_stress(["simple_pendulum"], settings=TINY)
    path = stress.write_stress(results, tmp_path)
    data = json.loads(path.read_text())
    assert [p.name for p in tmp_path.iterdir()] == ["stress.json"]  # no temporary file left
    assert data["systems"] == ["simple_pendulum"] and data["settings"]["drift_horizons"] == [5.0]
    assert len(data["drift"]) == len(stress.MUJOCO_INTEGRATORS) + len(stress.MIRROR_INTEGRATORS)
    keys = [(r["engine"], r["integrator"]) for r in data["drift"]]
    assert keys == sorted(keys)
    assert all(len(r["series"]["t"]) <= stress.SERIES_POINTS for r in data["drift"])
    assert {r["integrator"] for r in data["stability"]} == set(stress.MUJOCO_INTEGRATORS)
    before = path.read_text()
    with pytest.raises(TypeError):
        stress.write_stress({**results, "bad": object()}, tmp_path)
    assert path.read_text() == before
    assert [p.name for p in tmp_path.iterdir()] == ["stress.json"]


@pytest.mark.parametrize(
    ("names", "overrides", "message"),
    [
        (["dbl_pendulum"], (), "Unknown system"),
        (["gimbal"], (("body/link2/mass", 2.0),), "Unknown body 'link2'"),
        (["gimbal"], (("body/inner/size", 2.0),), "Valid keys"),
        (["double_pendulum_point"], (("body/link2/mass", 0.01),), "mjMINVAL"),
    ],
)
def test_bad_input_is_one_line(names, overrides, message):
    """Unknown systems, keys and bodies, and models MuJoCo refuses fail at once, on one line."""
    with pytest.raises(HarnessError) as exc:
        stress.run_stress(names, overrides=overrides, settings=TINY)
    assert message in str(exc.value) and "\n" not in str(exc.value)


@pytest.mark.parametrize("item", ["scale/mass=nan", "scale/mass=1e300", "body/link2/mass"])
def test_command_rejects_bad_overrides(item, tmp_path):
    """NaN, out-of-range and malformed --set values are refused by overrides.parse before anything runs."""
    import argparse

    args = argparse.Namespace(systems=["simple_pendulum"], set=[item], quick=True, out=tmp_path)
    with pytest.raises(HarnessError):
        stress.stress_command(args)
    assert not (tmp_path / "stress.json").exists()


def test_eulerdamp_keeps_stiff_friction_stable():
    """With 1000x the notes' damping (10 N m s) and a 5 ms step, Euler with MuJoCo's implicit damping
    (eulerdamp) and its mirror stay stable and agree, while Euler without it diverges: explicit damping
    is stable only below 2 M / D = 2 x 9e-3 / 10 = 1.8 ms on the elevation axis."""
    base = systems.load("gimbal")
    damped = systems.load(
        "gimbal", overrides=tuple((f"joint/{j}/damping", 1000 * base.view[f"joint/{j}/damping"]) for j in base.joints)
    )
    sources = make_sources(damped)
    q0, v0 = initial_state(damped)
    start, euler, kw = Start.of(q0, v0, np.zeros(2)), Scheme("Euler", 5e-3), {"t_end": 1.0, "sample_steps": 20}
    with_damp = stress.simulate(damped, sources, "mujoco", start, euler, **kw)
    mirror = stress.simulate(damped, sources, "mirror", start, euler, **kw)
    without = stress.simulate(damped, sources, "mujoco", start, euler, eulerdamp=False, **kw)
    assert with_damp.failure is None and mirror.failure is None
    assert np.abs(with_damp.q - mirror.q).max() < 1e-12
    E = stress.run_energy(sources["hand"], without)
    c = stress.classify_energy(without.t, E, V_min=0.0, failure=without.failure, t_fail=without.t_fail)
    assert c["class"] == "unstable", c


def test_the_summary_tables_keep_whole_system_names():
    """Issue 26: at 100 columns the console tables name double_pendulum_absolute in full, never
    "double_pendulum..."."""
    import io

    from lagrange_xval.studies.stress.output import print_summary
    from rich.console import Console

    names = ("double_pendulum_absolute", "double_pendulum_bars", "double_pendulum_point")
    drift = [
        {
            "system": n,
            "engine": "mujoco",
            "integrator": i,
            "horizon": 1000.0,
            "class": "bounded",
            "direction": "-",
            "relative_max": 1e-3,
            "rate": 1e-6,
        }
        for n in names
        for i in ("Euler", "implicitfast", "RK4")
    ]
    results = {"drift": drift, "stability": [], "conditioning": [], "conditioning_summary": [], "stiff_friction": []}
    results |= {"skipped": [], "solve_tier_proposal": None, "timing": {"total": 1.0}}
    out = io.StringIO()
    print_summary(results, Console(file=out, width=100))
    text = out.getvalue()
    assert "…" not in text and "..." not in text, text
    for n in names:
        assert n in text, f"{n} cut: {text}"

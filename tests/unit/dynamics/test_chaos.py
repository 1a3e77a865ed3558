"""Chaos measures: Lyapunov exponent, amplification, envelope, horizon, convergence order, energy drift."""

from __future__ import annotations

import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.dynamics import chaos
from lagrange_xval.dynamics.integrate import initial_state, mujoco_trajectory, time_grid
from lagrange_xval.dynamics.reference import reference_trajectory
from lagrange_xval.model.start import Scheme, Start
from lagrange_xval.sources import make_sources

NOTES_START = (np.array([0.0, 3.0]), np.zeros(2))  # theta = 0, phi = 3, at rest (the notes' ode45 run)
_sources: dict[str, dict] = {}


def sources_of(system):
    if system.name not in _sources:
        _sources[system.name] = make_sources(system)
    return _sources[system.name]


@pytest.fixture(scope="module")
def point():
    return systems.load("double_pendulum_point")


@pytest.fixture(scope="module")
def lyapunov(point):
    q0, v0 = NOTES_START
    return chaos.lyapunov_exponent(point, Start.at_rest(q0, v0), method="variational")


def test_lyapunov_exponent_of_the_notes_experiment(lyapunov):
    """lambda from (0, 3) over 500 s is 0.18-0.30 /s (measured 0.229; the running estimate wanders
    0.22-0.29 between 50 s and 2000 s, so a finite-time value is only good to about +-0.04)."""
    lam = lyapunov["lambda"]
    assert 0.18 <= lam <= 0.30, f"largest Lyapunov exponent {lam:.3f} /s outside [0.18, 0.30]"


def test_lyapunov_spectrum_is_hamiltonian(lyapunov):
    """A conservative system's spectrum comes in +-pairs and sums to zero (measured |l1 + l4| = 0.003)."""
    spec = lyapunov["spectrum"]
    assert abs(spec[0] + spec[-1]) < 0.01 and abs(sum(spec)) < 0.01, f"spectrum {np.round(spec, 4)} is not +-paired"
    assert abs(spec[1]) < 0.03 and abs(spec[2]) < 0.03, f"the middle exponents {spec[1]:.3f}, {spec[2]:.3f} are not ~0"


def test_two_lyapunov_methods_agree(point, lyapunov):
    """Two nearby trajectories (the simple path) and the variational QR method agree within the finite-time
    scatter (measured 0.206 vs 0.229 /s at 500 s)."""
    q0, v0 = NOTES_START
    two = chaos.lyapunov_exponent(point, Start.at_rest(q0, v0), method="two trajectories")
    assert abs(two["lambda"] - lyapunov["lambda"]) < 0.05, f"{two['lambda']:.3f} vs {lyapunov['lambda']:.3f} /s"


def test_amplification_is_the_finite_difference_sensitivity(point):
    """Phi(2 s) from the variational equations equals central differences of the reference (the simple path)."""
    q0, v0 = NOTES_START
    t = time_grid(2.0, 0.01)
    fl = chaos.flow(point, Start.of(q0, v0, np.zeros(2)), t)
    eps = 1e-6
    cols = []
    for j in range(4):
        ends = []
        for sign in (1, -1):
            x0 = np.concatenate([q0, v0])
            x0[j] += sign * eps
            ref, _ = reference_trajectory(point, Start.of(x0[:2], x0[2:], np.zeros(2)), t, cache_dir=None, check=None)
            ends.append(np.concatenate([ref.q[-1], ref.v[-1]]))
        cols.append((ends[0] - ends[1]) / (2 * eps))
    fd = np.stack(cols, axis=1)
    err = np.abs(fd - fl.phi[-1]).max() / np.abs(fl.phi[-1]).max()
    assert err < 1e-6, f"Phi(2 s) differs from finite differences by {err:.1e} (relative)"


def test_envelope_bounds_mujoco_rk4_and_the_judge_can_fail(point):
    """MuJoCo RK4 at 1 ms stays inside its propagated window-error envelope (measured ratio 0.27) and its
    error is the first-order propagation of those window errors; the same run started 1e-7 rad away
    leaves the envelope: the judge tells a wrong trajectory from an amplified right one."""
    src = sources_of(point)
    q0, v0 = NOTES_START
    tau = np.zeros(2)
    t = time_grid(10.0, 0.01)
    ref, _ = reference_trajectory(point, Start.of(q0, v0, tau), t, cache_dir=None, check=None)
    out = chaos.free_run_check(point, src, Start.of(q0, v0, tau), t, integrator="RK4", ref=ref)
    assert out["judge"]["passed"] and out["judge"]["max_ratio"] < 1, out["judge"]
    # the linear propagation of the window errors is not just a bound: it reproduces the error (measured 1e-3)
    assert out["prediction_mismatch"] < 1e-2, (out["error_at"], out["predicted_at"])
    env = chaos.error_envelope(
        chaos.flow(point, Start.of(q0, v0, tau), t),
        window_errors=chaos.window_errors(point, src, "mujoco", ref, tau, Scheme("RK4", 1e-3)),
        floor=chaos.rounding_floor(ref),
    )
    wrong = mujoco_trajectory(point, src["mujoco"], Start.of(q0 + [0.0, 1e-7], v0, tau), t, integrator="RK4")
    verdict = chaos.judge_free_run(t, np.abs(wrong.q - ref.q).max(axis=1), env)
    assert not verdict["passed"] and verdict["first_violation"] < 0.1, verdict


def test_horizon_from_rounding_matches_lambda(point, lyapunov):
    """The horizon at 1e-6 rad of the initial state's rounding, from the envelope (measured 73 s), is within
    a factor 1.5 of ln(tol / e0) / lambda (95 s)."""
    q0, v0 = NOTES_START
    h = chaos.horizon_from_rounding(point, Start.of(q0, v0, np.zeros(2)), tolerance=1e-6)
    estimate = np.log(1e-6 / h["e0"]) / lyapunov["lambda"]
    assert h["horizon"] is not None and 1 / 1.5 < h["horizon"] / estimate < 1.5, (h, estimate)


def test_predictability_horizon_is_the_first_crossing():
    t = np.arange(5.0)
    assert chaos.predictability_horizon(t, np.array([0, 1e-9, 1e-6, 1e-3, 1e-7]), 1e-6) == 2.0
    assert chaos.predictability_horizon(t, np.zeros(5), 1e-6) is None


@pytest.mark.parametrize(("integrator", "band"), [("RK4", (3.5, 4.5)), ("Euler", (0.8, 1.2))])
def test_convergence_order(system, integrator, band, tmp_path_factory):
    """Errors at 1 s against the reference fall as dt^4 (RK4) and dt (Euler) (measured 3.98-4.27 and 1.00)."""
    q0, v0 = initial_state(system)
    tau = np.zeros(system.nv)
    out = chaos.convergence_order(
        system,
        sources_of(system),
        Start.of(q0, v0, tau),
        integrator=integrator,
        cache_dir=tmp_path_factory.getbasetemp() / "reference",
        check=None,
    )
    lo, hi = band
    assert lo <= out["order"] <= hi, f"{system.name} {integrator}: order {out['order']:.2f}, errors {out['errors']}"


CONSERVATIVE = [n for n in systems.system_names() if not systems.load(n).uses & {"damping", "actuation"}]


@pytest.mark.parametrize("name", CONSERVATIVE)
def test_energy_drift_rk4_against_euler(name):
    """Without damping or inputs, RK4 at 1 ms keeps energy to 1e-7 of its scale over 10 s (measured
    <= 2.3e-9); semi-implicit Euler drifts by more than 1e-3 (measured 5e-3 to 7e-2)."""
    system = systems.load(name)
    q0, v0 = initial_state(system)
    tau = np.zeros(system.nv)
    t = time_grid(10.0, 0.01)
    ref, _ = reference_trajectory(system, Start.of(q0, v0, tau), t, cache_dir=None, check=None)
    rk4 = chaos.energy_drift(system, sources_of(system), Start.of(q0, v0, tau), t, integrator="RK4", ref=ref)
    euler = chaos.energy_drift(system, sources_of(system), Start.of(q0, v0, tau), t, integrator="Euler", ref=ref)
    assert rk4["relative"] < 1e-7, rk4
    assert euler["relative"] > 1e-3, euler


def test_a_mirror_the_wall_time_budget_stops_is_judged_until_its_stop(monkeypatch, tmp_path):
    """The wall-time budget is the harness's guard against a slow source, not evidence about the
    derivation: a loaded machine can spend it on a right one (the acrobot's Euler mirror, 10^4 round
    trips to a person's module at load 8). A mirror it stops is judged up to its stop, says so, and
    fails only for a difference before it; a mirror that diverges still fails."""
    import functools

    from lagrange_xval.dynamics.integrate import Budget
    from lagrange_xval.report.system_parts import mirror_notes

    system = systems.load("simple_pendulum")
    sources = make_sources(system)
    stopped = functools.partial(chaos.mirror_trajectory, budget=Budget(max_wall_s=0.0))
    monkeypatch.setattr(chaos, "mirror_trajectory", stopped)
    out = chaos.crossvalidate(system, sources, t_end=1.0, integrators=("Euler",), cache_dir=tmp_path)
    mirrors = out["integrators"]["Euler"]["mirrors"]
    assert out["passed"], mirrors
    for m in mirrors.values():
        assert m["passed"] and m["judged_short"].startswith("stopped: budget: wall time 0 s"), m
        assert m["judge"]["judged_until"] == 0.0
    notes = mirror_notes("Euler", mirrors)
    assert notes[0] == (
        "MuJoCo Euler's mirror on the hand equations: the harness's wall-time budget stopped it (wall time 0 s spent "
        "by t = 0 s), which says nothing of the equations; it agrees until 0 s, as far as it is judged."
    )
    failing = {"mujoco~hand": {"passed": False, "status": "diverged", "reason": "diverged at t = 2 s: |q| > 1e6"}}
    assert mirror_notes("RK4", failing) == [
        "MuJoCo RK4's mirror on the hand equations fails: diverged at t = 2 s: |q| > 1e6."
    ]

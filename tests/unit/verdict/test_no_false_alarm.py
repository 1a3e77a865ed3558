"""No false alarm at any model: the right derivations pass at held-out and extreme models and states.

Held-out models move every parameter of a derivation by its own factor in [0.5, 2] (`held_out`,
built as the probes build theirs, so MuJoCo, Pinocchio and the equations read the same numbers);
extreme ones set a 1:50 mass ratio or a 1:20 length ratio; the gimbal is sampled at gimbal lock.
Each property comes with its converse: a wrong derivation, or a run of other equations, still fails
there. The 20-model sweep is marked slow.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from lagrange_xval import systems
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.dynamics import chaos, estimate, freeruns, integrate
from lagrange_xval.dynamics.reference import WINDOW_CHECK_TOLERANCE, reference_trajectory, window_check
from lagrange_xval.model.start import Start
from lagrange_xval.sources import make_sources
from lagrange_xval.stages import pipeline
from lagrange_xval.verdict import pointwise as compare
from lagrange_xval.verdict import probes as probing
from lagrange_xval.verdict import verdict

from ...mutations import MUTATIONS, load_mutated

HELD_OUT_RANGE = (0.5, 2.0)


def held_out(name: str, seed: int):
    """The repository system with every non-zero parameter times its own log-uniform factor in [0.5, 2]."""
    system = systems.load(name)
    nominal = probing.param_fields(system.params)
    rng = np.random.default_rng([seed, 25])
    lo, hi = np.log(HELD_OUT_RANGE[0]), np.log(HELD_OUT_RANGE[1])
    for _ in range(probing.ATTEMPTS):
        values = {k: x * float(np.exp(rng.uniform(lo, hi))) if x else x for k, x in nominal.items()}
        try:
            return probing.build(system, values, index=1, label=f"held-out {seed}").system
        except HarnessError:  # a draw MuJoCo or the writer refuses (an inertia off the triangle inequality)
            continue
    raise AssertionError(f"no valid held-out model of {name} in {probing.ATTEMPTS} draws")


def with_params(name: str, **ratios: float):
    """The repository system with the given Params fields multiplied by the given factors."""
    system = systems.load(name)
    values = probing.param_fields(system.params)
    for key, k in ratios.items():
        values[key] *= k
    return probing.build(system, values, index=1, label="extreme").system


def wrong(system, mutation: str):
    """`system`'s model with one catalogued mistake in its equations."""
    m = next(m for m in MUTATIONS if m.system == system.name and m.name == mutation)
    return system.derive(equations=load_mutated(m))


def _failures(result) -> list[str]:
    from lagrange_xval.results.stages import outcome

    stages = {k: outcome(v) for k, v in result["stages"].items()}
    return [*result["failed"], *(f"{k}: {v}" for k, v in stages.items() if v.startswith("failed"))]


# ----------------------------------------------------------------------------------------------
# Pinocchio's ABA at an ill-conditioned model


def test_pinocchio_forward_keeps_the_per_state_accuracy_at_an_ill_conditioned_model():
    """At m2/50 and l2 = l1/20 (cond(M) ~2e4) Pinocchio's qacc stays within 1e-14 of the symbolic
    equations' (the world-convention batch was 1.3e-13 off) and is aba called per state, bit for bit."""
    system = with_params("double_pendulum_point", m2=1 / 50, l2=1 / 20)
    sources = make_sources(system)
    states = compare.random_states(system, n=300, seed=0)
    values = compare.evaluate(sources, states)
    p = sources["pinocchio"]
    scale = np.abs(values["symbolic"]["qacc"]).max()
    err = np.abs(values["pinocchio"]["qacc"] - values["symbolic"]["qacc"]).max() / scale
    assert err < 1e-14, f"pinocchio qacc {err:.2g} of its scale from the symbolic equations"
    force = states.tau + p.passive(states.q, states.v)
    per_state = [
        pin.aba(p.model, p.data, p._q(q), p._v(v), p._v(f))[p.vidx]
        for q, v, f in zip(states.q, states.v, force, strict=True)
    ]
    assert np.array_equal(values["pinocchio"]["qacc"], np.array(per_state))
    assert compare.pointwise_result(values, states, seed=0)["passed"]


# ----------------------------------------------------------------------------------------------
# Scales at special states


def _gimbal_lock_states(system, n=60):
    states = compare.random_states(system, n=n, seed=1)
    q = states.q.copy()
    q[:, system.coordinates.index("theta")] = np.pi / 2
    return compare.States(q, states.v, states.tau)


def test_gimbal_lock_passes_pointwise_and_term_by_term():
    """At gimbal lock the velocity terms vanish at every state: the engines and the right derivation
    still agree, judged against a force scale that does not collapse (max ||M|| max |v|^2)."""
    system = systems.load("gimbal")
    states = _gimbal_lock_states(system)
    sources = make_sources(system)
    values = compare.evaluate(sources, states)
    point = compare.pointwise_result(values, states, seed=0)
    assert point["passed"], [(r["quantity"], r["pair"], r["scaled"]) for r in point["rows"] if not r["passed"]]
    result = verdict.judge_derivation(system, states, sources, values=values, n_probes=1, seed=0)
    assert result["verdict"] == "agrees", result["statement"]


def test_gimbal_lock_still_catches_a_wrong_mass_matrix():
    system = wrong(systems.load("gimbal"), "sin and cos swapped in M11")
    states = _gimbal_lock_states(system)
    sources = make_sources(system)
    result = verdict.judge_derivation(system, states, sources, n_probes=1, seed=0)
    assert result["verdict"] == "disagrees" and result["first_disagreeing_term"] in {"mass matrix", "kinetic energy"}


# ----------------------------------------------------------------------------------------------
# Trajectories judged against each run's own error estimate


def test_richardson_estimate_tracks_mujoco_rk4_error():
    """On a held-out bars model whose RK4 error at 1 ms passed the old fixed 1e-6 rad (3.3e-6), the
    step-doubling estimate is within 20% of the actual error, and the run passes its own threshold."""
    system = held_out("double_pendulum_bars", 1)
    sources = make_sources(system)
    q0, v0 = integrate.initial_state(system)
    tau = np.zeros(system.nv)
    t = integrate.time_grid(10.0, 0.01)
    ref, _ = reference_trajectory(system, Start.of(q0, v0, tau), t)
    run = integrate.mujoco_trajectory(system, sources["mujoco"], Start.of(q0, v0, tau), t)
    est, how = estimate.mujoco_estimate(system, sources["mujoco"], run, Start.of(q0, v0, tau))
    err = integrate.error_against(run, ref)
    assert 0.8 < err.max() / est.max() < 1.2, (err.max(), est.max(), how)
    assert err.max() > estimate.FLOOR and np.all(err <= estimate.threshold(est))


def test_a_run_of_other_equations_is_beyond_its_own_threshold():
    """MuJoCo stepping a model with m2 5% heavier is judged against the reference of the model's own
    equations: beyond its threshold within the judged second, while the other runs pass."""
    system = systems.load("double_pendulum_point")
    sources = make_sources(system)
    sources["mujoco"] = make_sources(system.with_overrides(body__link2__mass=1.05))["mujoco"]
    traj = freeruns.trajectory_results(system, sources, t_end=1.0, dt_out=0.01)
    freeruns.judge_trajectories(traj, None, "failed: for the test")
    runs = {r["source"]: r for r in traj["runs"] if r.get("counts")}
    assert traj["judged_until"] == pytest.approx(freeruns.UNMEASURED_HORIZON)
    assert "failed: for the test" in traj["judged_because"]
    assert runs["mujoco"]["passed"] is False
    assert all(r["passed"] for k, r in runs.items() if k != "mujoco"), {
        k: r["max_error_vs_hand"] for k, r in runs.items()
    }


def test_a_failed_chaos_stage_leaves_a_conservative_horizon():
    t = integrate.time_grid(10.0, 0.01)
    until, why = freeruns.judged_interval(t, None, "failed: Diverged: ...")
    assert until == pytest.approx(freeruns.UNMEASURED_HORIZON) and "unknown" in why
    assert freeruns.judged_interval(t, np.ones_like(t))[0] == 10.0


# ----------------------------------------------------------------------------------------------
# Steps and rounding limits from the model


def test_convergence_sweep_starts_inside_the_stable_step():
    assert chaos.sweep_timesteps("RK4", 9.0)[0] == chaos.CONVERGENCE_TIMESTEPS["RK4"]
    dts, stable = chaos.sweep_timesteps("RK4", 440.0)
    assert dts[0] <= chaos.STABLE_FRACTION * stable and dts[0] == pytest.approx(0.0025)


def test_stiff_model_convergence_and_its_fresh_reference():
    """At m1 = m2/50 (max |lambda| ~440 /s) the RK4 sweep no longer diverges and shows order 4, and
    the reference just computed passes its own content check (it failed by 5e-5 rad)."""
    system = with_params("double_pendulum_point", m1=1 / 50)
    sources = make_sources(system)
    q0, v0 = integrate.initial_state(system)
    tau = np.zeros(system.nv)
    out = chaos.convergence_order(system, sources, Start.of(q0, v0, tau), integrator="RK4", check=None)
    assert out["stable_timestep"] is not None and out["timesteps"][0] < 0.02
    assert 3.5 <= out["order"] <= 4.5, out
    t = integrate.time_grid(2.0, 0.01)
    ref, _ = reference_trajectory(system, Start.of(q0, v0, tau), t, check=None)
    assert window_check(system, ref, tau) <= WINDOW_CHECK_TOLERANCE


# ----------------------------------------------------------------------------------------------
# Whole systems: right derivations pass, wrong ones are caught


SHORT = {"n_states": 40, "seed": 0, "n_probes": 1}


def test_wrong_derivation_is_caught_at_a_held_out_model():
    system = wrong(held_out("double_pendulum_bars", 1), "centrifugal theta'^2 dropped in row 2")
    result = pipeline.run_system(system, **SHORT, t_end=1.0)
    assert not result["passed"] and result["derivation"]["verdict"] == "disagrees"


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("name", systems.system_names())
def test_held_out_models_sweep(name, seed):
    """20 held-out models (every system, 4 seeds): the right derivation passes every stage."""
    result = pipeline.run_system(held_out(name, seed), n_states=100, seed=0, n_probes=1)
    assert result["passed"], _failures(result)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "ratios"),
    [
        ("double_pendulum_point", {"m2": 1 / 50}),
        ("double_pendulum_point", {"l2": 1 / 20}),
        ("double_pendulum_point", {"m2": 1 / 50, "l2": 1 / 20}),
        ("double_pendulum_absolute", {"m1": 1 / 50}),
        ("double_pendulum_absolute", {"l2": 1 / 20}),
        ("double_pendulum_bars", {"l1": 20.0}),
        ("double_pendulum_bars", {"m2": 1 / 50, "I2": 1 / 50}),
    ],
)
def test_extreme_models(name, ratios):
    """1:50 mass and 1:20 length ratios: the right derivation passes every stage."""
    result = pipeline.run_system(with_params(name, **ratios), n_states=100, seed=0, n_probes=1)
    assert result["passed"], _failures(result)


def test_a_chain_with_no_symbolic_source_gets_an_aba_reference():
    """Without a symbolic source, the reference is Pinocchio's ABA by DOP853 at rtol 1e-12, checked at half
    the tolerance; MuJoCo's RK4 at 1 ms lies within 1e-6 rad of it over 1 s (information only)."""
    system = systems.System.model_only(systems.MODELS_DIR / "double_pendulum_point.xml")
    sources = {k: v for k, v in make_sources(system).items() if k != "symbolic"}
    traj = freeruns.divergence_results(system, sources, t_end=1.0, dt_out=0.01, why="test", aba_reference=True)
    assert "Pinocchio ABA" in traj["reference"] and traj["reference_info"]["agreement_q"] < 1e-9, traj["reference"]
    runs = {r["source"]: r for r in traj["runs"]}
    assert runs["mujoco"]["max_error_vs_hand"] < 1e-6 and runs["pinocchio"]["max_error_vs_hand"] < 1e-8


def test_a_run_the_wall_time_budget_stops_is_judged_until_its_stop_and_no_further():
    """A free run the harness's wall-time budget stopped (a loaded machine, a slow module) is judged up
    to its stop, which it says; one the evaluation budget stopped (what a wrong derivation spends) fails."""
    t = np.linspace(0.0, 1.0, 11)
    err = np.where(t <= 0.5, 1e-9, np.nan)

    def run(reason: str) -> dict:
        stats = {"status": "stopped: budget", "stopped_at": 0.5, "reason": reason}
        return {"source": "hand", "counts": True, "error_vs_hand": err.tolist(), "stats": stats}

    wall = run("stopped: budget: wall time 60 s spent by t = 0.5 s")
    evals = run("stopped: budget: 200000 evaluations spent by t = 0.5 s")
    traj = {"t": t.tolist(), "threshold": 1e-6, "runs": [wall, evals]}
    freeruns.judge_trajectories(traj, None)
    assert wall["passed"] is True and wall["judged_until"] == 0.5
    assert wall["judged_because"] == "the harness's wall-time budget ran out then (wall time 60 s spent by t = 0.5 s)"
    assert evals["passed"] is False

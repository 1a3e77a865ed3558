"""Wrong derivations are the normal input: every integration is bounded and ends as a finding
(status, stopped_at, reason), never as an exception or a hang. The wrong systems are built here,
from the repository's modules with one substitution each; no file is touched."""

from __future__ import annotations

import dataclasses
import importlib.util
import inspect
import itertools
import math
import sys

import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.core.errors import IntegrationStopped
from lagrange_xval.dynamics import chaos, experiments, integrate, mirror, reference
from lagrange_xval.model.start import Scheme, Start
from lagrange_xval.sources import fastpath, make_source
from lagrange_xval.sources.hand import HandSource

PACKAGE = "lagrange_xval.equations"
_fresh = itertools.count()

# One realistic slip each, as (system, old, new); `old` occurs exactly once in the module.
FRICTION_SIGN = ("gimbal", "return -k * v", "return k * v")  # the gimbal then speeds up without bound
M11_SIGN = ("double_pendulum_point", "m11 = p.m1 * p.l1**2", "m11 = -p.m1 * p.l1**2")  # det M = I - cos^2 phi
M12_SIGN = ("double_pendulum_point", "(p.l2**2 + p.l1 * p.l2 * c) + p.I2", "(p.l2**2 - p.l1 * p.l2 * c) + p.I2")
LOST_TWO = ("double_pendulum_point", "2 * p.l1 * p.l2 * c) + p.I1", "p.l1 * p.l2 * c) + p.I1")  # det 0 at c = 0.618


def mutated(system: str, old: str, new: str) -> systems.System:
    """The system with its equations module re-executed from the substituted source, as
    lagrange_xval.equations._mutated_x_<n> (relative imports resolve). The System is made with
    dataclasses.replace: a new System, its own memo (caches keyed by the module tell them apart too)."""
    original = systems.load(system)
    text = inspect.getsource(original.equations)
    assert text.count(old) == 1, f"{system}: {old!r} occurs {text.count(old)} times"
    name = f"{PACKAGE}._mutated_x_{next(_fresh)}"
    spec = importlib.util.spec_from_loader(name, loader=None, origin=f"<mutated equations/{system}.py>")
    module = importlib.util.module_from_spec(spec)
    module.__package__ = PACKAGE
    module.__file__ = f"<mutated equations/{system}.py>"
    sys.modules[name] = module  # dataclasses look the module up while the class body runs
    exec(compile(text.replace(old, new), module.__file__, "exec"), module.__dict__)  # noqa: S102
    return dataclasses.replace(original, equations=module)


def start(system):
    q0, v0 = integrate.initial_state(system)
    return q0, v0, np.zeros(system.nv)


def assert_kept_until_stop(tr: integrate.Trajectory) -> None:
    """Samples up to stopped_at are finite, every later one is NaN."""
    k = int(np.searchsorted(tr.t, tr.stats["stopped_at"], side="right"))
    assert 1 <= k <= len(tr.t), tr.stats
    assert np.isfinite(tr.q[:k]).all() and np.isfinite(tr.v[:k]).all(), f"NaN before the stop: {tr.stats}"
    assert np.isnan(tr.q[k:]).all() and np.isnan(tr.v[k:]).all(), f"values after the stop: {tr.stats}"


# ----------------------------------------------------------------------------------------------
# Friction with the wrong sign: the motion grows without bound


def test_wrong_friction_sign_default_odeint_run_is_stopped_by_its_budget():
    """The default integration (odeint) of the self-accelerating gimbal ends as "diverged" or
    "stopped: budget" within the evaluation budget, the run kept up to there."""
    s = mutated(*FRICTION_SIGN)
    q0, v0, tau = start(s)
    tr = integrate.scipy_trajectory(s, make_source(s, "hand"), Start.of(q0, v0, tau), integrate.time_grid(10.0, 0.01))
    assert tr.stats["status"] in ("diverged", "stopped: budget"), tr.stats
    assert tr.stats["nfev"] <= integrate.DEFAULT_BUDGET.max_rhs_evaluations, tr.stats
    assert tr.stats["stopped_at"] < 10.0 and tr.stats["reason"].startswith(("diverged at t =", "stopped: budget"))
    assert_kept_until_stop(tr)


@pytest.mark.parametrize("method", ["DOP853", "RK45", "odeint"])
def test_an_evaluation_budget_is_spent_exactly(method):
    """With a small budget each driver stops after exactly that many right-hand-side evaluations."""
    s = mutated(*FRICTION_SIGN)
    q0, v0, tau = start(s)
    budget = integrate.Budget(max_rhs_evaluations=5_000)
    tr = integrate.scipy_trajectory(
        s, make_source(s, "hand"), Start.of(q0, v0, tau), integrate.time_grid(10.0, 0.01), method=method, budget=budget
    )
    assert tr.stats["status"] == "stopped: budget" and tr.stats["nfev"] == 5_000, tr.stats
    assert_kept_until_stop(tr)


def test_wrong_friction_sign_mirror_is_diverged_and_kept_up_to_there():
    """MuJoCo's Euler mirrored on the self-accelerating gimbal: "diverged at t = ...", finite before."""
    s = mutated(*FRICTION_SIGN)
    q0, v0, tau = start(s)
    tr = mirror.mirror_trajectory(
        s, make_source(s, "hand"), Start.of(q0, v0, tau), integrate.time_grid(10.0, 0.01), integrator="Euler"
    )
    assert tr.stats["status"] == "diverged" and tr.stats["reason"].startswith("diverged at t ="), tr.stats
    assert_kept_until_stop(tr)


def test_wrong_friction_sign_notes_experiment_records_the_stop():
    """The notes' experiment integration of a form that runs away keeps its run and says why it stopped."""
    s = mutated(*FRICTION_SIGN)
    q0, v0, tau = start(s)
    t = integrate.time_grid(experiments.T_END, experiments.DT_OUT)
    budget = integrate.Budget(max_rhs_evaluations=3_000)
    q, info = experiments._integrate(
        fastpath.scalar_rhs(s), q0, v0, tau, t, method="RK45", rtol=1e-6, atol=1e-6, budget=budget
    )
    assert info["status"] == "stopped: budget" and info["nfev"] == 3_000, info
    assert experiments._status(info).startswith("stopped: budget"), info
    k = int(np.searchsorted(t, info["stopped_at"], side="right"))
    assert np.isfinite(q[:k]).all() and np.isnan(q[k:]).all()


def test_taylor_reference_of_the_exploding_gimbal_raises_integration_stopped():
    """heyoka on the self-accelerating gimbal ends with IntegrationStopped (source, method, t, reason)
    within its step allowance: the step density of the blow-up outgrows it."""
    s = mutated(*FRICTION_SIGN)
    q0, v0, tau = start(s)
    t = integrate.time_grid(10.0, 0.01)
    with pytest.raises(IntegrationStopped) as info:
        reference.taylor_solve(s, q0, v0, tau, t, precision="double")
    exc = info.value
    assert exc.source == "hand" and exc.method.startswith("heyoka Taylor") and 0 < exc.t < 10.0, str(exc)
    assert exc.reason.startswith(("stopped: budget", "diverged")), str(exc)
    with pytest.raises(IntegrationStopped):
        chaos.flow(s, Start.of(q0, v0, tau), t)


# ----------------------------------------------------------------------------------------------
# A sign error that makes M singular


def test_singular_mass_matrix_gives_nan_accelerations_not_an_exception():
    """With m11's sign wrong, det M = I - cos^2 phi is exactly 0 on a band of states near phi = pi/2:
    forward and evaluate give NaN accelerations there and finite ones elsewhere."""
    s = mutated(*M11_SIGN)
    phi = math.acos(math.sqrt(s.params.I2)) + np.arange(-2000, 2001) * 1e-12
    q = np.stack([np.zeros_like(phi), phi], axis=-1)
    singular = np.linalg.det(s.equations.mass_matrix(s.params, q)) == 0
    assert singular.any() and not singular.all(), "the band of exactly singular states moved"
    hand = HandSource(s)
    a = hand.forward(q, np.zeros_like(q), np.zeros_like(q))
    assert np.isnan(a[singular]).all() and np.isfinite(a[~singular]).all()
    out = hand.evaluate(q, np.zeros_like(q), np.zeros_like(q))
    assert np.isnan(out["qacc"][singular]).all() and np.isfinite(out["qacc"][~singular]).all()


@pytest.mark.parametrize("method", ["DOP853", "Radau"])
def test_singular_mass_matrix_trajectory_is_a_finding_naming_M(method):
    """The trajectory through the singular M is "failed" or "diverged" with a reason naming M(q)."""
    s = mutated(*M12_SIGN)
    q0, v0, tau = start(s)
    tr = integrate.scipy_trajectory(
        s,
        make_source(s, "hand"),
        Start.of(q0, v0, tau),
        integrate.time_grid(3.0, 0.01),
        method=method,
        rtol=1e-8,
        atol=1e-8,
    )
    assert tr.stats["status"] in ("failed", "diverged"), tr.stats
    assert "M(q) is" in tr.stats["reason"], tr.stats["reason"]
    assert_kept_until_stop(tr)


def test_the_fast_path_raising_zero_division_is_a_failed_status():
    """A right-hand side that raises (as the generated code does at an exactly singular M) ends the
    odeint run at once as "failed", its samples before the stop identical to odeint's own."""
    from scipy.integrate import odeint

    def pendulum(t, y):
        if t > 1.0:
            raise ZeroDivisionError("float division by zero")
        return [y[1], -math.sin(y[0])]

    t = integrate.time_grid(2.0, 0.01)
    run = integrate.integrate_rhs(pendulum, np.array([1.0, 0.0]), t, method="odeint", rtol=1e-10, atol=1e-12)
    info = integrate.outcome(run, t, budget=integrate.DEFAULT_BUDGET, equations="test", solver="odeint", n=1)
    assert info["status"] == "failed" and "ZeroDivisionError" in info["reason"], info
    assert run.nfev < 2_000, run.nfev  # stopped at once, not 1e5 steps per sample
    plain = odeint(lambda tt, y: [y[1], -math.sin(y[0])], [1.0, 0.0], t, tfirst=True, rtol=1e-10, atol=1e-12)
    assert 90 <= run.good <= 101, run.good
    assert np.array_equal(run.y[: run.good], plain[: run.good]) and np.isnan(run.y[run.good :]).all()


def test_lost_factor_two_in_M_is_a_finding_not_an_exception():
    """Losing the 2 of 2 l1 l2 cos phi in M (singular at cos phi = 0.618) never raises: scipy, every
    mirror and the notes' experiments end with a status."""
    s = mutated(*LOST_TWO)
    q0, v0, tau = start(s)
    t = integrate.time_grid(3.0, 0.01)
    hand = make_source(s, "hand")
    small = integrate.Budget(max_rhs_evaluations=20_000)  # the default run spends 200,000 by t = 1.09 s
    tr = integrate.scipy_trajectory(s, hand, Start.of(q0, v0, tau), t, **integrate.SCIPY_DEFAULT, budget=small)
    assert tr.stats["status"] in integrate.STATUSES and (tr.stats["status"] == "ok") == (tr.stats["reason"] == "")
    if tr.stats["status"] != "ok":
        assert_kept_until_stop(tr)
    for name in mirror.INTEGRATORS:
        m = mirror.mirror_trajectory(s, hand, Start.of(q0, v0, tau), t, integrator=name)
        assert m.stats["status"] in integrate.STATUSES, (name, m.stats)


# ----------------------------------------------------------------------------------------------
# Correct systems: unchanged, and caches that tell a mutated module from the original


@pytest.mark.parametrize("name", systems.system_names())
def test_correct_systems_are_ok_and_bit_for_bit_the_plain_solvers(name):
    """On every correct system the guarded drivers report "ok" and give exactly the samples of plain
    odeint / solve_ivp on the same right-hand side."""
    from scipy.integrate import odeint, solve_ivp

    s = systems.load(name)
    q0, v0, tau = start(s)
    t = integrate.time_grid(3.0, 0.01)
    hand = make_source(s, "hand")
    f, y0 = fastpath.scalar_rhs(s), np.concatenate([q0, v0])
    tau_list = [0.0] * s.nv
    for method, plain in (
        ("odeint", lambda: odeint(f, y0, t, args=(tau_list,), tfirst=True, rtol=1e-11, atol=1e-14, mxstep=100000)),
        ("DOP853", lambda: solve_ivp(f, (t[0], t[-1]), y0, "DOP853", t, args=(tau_list,), rtol=1e-12, atol=1e-12).y.T),
    ):
        kw = integrate.SCIPY_DEFAULT if method == "odeint" else {"method": "DOP853", "rtol": 1e-12, "atol": 1e-12}
        tr = integrate.scipy_trajectory(s, hand, Start.of(q0, v0, tau), t, **kw)
        assert tr.stats["status"] == "ok" and tr.stats["reason"] == "" and tr.stats["stopped_at"] == t[-1], tr.stats
        assert np.array_equal(np.concatenate([tr.q, tr.v], axis=1), plain()), f"{name} {method}"
    m = mirror.mirror_trajectory(s, hand, Start.of(q0, v0, tau), t, integrator="RK4")
    assert m.stats["status"] == "ok" and np.isfinite(m.q).all(), m.stats


def test_taylor_guard_leaves_the_reference_bit_for_bit():
    """The step callback only watches: the guarded Taylor solution equals an unguarded propagate_grid."""
    s = systems.load("double_pendulum_point")
    q0, v0, tau = start(s)
    t = integrate.time_grid(2.0, 0.01)
    states, meta = reference.taylor_solve(s, q0, v0, tau, t, precision="double")
    ta = reference.taylor_integrator(s, "double", None)
    ta.time, ta.state[:], ta.pars[:] = 0.0, np.concatenate([q0, v0]), tau
    outcome, *_, plain = ta.propagate_grid(t)
    assert "time_limit" in str(outcome) and np.array_equal(states, plain) and meta["steps"] > 0


def test_generated_code_is_not_shared_with_a_mutated_module_of_the_same_name():
    """fastpath's code lives in the System's memo, which dataclasses.replace does not share: the mutated
    module gets code generated from its own equations, and the original keeps its own."""
    original = systems.load("gimbal")
    f_original = fastpath.scalar_rhs(original)
    s = dataclasses.replace(original, equations=mutated(*FRICTION_SIGN).equations)
    assert s.memo is not original.memo  # once one dict shared by replace: the hazard this guarded against
    f_mutated = fastpath.scalar_rhs(s)
    y, tau = [0.0, 0.3, 1.0, 0.0], [0.0, 0.0]  # theta' = 0: only friction acts on psi
    assert f_mutated(0.0, y, tau)[2] == -f_original(0.0, y, tau)[2] != 0.0
    assert fastpath.scalar_rhs(original) is f_original
    assert reference.symbolic_dynamics(s) != reference.symbolic_dynamics(original)


def test_lockstep_mujoco_side_never_reports_a_reset_state():
    """A state from which MuJoCo warns and resets gives NaN rows in the lockstep, not zeros as data."""
    import numpy as np
    from lagrange_xval import systems
    from lagrange_xval.dynamics import mirror
    from lagrange_xval.sources import make_source

    source = make_source(systems.load("double_pendulum_point"), "mujoco")
    q = np.array([[0.1, 0.2], [0.1, 0.2]])
    v = np.array([[0.0, 0.0], [1e12, -1e12]])  # MuJoCo's bad-qacc warning, then its reset
    q1, v1 = mirror.mujoco_steps(source, q, v, np.zeros(2), Scheme("Euler", 0.001), steps=3)
    assert np.all(np.isfinite(q1[0])) and np.all(np.isfinite(v1[0]))
    assert np.all(np.isnan(q1[1])) and np.all(np.isnan(v1[1]))

"""The checks can fail: deliberately wrong equations and a sign-flipped coordinate are caught."""

from __future__ import annotations

import types

import numpy as np
from lagrange_xval import systems
from lagrange_xval.forms import Implicit, stack_vector
from lagrange_xval.sources import make_sources
from lagrange_xval.verdict import judge
from lagrange_xval.verdict import pointwise as compare


def _with(system, **replaced):
    module = types.ModuleType(system.equations.__name__ + "_wrong")
    module.__dict__.update(vars(system.equations))
    module.__dict__.update(replaced)
    return systems.System(name=system.name, mjcf=system.mjcf, equations=module)


def _failed_quantities(system):
    states = compare.random_states(system, n=200, seed=1)
    rows = compare.compare(compare.evaluate(make_sources(system), states), states)
    return {r["quantity"] for r in rows if not r["passed"] and r["pair"].startswith("hand")}


def test_a_wrong_gravity_term_is_caught_and_named():
    s = systems.load("double_pendulum_point")
    eq = s.equations
    wrong = _with(s, bias=lambda p, q, v: eq.bias(p, q, v) * np.array([1.0, 0.5]) + 0 * q)
    failed = _failed_quantities(wrong)
    assert {"bias", "qacc", "tau_inverse"} <= failed
    assert "M" not in failed


def test_a_wrong_mass_matrix_is_caught_and_named():
    s = systems.load("double_pendulum_point")
    eq = s.equations
    wrong = _with(s, mass_matrix=lambda p, q: eq.mass_matrix(p, q) * 1.001)
    failed = _failed_quantities(wrong)
    assert "M" in failed and "qacc" in failed


def test_both_angles_flipped_is_caught_by_body_positions():
    """A global sign flip leaves M and q'' alike; only the body positions show it."""
    s = systems.load("double_pendulum_point")
    eq = s.equations
    flipped = _with(s, body_positions=lambda p, q: eq.body_positions(p, -q))
    failed = _failed_quantities(flipped)
    assert "body_positions" in failed
    assert "M" not in failed and "qacc" not in failed


def test_the_judge_finds_a_wrong_printed_form_and_its_term():
    s = systems.load("double_pendulum_point")

    def residual(p, q, v, a, tau):  # gravity with the wrong sign in the second row
        good = s.equations.VARIANTS[0].residual(p, q, v, a, tau)
        g = p.g / p.l * np.sin(q[..., 0] + q[..., 1])
        return good - stack_vector([0 * g, 2 * g])

    bad = Implicit(
        name="deliberately wrong",
        notes_equations=("test",),
        residual=residual,
        row_scale=s.equations.VARIANTS[0].row_scale,
    )
    states = compare.random_states(s, n=100, seed=2)
    terms = judge.EngineTerms(s, make_sources(s), states)
    verdict = judge.judge_variant(s, bad, terms, states)
    assert verdict["verdict"] == "disagrees"
    assert verdict["first_disagreeing_term"] == "gravity"

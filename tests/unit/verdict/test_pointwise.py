"""Four sources (hand, MuJoCo, Pinocchio, symbolic), every quantity, every pair, at 1000 seeded random states.

One test per quantity so a failure names the term; the assertion message names the pair, the
error and the worst state.
"""

from __future__ import annotations

import itertools

import pytest
from lagrange_xval.core.tolerances import QUANTITY_TIER
from lagrange_xval.sources import SOURCE_NAMES
from lagrange_xval.verdict import pointwise as compare

from ...conftest import evaluated


def _failures(system, quantity):
    states, _, values = evaluated(system)
    rows = [r for r in compare.compare(values, states) if r["quantity"] == quantity]
    assert {r["pair"] for r in rows} == {f"{a}~{b}" for a, b in itertools.combinations(sorted(SOURCE_NAMES), 2)}
    return [r for r in rows if not r["passed"]]


@pytest.mark.parametrize("quantity", sorted(QUANTITY_TIER))
def test_sources_agree(system, quantity):
    bad = _failures(system, quantity)
    assert not bad, "; ".join(
        f"{system.name} {quantity} {r['pair']}: scaled error {r['scaled']:.2e} > {r['tolerance']:.0e} "
        f"(max abs {r['max_abs']:.2e}) at {r['worst_state']}"
        for r in bad
    )


def test_mass_matrix_is_symmetric_positive_definite(system):
    import numpy as np

    _, _, values = evaluated(system)
    M = values["hand"]["M"]
    assert np.abs(M - np.swapaxes(M, -1, -2)).max() == 0.0
    assert np.linalg.eigvalsh(M).min() > 0.0


def test_solve_tier_grows_with_conditioning_but_not_below_its_floor():
    """An ill-conditioned state gets cond(M)-scaled room; a well-conditioned one keeps the tier."""
    import numpy as np
    from lagrange_xval.core.tolerances import TOLERANCES

    solve = TOLERANCES.solve
    assert solve.at(1.0) == solve.rtol
    assert solve.at(1e12) == pytest.approx(20 * 1e12 * 2.220446049250313e-16)
    states = compare.States(np.zeros((2, 2)), np.zeros((2, 2)), np.zeros((2, 2)))
    a, b = np.array([[1.0, 0.0], [1.0, 0.0]]), np.array([[1.0, 0.0], [1.0 + 1e-6, 0.0]])
    tight = compare.error_row("qacc", "x~y", a, b, states, tier="solve", cond=np.array([1.0, 10.0]))
    loose = compare.error_row("qacc", "x~y", a, b, states, tier="solve", cond=np.array([1.0, 1e10]))
    assert not tight["passed"] and loose["passed"]

"""Three sources, every quantity, every pair, at 1000 seeded random states.

One test per quantity so a failure names the term; the assertion message names the pair, the
error and the worst state.
"""

from __future__ import annotations

import pytest

from lagrange_xval.validate import compare
from lagrange_xval.validate.tolerances import QUANTITY_TIER

from .conftest import evaluated


def _failures(system, quantity):
    states, _, values = evaluated(system)
    rows = [r for r in compare.compare(values, states) if r["quantity"] == quantity]
    assert len(rows) == 3, "three pairs of sources"
    return [r for r in rows if not r["passed"]]


@pytest.mark.parametrize("quantity", sorted(QUANTITY_TIER))
def test_sources_agree(system, quantity):
    bad = _failures(system, quantity)
    assert not bad, "; ".join(
        f"{system.name} {quantity} {r['pair']}: scaled error {r['scaled']:.2e} > {r['tolerance']:.0e} "
        f"(max abs {r['max_abs']:.2e}) at {r['worst_state']}" for r in bad)


def test_mass_matrix_is_symmetric_positive_definite(system):
    import numpy as np

    _, _, values = evaluated(system)
    M = values["hand"]["M"]
    assert np.abs(M - np.swapaxes(M, -1, -2)).max() == 0.0
    assert np.linalg.eigvalsh(M).min() > 0.0

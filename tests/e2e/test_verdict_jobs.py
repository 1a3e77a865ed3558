"""The whole end-to-end jobs (marker `long`) of verdict/; their helpers stay with the unit tests in
tests/unit/verdict/."""

from __future__ import annotations

import pytest
from lagrange_xval.stages import pipeline

from tests.unit.verdict.test_no_false_alarm import SHORT, _failures, held_out, with_params


@pytest.mark.long
@pytest.mark.parametrize(
    "make",
    [
        pytest.param(lambda: held_out("double_pendulum_bars", 1), id="bars-held-out-1"),
        pytest.param(lambda: with_params("double_pendulum_point", m1=1 / 50), id="point-mass-1to50"),
    ],
)
def test_right_derivation_passes_every_stage(make):
    """The cases that raised false alarms (a held-out bars model over 10 s; a 1:50 mass ratio, whose
    chaos stage diverged) pass every stage."""
    result = pipeline.run_system(make(), **SHORT)
    assert result["passed"], _failures(result)

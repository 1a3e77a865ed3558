"""The whole end-to-end jobs (marker `long`) of symbolic/; their helpers stay with the unit tests in
tests/unit/symbolic/."""

from __future__ import annotations

import pytest

from tests.unit.symbolic.test_derivation import EXAMPLES, _cli


@pytest.mark.long
def test_derive_urdf_arm_latex_and_bad_input(tmp_path):
    urdf = EXAMPLES / "urdf" / "spatial_arm.urdf"
    done = _cli("derive", "--model", str(urdf), "--latex", "--coordinates", "q1,q2,q3")
    assert done.returncode == 0, done.stderr
    assert r"\ddot{q_{3}}" in done.stdout or r"\ddot{q}_{3}" in done.stdout
    assert "M[q1, q3] = " in done.stdout
    bad = _cli("derive", "--model", str(urdf), "--coordinates", "a,b")
    assert bad.returncode != 0 and "--coordinates needs 3 distinct names" in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1
    none = _cli("derive")
    assert none.returncode != 0 and "give --model PATH" in none.stderr

"""The whole end-to-end jobs (marker `long`) of core/; their helpers stay with the unit tests in
tests/unit/core/."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.unit.core.test_guard import _cli


@pytest.mark.long
def test_derive_of_a_chain_beyond_three_joints_is_exact_with_common_subexpressions(tmp_path: Path) -> None:
    """Beyond three joints `derive` does not simplify (minutes on a 6-joint arm): it says so on stderr
    and prints the exact equations with their common subexpressions, every term of M, C v and G named."""
    from lagrange_xval.studies.chains import chain_mjcf

    model = tmp_path / "chain4.xml"
    model.write_text(chain_mjcf(4, "spatial"))
    proc = _cli("derive", "--model", str(model))
    assert proc.returncode == 0, proc.stderr
    assert "4 joints; exact, not simplified" in proc.stderr
    out = proc.stdout
    assert "exact, not simplified: common subexpressions first" in out and "\nx0 = " in out
    names = [line.split(" = ")[0] for line in out.splitlines()]
    assert sum(n.startswith("M[") for n in names) == 10 and sum(n.startswith("G[") for n in names) == 4

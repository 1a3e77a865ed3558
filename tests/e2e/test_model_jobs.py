"""The whole end-to-end jobs (marker `long`) of model/; their helpers stay with the unit tests in
tests/unit/model/."""

from __future__ import annotations

import shutil

import pytest

from tests.unit.model.test_urdf import EQUATIONS, URDF, _cli


@pytest.mark.long
def test_run_on_a_urdf_outside_the_repository(tmp_path):
    """`run --model MY.urdf --equations MY.py --out DIR` from a folder of one's own: right, it passes
    with the report (saying URDF, with the alignments) and the replay; with the damping of two joints
    swapped, it fails naming the term."""
    shutil.copy(URDF, tmp_path / "my_arm.urdf")
    shutil.copy(EQUATIONS, tmp_path / "my_arm.py")
    done = _cli("run", "--model", "my_arm.urdf", "--equations", "my_arm.py", "--out", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stderr + done.stdout
    report = (tmp_path / "out" / "report.md").read_text()
    assert "URDF `" in report and "MuJoCo motor, gear 2" in report
    assert (tmp_path / "out" / "my_arm.rrd").stat().st_size > 0
    text = EQUATIONS.read_text().replace("b = np.array([p.b1, p.b2, p.b3])", "b = np.array([p.b1, p.b3, p.b2])")
    (tmp_path / "my_arm.py").write_text(text)
    done = _cli("run", "--model", "my_arm.urdf", "--equations", "my_arm.py", "--out", "wrong", cwd=tmp_path)
    assert done.returncode == 1, done.stderr + done.stdout
    assert "friction disagrees" in done.stdout + done.stderr

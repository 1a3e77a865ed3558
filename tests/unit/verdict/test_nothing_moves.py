"""A model in which no joint moves (a scene, a prop, a robot whose every joint is fixed) is a verdict,
not a refusal (issue 42: a verdict on every model MuJoCo loads): it has no equations of motion, and the
verdict says so, naming the readers that read it; `run` integrates nothing; `derive` and `new`, which
write equations, refuse it in one line and write nothing."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from lagrange_xval.cli import main

FIXED = """<mujoco model="prop"><worldbody>
  <body name="a" pos="0 0 1"><geom type="box" size=".1 .2 .3" mass="2"/>
    <body name="b" pos="0.5 0 0"><geom type="sphere" size=".1" mass="1"/></body>
  </body>
</worldbody></mujoco>"""

FIXED_URDF = """<robot name="prop"><link name="world"/>
  <link name="a"><inertial><mass value="2"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="w" type="fixed"><parent link="world"/><child link="a"/><origin xyz="0 0 1"/></joint>
</robot>"""


@pytest.mark.parametrize(("name", "text"), [("prop.xml", FIXED), ("prop.urdf", FIXED_URDF)])
def test_a_model_in_which_nothing_moves_gets_a_verdict_naming_its_readers(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, text: str
) -> None:
    path = tmp_path / name
    path.write_text(text)
    status = main(["check", "--model", str(path), "--states", "3", "--probes", "0", "--json"])
    verdict = json.loads(capsys.readouterr().out)["verdict"]
    statement = verdict["statement"]
    assert status == 0 and verdict["passed"] is True, statement
    assert "no joint moves" in statement and "no equations of motion" in statement
    assert "MuJoCo" in statement and "Pinocchio" in statement
    assert "derived equations" not in statement  # MuJoCo's numbers, no reader of the file


def test_run_on_a_model_in_which_nothing_moves_integrates_nothing(tmp_path: Path) -> None:
    path = tmp_path / "prop.xml"
    path.write_text(FIXED)
    out = tmp_path / "out"
    assert main(["run", "--model", str(path), "--states", "3", "--probes", "0", "--no-replay", "--out", str(out)]) == 0
    (result,) = json.loads((out / "results.json").read_text())["systems"].values()
    assert result["passed"] is True and result["trajectories"] is None
    assert result["stages"]["trajectories"] == {"outcome": "not run: no joint moves"}


@pytest.mark.parametrize("command", ["derive", "new"])
def test_derive_and_new_refuse_a_model_in_which_nothing_moves(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    path = tmp_path / "prop.xml"
    path.write_text(FIXED)
    args = ["derive", "--model", str(path)] if command == "derive" else ["new", "prop_eq", "--model", str(path)]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no joint moves" in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["prop.xml"]  # nothing written

"""Two files of one robot whose joints are named differently (issue 43): matched by structure, not by force.

The arm is a URDF written here (four hinges and a hand, a two-finger gripper welded or sliding); its twin
is the MJCF MuJoCo writes from a copy with other joint and link names (mj_saveLastXML, as
tests/unit/audit/test_audit.py's `_saved`), or a URDF mounted elsewhere in the world. A different robot
is examples/urdf/spatial_arm.urdf (three joints, other lengths).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from lagrange_xval.audit import matching, twofiles
from lagrange_xval.cli import main
from lagrange_xval.core.errors import HarnessError

ROOT = Path(__file__).resolve().parents[3]
SPATIAL = ROOT / "examples/urdf/spatial_arm.urdf"
OURS = ("j1", "j2", "j3", "j4", "finger_l", "finger_r")
THEIRS = ("panda_joint1", "panda_joint2", "panda_joint3", "panda_joint4", "panda_finger_joint1", "panda_finger_joint2")
# (parent, child, origin xyz, axis, mass, centre of mass): the four arm joints
ARM = (
    ("base", "l1", "0 0 0.1", "0 0 1", 1.2, "0 0 0.1"),
    ("l1", "l2", "0 0 0.2", "0 1 0", 1.0, "0.15 0 0"),
    ("l2", "l3", "0.3 0 0", "0 1 0", 0.8, "0.12 0 0.01"),
    ("l3", "hand", "0.25 0 0", "1 0 0", 0.4, "0.05 0.01 0"),
)


def _inertial(mass: float, com: str) -> str:
    return (
        f'<inertial><origin xyz="{com}"/><mass value="{mass}"/>'
        '<inertia ixx="0.004" ixy="0" ixz="0" iyy="0.005" iyz="0" izz="0.003"/></inertial>'
    )


def arm(names: tuple[str, ...] = OURS, gripper: str = "prismatic", links: str = "",
        mass: dict[int, float] | None = None, mount: str = "", turn: float = 0.0) -> str:  # fmt: skip
    """The arm as a URDF: joints named `names`, links prefixed `links`, the fingers `gripper` (or none),
    masses overridden by joint index, the base on a fixed mount at `mount` (xyz) turned `turn` rad about z."""
    mass = mass or {}
    out = [f'<robot name="arm"><link name="{links}base"/>']
    if mount:
        out.append(
            f'<link name="world"/><joint name="mount" type="fixed"><parent link="world"/>'
            f'<child link="{links}base"/><origin xyz="{mount}" rpy="0 0 {turn!r}"/></joint>'
        )
    for i, (parent, child, xyz, axis, m, com) in enumerate(ARM):
        out.append(
            f'<joint name="{names[i]}" type="revolute"><parent link="{links}{parent}"/><child link="{links}{child}"/>'
            f'<origin xyz="{xyz}"/><axis xyz="{axis}"/><limit lower="-2" upper="2" effort="10" velocity="1"/></joint>'
            f'<link name="{links}{child}">{_inertial(mass.get(i, m), com)}</link>'
        )
    if gripper:
        for k, side in ((4, 1), (5, -1)):
            kind = f'type="{gripper}"' + ('><axis xyz="0 1 0"/><limit lower="0" upper="0.04" effort="5" velocity="1"/'
                                          if gripper == "prismatic" else "")  # fmt: skip
            out.append(
                f'<joint name="{names[k]}" {kind}><parent link="{links}hand"/><child link="{links}finger{k}"/>'
                f'<origin xyz="0.08 {0.02 * side} 0"/></joint>'
                f'<link name="{links}finger{k}">{_inertial(0.05, "0.02 0 0")}</link>'
            )
    return "".join(out) + "</robot>"


def _saved(tmp_path: Path, text: str, name: str) -> Path:
    """The MJCF MuJoCo writes (mj_saveLastXML) from a URDF."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(text)
    path = tmp_path / name
    mujoco.mj_saveLastXML(str(path), model)
    return path


def _file(tmp_path: Path, text: str, name: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_renamed_twin_is_matched_by_structure_and_agrees(tmp_path, capsys):
    a = _file(tmp_path, arm(), "arm.urdf")
    b = _saved(tmp_path, arm(THEIRS, links="panda_"), "panda.xml")
    result = twofiles.compare(a, b)
    assert result["joint_map"] == dict(zip(OURS, THEIRS, strict=True)), result["joint_map"]
    assert set(result["match"]["joints"].values()) == {"anchor, axis, tree"}
    assert result["match"]["how"] == "structure" and result["match"]["of"] == (6, 6)
    assert result["passed"] and result["unmatched_joints"] == {"A": [], "B": []}, result["findings"]
    assert result["unmatched_bodies"] == {"A": [], "B": []}
    assert main(["audit", str(a), str(b)]) == 0
    out = capsys.readouterr().out
    assert "joints matched by structure (anchor, axis, tree), 6 of 6: j1 = panda_joint1, j2 = panda_joint2" in out
    assert "the two files describe the same robot" in out


def test_a_changed_mass_is_named_in_both_files_names(tmp_path):
    a = _file(tmp_path, arm(), "arm.urdf")
    b = _saved(tmp_path, arm(THEIRS, links="panda_", mass={2: 0.9}), "panda.xml")
    result = twofiles.compare(a, b)
    assert not result["passed"] and len(result["joint_map"]) == 6
    gravity = [f for f in result["findings"] if "gravity torque" in f]
    assert gravity and gravity[0].startswith("j2 (B: panda_joint2) gravity torque differs by up to"), gravity
    assert "the group joint j3 (B: panda_joint3) moves (links l3 (B: panda_l3)): mass 0.8 kg in A, 0.9 kg" in gravity[0]


def test_a_gripper_only_one_file_moves_is_a_partial_match_that_agrees_on_the_arm(tmp_path, capsys):
    """A welds the fingers (the same masses, where B's sliding fingers sit at their reference)."""
    a = _file(tmp_path, arm(gripper="fixed"), "arm.urdf")
    b = _saved(tmp_path, arm(THEIRS, links="panda_"), "panda.xml")
    result = twofiles.compare(a, b)
    assert result["joint_map"] == dict(zip(OURS[:4], THEIRS[:4], strict=True))
    assert result["match"]["matched"] == 4 and result["match"]["of"] == (4, 6)
    assert result["unmatched_joints"] == {"A": [], "B": ["panda_finger_joint1", "panda_finger_joint2"]}
    assert result["passed"], result["findings"]
    assert main(["audit", str(a), str(b)]) == 0
    out = capsys.readouterr().out
    assert "partial match: 4 of 6 joints matched; joints only in B: panda_finger_joint1, panda_finger_joint2" in out


def test_two_different_robots_are_refused_not_matched_by_force(tmp_path, capsys):
    b = _file(tmp_path, arm(), "arm.urdf")
    with pytest.raises(HarnessError, match=r"no structural match: A has 3 joints, B 6.*--map A=B"):
        twofiles.compare(SPATIAL, b)
    assert main(["audit", str(SPATIAL), str(b)]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and "two different robots" in err and "--map" in err, err


def test_joints_of_one_name_that_turn_about_other_axes_are_two_robots(tmp_path, capsys):
    """A name is a hint: two files whose joints share names (joint1 ... joint6 of two arms, pybullet's xArm6
    against example-robot-data's xArm7) but mostly turn about other axes are refused, as are files of as many
    joints paired by their place in the tree alone (a cart-pole against a gripper, both named "physics")."""
    a = _file(tmp_path, arm(), "arm.urdf")
    other = (
        arm()
        .replace('<axis xyz="0 1 0"/>', '<axis xyz="0 0 1"/>')
        .replace('<axis xyz="1 0 0"/>', '<axis xyz="0 0 1"/>')
    )
    b = _file(tmp_path, other, "other.urdf")
    with pytest.raises(HarnessError, match=r"no structural match: A has 6 joints, B 6, and only 1 of the 6 joints"):
        twofiles.compare(a, b)
    assert main(["audit", str(a), str(b)]) == 2
    assert "--map" in capsys.readouterr().err
    assert twofiles.compare(a, _file(tmp_path, arm(), "same.urdf"))["passed"]  # the same arm still agrees


def test_a_map_compares_them_anyway_and_overrides_the_structure(tmp_path, capsys):
    b = _file(tmp_path, arm(), "arm.urdf")
    assert main(["audit", str(SPATIAL), str(b), "--map", "yaw=j1, shoulder=j2,elbow=j3", "--json"]) == 1
    import json

    result = json.loads(capsys.readouterr().out)
    assert result["joint_map"] == {"yaw": "j1", "shoulder": "j2", "elbow": "j3"}
    assert result["match"]["how"] == "map" and set(result["match"]["joints"].values()) == {"map"}
    a = _file(tmp_path, arm(), "a.urdf")
    twin = _saved(tmp_path, arm(THEIRS, links="panda_"), "panda.xml")
    crossed = twofiles.compare(a, twin, joint_map={"j2": "panda_joint3", "j3": "panda_joint2"})
    assert crossed["joint_map"]["j2"] == "panda_joint3" and crossed["match"]["joints"]["j2"] == "map"
    assert not crossed["passed"] and any(f.startswith("j2 (B: panda_joint3)") for f in crossed["findings"])


@pytest.mark.parametrize(
    ("given", "said"),
    [
        ("j1=nope", "--map j1=nope: no joint 'nope' in B; its joints: panda_joint1, panda_joint2"),
        ("nope=panda_joint1", "--map nope=panda_joint1: no joint 'nope' in A; its joints: j1, j2"),
        ("j1", "--map: 'j1' is not A=B; the form is --map A_JOINT=B_JOINT,..."),
        ("j1=panda_joint1,,", "--map: '' is not A=B; the form is"),
        ("j1=panda_joint1,j2=panda_joint1", "--map: B's joint 'panda_joint1' is given twice"),
    ],
)
def test_a_bad_map_is_one_error_line(tmp_path, capsys, given, said):
    a = _file(tmp_path, arm(), "arm.urdf")
    b = _saved(tmp_path, arm(THEIRS, links="panda_"), "panda.xml")
    assert main(["audit", str(a), str(b), "--map", given]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and said in err, err


def test_a_map_with_one_file_is_refused(tmp_path, capsys):
    a = _file(tmp_path, arm(), "arm.urdf")
    assert main(["audit", str(a), "--map", "j1=j1"]) == 2
    assert "--map pairs the joints of two files" in capsys.readouterr().err


def test_a_robot_mounted_elsewhere_is_matched_and_the_offset_said(tmp_path, capsys):
    a = _file(tmp_path, arm(), "arm.urdf")
    b = _file(tmp_path, arm(THEIRS, mount="0.3 -0.2 0.5"), "mounted.urdf")
    result = twofiles.compare(a, b)
    assert np.allclose(result["match"]["offset"], [0.3, -0.2, 0.5]) and len(result["joint_map"]) == 6
    assert result["passed"], result["findings"]
    assert main(["audit", str(a), str(b)]) == 0
    assert "the two files place the robot differently in the world" in capsys.readouterr().out


def test_a_robot_turned_a_quarter_about_the_vertical_is_matched_and_the_turn_said(tmp_path, capsys):
    a = _file(tmp_path, arm(), "arm.urdf")
    b = _file(tmp_path, arm(THEIRS, mount="1 2 0.75", turn=np.pi / 2), "turned.urdf")
    result = twofiles.compare(a, b)
    assert abs(result["match"]["yaw"] - 90.0) < 1e-6 and np.allclose(result["match"]["offset"], [1, 2, 0.75])
    assert set(result["match"]["joints"].values()) == {"anchor, axis, tree"}
    assert result["passed"], result["findings"]
    assert main(["audit", str(a), str(b)]) == 0
    assert "B's is A's turned 90 degrees about the vertical, then moved" in capsys.readouterr().out


def test_same_names_are_matched_by_name_as_before(tmp_path):
    a = _file(tmp_path, arm(), "arm.urdf")
    result = twofiles.compare(a, _saved(tmp_path, arm(), "arm.xml"))
    assert result["match"]["how"] == "name" and result["matched_joints"] == list(OURS)
    assert twofiles.lines(result)[1] == f"  matched by name: 6 joints ({', '.join(OURS)})"


def test_name_tokens_are_a_hint_without_the_usual_words():
    assert matching.tokens("FR_hip_joint") == {"fr", "hip"} == matching.tokens("FR_hip_leg_joint") - {"leg"}
    assert matching.tokens("panda_joint01") == {"panda", "1"} and matching.tokens("joint1") == {"1"}

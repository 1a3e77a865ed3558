"""The model audit (issue 29): MuJoCo, Pinocchio and Drake read the same file; where they differ the
reader in the minority is named with the mass-matrix consequence. Faults are planted in copies of
example-robot-data's UR5; where all three readers agree on a fault, the test says so. A fault planted
in one reader's input only proves that the minority is named correctly."""

from __future__ import annotations

import importlib.util
import os
import re
from pathlib import Path

import pytest
from lagrange_xval.validate.checks import audit
from lagrange_xval.validate.cli import main
from lagrange_xval.validate.errors import HarnessError
from lagrange_xval.validate.systems import System, load
from lagrange_xval.validate.systems.urdf import robots_folder

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = robots_folder() or ROOT / "example-robot-data not installed"
pytestmark = [
    pytest.mark.skipif(
        importlib.util.find_spec("pydrake") is None and os.environ.get("CI") != "true", reason="pydrake not installed"
    ),
    pytest.mark.skipif(not ROBOTS.is_dir() and os.environ.get("CI") != "true", reason="example-robot-data missing"),
]
UR5 = ROBOTS / "ur_description/urdf/ur5_robot.urdf"
FOREARM = """<origin rpy="0 0 0" xyz="0.0 0.0 0.25"/>
      <inertia ixx="0.049443313556" ixy="0.0" ixz="0.0" iyy="0.049443313556" iyz="0.0" izz="0.004095"/>"""
TILTED = """<origin rpy="0.3 0.2 0.1" xyz="0.0 0.0 0.25"/>
      <inertia ixx="0.05" ixy="0" ixz="0" iyy="0.04" iyz="0" izz="0.03"/>"""
TOOL = """<link name="tool_a"><inertial><mass value="0.7"/><origin rpy="0.4 0 0.2" xyz="0.01 0.02 0.05"/>
<inertia ixx="0.003" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.0015"/></inertial></link>
<joint name="tool_a_joint" type="fixed"><parent link="wrist_3_link"/><child link="tool_a"/>
<origin xyz="0 0.1 0" rpy="0.5 0 0.3"/></joint>
<link name="tool_b"/>
<joint name="tool_b_joint" type="fixed"><parent link="tool_a"/><child link="tool_b"/><origin xyz="0 0 0.1"/></joint>
</robot>"""


def _copy(tmp_path: Path, name: str, text: str) -> System:
    path = tmp_path / f"{name}.urdf"
    path.write_text(text)
    return System.model_only(path)


def _ur5() -> str:
    text = UR5.read_text()
    assert FOREARM in text, "the UR5's forearm inertial changed: update the planted faults"
    return text


def _differing(result: dict) -> dict[str, str | None]:
    return {r["key"]: r.get("minority") for r in result["rows"] if not r["agree"]}


@pytest.mark.parametrize(
    ("path", "locked"),
    [
        ("ur_description/urdf/ur5_robot.urdf", ()),
        ("panda_description/urdf/panda.urdf", ("panda_finger_joint1", "panda_finger_joint2")),
        ("double_pendulum_description/urdf/double_pendulum.urdf", ()),
    ],
    ids=["ur5", "panda", "double_pendulum"],
)
def test_the_real_robots_are_read_alike_by_three_readers(path, locked):
    """UR5, Panda and the double pendulum: every field the dynamics use agrees; M within 1e-13."""
    result = audit.audit(System.model_only(ROBOTS / path, locked=locked))
    assert result["readers"] == ["mujoco", "pinocchio", "drake"] and result["passed"], result["findings"]
    assert max(result["mass_matrix"]["max_abs"].values()) < 1e-13
    # The double pendulum's revolute joints have <limit> without lower/upper (0, 0): Pinocchio and Drake
    # read [0, 0], MuJoCo no limit; information only (every engine's limits are off here).
    assert set(_differing(result).values()) <= {"mujoco"}
    assert all(k.endswith("/limits") for k in _differing(result))


def test_an_inertial_rpy_is_read_alike_by_all_three(tmp_path):
    """A rotated inertial frame (MuJoCo's URDF reader once dropped it, mujoco issue 3559): MuJoCo 4.0.0,
    Pinocchio and Drake all apply it, so the audit finds agreement."""
    result = audit.audit(_copy(tmp_path, "tilted", _ur5().replace(FOREARM, TILTED)))
    assert result["passed"] and not result["findings"]


def test_a_dropped_rpy_in_one_readers_input_names_that_reader(tmp_path):
    """MuJoCo given the copy without the rpy: MuJoCo named, the cause guessed, the M gap shown."""
    tilted = _copy(tmp_path, "tilted", _ur5().replace(FOREARM, TILTED))
    flat = _copy(tmp_path, "flat", _ur5().replace(FOREARM, TILTED.replace("0.3 0.2 0.1", "0 0 0")))
    result = audit.audit(tilted, inputs={"mujoco": flat})
    assert _differing(result) == {"body/forearm_link/inertia": "mujoco"}
    assert "MuJoCo reads forearm_link's inertia differently" in result["findings"][0]
    assert "rpy" in result["findings"][0] and "Pinocchio and Drake agree" in result["findings"][0]
    gaps = result["mass_matrix"]["max_abs"]
    assert gaps["mujoco~pinocchio"] > 1e-4 and gaps["mujoco~drake"] > 1e-4 and gaps["pinocchio~drake"] < 1e-13
    assert not result["passed"]


def test_a_fixed_joint_between_massive_links_and_a_link_without_inertial(tmp_path):
    """Two massive links welded (the wrist and a tilted tool) and a massless leaf: MuJoCo fuses, Pinocchio
    appends, Drake's spatial inertias are summed; all three agree on the composite (mujoco issue 2982)."""
    result = audit.audit(_copy(tmp_path, "tool", _ur5().replace("</robot>", TOOL)))
    assert result["passed"] and not result["findings"]
    plain = audit.audit(System.model_only(UR5))
    rows = {r["key"]: r["values"]["drake"] for r in result["rows"]}
    assert rows["body/wrist_3_link/mass"] == pytest.approx(
        {r["key"]: r["values"]["drake"] for r in plain["rows"]}["body/wrist_3_link/mass"] + 0.7
    )


def test_a_moving_link_without_inertial_is_refused_by_mujoco(tmp_path):
    """Pinocchio and Drake would read it massless; MuJoCo refuses a massless moving body: said so."""
    text = _ur5()
    i = text.index('<link name="forearm_link">')
    j = text.index("</link>", i)
    bare = text[:i] + re.sub(r"<inertial>.*?</inertial>", "", text[i:j], flags=re.S) + text[j:]
    with pytest.raises(HarnessError, match="MuJoCo cannot compile this URDF"):
        audit.audit(_copy(tmp_path, "bare", bare))


def test_a_mimic_joint_is_audited_with_its_coupling_left_out(tmp_path):
    """A <mimic> coupling is a constraint: left out of the readings' comparison, never a refusal."""
    text = _ur5().replace(
        '<joint name="wrist_3_joint" type="revolute">',
        '<joint name="wrist_3_joint" type="revolute"><mimic joint="wrist_2_joint" multiplier="1"/>',
    )
    system = _copy(tmp_path, "mimic", text)
    assert any("coupled to joint 'wrist_2_joint'" in line for line in system.left_out), system.left_out
    assert audit.audit(system)["passed"]


def test_damping_dropped_by_one_reader_names_it(tmp_path):
    """Pinocchio given the copy without the elbow's damping: Pinocchio named, 'damping dropped'."""
    text = _ur5()
    i = text.index('<joint name="elbow_joint"')
    damped = text[:i] + text[i:].replace('<dynamics damping="0.0"', '<dynamics damping="0.7"', 1)
    result = audit.audit(_copy(tmp_path, "damped", damped), inputs={"pinocchio": _copy(tmp_path, "plain", _ur5())})
    assert _differing(result) == {"joint/elbow_joint/damping": "pinocchio"}
    assert "damping dropped" in result["findings"][0]


def test_a_wrong_mass_in_drakes_input_names_drake(tmp_path):
    """Drake given a copy with the forearm at 1 kg: Drake named on the mass, and the M gap is Drake's."""
    heavy = _ur5().replace('<mass value="2.275"/>', '<mass value="1.0"/>', 1)
    result = audit.audit(System.model_only(UR5), inputs={"drake": _copy(tmp_path, "heavy", heavy)})
    assert _differing(result)["body/forearm_link/mass"] == "drake"
    gaps = result["mass_matrix"]["max_abs"]
    assert gaps["mujoco~drake"] > 1e-3 and gaps["mujoco~pinocchio"] < 1e-13


def test_an_mjcf_model_is_audited_too():
    result = audit.audit(load("double_pendulum_bars"))
    assert result["format"] == "mjcf" and result["passed"] and len(result["readers"]) == 3


def test_the_audit_command_prints_one_screen(capsys):
    assert main(["audit", str(UR5)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("audit: ur5_robot.urdf (URDF), read by MuJoCo, Pinocchio, Drake")
    assert "every field agrees" in out and len(out.splitlines()) <= 25

"""What each reader of a URDF is given where MuJoCo cannot compile the file as written.

- A valid URDF whose links are point masses (inertia 0) gets MuJoCo's floor (boundinertia 1e-12 per
  axis) for every reader: all read the same numbers, nothing differs, nothing is called a defect.
- A link that violates A + B >= C is the file's defect: MuJoCo alone is given the balanced tensor, so
  the readings differ, and the verdict names the defect as the file's (the link, the inequality) and
  who was given which numbers, not "Pinocchio reads the model otherwise than MuJoCo".
"""

from __future__ import annotations

from pathlib import Path

import lagrange_xval as lx
import numpy as np
from lagrange_xval.sources import make_source
from lagrange_xval.systems import System


def arm(inertia1: str, inertia2: str) -> str:
    """A 2-link URDF arm hanging along -z, both revolute joints about y."""
    return f"""<?xml version="1.0"?>
<robot name="two_link">
  <link name="base"/>
  <link name="link1">
    <inertial><origin xyz="0 0 -0.25"/><mass value="1.0"/><inertia {inertia1}/></inertial>
  </link>
  <link name="link2">
    <inertial><origin xyz="0 0 -0.2"/><mass value="0.5"/><inertia {inertia2}/></inertial>
  </link>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="link1"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="0" velocity="0"/>
  </joint>
  <joint name="j2" type="revolute">
    <parent link="link1"/><child link="link2"/><origin xyz="0 0 -0.5"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="0" velocity="0"/>
  </joint>
</robot>
"""


ZERO = 'ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"'
VALID = 'ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.001"'
TRIANGLE = 'ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.01"'  # 0.001 + 0.002 < 0.01


def _system(tmp_path: Path, text: str) -> System:
    path = tmp_path / "two_link.urdf"
    path.write_text(text)
    return System.model_only(path)


def test_point_masses_get_the_same_floor_for_every_reader_and_no_defect(tmp_path):
    """Inertia 0 on both links (point masses, a valid URDF): every reader's M is MuJoCo's to 1e-15,
    and the verdict passes without "the file has a defect"."""
    system = _system(tmp_path, arm(ZERO, ZERO))
    assert system.defects == [] and len(system.floors) == 2, system.floors
    q = np.random.default_rng(0).uniform(-3, 3, (10, 2))
    M_mj = make_source(system, "mujoco").mass_matrix(q)
    M_pin = make_source(system, "pinocchio").mass_matrix(q)
    assert np.abs(M_pin - M_mj).max() <= 1e-15, np.abs(M_pin - M_mj).max()
    result = lx.check(system, n_states=20, probes=0)
    assert result.passed, result.statement
    assert "defect" not in result.statement and "given to every reader" in result.statement, result.statement


def test_a_triangle_inequality_defect_is_named_as_the_files(tmp_path):
    """link1 violates A + B >= C; MuJoCo is given the balanced tensor, Pinocchio the file's: the verdict
    opens with the file's defect, the link and the inequality, and who got which numbers."""
    system = _system(tmp_path, arm(TRIANGLE, VALID))
    assert system.defective_bodies == {"link1": "link1"}
    result = lx.check(system, n_states=20, probes=0)
    text = result.statement
    assert not result.passed  # the readers were given different numbers: their dynamics differ
    assert text.startswith("the file has a defect: link 'link1': principal moments violate A + B >= C"), text
    assert "given to MuJoCo" in text and "Pinocchio reads it as written" in text, text
    assert "reads the model otherwise" not in text, text


def test_with_balance_inertia_every_reader_gets_the_balanced_tensor(tmp_path):
    """--balance-inertia: the same numbers for every reader, so the readings agree; the defect is still said."""
    path = tmp_path / "two_link.urdf"
    path.write_text(arm(TRIANGLE, VALID))
    result = lx.check(System.model_only(path, balance_inertia=True), n_states=20, probes=0)
    assert result.passed, result.statement
    assert "the file has a defect: link 'link1'" in result.statement and "every reader" in result.statement

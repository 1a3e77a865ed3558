"""URDF as well as MJCF (issue 12): MuJoCo compiles the URDF, Pinocchio reads it natively, the
model-parity check names every parameter on which the two readings differ, and a derivation is
checked against a URDF end to end from a folder outside the repository.

examples/urdf/spatial_arm.urdf is examples/spatial_arm.xml written as a URDF (continuous and
revolute joints with limits and effort, damping, transmissions, a massless base, geometry), so
that the same derivation, examples/spatial_arm.py, checks both.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import lagrange_xval as lx
import numpy as np
import pytest
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.sources.pinocchio import PinocchioSource
from lagrange_xval.systems import System, pairs_in
from lagrange_xval.verdict import modelsync

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
URDF = EXAMPLES / "urdf" / "spatial_arm.urdf"
EQUATIONS = EXAMPLES / "spatial_arm.py"


@pytest.fixture(scope="module")
def arm() -> System:
    return System.from_files(URDF, EQUATIONS)


def _urdf(tmp_path: Path, old: str = "", new: str = "", name: str = "arm") -> Path:
    text = URDF.read_text()
    if old:
        assert text.count(old) >= 1, old
        text = text.replace(old, new)
    path = tmp_path / f"{name}.urdf"
    path.write_text(text)
    return path


def test_mujoco_reads_the_urdf_as_the_mjcf_it_was_written_from(arm):
    """Every number MuJoCo compiles from the URDF equals the MJCF's, but the scene options URDF cannot
    state (MuJoCo's timestep and integrator are not model keys): the reading is not approximate."""
    mjcf = System.from_files(EXAMPLES / "spatial_arm.xml", EQUATIONS)
    assert arm.model_format == "urdf" and mjcf.model_format == "mjcf"
    assert arm.reads_urdf
    assert set(arm.view) == set(mjcf.view)
    for key in mjcf.view:
        a, b = arm.view[key], mjcf.view[key]
        if isinstance(b, str):
            assert a == b, key
        else:
            np.testing.assert_allclose(
                np.asarray(a, dtype=float), np.asarray(b, dtype=float), rtol=1e-13, atol=1e-15, err_msg=key
            )


def test_the_mjcf_derivation_passes_on_the_urdf_at_every_probe(arm):
    result = lx.check(arm, n_states=200, probes=4)
    result.assert_ok()
    model = result.data["model_checks"]
    assert model["passed"] and model["n_checked"] > 60
    text = "\n".join(model["alignments"])
    for named in ("link1", "shoulder, elbow", "yaw", "transmission of 'elbow_motor'", "gear 3", "gravity"):
        assert named in text, named
    assert {r.probe for r in result.rows if r.check == "derivation"} >= {0, 1, 2, 3, 4}


def test_parity_names_what_the_two_readings_disagree_on(arm):
    """A Pinocchio reading that differs in a mass, an axis, an anchor or a damping is named by key."""
    pin = PinocchioSource(arm)
    assert modelsync.check(arm, pin)["passed"]
    jid = pin.model.getJointId("elbow")
    pin.model.inertias[jid].mass = pin.model.inertias[jid].mass * 1.01
    pin.model.damping[pin.model.joints[jid].idx_v] = 0.5
    shoulder = pin.model.getJointId("shoulder")
    placement = pin.model.jointPlacements[shoulder]
    placement.translation = placement.translation + np.array([0.0, 0.0, 1e-6])
    pin.model.jointPlacements[shoulder] = placement
    keys = {m["key"] for m in modelsync.check(arm, pin)["mismatches"]}
    assert {"body/link3/mass", "joint/elbow/damping", "joint/shoulder/anchor", "joint/elbow/anchor"} <= keys
    assert "body/link1/mass" not in keys and "joint/yaw/anchor" not in keys


def test_a_mujoco_only_extension_is_named_as_a_parity_difference(tmp_path):
    """MuJoCo's URDF extension <compiler balanceinertia> changes an inertia Pinocchio keeps as
    written: the parity check names that body's inertia, and the alignments name the extension."""
    path = _urdf(
        tmp_path,
        'ixx="0.0136" iyy="0.0158" izz="0.0121"',
        'ixx="0.0036" iyy="0.0058" izz="0.0121"',
    )
    path.write_text(path.read_text().replace("</robot>", '<mujoco><compiler balanceinertia="true"/></mujoco></robot>'))
    system = System.from_files(path, EQUATIONS)
    result = modelsync.check(system, PinocchioSource(system))
    assert [m["key"] for m in result["mismatches"]] == ["body/link3/inertia"]
    assert any("balanceinertia" in a for a in result["alignments"])


@pytest.mark.parametrize(
    ("old", "new", "named"),
    [
        ('type="continuous"', 'type="floating"', "joint 'yaw' is a floating joint"),
        ('<mass value="1.7"/>', '<mass value="-1.7"/>', "MuJoCo cannot"),
        ("</robot>", "", "not well-formed XML"),
        ('<child link="link3"/>', '<child link="link9"/>', "MuJoCo cannot"),
    ],
)
def test_a_urdf_outside_scope_or_broken_is_one_line(tmp_path, old, new, named):
    with pytest.raises(HarnessError, match=named) as err:
        System.from_files(_urdf(tmp_path, old, new), EQUATIONS)
    assert "\n" not in str(err.value)


MIMIC = (
    '<link name="l4"><inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" '
    'iyz="0"/></inertial></link><joint name="wrist" type="revolute"><parent link="link3"/><child link="l4"/>'
    '<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/><mimic joint="elbow"/></joint>'
    "</robot>"
)


@pytest.mark.parametrize(
    ("old", "new", "named"),
    [
        ('<dynamics damping="0.23"/>', '<dynamics damping="0.23" friction="0.4"/>', "frictionloss) of 'shoulder'"),
        ("</robot>", MIMIC, "(joint 'wrist' coupled to joint 'elbow')"),
    ],
    ids=["friction", "mimic"],
)
def test_a_urdf_with_friction_or_a_mimic_joint_is_read_with_them_left_out(tmp_path, old, new, named):
    """Dry friction and a <mimic> coupling are constraints: named as left out, not refused, and every
    reader agrees on the chain without them."""
    system = System.model_only(_urdf(tmp_path, old, new))
    assert any(named in line for line in system.left_out), system.left_out
    assert lx.check(system, n_states=30).passed


def test_overrides_on_a_urdf_edit_its_mjcf_form(arm):
    """An override cannot be written into a URDF the engines read themselves: the system is then its
    MJCF form, written at full precision, with the override applied; the derivation still passes."""
    heavier = arm.with_overrides(body__link2__mass=2.0)
    assert not heavier.reads_urdf and heavier.model_format == "urdf"
    assert heavier.view["body/link2/mass"] == 2.0
    lx.check(heavier, n_states=100, probes=0).assert_ok()


def test_a_folder_pairs_urdf_files_too(tmp_path):
    shutil.copy(URDF, tmp_path / "arm.urdf")
    shutil.copy(EQUATIONS, tmp_path / "arm.py")
    assert pairs_in(tmp_path) == [(tmp_path / "arm.urdf", tmp_path / "arm.py")]
    shutil.copy(EXAMPLES / "spatial_arm.xml", tmp_path / "arm.xml")
    with pytest.raises(HarnessError, match="arm has both an .xml and a .urdf model"):
        pairs_in(tmp_path)


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "lagrange_xval.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_new_writes_a_module_for_a_urdf(tmp_path):
    """`new` reads a URDF's joints, bodies and motors, into a folder it creates if need be."""
    folder = tmp_path / "not" / "yet"
    done = _cli("new", "my_arm", "--model", str(URDF), "--dir", str(folder), cwd=tmp_path)
    assert done.returncode == 0, done.stderr + done.stdout
    text = (folder / "my_arm.py").read_text()
    for name in ("'yaw'", "'shoulder'", "'elbow'", "link3", "elbow_motor"):
        assert name in text, name


def test_random_states_stay_inside_the_joints_stated_limits(arm):
    """The URDF's <limit lower upper> narrows the draw (never its forces: limits are not compared)."""
    from lagrange_xval.verdict.pointwise import random_states

    ranges = arm.joint_ranges
    assert ranges[0].tolist() == [float("-inf"), float("inf")]  # the continuous yaw
    assert ranges[1].tolist() == [-2.5, 2.5] and ranges[2].tolist() == [-2.8, 2.8]
    q = random_states(arm, n=2000, seed=0).q
    assert np.all(np.abs(q[:, 1]) <= 2.5) and np.all(np.abs(q[:, 2]) <= 2.8)
    assert np.abs(q[:, 0]).max() > 2.9  # the unlimited joint keeps the full [-pi, pi]

"""Drake's parser where its death is one line (issue 42): Drake 1.51 aborts the process on an MJCF
`<inertial mass="0" diaginertia="0 0 0">`; the harness parses such a text in a child process first, so
that Drake is left out with "Drake cannot read it: ..." and MuJoCo, Pinocchio and the symbolic source
still judge. Each test runs in pytest's own process: were the guard missing, pytest would die with it."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest
from lagrange_xval.cli import main
from lagrange_xval.sources import make_sources
from lagrange_xval.sources.drakeparse import abort_line, may_abort
from lagrange_xval.systems import System

HAS_DRAKE = importlib.util.find_spec("pydrake") is not None
needs_drake = pytest.mark.skipif(not HAS_DRAKE and os.environ.get("CI") != "true", reason="pydrake not installed")

ZERO = """<mujoco model="zero">
  <worldbody>
    <body name="arm">
      <joint name="j" axis="0 1 0"/>
      <inertial pos="0 0 -0.5" mass="1" diaginertia="0.1 0.1 0.01"/>
      <body name="tool" pos="0 0 -1"><inertial pos="0 0 0" mass="{mass}" diaginertia="{inertia}"/></body>
    </body>
  </worldbody>
</mujoco>"""


def test_the_cheap_look_finds_a_massless_inertial_only() -> None:
    assert may_abort(ZERO.format(mass="0", inertia="0 0 0"), "xml")
    assert may_abort(ZERO.format(mass="0.0", inertia="1 1 1"), "xml")
    assert not may_abort(ZERO.format(mass="0.2", inertia="0 0 0"), "xml")
    assert not may_abort(ZERO.format(mass="0", inertia="0 0 0"), "urdf")  # Drake's URDF parser reads it


@needs_drake
def test_a_text_drake_dies_on_is_one_line_and_a_good_one_is_parsed_in_process() -> None:
    said = abort_line(ZERO.format(mass="0", inertia="0 0 0"), "xml")
    assert said.startswith("its parser ends the process") and "mass > 0" in said, said
    assert abort_line(ZERO.format(mass="0.2", inertia="0.001 0.001 0.001"), "xml") == ""


@needs_drake
def test_a_zero_mass_body_leaves_drake_out_and_the_others_judge(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "zero.xml"
    path.write_text(ZERO.format(mass="0", inertia="0 0 0"))
    sources = make_sources(System.model_only(path))
    assert {"mujoco", "pinocchio", "symbolic"} <= set(sources) and "drake" not in sources
    assert sources.skipped["drake"].startswith("zero.xml: Drake cannot read it: its parser ends the process")
    assert main(["check", "--model", str(path), "--states", "5", "--probes", "0"]) == 0
    out = capsys.readouterr().out
    assert "verdict: zero: pass" in out and "MuJoCo, Pinocchio and the derived equations agree" in out, out[-800:]


@needs_drake
def test_the_audit_leaves_drake_out_of_a_zero_mass_body(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "zero.xml"
    path.write_text(ZERO.format(mass="0", inertia="0 0 0"))
    main(["audit", str(path)])
    out = capsys.readouterr().out
    assert "Drake cannot read it: its parser ends the process" in out, out[-800:]


REVERSED = """<robot name="slider">
  <link name="base"/>
  <link name="cart"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>
  </inertial></link>
  <joint name="x" type="prismatic"><parent link="base"/><child link="cart"/><axis xyz="1 0 0"/>
    <limit lower="{lower}" upper="-1" effort="1" velocity="1"/></joint>
</robot>"""


@needs_drake
def test_a_reversed_urdf_limit_leaves_drake_out_naming_the_limit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """pybullet's "no limit" (lower 1, upper -1) aborts Drake's URDF parser: one reader left out, the
    cause named as the limit, the others judge; an ordered limit is parsed in process."""
    assert may_abort(REVERSED.format(lower="1"), "urdf") and not may_abort(REVERSED.format(lower="-2"), "urdf")
    path = tmp_path / "slider.urdf"
    path.write_text(REVERSED.format(lower="1"))
    assert main(["check", "--model", str(path), "--states", "5", "--probes", "0"]) == 0
    out = capsys.readouterr().out
    assert "Drake cannot read it: its parser ends the process" in out, out[-800:]
    assert "a joint <limit> whose lower bound is above its upper one" in out, out[-800:]

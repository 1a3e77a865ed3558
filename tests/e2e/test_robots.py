"""Models no one here wrote (issue 14): real robot URDFs shipped by the `example-robot-data` package
(in requirements.lock; nothing is downloaded at run time), read by MuJoCo and Pinocchio each with
its own parser, checked without a hand derivation: the readings' parity, and MuJoCo, Pinocchio (and
the derived equations, for chains short enough) pointwise within the tolerance tiers."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.model.urdf import robots_folder
from lagrange_xval.sources import SYMBOLIC_MAX_DOF, make_sources
from lagrange_xval.systems import System
from lagrange_xval.verdict import modelsync, pointwise

ROBOTS = robots_folder()
needs_robots = pytest.mark.skipif(
    ROBOTS is None and os.environ.get("CI") != "true",  # under CI the lock installs it: a missing one fails
    reason="example-robot-data is not installed (pip install -r requirements.lock)",
)

# (file, joints locked as a named step, moving joints expected)
ARMS = [
    ("ur_description/urdf/ur5_robot.urdf", (), 6),
    # the gripper's fingers: the second mimics the first (an equality constraint in MuJoCo's reading)
    ("panda_description/urdf/panda.urdf", ("panda_finger_joint1", "panda_finger_joint2"), 7),
    # its fingers are fixed joints with transmissions: the transmissions are ignored, and listed so
    ("kinova_description/robots/kinova.urdf", (), 6),
    ("double_pendulum_description/urdf/double_pendulum_continuous.urdf", (), 2),
]


@needs_robots
@pytest.mark.parametrize(("path", "locked", "dof"), ARMS, ids=[Path(a[0]).stem for a in ARMS])
def test_real_robots_engines_agree_and_every_alignment_is_named(path, locked, dof):
    assert ROBOTS is not None, "example-robot-data is not installed"
    system = System.model_only(ROBOTS / path, locked=locked)
    assert system.nv == dof and system.model_format == "urdf"
    sources = make_sources(system)
    assert ("symbolic" in sources) is (dof <= SYMBOLIC_MAX_DOF)
    parity = modelsync.check(system, sources["pinocchio"])
    assert parity["passed"], parity["mismatches"]
    assert parity["n_checked"] >= 5 * dof  # masses, centres, inertias, anchors, axes, damping
    text = "\n".join(parity["alignments"])
    assert ("joint limits of" in text or "continuous joint(s)" in text) and "geometry removed" in text
    if locked:
        assert f"joint(s) {', '.join(locked)} locked" in text
    states = pointwise.random_states(system, n=200, seed=1)
    rows = pointwise.compare(pointwise.evaluate(sources, states), states)
    assert {r["pair"] for r in rows} >= {"mujoco~pinocchio"}
    bad = [f"{r['quantity']} {r['pair']} {r['scaled']:.1e} > {r['tolerance']:.0e}" for r in rows if not r["passed"]]
    assert not bad, bad


@needs_robots
def test_a_mimic_joint_is_left_out_and_fixed_finger_transmissions_are_listed():
    assert ROBOTS is not None
    panda = System.model_only(ROBOTS / "panda_description/urdf/panda.urdf")
    assert any("(joint 'panda_finger_joint2' coupled to joint 'panda_finger_joint1')" in x for x in panda.left_out)
    with pytest.raises(HarnessError, match="no joint 'nope' to lock"):
        System.model_only(ROBOTS / "panda_description/urdf/panda.urdf", locked=("nope",))
    kinova = System.model_only(ROBOTS / "kinova_description/robots/kinova.urdf")
    assert any("on the fixed joint 'j2s6s200_joint_finger_1' ignored" in a for a in kinova.alignments)


@needs_robots
def test_run_on_a_robot_urdf_alone_end_to_end(tmp_path, cli_run):
    """`lagrange-xval run --model ur5_robot.urdf --out DIR`: no equations module, report and replay."""
    assert ROBOTS is not None
    done, out = cli_run("--model", str(ROBOTS / ARMS[0][0]))
    assert done.returncode == 0, done.stdout + done.stderr
    report = (out / "report.md").read_text()
    assert "No derivation given: the engines' readings of the model and their dynamics compared" in report
    assert "URDF `" in report and "hand derivation" not in report  # issue 26: nothing of a derivation not given
    assert "no derivation given; MuJoCo, Pinocchio and Drake agree on the model and its dynamics" in done.stdout
    assert "made a MuJoCo motor" in report
    assert (out / "ur5_robot.rrd").stat().st_size > 0
    bad = subprocess.run(
        [
            *(sys.executable, "-m", "lagrange_xval.cli", "simulate", "--model", str(ROBOTS / ARMS[0][0])),
            *("--source", "mujoco", "--q0", "0", "--v0", "0", "--t-end", "1", "--dt-out", "0.1", "--out", "x.csv"),
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert bad.returncode != 0 and "take a model alone" in bad.stderr, bad.stderr


@pytest.mark.long
@needs_robots
@pytest.mark.parametrize(
    ("path", "lock"),
    [
        ("panda_description/urdf/panda.urdf", "panda_finger_joint1,panda_finger_joint2"),
        ("kinova_description/robots/kinova.urdf", ""),
    ],
    ids=["panda", "kinova"],
)
def test_run_the_other_arms_end_to_end(cli_run, path, lock):
    """The Panda with its fingers locked from the command line (a step the report lists) and the Kinova."""
    assert ROBOTS is not None
    done, out = cli_run("--model", str(ROBOTS / path), *(["--lock", lock] if lock else []))
    assert done.returncode == 0, done.stdout + done.stderr
    assert re.search(
        r"no derivation given; MuJoCo, Pinocchio(, Drake and the derived equations| and Drake) agree", done.stdout
    )
    report = (out / "report.md").read_text()
    if lock:
        assert "panda_finger_joint1, panda_finger_joint2 locked at zero" in report
    assert (out / f"{Path(path).stem}.rrd").stat().st_size > 0


@needs_robots
def test_run_on_ur5_compares_three_readers(cli_run):
    """`run --model ur5_robot.urdf`: Drake in the pointwise rows and the audit with three readers (the
    session's one run of the UR5, which test_run_on_a_robot_urdf_alone_end_to_end reads too)."""
    assert ROBOTS is not None
    done, out = cli_run("--model", str(ROBOTS / "ur_description/urdf/ur5_robot.urdf"))
    assert done.returncode == 0, done.stdout + done.stderr
    result = json.loads((out / "results.json").read_text())["systems"]["ur5_robot"]
    assert result["audit"]["readers"] == ["mujoco", "pinocchio", "drake"] and result["audit"]["passed"]
    pairs = {r["pair"] for r in result["pointwise"]["rows"]}
    assert {"drake~mujoco", "drake~pinocchio"} <= pairs
    assert "Model audit: three readers" in (out / "report.md").read_text()


@pytest.mark.long
@needs_robots
def test_the_panda_says_which_engine_departs_and_why(cli_run):
    """The Panda from 0.5 rad is chaotic (lambda of several 1/s): MuJoCo's RK4 at the URDF's 2 ms step is
    trusted only until its own error estimate passes 1e-3 rad, and its departure is expected (read from
    the session's one `run` of the Panda, which test_run_the_other_arms_end_to_end reads too)."""
    assert ROBOTS is not None
    lock = "panda_finger_joint1,panda_finger_joint2"
    done, out = cli_run("--model", str(ROBOTS / "panda_description/urdf/panda.urdf"), "--lock", lock)
    assert done.returncode == 0, done.stdout + done.stderr
    traj = json.loads((out / "results.json").read_text())["systems"]["panda"]["trajectories"]
    found = traj["trust"]
    assert found["lyapunov_exponent"] > 1.0 and found["predictability_horizon"] < 10.0, found
    mujoco = next(r for r in traj["runs"] if r["source"] == "mujoco")
    assert mujoco["trust"]["trusted_until"] < 10.0 and mujoco["trust"]["expected"] is True, mujoco["trust_statement"]

"""`--lock JOINTS` on every command that takes a model (issue 24 item 7): the joints of a --model URDF
made fixed at zero, the same step on `run`, `check`, `simulate`, `bench`, `stress`, `new` and
`derive`; `replay` locks what the results recorded. A bad name is one line before any work."""

from __future__ import annotations

from pathlib import Path

import pytest
from lagrange_xval.cli import main
from lagrange_xval.cli.parser import build_parser
from lagrange_xval.systems import System, from_key, key_of

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
ARM = EXAMPLES / "urdf" / "spatial_arm.urdf"
FILES = ["--model", str(ARM), "--equations", str(EXAMPLES / "spatial_arm.py")]
SIMULATE = ["--source", "hand", "--q0", "0,0,0", "--v0", "0,0,0", "--t-end", "1", "--dt-out", "0.5", "--out", "x.csv"]
COMMANDS = {
    "run": ["run", *FILES, "--no-replay"],
    "check": ["check", *FILES],
    "simulate": ["simulate", *FILES, *SIMULATE],
    "bench": ["bench", *FILES, "--quick"],
    "stress": ["stress", *FILES, "--quick"],
    "new": ["new", "mine", "--model", str(ARM)],
    "derive": ["derive", "--model", str(ARM)],
}


def _subcommands() -> dict[str, object]:
    parser = build_parser()
    (sub,) = [a for a in parser._actions if a.dest == "command"]
    return dict(sub.choices)  # type: ignore[attr-defined]


def test_every_command_that_takes_a_model_takes_lock():
    """Discovered from the parser, not listed: a command with --model has --lock, with one help."""
    helps = set()
    for name, sub in _subcommands().items():
        options = {o: a for a in sub._actions for o in a.option_strings}  # type: ignore[attr-defined]
        if "--model" in options:
            assert "--lock" in options, f"`{name}` takes --model but not --lock"
            helps.add(options["--lock"].help)
    assert len(helps) == 1, helps


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_an_unknown_joint_to_lock_is_one_line_before_any_work(command, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main([*COMMANDS[command], "--lock", "shoulder,nope"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no joint 'nope' to lock" in err[0], err
    assert list(tmp_path.iterdir()) == [], "something was written"


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["check", "simple_pendulum", "--lock", "theta"], "--lock takes joints of the --model URDF"),
        (["derive", "simple_pendulum", "--lock", "theta"], "--lock takes joints of the --model URDF"),
        (["derive", "--model", str(EXAMPLES / "acrobot.xml"), "--lock", "shoulder"], "joints of a URDF model"),
        (["check", *FILES, "--lock", "yaw,,elbow"], "not a comma-separated list of joint names"),
        (["check", *FILES, "--lock", "yaw,yaw"], "joint 'yaw' is named twice"),
    ],
    ids=["no-model", "derive-no-model", "mjcf", "empty-name", "twice"],
)
def test_lock_refusals_name_what_to_do(args, says, capsys):
    try:
        code = main(args)
    except SystemExit as exc:  # a value argparse refuses
        code = exc.code
    assert code == 2
    assert says in capsys.readouterr().err


def test_derive_lock_derives_the_locked_chain(capsys):
    """`derive --model URDF --lock yaw`: the equations of the two joints left."""
    assert main(["derive", "--model", str(ARM), "--lock", "yaw"]) == 0
    out = capsys.readouterr().out
    assert "M[shoulder, elbow] = " in out and "yaw" not in out


def test_a_locked_system_keeps_its_lock_in_the_workers():
    """bench and stress find a person's system again in a worker by its key: the lock travels with it."""
    system = System.from_files(ARM, EXAMPLES / "spatial_arm.py", locked=("elbow",))
    assert from_key(key_of(system)).locked == ("elbow",)
    assert from_key(key_of(System.from_files(ARM, EXAMPLES / "spatial_arm.py"))).locked == ()


def test_a_locked_urdf_takes_overrides_so_probes_can_move_it():
    """Overrides (and the probes, which are overrides) edit the locked URDF's MJCF form, locked."""
    system = System.model_only(ARM, locked=("elbow",))
    heavier = system.with_overrides(**{"body/link2/mass": 3.5})
    assert heavier.mujoco_model().nv == system.mujoco_model().nv == 2
    assert heavier.view["body/link2/mass"] == 3.5


def test_replay_locks_what_run_recorded(tmp_path, monkeypatch, capsys):
    """`run --lock` records the locked joints in results.json; `replay` reads the model with them
    locked again (without them the recorded trajectories would not fit the model's joints)."""
    import json

    monkeypatch.chdir(tmp_path)
    args = ["run", "--model", str(ARM), "--lock", "elbow", "--states", "50", "--probes", "0", "--out", "out"]
    assert main(args) == 0, capsys.readouterr().out[-2000:]
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    assert results["systems"]["spatial_arm"]["locked"] == ["elbow"]
    assert main(["replay", "spatial_arm", "--results", "out/results.json", "--save", "again.rrd"]) == 0
    assert (tmp_path / "again.rrd").stat().st_size > 0


WRIST = (
    '  <link name="link4"><inertial><origin xyz="0.05 0 0"/><mass value="0.2"/>'
    '<inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>\n'
    '  <joint name="wrist" type="revolute"><parent link="link3"/><child link="link4"/><origin xyz="0.34 0 0"/>'
    '<axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>\n</robot>'
)


def test_a_urdf_with_more_joints_than_the_equations_points_to_the_lock(tmp_path, capsys):
    """Issue 44: "has 4 degrees of freedom; equations/<module>.py has 3" named a file elsewhere and not the fix: the
    line names the module's own file and the --lock of the joints the equations leave out; with it, it passes."""
    arm = tmp_path / "arm4.urdf"
    arm.write_text(ARM.read_text().replace("</robot>", WRIST))
    files = ["--model", str(arm), "--equations", str(EXAMPLES / "spatial_arm.py"), "--states", "5", "--probes", "0"]
    assert main(["check", *files]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("arm4.urdf has 4 degrees of freedom; spatial_arm.py has 3 (yaw, shoulder, elbow); to "
                        "compare the joints your equations move, lock the others: --lock wrist."), err  # fmt: skip
    assert main(["check", *files, "--lock", "wrist"]) == 0

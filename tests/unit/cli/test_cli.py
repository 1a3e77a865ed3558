"""The command line: `check --json` schema, `simulate`, `list`, and bad input."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.cli import main

CLI = [sys.executable, "-m", "lagrange_xval.cli"]


def run_cli(*args, cwd=None):
    return subprocess.run([*CLI, *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=300)


def test_check_json_schema(tmp_path, capsys, system):
    n = system.nv
    states = [{"q": [0.1 * (i + 1)] * n, "v": [0.5] * n, "tau": [0.2] * n} for i in range(3)]
    states.append({"q": [0.3] * n, "v": [0.0] * n})  # tau optional
    path = tmp_path / "states.json"
    path.write_text(json.dumps(states))
    assert main(["check", system.name, "--states-file", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["system"] == system.name
    assert out["coordinates"] == list(system.coordinates)
    assert len(out["states"]) == 4
    assert out["states"][3]["tau"] == [0.0] * n
    for state in out["states"]:
        assert set(state) == {"q", "v", "tau", "sources"}
        assert set(state["sources"]) == {"hand", "mujoco", "pinocchio", "symbolic", "drake"}
        for src in state["sources"].values():
            assert set(src) == {"M", "bias", "qacc", "tau_inverse", "T", "V"}
            assert np.shape(src["M"]) == (n, n) and np.shape(src["qacc"]) == (n,)
            # inverse dynamics at the hand accelerations gives tau back
            assert np.allclose(src["tau_inverse"], state["tau"], rtol=0.0, atol=1e-9)
    assert out["passed"] is True
    assert set(out["max_disagreement"]) >= {"M", "bias", "qacc", "tau_inverse", "T", "V"}


def test_list_names_every_system(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in systems.system_names():
        assert name in out


def test_simulate_writes_csv_and_json(tmp_path):
    csv = tmp_path / "t.csv"
    assert (
        main(
            [
                "simulate",
                "double_pendulum_point",
                "--source",
                "mujoco",
                "--q0",
                "0,3",
                "--v0",
                "0,0",
                "--t-end",
                "0.5",
                "--dt-out",
                "0.01",
                "--out",
                str(csv),
            ]
        )
        == 0
    )
    lines = [line for line in csv.read_text().splitlines() if not line.startswith("#")]  # the header
    assert lines[0] == "t,theta,phi,dtheta,dphi" and len(lines) == 52
    js = tmp_path / "t.json"
    assert (
        main(
            [
                "simulate",
                "double_pendulum_point",
                "--source",
                "hand",
                "--q0",
                "0,3",
                "--v0",
                "0,0",
                "--t-end",
                "0.5",
                "--dt-out",
                "0.01",
                "--out",
                str(js),
            ]
        )
        == 0
    )
    rows = np.array(json.loads(js.read_text())["rows"])
    mj = np.loadtxt(lines[1:], delimiter=",")
    assert rows.shape == mj.shape == (51, 5)
    assert np.abs(rows[:, 1:3] - mj[:, 1:3]).max() < 1e-8  # MuJoCo RK4 at 1 ms vs DOP853 over 0.5 s


def simulate_args(*, source: str = "hand", q0: str = "0,0", v0: str = "0,0", out: str = "{tmp}/x.csv") -> list[str]:
    """A `simulate` command line that is valid but for the one argument a case changes."""
    return ["simulate", "double_pendulum_point", "--source", source, "--q0", q0, "--v0", v0,
            "--t-end", "1", "--dt-out", "0.1", "--out", out]  # fmt: skip


BAD_INPUT = {
    "unknown system": (["check", "dbl_pendulum"], "Did you mean"),
    "unknown source": (simulate_args(source="bullet"), "invalid choice"),
    "wrong length": (simulate_args(q0="0,0,0"), "2 values per state"),
    "NaN state": (simulate_args(q0="nan,0"), "not finite"),
    "infinite state": (simulate_args(v0="inf,0"), "not finite"),
    "bad output suffix": (simulate_args(out="{tmp}/x.txt"), ".csv or .json"),
    "missing states file": (["check", "double_pendulum_point", "--states-file", "{tmp}/none.json"], "not found"),
    "states not JSON": (["check", "double_pendulum_point", "--states-file", "{tmp}/garbage.json"], "not valid JSON"),
    "states NaN": (["check", "double_pendulum_point", "--states-file", "{tmp}/nan.json"], "not finite"),
    "states wrong length": (
        ["check", "double_pendulum_point", "--states-file", "{tmp}/short.json"],
        "list of 2 numbers",
    ),
    "states unknown key": (["check", "double_pendulum_point", "--states-file", "{tmp}/key.json"], "unknown keys"),
    "missing report results": (["report", "--out", "{tmp}/empty"], "not found"),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUT))
def test_bad_input_is_one_line_nonzero_and_writes_nothing(tmp_path, case):
    (tmp_path / "garbage.json").write_text("{not json")
    (tmp_path / "nan.json").write_text('[{"q": [NaN, 0], "v": [0, 0]}]')
    (tmp_path / "short.json").write_text('[{"q": [0], "v": [0, 0]}]')
    (tmp_path / "key.json").write_text('[{"q": [0, 0], "v": [0, 0], "qdd": [0, 0]}]')
    before = sorted(p.name for p in tmp_path.iterdir())
    args, expected = BAD_INPUT[case]
    proc = run_cli(*[a.replace("{tmp}", str(tmp_path)) for a in args], cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 or case == "unknown source", proc.stderr  # argparse prints its usage line first
    assert expected in proc.stderr
    assert "Traceback" not in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == before, "nothing may be written"


def test_malformed_mjcf_is_one_line(tmp_path):
    from lagrange_xval.core.errors import HarnessError

    bad = tmp_path / "broken.xml"
    bad.write_text("<mujoco><worldbody><body name='a'><joint type='hinge'/></body></worldbody>")
    with pytest.raises(HarnessError) as err:
        systems.compile_mjcf(bad)
    assert "broken.xml: not" in str(err.value) and "\n" not in str(err.value)
    not_a_model = tmp_path / "page.xml"
    not_a_model.write_text("<html><body/></html>")
    with pytest.raises(HarnessError, match=r"root element <html>, expected <mujoco> for MJCF or <robot> for URDF"):
        systems.compile_model(not_a_model)
    with pytest.raises(HarnessError, match="not found"):
        systems.compile_mjcf(tmp_path / "absent.xml")

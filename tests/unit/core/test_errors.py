"""One error boundary and strict input: every failure is one `lagrange-xval: error:` line and status 2,
input is checked and never coerced, and stdout carries nothing but the command's own output."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from lagrange_xval import cli, systems
from lagrange_xval.cli import main
from lagrange_xval.dynamics import integrate
from lagrange_xval.model.start import Start
from lagrange_xval.sources import make_source

CLI = [sys.executable, "-m", "lagrange_xval.cli"]


def _one_error_line(capsys, *expected):
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("lagrange-xval: error:"), captured.err
    for text in expected:
        assert text in lines[0], lines[0]
    return captured


def _states(tmp_path, text: str | bytes):
    path = tmp_path / "states.json"
    path.write_bytes(text.encode() if isinstance(text, str) else text)
    return ["check", "double_pendulum_point", "--states-file", str(path)]


STATES = {
    "a string for a number": ('[{"q": ["0.5", 0], "v": [0, 0]}]', "must be numbers; got '0.5' (str)"),
    "true for a number": ('[{"q": [0, 0], "v": [true, 0]}]', "must be numbers; got True (bool)"),
    "null for a number": ('[{"q": [0, 0], "v": [0, 0], "tau": [null, 0]}]', "must be numbers; got None"),
    "a huge integer": ('[{"q": [' + "9" * 400 + ', 0], "v": [0, 0]}]', "integer too large"),
    "an integer of 5000 digits": ('[{"q": [' + "9" * 5000 + ', 0], "v": [0, 0]}]', "not valid JSON"),
    "deep nesting": ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    "Infinity": ('[{"q": [Infinity, 0], "v": [0, 0]}]', "not finite"),
    "invalid UTF-8": (b'[{"q": [0, 0], "v": [0, 0]}]\xff\xfe', "not UTF-8"),
    "an object, not a list": ('{"q": [0, 0], "v": [0, 0]}', "non-empty JSON list"),
}


@pytest.mark.parametrize("case", sorted(STATES))
def test_a_states_file_is_checked_not_coerced(tmp_path, capsys, case):
    text, expected = STATES[case]
    assert main(_states(tmp_path, text)) == 2
    _one_error_line(capsys, expected)


def _special(tmp_path, kind):
    if kind == "missing":
        return tmp_path / "none.json", "states file not found"
    if kind == "directory":
        return tmp_path, "is a directory"
    if kind == "FIFO":
        os.mkfifo(tmp_path / "fifo")
        return tmp_path / "fifo", "is a FIFO"
    if kind == "device":
        return "/dev/zero", "is a character device"
    big = tmp_path / "big.json"
    with open(big, "wb") as f:
        f.truncate(cli.MAX_STATES_FILE_BYTES + 1)  # sparse: nothing is written, nothing may be read
    return big, "bytes; at most"


@pytest.mark.parametrize("kind", ["missing", "directory", "FIFO", "device", "too big"])
def test_a_bad_states_path_is_named_as_what_it_is(tmp_path, capsys, kind):
    path, expected = _special(tmp_path, kind)
    assert main(["check", "double_pendulum_point", "--states-file", str(path)]) == 2  # a FIFO would block if opened
    _one_error_line(capsys, expected)


ARGS = {
    "--seed -1": (["check", "simple_pendulum", "--seed", "-1"], "must be from 0"),
    "--states 1e9": (["check", "simple_pendulum", "--states", "1e9"], "not a whole number"),
    "--states 1000000000": (["check", "simple_pendulum", "--states", "1000000000"], "must be from 1 to 100000"),
    "run --out ''": (["run", "--out", ""], "must not be empty"),
    "simulate --out ''": (
        [
            "simulate",
            "simple_pendulum",
            "--source",
            "hand",
            "--q0",
            "0",
            "--v0",
            "0",
            "--t-end",
            "1",
            "--dt-out",
            "0.1",
            "--out",
            "",
        ],
        "must not be empty",
    ),  # fmt: skip
}


@pytest.mark.parametrize("case", sorted(ARGS))
def test_bad_arguments_are_refused_by_the_parser(capsys, case):
    args, expected = ARGS[case]
    with pytest.raises(SystemExit) as exit_:
        main(args)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert expected in err and "Traceback" not in err


def _simulate(tmp_path, out, *, dt_out="0.1", source="hand", v0="0,0"):
    return ["simulate", "double_pendulum_point", "--source", source, "--q0", "0,3", "--v0", v0,
            "--t-end", "1", "--dt-out", dt_out, "--out", str(out)]  # fmt: skip


def test_simulate_refuses_a_directory_and_a_grid_too_fine(tmp_path, capsys):
    (tmp_path / "x.csv").mkdir()
    assert main(_simulate(tmp_path, tmp_path / "x.csv")) == 2
    _one_error_line(capsys, "is a directory")
    assert main(_simulate(tmp_path, tmp_path / "y.csv", dt_out="1e-300")) == 2
    _one_error_line(capsys, "1e+300 samples of 5 numbers", "the limit is 1 GiB in memory")
    assert not (tmp_path / "y.csv").exists()


def test_simulate_writes_no_non_finite_row(tmp_path, capsys, monkeypatch):
    real = integrate.scipy_trajectory

    def nan_at_half_second(*args, **kwargs):
        traj = real(*args, **kwargs)
        traj.v[5, 1] = np.nan
        return traj

    monkeypatch.setattr(integrate, "scipy_trajectory", nan_at_half_second)
    assert main(_simulate(tmp_path, tmp_path / "x.csv")) == 2
    _one_error_line(capsys, "dphi is nan at t = 0.5 s")
    assert not (tmp_path / "x.csv").exists()


def test_an_unstable_mujoco_run_is_an_error_and_leaves_no_log(tmp_path, capsys, monkeypatch):
    """MuJoCo resets an unstable state to zeros and carries on; the harness stops there, naming the time,
    and MuJoCo's MUJOCO_LOG.TXT does not appear in the working directory."""
    monkeypatch.chdir(tmp_path)
    assert main(_simulate(tmp_path, tmp_path / "x.csv", source="mujoco", v0="10000,-10000")) == 2
    _one_error_line(capsys, "diverged between t = 0 s and t = 0.1 s", "mjWARN_BADQACC", "reset the state")
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_mujoco_trajectory_raises_diverged_never_returns_zeros():
    system = systems.load("double_pendulum_point")
    src = make_source(system, "mujoco")
    t = integrate.time_grid(1.0, 0.1)
    with pytest.raises(integrate.Diverged):
        integrate.mujoco_trajectory(system, src, Start.of(np.array([0.0, 3.0]), np.array([1e4, -1e4]), np.zeros(2)), t)
    ok = integrate.mujoco_trajectory(system, src, Start.of(np.array([0.0, 3.0]), np.zeros(2), np.zeros(2)), t)
    assert np.all(np.isfinite(ok.q)) and np.abs(ok.q[-1]).max() > 0  # the warning counters were reset


@pytest.mark.parametrize(
    "content, expected",
    [
        (b'{"systems": {}}', 'no "meta"'),
        (b'{"meta": {}, "systems": [], "passed": true}', '"systems" is a JSON list'),
        (b'{"meta": {}, "systems": {"a": {"name": "a"}}, "passed": true}', 'has no "passed"'),
        (b"[1, 2]", "a JSON list"),
        (b'{"meta": {}, "systems": {}, "passed": true}\xff', "not UTF-8"),
    ],
)
def test_report_refuses_a_results_file_of_another_shape(tmp_path, capsys, content, expected):
    (tmp_path / "results.json").write_bytes(content)
    assert main(["report", "--out", str(tmp_path)]) == 2
    _one_error_line(capsys, expected)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.json"]


def test_an_unexpected_exception_is_one_line_and_debug_shows_the_traceback(capsys, monkeypatch):
    def broken(args):
        raise ZeroDivisionError("division by zero")

    monkeypatch.setitem(cli.COMMANDS, "list", broken)
    assert main(["list"]) == 2
    _one_error_line(capsys, "unexpected ZeroDivisionError: division by zero", "--debug")
    assert main(["list", "--debug"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" in err and err.strip().splitlines()[-1].startswith("lagrange-xval: error: unexpected")


def test_a_broken_equations_module_does_not_hide_the_others(capsys, monkeypatch):
    real = systems.loader.importlib.import_module
    names = systems.system_names()

    def syntax_error_in_one(name, *args):
        if name.endswith("." + names[0]):
            raise SyntaxError("invalid syntax", (f"{names[0]}.py", 12, 1, "x = = 1\n"))
        return real(name, *args)

    systems.loader.repository_module.cache_clear()
    monkeypatch.setattr(systems.loader.importlib, "import_module", syntax_error_in_one)
    try:
        assert main(["list"]) == 1
    finally:
        systems.loader.repository_module.cache_clear()
    captured = capsys.readouterr()
    assert f"{names[0]}: BROKEN: equations/{names[0]}.py: syntax error at line 12" in captured.out, captured.out
    for name in names[1:]:
        assert f"{name}: " in captured.out and f"{name}: BROKEN" not in captured.out


def test_an_include_is_read_from_the_models_folder(tmp_path, monkeypatch):
    models = tmp_path / "models"
    models.mkdir()
    (models / "parts.xml").write_text(
        '<mujoco><body name="b"><joint name="j" type="hinge"/><inertial pos="0 0 0" mass="1" '
        'diaginertia="1 1 1"/></body></mujoco>'
    )
    (models / "m.xml").write_text('<mujoco model="m"><worldbody><include file="parts.xml"/></worldbody></mujoco>')
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert systems.compile_mjcf(models / "m.xml").nbody == 2


def _cli(*args, env=None, stdout=subprocess.PIPE):
    return subprocess.run([*CLI, *args], stdout=stdout, stderr=subprocess.PIPE, text=True, env=env, timeout=300)


def test_a_closed_or_full_stdout_is_one_line():
    """`lagrange-xval list | head -0` (the reader gone) and `> /dev/full`: one line, status 2."""
    proc = subprocess.Popen([*CLI, "list"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stdout.close()  # before the command writes: its first write meets a closed pipe
    err = proc.stderr.read()
    assert proc.wait(timeout=300) == 2, err
    assert err.strip().splitlines() == ["lagrange-xval: error: the output was closed before it was all written "
                                        "(broken pipe)."]  # fmt: skip
    with open("/dev/full", "w") as full:
        proc = _cli("list", stdout=full)
    assert proc.returncode == 2 and proc.stderr.strip().splitlines() == [
        "lagrange-xval: error: no space left on device; previous reports are intact."
    ], proc.stderr


def test_stdout_holds_only_the_commands_output_when_a_library_logs(tmp_path):
    """heyoka logs on the process's stdout where its disk cache cannot be written (here: a path under a
    file; HOME unset turns that cache off instead); `--json` consumers must still get JSON."""
    (tmp_path / "file").write_text("")
    env = dict(os.environ)
    code = (
        f"import heyoka; heyoka.llvm_state.set_diskcache_path({str(tmp_path / 'file' / 'x')!r});"
        "import sys; from lagrange_xval import cli, systems;"
        "from lagrange_xval.dynamics import reference;"
        "from lagrange_xval.dynamics.integrate import time_grid;"
        "from lagrange_xval.model.start import Start;"
        "s = systems.load('simple_pendulum');"
        "cli.COMMANDS['list'] = lambda a: (reference.reference_trajectory(s, Start.of([0.5], [0.0], [0.0]),"
        " time_grid(1, 0.1),"
        " cache_dir=None, check=None), print('{\"ok\": true}'), 0)[-1];"
        "sys.exit(cli.main(['list']))"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {"ok": True}, proc.stdout
    assert "heyoka" in proc.stderr, "the library's log still reaches the person, on stderr"

"""A person's equations module cannot hang, exit or fool the harness (issue 28, validate/core/guard.py):
a call that does not return within the time limit, `sys.exit` and `os._exit` are one-line findings
naming the function; what a module prints never reaches stdout; the other systems' results are kept;
SIGTERM stops a run whatever the module is doing.

Every module is written into a temporary folder with a copy of models/simple_pendulum.xml; the time
limit is 2 s, and every command line runs with a timeout.
"""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import lagrange_xval as lx
import pytest
from lagrange_xval.core.errors import HarnessError

ROOT = Path(__file__).resolve().parents[3]
CLI = [sys.executable, "-m", "lagrange_xval.cli"]
LIMIT = "2"
TIMEOUT = 120  # s: a command that hangs fails the test instead of the suite

PENDULUM = '''
"""A simple pendulum, minimal: parameters and form (a)."""
from dataclasses import dataclass
import os
import sys
import time

import numpy as np


@dataclass(frozen=True)
class Params:
    m: float
    l: float
    g: float
    I: float


def parameters(model):
    return Params(model["body/link/mass"], -model["body/link/com"][1], -model["gravity"][1],
                  model["body/link/inertia"][2, 2])


def mass_matrix(p, q):
    {mass_matrix}
    return (p.m * p.l**2 + p.I) * np.ones(np.shape(q) + (1,))


def bias(p, q, v):
    return p.m * p.g * p.l * np.sin(q)

{at_import}
'''


def _system(folder: Path, name: str, mass_matrix: str = "pass", at_import: str = "") -> tuple[Path, Path]:
    """(model, equations) of a pendulum whose mass_matrix first runs `mass_matrix` (one line) and whose
    import ends with `at_import`."""
    folder.mkdir(parents=True, exist_ok=True)
    model = folder / f"{name}.xml"
    shutil.copy(ROOT / "models" / "simple_pendulum.xml", model)
    equations = folder / f"{name}.py"
    equations.write_text(PENDULUM.format(mass_matrix=mass_matrix, at_import=at_import))
    return model, equations


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=TIMEOUT)


def _check(model: Path, equations: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return _cli(
        "check", "--model", str(model), "--equations", str(equations), "--states", "5", "--time-limit", LIMIT, *extra
    )


def _error_line(proc: subprocess.CompletedProcess[str]) -> str:
    lines = [x for x in proc.stderr.splitlines() if x.startswith("lagrange-xval: error:")]
    assert len(lines) == 1, f"expected one error line; stderr:\n{proc.stderr[-2000:]}"
    return lines[0]


def test_a_mass_matrix_that_sleeps_is_stopped_at_the_time_limit(tmp_path: Path) -> None:
    """`check` on a mass_matrix sleeping 1000 s ends after the limit with one line naming the function."""
    proc = _check(*_system(tmp_path, "sleepy", "time.sleep(1000)"))
    assert proc.returncode == 2, proc.stderr
    assert "mass_matrix did not return within 2 s" in _error_line(proc)
    assert "sleepy.py" in _error_line(proc)


def test_a_mass_matrix_that_loops_forever_is_a_failing_verdict_in_the_api(tmp_path: Path) -> None:
    """The API: an endless loop (that even swallows exceptions) is a failing row naming the function."""
    model, equations = _system(
        tmp_path, "loops", "while True:\n        try:\n            pass\n        except Exception:\n            pass"
    )
    start = time.monotonic()
    result = lx.check(lx.System.from_files(model, equations, time_limit=1.0), n_states=5, probes=0)
    assert time.monotonic() - start < 60
    assert not result.passed
    assert "mass_matrix did not return within 1 s" in result.statement
    with pytest.raises(AssertionError, match="mass_matrix did not return"):
        result.assert_ok()


def test_sys_exit_in_mass_matrix_is_an_error_not_a_silent_success(tmp_path: Path) -> None:
    """sys.exit(0) inside mass_matrix: status 2 and a line saying so, never status 0 with no output."""
    proc = _check(*_system(tmp_path, "quits", "sys.exit(0)"))
    assert proc.returncode == 2, proc.stderr
    assert "mass_matrix called sys.exit(0)" in _error_line(proc)


def test_sys_exit_at_import_is_an_error(tmp_path: Path) -> None:
    """sys.exit at import: the command line and System.from_files name the import."""
    model, equations = _system(tmp_path, "quits_early", at_import="sys.exit(0)")
    proc = _check(model, equations)
    assert proc.returncode == 2, proc.stderr
    assert "importing it called sys.exit(0)" in _error_line(proc)
    with pytest.raises(HarnessError, match="importing it called sys.exit"):
        lx.System.from_files(model, equations)


def test_an_import_that_sleeps_is_stopped(tmp_path: Path) -> None:
    """A module sleeping at import is refused after the time limit, naming the file and the import."""
    model, equations = _system(tmp_path, "slow_import", at_import="time.sleep(1000)")
    start = time.monotonic()
    with pytest.raises(HarnessError, match=r"slow_import\.py: importing it did not return within 1 s"):
        lx.System.from_files(model, equations, time_limit=1.0)
    assert time.monotonic() - start < 30


def test_what_a_module_prints_never_reaches_stdout(tmp_path: Path) -> None:
    """A module that prints at import and in mass_matrix: check --json's stdout is the JSON alone."""
    model, equations = _system(tmp_path, "chatty", 'print("from mass_matrix")', at_import='print("from the import")')
    proc = _check(model, equations, "--json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["system"] == "chatty"
    assert "from mass_matrix" in proc.stderr and "from the import" in proc.stderr


def test_check_names_the_function_that_raises(tmp_path: Path) -> None:
    """`check` on a mass_matrix that raises ends with its verdict line naming the function and the exception."""
    proc = _check(*_system(tmp_path, "raises", "1 / 0"))
    assert proc.returncode == 1, proc.stderr
    last = proc.stdout.strip().splitlines()[-1]
    assert "mass_matrix() raised ZeroDivisionError" in last and last.startswith("verdict: raises: FAIL"), proc.stdout


@pytest.mark.parametrize(
    "ending", ["os._exit(3)", "os.kill(os.getpid(), __import__('signal').SIGKILL)"], ids=["os_exit", "sigkill"]
)
def test_a_module_that_ends_its_process_fails_alone(tmp_path: Path, ending: str) -> None:
    """`run --systems` with a module that ends its process beside a good one: the good one's results
    are kept, the bad one is named (os._exit is refused in the process; a signal ends its worker)."""
    folder = tmp_path / "systems"
    _system(folder, "good")
    _system(folder, "bad", ending)
    out = tmp_path / "out"
    proc = _cli(
        "run", "--systems", str(folder), "--out", str(out), "--states", "20", "--probes", "0",
        "--no-replay", "--no-cache", "--time-limit", LIMIT,
    )  # fmt: skip
    assert proc.returncode == 1, proc.stderr
    results = json.loads((out / "results.json").read_text())["systems"]
    assert results["good"]["passed"] is True
    assert results["bad"]["passed"] is False
    expected = "mass_matrix called os._exit(3)" if ending.startswith("os._exit") else "worker process ended"
    assert expected in results["bad"]["failed"][0]
    assert "bad" in proc.stdout and expected in proc.stdout


def test_sigterm_stops_a_run_of_one_blocked_system(tmp_path: Path) -> None:
    """SIGTERM to `run` of one system whose mass_matrix blocks: status 143 within a few seconds."""
    model, equations = _system(tmp_path, "blocked", "time.sleep(1000)")
    cmd = [*CLI, "run", "--model", str(model), "--equations", str(equations), "--out", str(tmp_path / "out")]
    proc = subprocess.Popen(
        [*cmd, "--no-replay", "--no-cache"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        deadline = time.monotonic() + 60
        line = ""
        while "started" not in line and time.monotonic() < deadline:  # the system is being checked
            line = proc.stderr.readline() if proc.stderr else ""
        time.sleep(1.0)
        proc.send_signal(signal.SIGTERM)
        sent = time.monotonic()
        status = proc.wait(timeout=10)
        assert status == 143
        assert time.monotonic() - sent < 5
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert not (tmp_path / "out").exists()


def test_derive_refuses_a_chain_predicted_past_its_budget(tmp_path: Path) -> None:
    """`derive --model` on a 50-joint chain refuses within seconds, naming the size and --force."""
    from lagrange_xval.studies.chains import chain_mjcf

    model = tmp_path / "chain50.xml"
    model.write_text(chain_mjcf(50, "planar"))
    proc = _cli("derive", "--model", str(model))
    assert proc.returncode == 2, proc.stderr
    line = _error_line(proc)
    assert "50 joints" in line and "--force" in line


def test_a_module_that_swallows_every_stop_is_ended(tmp_path: Path) -> None:
    """A loop with a bare `except:` has nothing to swallow: its worker is killed at the limit, status 2."""
    body = "while True:\n        try:\n            time.sleep(1000)\n        except BaseException:\n            pass"
    proc = _check(*_system(tmp_path, "stubborn", body))
    assert proc.returncode == 2, proc.stderr
    assert "mass_matrix did not return within 2 s (the time limit per system" in _error_line(proc)


def test_the_guard_restores_someone_elses_alarm() -> None:
    """A handler and timer of SIGALRM set before a guarded call (pytest-timeout's) are there after it."""
    from lagrange_xval.core.guard import Guard, guarded

    def theirs(signum: int, frame: object) -> None:
        raise AssertionError("their alarm fired during the test")

    before = signal.signal(signal.SIGALRM, theirs)
    signal.setitimer(signal.ITIMER_REAL, 100.0)
    try:
        assert guarded(Guard("mine.py", 5.0), "mass_matrix", lambda x: 2 * x)(3) == 6
        assert signal.getsignal(signal.SIGALRM) is theirs
        assert 90.0 < signal.getitimer(signal.ITIMER_REAL)[0] <= 100.0
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, before)


def test_a_stop_survives_pickling() -> None:
    """A Stopped raised in a worker reaches the parent with its file and reason."""
    import pickle

    from lagrange_xval.core.guard import Stopped

    stop = pickle.loads(pickle.dumps(Stopped("mine.py", "bias called sys.exit(1)")))
    assert (stop.where, stop.why, str(stop)) == (
        "mine.py",
        "bias called sys.exit(1)",
        "mine.py: bias called sys.exit(1)",
    )


def _pid(x: int) -> tuple[int, int]:
    import os

    time.sleep(0.3)  # long enough to outlive the pool thread that reported the previous task
    return x, os.getpid()


def _ends(code: int) -> None:
    import os

    os._exit(code)


def test_one_process_per_task_and_a_dying_task_fails_alone() -> None:
    """OnePerTask: more tasks than workers each run in a process of their own (those forked after the
    first survive the pool thread that reported the previous result); one that ends its process fails
    alone with BrokenProcessPool."""
    from concurrent.futures.process import BrokenProcessPool

    from lagrange_xval.core.parallel import executor_for

    with executor_for(None, tasks=1, isolated=True) as pool:
        futures = [pool.submit(_pid, i) for i in range(3)]
        dying = pool.submit(_ends, 3)
        after = pool.submit(_pid, 3)
        results = [f.result(timeout=60) for f in futures]
        with pytest.raises(BrokenProcessPool):
            dying.result(timeout=60)
        assert after.result(timeout=60)[0] == 3
    assert [x for x, _ in results] == [0, 1, 2]
    assert len({pid for _, pid in results} | {after.result()[1]}) == 4


@pytest.mark.parametrize("command", ["bench", "stress"])
def test_bench_and_stress_take_the_time_limit(tmp_path: Path, command: str) -> None:
    """`bench` and `stress` on a person's module that sleeps at import: one line naming the import and
    the --time-limit given, soon after it."""
    model, equations = _system(tmp_path, "slow_start", at_import="time.sleep(1000)")
    start = time.monotonic()
    proc = _cli(
        command,
        "--model",
        str(model),
        "--equations",
        str(equations),
        "--quick",
        "--out",
        str(tmp_path / "o"),
        "--time-limit",
        "1",
    )
    assert proc.returncode == 2, proc.stderr
    assert "slow_start.py: importing it did not return within 1 s" in _error_line(proc)
    assert time.monotonic() - start < 60 and not (tmp_path / "o").exists()


def test_a_persons_time_limit_travels_to_the_workers(tmp_path: Path) -> None:
    """bench's and stress's workers find a person's system by its key: its time limit comes with it."""
    from lagrange_xval.systems import from_key, key_of

    system = lx.System.from_files(*_system(tmp_path, "limited"), time_limit=3.5)
    assert from_key(key_of(system)).equations.GUARD.time_limit == 3.5

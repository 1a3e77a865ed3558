"""A person's module runs in a worker process the judge can always stop (issue 35, validate/handwritten/worker.py):
a module that switches the alarm off, blocks in one C call, forks, leaves threads or atexit handlers,
ends its process from a thread, patches numpy, raises anything or forges a verdict line gets the right
verdict or one error line, the right status, ends within its time limit and a few seconds, and leaves
no process behind.

Every module is the pendulum of tests/unit/core/test_guard.py with one line in mass_matrix and/or at import;
the time limit is 2 s, and every command line runs with a timeout.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import lagrange_xval as lx
import numpy as np
import pytest
from lagrange_xval.core.guard import Stopped
from lagrange_xval.handwritten.worker import ModuleWorker, escape, sandbox

from tests.unit.core.test_guard import CLI, LIMIT, TIMEOUT, _check, _error_line, _system

# A command that starts (about 3 to 6 s here: imports, MuJoCo, Pinocchio, Drake) and is stopped at the
# 2 s limit ends well within this; one that hangs runs into TIMEOUT instead.
ENDS_WITHIN = 60.0


def _alive(pid: int) -> bool:
    """Whether `pid` is a process that has not ended (a zombie has ended)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def _pids(path: Path) -> list[int]:
    return [int(x) for x in path.read_text().split()] if path.exists() else []


def _none_left(pids: list[int]) -> None:
    """Every process the module started has ended (a killed orphan is reaped by init: given 5 s)."""
    assert pids, "the module did not record its processes"
    deadline = time.monotonic() + 5
    while any(_alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not [p for p in pids if _alive(p)], "a process of the module outlived the command"


def _timed_check(model: Path, equations: Path, *extra: str) -> tuple[subprocess.CompletedProcess[str], float]:
    start = time.monotonic()
    proc = _check(model, equations, *extra)
    return proc, time.monotonic() - start


# The process's id as this machine's /proc names it: the worker runs in a PID namespace of its own, where
# os.getpid() is another number (/proc/self is resolved in the namespace of the /proc mount: the host's).
RECORD = "open({pids!r}, 'a').write(os.readlink('/proc/self') + ' ')"
ESCAPES = (
    "import subprocess, sys\n"
    'subprocess.Popen([sys.executable, "-c", "import os, time; {record}; time.sleep(1000)"], start_new_session=True)'
)
DAEMON = (
    "import signal\n"
    "if os.fork() == 0:\n"
    "    os.setsid()\n"
    "    if os.fork() == 0:\n"
    "        {record}\n"
    "        time.sleep(1000)\n"
    "    os.kill(os.getpid(), signal.SIGKILL)\n"
    "time.sleep(0.5)"
)


@pytest.mark.parametrize(
    "at_import, body",
    [
        (
            "import signal\nsignal.signal(signal.SIGALRM, signal.SIG_IGN)\nsignal.setitimer(signal.ITIMER_REAL, 0)",
            "signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})\n    while True:\n        pass",
        ),
        ("", "sum(range(10**13))"),
    ],
    ids=["alarm_off_and_loop", "one_long_c_call"],
)
def test_a_module_that_cannot_be_interrupted_is_stopped_at_the_limit(tmp_path: Path, at_import: str, body: str) -> None:
    """The alarm ignored, cleared and blocked, then a loop; or one C call of hours: status 2 and the one
    line naming the function and the limit per system, and the worker is gone."""
    pids = tmp_path / "pids"
    model, equations = _system(tmp_path, "stuck", f"{RECORD.format(pids=str(pids))}\n    {body}", at_import)
    proc, took = _timed_check(model, equations)
    assert proc.returncode == 2, proc.stderr
    line = _error_line(proc)
    assert "mass_matrix did not return within 2 s (the time limit per system; --time-limit SECONDS sets it)" in line
    assert took < ENDS_WITHIN
    _none_left(_pids(pids))


@pytest.mark.parametrize(
    "at_import, body",
    [
        ("", "if os.fork() == 0:\n        {record}\n        time.sleep(1000)"),
        ("import threading\nthreading.Thread(target=time.sleep, args=(1000,)).start()\n{record}", "pass"),
        ("import atexit\natexit.register(time.sleep, 1000)\n{record}", "pass"),
        (ESCAPES, "pass"),
        (DAEMON, "pass"),
    ],
    ids=["fork", "non_daemon_thread", "atexit", "new_session", "double_fork_daemon"],
)
def test_nothing_a_module_leaves_outlives_the_verdict(tmp_path: Path, at_import: str, body: str) -> None:
    """A child forked in mass_matrix, a non-daemon thread or an atexit handler that sleeps 1000 s, a process
    started in a session of its own or a daemon after a double fork: the verdict is printed (pass: the
    dynamics are right), the command ends at once, no process is left (the worker's PID namespace); where
    the machine allows no namespace, the command says so."""
    pids = tmp_path / "pids"
    record = RECORD.format(pids=str(pids))
    model, equations = _system(tmp_path, "leaves", body.format(record=record), at_import.format(record=record))
    proc, took = _timed_check(model, equations)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1].startswith("verdict: leaves: pass"), proc.stdout
    assert took < ENDS_WITHIN
    if not sandbox() and _escapes(at_import):
        assert "allows no PID namespace" in proc.stderr, proc.stderr
        return
    _none_left(_pids(pids))


def _escapes(at_import: str) -> bool:
    """Whether the case leaves the worker's process group (what only a namespace ends)."""
    return "start_new_session" in at_import or "setsid" in at_import


def test_a_daemon_thread_that_ends_the_process_is_an_error_not_a_silent_success(tmp_path: Path) -> None:
    """os._exit(0) from a daemon thread 0.3 s after import ends the worker, never the command: status 2
    and a line saying the worker ended."""
    at_import = "import threading\nthreading.Thread(target=lambda: (time.sleep(0.3), os._exit(0)), daemon=True).start()"
    body = "time.sleep(1)"  # the thread ends the worker during the first call of mass_matrix at the latest
    proc, took = _timed_check(*_system(tmp_path, "vanishes", body, at_import))
    assert proc.returncode == 2, proc.stderr
    assert "the module's worker process ended (exit status 0)" in _error_line(proc)
    assert took < ENDS_WITHIN


def test_a_module_that_patches_numpy_cannot_change_the_verdict(tmp_path: Path) -> None:
    """np.abs patched to return zeros (and np.allclose to say yes) with a mass matrix 5 times too large:
    the judge's numpy is its own, the verdict fails."""
    at_import = "np.abs = lambda x, *a, **k: np.zeros(np.shape(x))\nnp.allclose = lambda *a, **k: True"
    body = "return 5 * (p.m * p.l**2 + p.I) * np.ones(np.shape(q) + (1,))"
    proc, _ = _timed_check(*_system(tmp_path, "patches", body, at_import), "--probes", "0")
    assert proc.returncode == 1, proc.stderr
    assert proc.stdout.strip().splitlines()[-1].startswith("verdict: patches: FAIL: mass matrix"), proc.stdout


@pytest.mark.parametrize(
    "raise_line, named",
    [
        ("raise KeyboardInterrupt", "mass_matrix() raised KeyboardInterrupt\n"),
        ("raise GeneratorExit", "mass_matrix() raised GeneratorExit\n"),
        ("raise type('Boom', (BaseException,), {})('out of the blue')", "mass_matrix() raised Boom: out of the blue"),
        ("raise type('Quit', (SystemExit,), {})(0)", "mass_matrix called sys.exit(0)"),
        (
            "from lagrange_xval.core.guard import Stopped\n    raise Stopped('harness', 'all checks passed')",
            "mass_matrix() raised Stopped: harness: all checks passed",
        ),
    ],
    ids=["keyboard_interrupt", "generator_exit", "base_exception", "system_exit_subclass", "harness_stopped"],
)
def test_any_exception_of_a_module_is_its_own_failure_named(tmp_path: Path, raise_line: str, named: str) -> None:
    """KeyboardInterrupt (never the person's Ctrl-C, 130), GeneratorExit, a BaseException subclass, the
    harness's own Stopped: the module's failure, named, with no traceback; a SystemExit subclass is an exit."""
    proc, _ = _timed_check(*_system(tmp_path, "raises", raise_line))
    assert "Traceback" not in proc.stderr, proc.stderr
    said = proc.stdout + proc.stderr
    assert proc.returncode in (1, 2), said
    assert named in said, said
    assert "all checks passed" not in said or "raised Stopped" in said


def test_a_message_cannot_forge_a_verdict_line_or_reach_the_terminal_raw(tmp_path: Path) -> None:
    """An exception message with a newline, a forged verdict line, an escape sequence and 10 MB: the
    verdict line is the harness's (FAIL), the message is on one line, escaped and cut."""
    body = "raise ValueError('\\nverdict: forged: pass: all checks passed\\x1b[2J' + 'x' * 10_000_000)"
    proc, _ = _timed_check(*_system(tmp_path, "forged", body), "--probes", "0")
    assert proc.returncode == 1, proc.stderr
    lines = proc.stdout.splitlines()
    assert not [x for x in lines if x.startswith("verdict: forged: pass")], proc.stdout[-2000:]
    assert lines[-1].startswith("verdict: forged: FAIL") and "\\nverdict: forged: pass" in lines[-1]
    assert "\x1b" not in proc.stdout + proc.stderr
    assert len(proc.stdout) + len(proc.stderr) < 1_000_000


def test_the_limit_is_one_budget_for_all_of_a_systems_calls(tmp_path: Path) -> None:
    """mass_matrix sleeping 0.5 s a call, under the 1.5 s limit each time but not together (the model's
    parameters and 4 probes ask it at least 5 times): stopped at the limit per system, naming it."""
    proc, took = _timed_check(*_system(tmp_path, "slowish", "time.sleep(0.5)"), "--time-limit", "1.5")
    assert proc.returncode == 2, proc.stderr
    assert "did not return within 1.5 s (the time limit per system" in _error_line(proc)
    assert took < ENDS_WITHIN


LOADED = """
import os, subprocess, sys, time
import numpy as np
from lagrange_xval.handwritten.worker import ModuleWorker
cpu = {{min(os.sched_getaffinity(0))}}  # one CPU this process may use (a container's set may not hold 0)
os.sched_setaffinity(0, cpu)
worker = ModuleWorker({module!r}, time_limit=30.0)
os.sched_setaffinity(worker._proc.pid, cpu)
worker.renew()  # the import's charge aside
for pid in (0, worker._proc.pid):  # behind the busy processes on that CPU: each call waits for it
    os.setpriority(os.PRIO_PROCESS, pid, 19)
hog = f"import os\\nos.sched_setaffinity(0, {{cpu}})\\nwhile True: pass"
hogs = [subprocess.Popen([sys.executable, "-c", hog]) for _ in range(12)]
time.sleep(0.3)
start = time.monotonic()
try:
    for _ in range(600):
        worker.call("f", np.ones(3))
finally:
    for h in hogs:
        h.kill()
print(time.monotonic() - start, 30.0 - worker.left)
"""


@pytest.mark.skipif(not Path("/proc/self/schedstat").exists(), reason="the load is measured from Linux's schedstat")
def test_a_loaded_machine_does_not_spend_the_modules_budget(tmp_path: Path) -> None:
    """600 calls of a trivial function, worker and caller niced behind twelve busy processes on one CPU:
    the calls take about a second, but the waits for the CPU are the machine's, not the module's, and are
    not charged (the old rule, wall time less 5 ms a call, charged 0.3 to 0.8 s here; before, a right
    derivation failed `run` at load 8 for \"did not return within 30 s\")."""
    module = tmp_path / "m.py"
    module.write_text("import numpy as np\n\ndef f(x):\n    return np.asarray(x) * 2.0\n")
    done = subprocess.run(
        [sys.executable, "-c", LOADED.format(module=str(module))], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    took, charged = map(float, done.stdout.split())
    assert took > 0.3 and charged < 0.1, (took, charged)


@pytest.mark.parametrize(
    "body", ["sum(range(10**13))", "while True:\n        pass"], ids=["one long C call", "a Python busy loop"]
)
def test_run_fails_a_hanging_system_alone(tmp_path: Path, body: str) -> None:
    """`run --systems` with a module stuck in one C call, or in a Python busy loop, beside a good one: the
    good one's results are kept, the stuck one is stopped at the limit per system and fails with the one
    line naming it, and the run ends."""
    folder = tmp_path / "systems"
    _system(folder, "good")
    _system(folder, "stuck", body)
    out = tmp_path / "out"
    start = time.monotonic()
    proc = subprocess.run(
        [*CLI, "run", "--systems", str(folder), "--out", str(out), "--states", "20", "--probes", "0",
         "--no-replay", "--no-cache", "--time-limit", LIMIT],
        capture_output=True, text=True, timeout=TIMEOUT,
    )  # fmt: skip
    assert time.monotonic() - start < TIMEOUT
    assert proc.returncode == 1, proc.stderr
    results = json.loads((out / "results.json").read_text())["systems"]
    assert results["good"]["passed"] is True
    assert results["stuck"]["passed"] is False
    assert "mass_matrix did not return within 2 s (the time limit per system" in results["stuck"]["failed"][0]


def test_the_api_returns_a_failing_row_for_a_module_that_raises_keyboard_interrupt(tmp_path: Path) -> None:
    """lagrange_xval.check on a module raising KeyboardInterrupt: a failing result naming it, never an
    interrupt of the caller."""
    system = lx.System.from_files(*_system(tmp_path, "interrupts", "raise KeyboardInterrupt"), time_limit=10)
    result = lx.check(system, n_states=5, probes=0)
    assert not result.passed
    assert result.statement.endswith("mass_matrix() raised KeyboardInterrupt"), result.statement


def test_module_worker_calls_and_closes(tmp_path: Path) -> None:
    """The worker's API: a call on arrays gives the module's array; close ends the process; a call
    after a stop raises the same Stopped at once."""
    _, equations = _system(tmp_path, "plain")
    worker = ModuleWorker(equations, time_limit=10)
    try:
        params = worker.call("parameters", {"body/link/mass": 2.0, "body/link/com": np.array([0.0, -0.5, 0.0]),
                                             "gravity": np.array([0.0, -9.81, 0.0]),
                                             "body/link/inertia": np.eye(3)})  # fmt: skip
        M = worker.call("mass_matrix", params, np.zeros((4, 1)))
        assert isinstance(M, np.ndarray) and M.dtype == float and M.shape == (4, 1, 1)
        np.testing.assert_array_equal(M, np.full((4, 1, 1), 2.0 * 0.25 + 1.0))
    finally:
        worker.close()
    assert not _alive(worker._proc.pid)
    with pytest.raises(Stopped, match="closed"):
        worker.call("mass_matrix", params, np.zeros(1))


def test_escape_keeps_text_on_one_line_and_cut() -> None:
    assert escape("a\nb\x1b[2J") == "a\\nb\\x1b[2J"
    long = escape("x" * 1000, 10)
    assert long.startswith("x" * 10 + "...") and "990 more characters" in long
    assert os.linesep not in escape("line\r\nline")


def test_a_forked_copy_of_the_harness_gets_a_worker_of_its_own(tmp_path: Path) -> None:
    """A process forked after a module was loaded starts its own worker on its first call (never
    talking on, or killing, the parent's); the parent's worker still answers after."""
    system = lx.System.from_files(*_system(tmp_path, "shared"), time_limit=30)
    eq, p = system.equations, system.params
    expected = eq.mass_matrix(p, np.zeros(1))
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the forked copy
        try:
            same = np.array_equal(eq.mass_matrix(p, np.zeros(1)), expected)
            os.write(write, b"1" if same and eq.WORKER._proc.pid != os.getpid() else b"0")
            eq.WORKER.close()
        finally:
            os._exit(0)
    os.waitpid(pid, 0)
    assert os.read(read, 1) == b"1"
    np.testing.assert_array_equal(eq.mass_matrix(p, np.zeros(1)), expected)
    eq.WORKER.close()


def test_an_import_that_raises_keyboard_interrupt_is_a_one_line_refusal(tmp_path: Path) -> None:
    """KeyboardInterrupt raised while the module is imported: refused in one line naming it, never
    taken for the person's Ctrl-C."""
    model, equations = _system(tmp_path, "interrupted", at_import="raise KeyboardInterrupt")
    proc = _check(model, equations)
    assert proc.returncode == 2, proc.stderr
    assert "importing it raised KeyboardInterrupt" in _error_line(proc) and "Traceback" not in proc.stderr


@pytest.mark.parametrize("where", ["main", "thread"])
def test_the_worker_dies_with_a_harness_killed_outright(tmp_path: Path, where: str) -> None:
    """A process that loaded a module (from its main thread, or from a thread that has ended since) and
    is then killed with SIGKILL takes the module's worker with it, even in the middle of a call."""
    _, equations = _system(tmp_path, "orphan", "time.sleep(1000)")
    script = (
        "import sys, threading, time\n"
        "from lagrange_xval.handwritten.worker import ModuleWorker\n"
        "box = []\n"
        "start = lambda: box.append(ModuleWorker(sys.argv[1], 100))\n"
        "thread = threading.Thread(target=start)\n"
        "start() if sys.argv[2] == 'main' else (thread.start(), thread.join())\n"
        "print(box[0]._proc.pid, flush=True)\n"
        "box[0].call('mass_matrix', None, 0.0)\n"
    )
    proc = subprocess.Popen(
        [*CLI[:1], "-c", script, str(equations), where], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True
    )
    try:
        assert proc.stdout is not None
        pid = int(proc.stdout.readline())
        time.sleep(0.5)  # inside mass_matrix's sleep
        assert _alive(pid)
    finally:
        proc.kill()
        proc.wait()
    _none_left([pid])


FORGED_ARRAY = (  # a whole message in the protocol's framing: an array of dtype object, 8 bytes
    "(lambda j: __import__('struct').pack('!II', len(j), 1) + j + __import__('struct').pack('!Q', 8) + bytes(8))"
    '(b\'{"ok":{"A":0,"d":"|O8","s":[1]}}\')'
)


@pytest.mark.parametrize("forged", ["b'\\xff' * 16", FORGED_ARRAY], ids=["huge_header", "object_array"])
def test_a_module_writing_on_the_pipe_is_refused_in_one_line(tmp_path: Path, forged: str) -> None:
    """A module that writes its own bytes on the worker's pipe (a header claiming gigabytes, an array of
    Python objects): one line saying the worker sent what is not data, status 2; nothing is unpickled."""
    body = f"os.write(int(sys.argv[2]), {forged})\n    time.sleep(1000)"
    proc, took = _timed_check(*_system(tmp_path, "forger", body))
    assert proc.returncode == 2, proc.stderr
    line = _error_line(proc)
    assert "mass_matrix" in line and ("is not data" in line or "did not return" in line), line
    assert took < ENDS_WITHIN


def test_a_module_that_allocates_without_bound_fails_alone(tmp_path: Path) -> None:
    """With the worker's address space limited to 1 GiB, a mass_matrix allocating 2 GiB raises
    MemoryError in its worker: the module's failure, named; the command is unharmed."""
    body = "np.ones(2 * 2**30 // 8)"
    model, equations = _system(tmp_path, "greedy", body)
    start = time.monotonic()
    proc = subprocess.run(
        [*CLI, "check", "--model", str(model), "--equations", str(equations), "--states", "5", "--probes", "0"],
        capture_output=True, text=True, timeout=TIMEOUT, env={**os.environ, "LAGRANGE_XVAL_WORKER_MEMORY": str(2**30)},
    )  # fmt: skip
    assert proc.returncode == 1, proc.stderr
    assert "mass_matrix() raised MemoryError" in proc.stdout.strip().splitlines()[-1], proc.stdout[-2000:]
    assert time.monotonic() - start < ENDS_WITHIN


def test_each_check_of_the_api_has_the_whole_time_limit(tmp_path: Path) -> None:
    """lagrange_xval.check on a system whose budget an earlier check spent: the limit is per check (as it
    is per command), so the second check has all of it again."""
    system = lx.System.from_files(*_system(tmp_path, "again"), time_limit=10)
    assert lx.check(system, n_states=5, probes=0).passed
    system.equations.WORKER.left = -1.0  # as if the first check had spent it all, and more
    result = lx.check(system, n_states=5, probes=0)
    assert result.passed, result.statement

"""`lagrange-xval watch`: a planted mistake is reported after a save and the pass comes back after the
fix; a module that cannot be imported is one error line and the watch goes on; Ctrl-C is status 130;
`--once` is `check`'s status; a save abandons a verdict at the next stage boundary; a module saved
twice in one second with the same size runs its new code. Driven with a subprocess and file writes,
with generous timeouts: content is asserted, never speed (that is `bench`'s)."""

from __future__ import annotations

import os
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from lagrange_xval.cli import main
from lagrange_xval.cli.watch import Saves
from lagrange_xval.results.stages import Cancelled, Clock
from lagrange_xval.systems import PACKAGE_ROOT, System, load, load_module
from lagrange_xval.verdict.decide import decide

CLI = [sys.executable, "-m", "lagrange_xval.cli"]
EXAMPLES = PACKAGE_ROOT / "examples"
RIGHT = "- p.mp * p.g * lc * s"  # cart_pole.py's gravity in the theta row
WRONG = "- p.mc * p.g * lc * s"  # the cart's mass in its place: the same length, so the same file size
TIMEOUT = 240.0  # s: generous, on a loaded machine; the test asserts what is printed, not how fast


@pytest.fixture
def cart_pole(tmp_path: Path) -> tuple[Path, Path]:
    for suffix in (".xml", ".py"):
        shutil.copy(EXAMPLES / f"cart_pole{suffix}", tmp_path / f"cart_pole{suffix}")
    assert RIGHT in (tmp_path / "cart_pole.py").read_text()
    return tmp_path / "cart_pole.xml", tmp_path / "cart_pole.py"


class Watching:
    """`lagrange-xval watch` in a process group of its own, its stdout and stderr read line by line."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen(
            [*CLI, "watch", *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
        self.lines: queue.Queue[tuple[str, str]] = queue.Queue()
        self.seen: list[tuple[str, str]] = []
        for name in ("stdout", "stderr"):
            threading.Thread(target=self._read, args=(name,), daemon=True).start()

    def _read(self, name: str) -> None:
        for line in getattr(self.proc, name):
            self.lines.put((name, line.rstrip("\n")))

    def next_line(self, stream: str, starts: str) -> str:
        """The next line of `stream` that starts with `starts` (lines before it are kept in `seen`)."""
        deadline = time.monotonic() + TIMEOUT
        while time.monotonic() < deadline:
            try:
                name, line = self.lines.get(timeout=1.0)
            except queue.Empty:
                assert self.proc.poll() is None, f"watch ended ({self.proc.returncode}): {self.seen}"
                continue
            self.seen.append((name, line))
            if name == stream and line.startswith(starts):
                return line
        raise AssertionError(f"no {stream} line starting {starts!r} within {TIMEOUT:g} s; seen: {self.seen}")

    def after(self, line: str) -> list[str]:
        """The stdout lines printed after `line` up to the verdict's seconds (the failing terms)."""
        self.next_line("stdout", "verdict in ")
        out = [x for name, x in self.seen if name == "stdout"]
        start = len(out) - 1 - out[::-1].index(line)
        return out[start + 1 : -1]

    def interrupt(self) -> tuple[int, str]:
        """Ctrl-C as a terminal sends it (SIGINT to the process group): the status and the rest of stderr."""
        os.killpg(self.proc.pid, signal.SIGINT)
        self.proc.wait(timeout=60)
        time.sleep(0.2)  # the readers drain what is left
        rest = []
        while not self.lines.empty():
            rest.append(self.lines.get())
        self.seen += rest
        return self.proc.returncode, "\n".join(x for name, x in self.seen if name == "stderr")

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(timeout=60)


def _save(path: Path, text: str) -> None:
    """A save as an editor makes it: the whole file written again."""
    path.write_text(text)


def test_a_planted_mistake_is_reported_after_a_save_and_the_pass_comes_back_after_the_fix(cart_pole):
    model, equations = cart_pole
    right = equations.read_text()
    watching = Watching("--model", str(model), "--equations", str(equations), "--states", "200")
    try:
        assert watching.next_line("stdout", "verdict: ").startswith("verdict: cart_pole: pass: ")
        _save(equations, right.replace(RIGHT, WRONG))
        failed = watching.next_line("stdout", "verdict: cart_pole: FAIL")
        assert "gravity" in failed and "mc" in failed, failed
        terms = watching.after(failed)
        assert any(t.startswith("gravity") and t.endswith("FAIL") for t in terms), terms
        assert not any(t.endswith("pass") for t in terms), f"only the failing terms are listed: {terms}"
        _save(equations, right)
        assert watching.next_line("stdout", "verdict: ").startswith("verdict: cart_pole: pass: ")
    finally:
        watching.close()


def test_a_module_with_a_syntax_error_is_one_error_line_and_the_watch_goes_on(cart_pole):
    model, equations = cart_pole
    right = equations.read_text()
    watching = Watching("--model", str(model), "--equations", str(equations), "--states", "200")
    try:
        watching.next_line("stdout", "verdict: cart_pole: pass")
        _save(equations, right.replace("def residual(", "def residual(:", 1))
        error = watching.next_line("stderr", "lagrange-xval: error: ")
        assert f"{equations}:" in error and "syntax error" in error, error
        _save(equations, right)
        watching.next_line("stdout", "verdict: cart_pole: pass")
        errors = [x for name, x in watching.seen if name == "stderr" and x.strip()]
        assert errors == [error], f"one error line for the broken save: {errors}"
        assert not any("Traceback" in x for _, x in watching.seen)
    finally:
        watching.close()


def test_ctrl_c_ends_the_watch_with_status_130_and_no_traceback(cart_pole):
    model, equations = cart_pole
    watching = Watching("--model", str(model), "--equations", str(equations), "--states", "50", "--probes", "0")
    try:
        watching.next_line("stdout", "verdict: cart_pole: pass")
        status, err = watching.interrupt()
        assert status == 130, err
        assert err.splitlines()[-1].startswith("lagrange-xval: watch stopped"), err
        assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    finally:
        watching.close()


def test_once_exits_with_checks_status(cart_pole, capsys):
    """--once: 0 and the statement for a right derivation, 1 and the failing term for a wrong one, 2 and
    one line for a file that is not there."""
    model, equations = cart_pole
    base = ["watch", "--model", str(model), "--equations", str(equations), "--states", "100", "--once"]
    assert main(base) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("verdict: cart_pole: pass: ") and out[-1].startswith("verdict in "), out
    equations.write_text(equations.read_text().replace(RIGHT, WRONG))
    assert main(base) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("verdict: cart_pole: FAIL: gravity"), out
    assert any(line.startswith("gravity") and line.endswith("FAIL") for line in out), out
    assert main(["watch", "--model", str(model), "--equations", str(equations.with_name("none.py")), "--once"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("lagrange-xval: error: equations file not found"), err


def test_watch_prints_the_line_check_prints(capsys):
    """The statement line is `check`'s last line, word for word."""
    args = ["simple_pendulum", "--states", "100", "--probes", "1"]
    assert main(["check", *args]) == 0
    checked = capsys.readouterr().out.splitlines()[-1]
    assert main(["watch", *args, "--once"]) == 0
    assert capsys.readouterr().out.splitlines()[0] == checked


def test_a_set_cancel_event_abandons_the_verdict_at_the_next_stage():
    """decide laps each stage on the clock it is given; a clock whose cancel event is set raises
    Cancelled at the first lap, and one without a set event records every stage's seconds."""
    system = load("simple_pendulum")
    clock = Clock()
    decide(system, n_states=20, seed=0, probes=1, clock=clock)
    assert list(clock.seconds) == ["model checks", "pointwise", "probes", "terms"]
    assert all(s > 0 for s in clock.seconds.values()), clock.seconds
    cancel = threading.Event()
    cancel.set()
    with pytest.raises(Cancelled):
        decide(system, n_states=20, seed=0, probes=1, clock=Clock(cancel=cancel))


def test_saves_keep_only_the_watched_files(tmp_path):
    watched = tmp_path / "arm.py"
    saves = Saves([watched.resolve()])
    saves.add([str(tmp_path / "other.py"), str(tmp_path / ".arm.py.swp")])
    assert not saves.event.is_set() and saves.take() == set()
    saves.add([str(watched)])
    assert saves.event.is_set()
    assert saves.take() == {watched.resolve()} and not saves.event.is_set()


def test_a_module_saved_twice_in_one_second_with_the_same_size_runs_its_new_code(cart_pole, monkeypatch):
    """Python's bytecode cache is keyed by the source's whole-second mtime and size: the module is
    compiled from its source on every load, so the second save is the one judged."""
    monkeypatch.setattr(sys, "dont_write_bytecode", False)  # the cache as a person's Python keeps it
    model, equations = cart_pole
    right = equations.read_text()
    assert System.from_files(model, equations).equations is not None
    stat = equations.stat()
    equations.write_text(right.replace(RIGHT, WRONG))
    os.utime(equations, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    assert equations.stat().st_size == stat.st_size
    module = load_module(equations, model=model)
    assert _gravity_reads_cart_mass(module), "the first save's code ran"


def _gravity_reads_cart_mass(module) -> bool:
    """The loaded residual's theta row at rest, tipped: it scales with mc (the wrong code) or mp."""
    import numpy as np

    p = module.Params(mc=7.0, ccx=0, ccy=0, ccz=0, h=0, py=0, pz=0, mp=1.0, l=1.0, kx=0, g=1.0)
    zero = np.zeros(2)
    r = module.residual(p, np.array([0.0, np.pi / 2]), zero, zero, zero)
    return bool(np.isclose(r[1], -7.0 * 0.5))


def _unbounded_caches(path: Path) -> list[str]:
    """The process-wide caches of one module that can grow without bound: `functools.cache` or
    `lru_cache(maxsize=None)` on a function that takes arguments, a module-level `Memo()` without a
    maxsize, and a module-level dict that functions store into by key."""
    import ast

    tree = ast.parse(path.read_text())
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef) and (node.args.args or node.args.kwonlyargs):
            for d in node.decorator_list:
                text = ast.unparse(d)
                if text in ("functools.cache", "cache") or "maxsize=None" in text:
                    found.append(f"{path.name}:{node.lineno} @{text} {node.name}")
    for node in tree.body:
        target = node.targets[0] if isinstance(node, ast.Assign) else getattr(node, "target", None)
        value = getattr(node, "value", None)
        if not isinstance(target, ast.Name) or value is None:
            continue
        if isinstance(value, ast.Call) and ast.unparse(value.func) == "Memo" and not value.keywords and not value.args:
            found.append(f"{path.name}:{node.lineno} {target.id} = Memo()")
        if isinstance(value, ast.Dict) and not value.keys:
            stores = [
                n
                for n in ast.walk(tree)
                if isinstance(n, ast.Subscript) and isinstance(n.ctx, ast.Store) and ast.unparse(n.value) == target.id
            ]
            if stores:
                found.append(f"{path.name}:{node.lineno} {target.id}: a dict stored into by key")
    return found


def test_every_process_wide_cache_is_bounded():
    """A watch runs for hours, one module loaded per save: every cache kept for the process has a
    bound (a System's own memo goes with the System)."""
    validate = PACKAGE_ROOT / "validate"
    found = [line for path in sorted(validate.rglob("*.py")) for line in _unbounded_caches(path)]
    assert not found, f"unbounded process-wide caches: {found}"


def test_the_unbounded_cache_finder_finds_each_kind(tmp_path):
    module = tmp_path / "m.py"
    module.write_text(
        "import functools\n_SEEN = {}\n_MEMO = Memo()\n"
        "@functools.cache\ndef f(x):\n    _SEEN[x] = 1\n"
        "@functools.lru_cache(maxsize=None)\ndef g(x):\n    return x\n"
        "@functools.cache\ndef h():\n    return 1\n"
    )
    found = _unbounded_caches(module)
    assert len(found) == 4 and not any(" h" in x for x in found), found


def test_the_api_check_repeated_on_an_unchanged_system_is_not_judged_again(monkeypatch):
    """`lagrange_xval.check` on the same System and options gives the kept verdict (decide runs once); other
    options, or a function of the module replaced in place, are judged afresh."""
    import lagrange_xval as lx
    from lagrange_xval import api

    calls = []
    real = api.decide

    def counted(*args, **kwargs):
        calls.append(kwargs["n_states"])
        return real(*args, **kwargs)

    monkeypatch.setattr(api, "decide", counted)
    system = load("simple_pendulum")
    first = lx.check(system, n_states=20, probes=1)
    assert lx.check(system, n_states=20, probes=1) == first and calls == [20]
    lx.check(system, n_states=21, probes=1)
    assert calls == [20, 21]
    original = system.equations.mass_matrix
    monkeypatch.setattr(system.equations, "mass_matrix", lambda p, q: 2 * original(p, q))
    wrong = lx.check(system, n_states=20, probes=1)
    assert calls == [20, 21, 20] and [r.quantity for r in wrong.failures][:1] == ["mass matrix"], wrong.statement


def test_the_command_line_imports_only_what_a_verdict_needs():
    """`check` and `watch` start without the pipeline, scipy's integrators, the report or the replay: the
    commands that use them import them."""
    code = (
        "import sys, lagrange_xval.cli; "
        "print(sorted(m for m in ('lagrange_xval.stages.pipeline', 'scipy.integrate', 'matplotlib', 'rerun', "
        "'jinja2', 'lagrange_xval.report', 'lagrange_xval.studies.bench') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_once_judges_every_system_of_a_folder(tmp_path, capsys):
    """`watch --systems DIR --once`: each <name>.xml with its <name>.py judged, the status check's for
    the worst (a wrong one among right ones fails)."""
    for name in ("cart_pole", "wrong_pole"):
        shutil.copy(EXAMPLES / "cart_pole.xml", tmp_path / f"{name}.xml")
        text = (EXAMPLES / "cart_pole.py").read_text()
        (tmp_path / f"{name}.py").write_text(text if name == "cart_pole" else text.replace(RIGHT, WRONG))
    assert main(["watch", "--systems", str(tmp_path), "--states", "100", "--probes", "1", "--once"]) == 1
    verdicts = [line for line in capsys.readouterr().out.splitlines() if line.startswith("verdict: ")]
    assert [v.split(":")[1:3] for v in verdicts] == [[" cart_pole", " pass"], [" wrong_pole", " FAIL"]], verdicts


def test_watch_takes_one_thing_to_watch(cart_pole, capsys):
    model, equations = cart_pole
    assert main(["watch", "simple_pendulum", "--model", str(model), "--equations", str(equations), "--once"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("lagrange-xval: error: watch one thing: a SYSTEM, or --model"), err


def test_what_the_model_leaves_out_is_said_once_per_model_not_per_verdict(tmp_path, capsys):
    """Issue 44 item 3: the left-out clause (here a joint's range) on its own line, once for the model,
    however many saves are judged; never inside a verdict line."""
    import gymnasium
    from lagrange_xval.cli import watch

    model = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "inverted_double_pendulum.xml"
    name = "inverted_double_pendulum"
    target = watch.Target(name, model, EXAMPLES / "gymnasium" / f"{name}.py")
    options = watch.Options(n_states=5, seed=0, probes=0)
    for _ in range(2):
        watch.judge(target, options, None)
    lines = capsys.readouterr().out.splitlines()
    left = [line for line in lines if line.startswith("left out, as no equation of motion contains them: ")]
    verdicts = [line for line in lines if line.startswith(f"verdict: {name}: ")]
    assert len(left) == 1 and len(verdicts) == 2, lines
    assert not any("left out" in v for v in verdicts), verdicts


def test_a_loop_of_links_or_a_module_linked_to_itself_does_not_end_the_watch(tmp_path):
    """Issue 47 item 6: Path.resolve() raised on a loop of links beside the module (or the module made a
    link to itself) in the watcher thread, which ended while the last verdict stayed on screen."""
    from lagrange_xval.cli import watch

    module = tmp_path / "mine.py"
    module.write_text("x = 1\n")
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    saves = watch.Saves([watch.resolved(module)])
    saves.add([str(tmp_path / "a"), str(module)])  # the loop is no watched file, the module is
    assert saves.take() == {module.resolve()}
    module.unlink()
    module.symlink_to(module)  # a link to itself
    target = watch.Target("mine", tmp_path / "mine.xml", module)
    assert module.absolute() in target.files


def test_the_watcher_thread_survives_what_the_file_system_does(monkeypatch, capsys):
    """An exception in the file watcher (a folder deleted under it) is one line; it watches again and
    the saved files are judged again."""
    import watchfiles
    from lagrange_xval.cli import watch

    calls = []

    def flaky(*folders, stop_event, **options):
        calls.append(1)
        if len(calls) == 1:
            raise RuntimeError("the folder went away")
        stop_event.wait(5.0)
        return iter(())

    monkeypatch.setattr(watchfiles, "watch", flaky)
    monkeypatch.setattr(watch, "RETRY_S", 0.01)
    saves, stop = watch.Saves([Path("/tmp/watched.py")]), threading.Event()
    thread = watch.watch_files(saves, stop)
    assert saves.event.wait(5.0), "the saved files were not judged again"
    stop.set()
    thread.join(5.0)
    assert len(calls) >= 2 and not thread.is_alive()
    assert "watch: RuntimeError: the folder went away; watching again" in capsys.readouterr().err

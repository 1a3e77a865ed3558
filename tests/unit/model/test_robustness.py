"""Bad input never breaks the harness: models the sources read differently, out-of-range values,
unwritable or full report folders, Ctrl-C mid-run. Each: one line, non-zero exit, old reports intact."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import psutil
import pytest
from lagrange_xval import systems
from lagrange_xval.cli import main
from lagrange_xval.sources import make_source
from lagrange_xval.verdict import modelsync

POINT = systems.load("double_pendulum_point")


def _variant(tmp_path, old: str, new: str) -> systems.System:
    text = POINT.mjcf.read_text()
    assert old in text
    path = tmp_path / "double_pendulum_point.xml"
    path.write_text(text.replace(old, new, 1))
    return systems.System(name=POINT.name, mjcf=path, equations=POINT.equations)


def test_collision_free_geom_mass_that_pinocchio_drops_is_named(tmp_path):
    """A body whose mass comes from a collision-free geom: MuJoCo counts it, Pinocchio drops it."""
    s = _variant(
        tmp_path,
        '<inertial pos="0 -1 0" mass="1" diaginertia="1e-14 1e-14 1e-14"/>\n      <geom name="rod1"',
        '<geom name="bobmass" type="sphere" pos="0 -1 0" size="0.05" mass="1"/>\n      <geom name="rod1"',
    )
    bad = {r["key"] for r in modelsync.pinocchio_vs_mujoco(s, make_source(s, "pinocchio")) if not r["passed"]}
    assert "body/link1/mass" in bad


def test_mesh_geom_that_pinocchio_reads_as_one_kilogram_is_named(tmp_path):
    """A 2 kg mesh bob: MuJoCo integrates the mesh, Pinocchio gives a mesh geom 1 kg and unit inertia."""
    s = _variant(
        tmp_path,
        '<inertial pos="0 -1 0" mass="1" diaginertia="1e-14 1e-14 1e-14"/>\n      <geom name="rod1"',
        '<geom name="bobmesh" type="mesh" mesh="tetra" pos="0 -1 0" mass="2"/>\n      <geom name="rod1"',
    )
    tetra = '<asset><mesh name="tetra" vertex="0 0 0  0.05 0 0  0 0.05 0  0 0 0.05"/></asset>'
    text = s.mjcf.read_text().replace("<worldbody>", f"{tetra}\n<worldbody>", 1)
    s.mjcf.write_text(text)
    bad = {r["key"] for r in modelsync.pinocchio_vs_mujoco(s, make_source(s, "pinocchio")) if not r["passed"]}
    assert {"body/link1/mass", "body/link1/com", "body/link1/inertia"} <= bad


FLAGS = (
    '<flag contact="disable" constraint="disable" limit="disable" frictionloss="disable"\n'
    '          spring="disable" damper="disable" actuation="disable" energy="enable"/>'
)
ENABLED = '<flag spring="disable" damper="disable" actuation="disable" energy="enable"/>'


CONSTRAINTS = [
    (
        [
            (FLAGS, ENABLED),
            ('<geom contype="0" conaffinity="0" mass="0"/>', '<geom mass="0"/>'),
            (
                "<worldbody>",
                '<worldbody><geom name="floor" type="plane" size="5 5 0.1" pos="0 -3 0" zaxis="0 1 0"/>',
            ),
        ],
        "contacts between",
    ),
    (
        [(FLAGS, ENABLED), ("</worldbody>", '</worldbody><contact><pair geom1="bob1" geom2="bob2"/></contact>')],
        "bob1~bob2",
    ),
    (
        [(FLAGS, ENABLED), ("</worldbody>", '</worldbody><equality><joint joint1="theta" joint2="phi"/></equality>')],
        "equality constraint(s) 'equality#0' (joint 'theta' coupled to joint 'phi')",
    ),
    (
        [(FLAGS, ENABLED), ('<joint name="phi" type="hinge"', '<joint name="phi" range="-1 1" type="hinge"')],
        "the range of joint(s) 'phi'",
    ),
    (
        [(FLAGS, ENABLED), ('<joint name="phi" type="hinge"', '<joint name="phi" frictionloss="0.1" type="hinge"')],
        "the dry friction (frictionloss) of 'phi'",
    ),
    (
        [
            (
                "</worldbody>",
                '</worldbody><tendon><fixed name="couple" stiffness="3"><joint joint="theta" coef="1"/>'
                '<joint joint="phi" coef="-1"/></fixed></tendon>',
            )
        ],
        "the spring and damper of tendon(s) 'couple' (MuJoCo only, not compared)",
    ),
]


@pytest.mark.parametrize(
    ("edits", "named"),
    CONSTRAINTS,
    ids=["colliding geoms", "contact pair", "equality", "limit", "frictionloss", "tendon"],
)
def test_constraints_are_left_out_by_name_and_a_right_derivation_still_passes(tmp_path, edits, named, capsys):
    """Contacts, equality constraints, limits, friction loss and a tendon's spring add forces that no
    equation of motion of the chain contains: each is named once as left out (switched off in every
    source), never refused, and the notes' right derivation passes on the model that has them."""
    text = POINT.mjcf.read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = tmp_path / "double_pendulum_point.xml"
    path.write_text(text)
    system = systems.System(name=POINT.name, mjcf=path, equations=POINT.equations)
    assert any(named in line for line in system.left_out), system.left_out
    eq = tmp_path / "double_pendulum_point.py"
    eq.write_text("from lagrange_xval.equations.double_pendulum_point import *  # noqa: F403\n")
    assert main(["check", "--model", str(path), "--equations", str(eq), "--states", "30", "--probes", "1"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-1].startswith("verdict: double_pendulum_point: pass") and "left out" not in lines[-1], lines[-1]
    assert lines[-2].startswith("left out, as no equation of motion contains them: ") and named in lines[-2], lines


@pytest.mark.parametrize(
    ("old", "new", "named"),
    [
        ('<joint name="phi" type="hinge"', '<joint name="phi" type="ball"', "ball joint 'phi'"),
        (
            '<joint name="theta" type="hinge" axis="0 0 1" pos="0 0 0"/>',
            '<freejoint name="float"/>',
            "free joint 'float'",
        ),
    ],
    ids=["ball", "free"],
)
def test_free_and_ball_joints_are_compared_as_slides_and_hinges(tmp_path, old, new, named, capsys):
    """A ball or free joint becomes hinges (and slides) in the same body that every reader shares,
    listed in the alignments; the model alone passes."""
    text = POINT.mjcf.read_text()
    assert old in text
    path = tmp_path / "jointed.xml"
    path.write_text(text.replace(old, new, 1))
    system = systems.System.model_only(path)
    assert any(named in line for line in system.alignments), system.alignments
    assert main(["check", "--model", str(path), "--states", "30"]) == 0, capsys.readouterr().out[-400:]


def test_the_same_elements_switched_off_by_the_model_are_in_scope(tmp_path):
    """A limit, friction loss or colliding geoms in a model whose <option> disables them: compared."""
    text = POINT.mjcf.read_text().replace(
        '<joint name="phi" type="hinge"', '<joint name="phi" range="-1 1" frictionloss="0.1" type="hinge"', 1
    )
    text = text.replace('<geom contype="0" conaffinity="0" mass="0"/>', '<geom mass="0"/>', 1)
    path = tmp_path / "double_pendulum_point.xml"
    path.write_text(text)
    assert systems.System(name=POINT.name, mjcf=path, equations=POINT.equations).mujoco_model().njnt == 2


def test_check_fails_a_model_that_differs_from_what_the_derivation_assumes(tmp_path, monkeypatch, capsys):
    """The model checks come first: a model the derivation does not describe is the verdict (exit 1, the
    key named on the verdict line), as in run and the API."""
    s = _variant(tmp_path, 'pos="0 -1 0" mass="1"', 'pos="0.1 -1 0" mass="1"')  # bob off the rod
    from lagrange_xval import cli

    monkeypatch.setattr(cli.commands, "load", lambda name, overrides=(), **_: s)  # the name the CLI resolves systems by
    assert main(["check", "double_pendulum_point", "--states", "5"]) == 1
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.startswith("verdict: double_pendulum_point: FAIL") and "body/link1/com" in last, last


@pytest.mark.parametrize(
    "state, message",
    [
        ({"q": [0, 0], "v": [1e200, 0]}, "accepts |v| <= 10000"),
        ({"q": [1e30, 0], "v": [0, 0]}, "accepts |q|"),
        ({"q": [0, 0], "v": [0, 0], "tau": [1e12, 0]}, "accepts |tau|"),
        ({"q": [0, "x"], "v": [0, 0]}, "must be numbers"),
    ],
)
def test_huge_or_non_numeric_states_are_refused(tmp_path, capsys, state, message):
    path = tmp_path / "s.json"
    path.write_text(json.dumps([state]))
    assert main(["check", "double_pendulum_point", "--states-file", str(path)]) == 2
    assert message in capsys.readouterr().err


def _old_reports(out):
    out.mkdir()
    for name in ("results.json", "report.md", "report.html"):
        (out / name).write_text("OLD")


def test_a_full_disk_leaves_every_previous_report_intact(tmp_path, monkeypatch, capsys):
    out = tmp_path / "reports"
    _old_reports(out)
    real_fdopen, calls = os.fdopen, {"n": 0}

    def full_after_two(fd, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] > 2:
            os.close(fd)
            raise OSError(28, "No space left on device")
        return real_fdopen(fd, *args, **kwargs)

    monkeypatch.setattr(os, "fdopen", full_after_two)
    assert main(["run", "simple_pendulum", "--states", "10", "--out", str(out), "--no-replay"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "No space left on device" in err[-1] and err[-1].startswith("lagrange-xval: error:")
    assert not any("Traceback" in line for line in err)
    assert {p.name: p.read_text() for p in out.iterdir() if p.name != ".cache"} == {
        n: "OLD" for n in ("results.json", "report.md", "report.html")
    }


def test_a_report_folder_that_cannot_be_created_is_one_line(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    assert main(["run", "simple_pendulum", "--states", "10", "--out", str(blocker / "reports"), "--no-replay"]) == 2
    assert "cannot write" in capsys.readouterr().err


REPEATS = 5 if os.environ.get("CI") else 1  # CI proves the stop is deterministic by doing it several times


def _start_run(out):
    """`run` in its own process group, returned once its first progress line says the work is under way
    (the pool's workers started), with that line and the workers' processes."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "lagrange_xval.cli", "run", "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    first = proc.stderr.readline()
    assert "started" in first, first + proc.stderr.read()
    workers = psutil.Process(proc.pid).children(recursive=True)
    assert workers, "the run has a pool of workers"
    return proc, first, workers


@pytest.mark.parametrize("attempt", range(REPEATS))
@pytest.mark.parametrize(
    "how, status, line",
    [
        ("SIGINT", 130, "lagrange-xval: interrupted; nothing half-written (previous reports are intact)."),
        ("SIGTERM", 143, "lagrange-xval: terminated; nothing half-written (previous reports are intact)."),
    ],
)
def test_ctrl_c_mid_run_stops_cleanly(tmp_path, how, status, line, attempt):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) and SIGTERM (to the parent
    only, as `kill` sends it) once the run is known to be working: one line, the status, no worker
    left, the previous reports untouched."""
    out = tmp_path / "reports"
    _old_reports(out)
    proc, first, workers = _start_run(out)
    if how == "SIGINT":
        os.killpg(proc.pid, signal.SIGINT)
    else:
        proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=180)
    err = first + err
    assert proc.returncode == status, err
    lines = err.strip().splitlines()  # progress lines come first
    assert lines[-1] == line
    assert not any("Traceback" in x or "KeyboardInterrupt" in x for x in lines), err
    _, alive = psutil.wait_procs(workers, timeout=10)
    assert not alive, f"workers left running after {how}: {alive}"
    assert {p.name: p.read_text() for p in out.iterdir() if p.name != ".cache"} == {
        n: "OLD" for n in ("results.json", "report.md", "report.html")
    }
    assert not list(tmp_path.glob(".reports.staging-*")), "nothing staged may be left behind"


def test_workers_exit_when_the_parent_is_killed(tmp_path):
    """A parent killed outright (SIGKILL: no handler runs) takes its pool's workers with it."""
    proc, _, workers = _start_run(tmp_path / "reports")
    os.kill(proc.pid, signal.SIGKILL)
    proc.communicate(timeout=180)
    _, alive = psutil.wait_procs(workers, timeout=10)
    assert not alive, f"orphaned workers: {alive}"


def test_a_worker_signalled_before_its_initializer_ran_stays_quiet():
    """A worker forked with the CLI's handlers (the signal came before its initializer): SIGINT is the
    parent's to report, SIGTERM ends the worker by the signal, without a traceback."""
    from lagrange_xval.cli import _handlers

    interrupt, terminate = _handlers(os.getpid())
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the worker: whatever happens, it never returns into pytest
        try:
            os.close(r)
            os.dup2(w, 2)
            signal.signal(signal.SIGINT, interrupt)
            signal.signal(signal.SIGTERM, terminate)
            os.kill(os.getpid(), signal.SIGINT)
            os.kill(os.getpid(), signal.SIGTERM)
        except BaseException as exc:  # noqa: BLE001 - what the old handlers did: reported as the failure
            os.write(2, repr(exc).encode())
        os._exit(0)  # not reached when SIGTERM's default action ends the process
    os.close(w)
    _, status = os.waitpid(pid, 0)
    with os.fdopen(r) as f:
        err = f.read()
    assert os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGTERM, status
    assert err == ""


def test_completed_gives_each_future_once_as_it_finishes():
    """parallel.completed (run's, bench's and stress's wait): every future once, in the order they
    finish, those finished before it is called included."""
    import threading
    from concurrent.futures import Future, ThreadPoolExecutor

    from lagrange_xval.core.parallel import completed

    early: Future[int] = Future()
    early.set_result(-1)
    gates = [threading.Event() for _ in range(3)]
    with ThreadPoolExecutor(max_workers=3) as pool:
        futures = [pool.submit(lambda i=i: gates[i].wait(10) and i) for i in range(3)]
        order = []
        stream = completed([*futures, early])
        order.append(next(stream).result())
        for i in (2, 0, 1):
            gates[i].set()
            order.append(next(stream).result())
        assert list(stream) == []
    assert order == [-1, 2, 0, 1]

"""`lagrange-xval survey DIR` (issue 43): every model under a folder judged at once, each from its own
folder in a process of its own; one row per model whatever it does (a pass, a FAIL with its
reproducers, a refusal with its reason, a timeout), in the files' order; files of one robot compared by
the two-file audit; the same rows on a dask cluster; bad input one line and nothing written."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from lagrange_xval.cli import main

from tests.unit.verdict.test_left_out import SETTOTALMASS, chain, needs_drake

BROKEN = '<mujoco model="broken"><worldbody><body><joint type="hinge"/></worldbody></mujoco>'  # not well-formed
FRAGMENT = "<mujocoinclude><body name='x'/></mujocoinclude>"  # part of the models that include it: no row


def _named(text: str, name: str) -> str:
    return text.replace('model="m"', f'model="{name}"')


def _folder(tmp_path: Path) -> Path:
    folder = tmp_path / "models"
    (folder / "sub").mkdir(parents=True)
    (folder / "ok.xml").write_text(_named(chain(2), "ok"))
    (folder / "sub" / "total.xml").write_text(_named(chain(5, compiler=SETTOTALMASS), "total"))
    (folder / "broken.xml").write_text(BROKEN)
    (folder / "fragment.xml").write_text(FRAGMENT)
    (folder / "notes.txt").write_text("not a model")
    return folder


def _rows(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "survey.jsonl").read_text().splitlines()]


@needs_drake
def test_every_model_is_one_row_in_the_files_order_with_its_verdict_and_proof(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder, out = _folder(tmp_path), tmp_path / "out"
    status = main(["survey", str(folder), "--out", str(out), "--workers", "2", "--states", "3"])
    stdout = capsys.readouterr().out
    rows = _rows(out)
    assert [(r["model"], r["outcome"]) for r in rows] == [
        ("broken.xml", "refused"),
        ("ok.xml", "pass"),
        ("sub/total.xml", "FAIL"),
    ], rows
    assert status == 1  # a FAIL fails the survey; a refusal is said, not a failure
    broken, ok, total = rows
    assert "not well-formed" in broken["why"] and not broken["why"].startswith("broken.xml"), broken["why"]
    assert "settotalmass" in total["why"] and total["reproducers"], total
    for script in total["reproducers"]:
        assert (out / script).is_file() and script.startswith("reproducers/"), script
    assert ok["format"] == "mjcf" and ok["robot"] == "ok", ok
    assert ok["audit"] == "agrees" or ok["findings"], ok
    assert "3 models in" in stdout and "1 pass, 1 FAIL (1 with reproducers), 1 refused, 0 crash" in stdout, stdout
    page = (out / "survey.html").read_text()
    assert page.count("<details") >= 3 and all(r["model"] in page for r in rows)
    assert page.index("sub/total.xml") < page.index("ok.xml")  # by outcome: the FAIL first
    assert "<script" not in page


def test_a_model_past_its_time_is_one_crash_row_and_leaves_no_process(tmp_path: Path) -> None:
    folder, out = _folder(tmp_path), tmp_path / "out"
    status = main(["survey", str(folder), "--out", str(out), "--workers", "2", "--timeout", "0.3", "--states", "3"])
    rows = _rows(out)
    assert status == 1 and len(rows) == 3
    assert all(r["outcome"] == "crash" and r["why"].startswith("timed out after 0.3 s") for r in rows), rows
    assert not _survey_processes(), _survey_processes()


def _survey_processes() -> list[str]:
    """The command lines of the processes running `survey --one` (a model's own process) now."""
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            line = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        if "survey --one" in line:
            found.append(line)
    return found


@needs_drake
def test_files_of_one_robot_are_compared_by_the_two_file_audit(tmp_path: Path) -> None:
    folder, out = tmp_path / "arms", tmp_path / "out"
    folder.mkdir()
    (folder / "a.xml").write_text(_named(chain(2), "arm"))
    (folder / "b.xml").write_text(_named(chain(2), "arm").replace('mass="1.5"', 'mass="2.5"'))
    (folder / "c.xml").write_text(_named(chain(2), "arm"))
    main(["survey", str(folder), "--out", str(out), "--states", "3"])
    pairs = {(p["a"], p["b"]): p for p in json.loads((out / "survey.json").read_text())["pairs"]}
    assert set(pairs) == {("a.xml", "b.xml"), ("a.xml", "c.xml")}, pairs
    assert pairs["a.xml", "c.xml"]["outcome"] == "same robot", pairs["a.xml", "c.xml"]
    differ = pairs["a.xml", "b.xml"]
    assert differ["outcome"] == "differ" and "mass" in " ".join(differ["findings"]), differ


@needs_drake
def test_a_dask_cluster_gives_the_same_rows(tmp_path: Path) -> None:
    folder = tmp_path / "models"
    folder.mkdir()
    (folder / "ok.xml").write_text(_named(chain(2), "ok"))
    (folder / "total.xml").write_text(_named(chain(5, compiler=SETTOTALMASS), "total"))
    outcomes = {}
    for executor in ("local", "dask"):
        out = tmp_path / executor
        main(["survey", str(folder), "--out", str(out), "--states", "3", "--executor", executor, "--workers", "2"])
        outcomes[executor] = [(r["model"], r["outcome"], r["why"], len(r["reproducers"])) for r in _rows(out)]
    assert outcomes["dask"] == outcomes["local"] and len(outcomes["local"]) == 2, outcomes


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["survey", "{tmp}/nowhere"], "is not a folder"),
        (["survey", "{tmp}/empty"], "no MJCF or URDF model file under"),
        (["survey", "{tmp}/empty", "--pairs", "a.xml"], "--pairs entry 'a.xml': give A:B"),
        (["survey"], "give a folder of models"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], says: str
) -> None:
    (tmp_path / "empty").mkdir()
    out = tmp_path / "out"
    status = main([a.format(tmp=tmp_path) for a in args] + ["--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and says in err[0], err
    assert not out.exists()

"""The output of a command is one set: switched in whole, or not at all, whatever fails and wherever."""

from __future__ import annotations

import os

import pytest
from lagrange_xval.cli import main, outputs
from lagrange_xval.core.errors import HarnessError

OLD = {
    "results.json": "old results",
    "report.md": "old md",
    "report.html": "old html",
    "gone_system.rrd": "old rrd",
    "img/gone_system_pointwise.png": "old png",
    "bench.json": "bench",
    ".cache/reference/x.npz": "cached",
    ".gitkeep": "",
}
NEW = {"results.json": b"new results", "report.md": b"new md", "report.html": b"new html", "img/a.png": b"png"}


def _tree(folder):
    return {str(p.relative_to(folder)): p.read_text() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def out(tmp_path):
    folder = tmp_path / "reports"
    for name, text in OLD.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(text)
    return folder


def _no_staging_left(out):
    return not [p.name for p in out.parent.iterdir() if ".staging-" in p.name]


def test_a_run_replaces_its_own_files_and_keeps_the_others(out):
    """The previous run's .rrd and plots go (their systems are not in this run); bench.json and the
    cache, which `run` does not write, stay."""
    outputs.replace_set(out, NEW, replaces=outputs._from_run)
    assert _tree(out) == {
        **{k: v.decode() for k, v in NEW.items()},
        "bench.json": "bench",
        ".cache/reference/x.npz": "cached",
        ".gitkeep": "",
    }
    assert _no_staging_left(out)
    assert all(p.stat().st_mode & 0o777 == 0o644 for p in out.rglob("*") if p.is_file() and ".cache" not in str(p))


def test_report_replaces_only_the_report(out):
    outputs.replace_set(out, {"report.md": b"md", "report.html": b"html"}, replaces=outputs._from_report)
    kept = {k: v for k, v in OLD.items() if not k.startswith("img/")}  # the old plots go with the old report
    assert _tree(out) == {**kept, "report.md": "md", "report.html": "html"}


def _fail(*args, **kwargs):
    raise OSError(5, "Input/output error")


@pytest.mark.parametrize(
    "where",
    ["writing the third file", "linking the cache", "the switch", "the second rename (no exchange)", "Ctrl-C"],
)
def test_a_failure_at_any_point_leaves_the_previous_set_whole(out, monkeypatch, where):
    before = _tree(out)
    if where == "writing the third file":
        real, calls = os.fdopen, {"n": 0}

        def third_fails(fd, *args, **kwargs):
            calls["n"] += 1
            if calls["n"] == 3:
                os.close(fd)
                raise OSError(28, "No space left on device")
            return real(fd, *args, **kwargs)

        monkeypatch.setattr(os, "fdopen", third_fails)
    elif where == "linking the cache":
        monkeypatch.setattr(outputs, "_carry", _fail)
    elif where == "the switch":
        monkeypatch.setattr(outputs, "_switch", _fail)
    elif where == "the second rename (no exchange)":
        monkeypatch.setattr(outputs, "_exchange", lambda a, b: False)
        real_rename = os.rename

        def second_fails(a, b):
            if str(b) == str(out) and ".staging-" in str(a) and not str(a).endswith("-old"):
                raise OSError(16, "Device or resource busy")
            return real_rename(a, b)

        monkeypatch.setattr(os, "rename", second_fails)
    else:

        def interrupted(*args):
            raise KeyboardInterrupt

        monkeypatch.setattr(outputs, "_carry", interrupted)
    with pytest.raises((HarnessError, KeyboardInterrupt)) as err:
        outputs.replace_set(out, NEW, replaces=outputs._from_run)
    if err.type is HarnessError:
        assert "previous files left as they were" in str(err.value) and "\n" not in str(err.value)
    assert _tree(out) == before
    assert _no_staging_left(out)


def test_the_portable_switch_without_exchange(out, monkeypatch):
    monkeypatch.setattr(outputs, "_exchange", lambda a, b: False)
    outputs.replace_set(out, NEW, replaces=outputs._from_run)
    assert _tree(out)["results.json"] == "new results" and "gone_system.rrd" not in _tree(out)
    assert _no_staging_left(out)


def test_a_directory_where_a_report_goes_is_replaced_with_the_set(out):
    (out / "report.html").unlink()
    (out / "report.html").mkdir()
    (out / "report.html" / "x").write_text("in the way")
    outputs.replace_set(out, NEW, replaces=outputs._from_run)
    assert (out / "report.html").read_text() == "new html"


def test_a_first_run_creates_the_folder(tmp_path):
    outputs.replace_set(tmp_path / "a" / "reports", NEW, replaces=outputs._from_run)
    assert _tree(tmp_path / "a" / "reports") == {k: v.decode() for k, v in NEW.items()}


@pytest.mark.parametrize("kind", ["a file", "a folder of other files"])
def test_an_out_that_is_not_a_reports_folder_is_refused_before_any_work(tmp_path, capsys, kind):
    target = tmp_path / "target"
    if kind == "a file":
        target.write_text("mine")
    else:
        target.mkdir()
        (target / "thesis.tex").write_text("mine")
    assert main(["run", "simple_pendulum", "--states", "10", "--out", str(target)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and ("is a file" in err[0] or "thesis.tex" in err[0]), err
    assert (target / "thesis.tex" if kind != "a file" else target).read_text() == "mine"

"""One verdict path: `lagrange_xval.check`, the `check` command and `run` give the same verdict on
the same system (verdict/decide.py), and `lagrange_xval.check` writes nothing."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import lagrange_xval as lx
import pytest
from lagrange_xval import systems
from lagrange_xval.cli import main
from lagrange_xval.core.cachedir import Cache
from lagrange_xval.systems import PACKAGE_ROOT

from ...mutations import MUTATIONS, mutated_source

HIDDEN = next(m for m in MUTATIONS if m.system == "simple_pendulum" and m.name.startswith("g sin th without l"))


def _copy(folder: Path, source: str | None = None, name: str = "mine") -> tuple[Path, Path]:
    """simple_pendulum's model and module in `folder` as `name`, the module's text replaced by `source`."""
    system = systems.load("simple_pendulum")
    folder.mkdir(parents=True, exist_ok=True)
    model, module = folder / f"{name}.xml", folder / f"{name}.py"
    model.write_text(system.mjcf.read_text())
    module.write_text(source if source is not None else Path(system.equations.__file__).read_text())
    return model, module


def _raising_assumptions() -> str:
    text = Path(systems.load("simple_pendulum").equations.__file__).read_text()
    head = "def assumptions(p: Params) -> dict[str, Any]:\n"
    assert head in text
    return text.replace(head, head + '    raise KeyError("body/nope/mass")\n')


def _cli_check(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, dict]:
    status = main(["check", *args, "--states", "20", "--probes", "2", "--json"])
    return status, json.loads(capsys.readouterr().out)


def _cli_run(capsys: pytest.CaptureFixture[str], out: Path, *args: str) -> dict:
    main(["run", *args, "--states", "20", "--probes", "2", "--no-replay", "--no-cache", "--out", str(out)])
    capsys.readouterr()
    (result,) = json.loads((out / "results.json").read_text())["systems"].values()
    return result


def test_assumptions_that_raise_give_one_verdict_through_the_api_check_and_run(tmp_path, capsys):
    """assumptions() raising KeyError: the API returns the verdict (no raw KeyError), the `check`
    command and `run` say the same words, naming assumptions() (not "parameters disagrees")."""
    model, module = _copy(tmp_path / "in", _raising_assumptions())
    api = lx.check(lx.System.from_files(model, module), n_states=20, probes=2)
    status, cli = _cli_check(capsys, "--model", str(model), "--equations", str(module))
    run = _cli_run(capsys, tmp_path / "out", "--model", str(model), "--equations", str(module))
    assert not api.passed and status == 1 and cli["passed"] is False and run["passed"] is False
    assert api.statement.startswith("assumptions() raised KeyError: 'body/nope/mass'"), api.statement
    assert cli["verdict"]["statement"] == api.statement == run["derivation"]["statement"]
    assert "parameters disagrees" not in api.statement


def test_a_model_alone_gives_one_verdict_through_the_api_check_and_run(tmp_path, capsys):
    """System.model_only: the API checks the model (no AttributeError on a None module), and the
    `check` command and `run` give the same verdict."""
    model, _ = _copy(tmp_path / "in")
    api = lx.check(lx.System.model_only(model), n_states=20, probes=2)
    status, cli = _cli_check(capsys, "--model", str(model))
    run = _cli_run(capsys, tmp_path / "out", "--model", str(model))
    assert api.passed and status == 0 and cli["passed"] is True, api.statement
    assert {r.check for r in api.rows} == {"pointwise"}
    assert cli["verdict"]["statement"] == api.statement == run["statement"]  # decide's sentence, kept in results
    assert run["derivation"]["verdict"] == cli["verdict"]["derivation"] == "not applicable"
    assert run["pointwise"]["passed"] is True


def test_check_names_a_mistake_the_models_values_hide_and_pointwise_only_does_not(tmp_path, capsys):
    """g sin th without l (l = 1 in the model): `check --pointwise-only` passes it, `check` fails it
    naming gravity and the probe, with the API's words, its verdict line last and status 1."""
    model, module = _copy(tmp_path / "in", mutated_source(HIDDEN))
    files = ("--model", str(model), "--equations", str(module))
    assert main(["check", *files, "--states", "20", "--pointwise-only"]) == 0
    assert "verdict:" not in capsys.readouterr().out
    assert main(["check", *files, "--states", "20", "--probes", "2"]) == 1
    lines = capsys.readouterr().out.splitlines()
    api = lx.check(lx.System.from_files(model, module), n_states=20, probes=2)
    assert lines[-1] == f"verdict: mine: FAIL: {api.statement}"
    assert "gravity disagrees at probe" in lines[-1] and "hidden by the model's values" in lines[-1], lines[-1]
    assert any(line.startswith("gravity") and line.endswith("FAIL") for line in lines), lines
    status, cli = _cli_check(capsys, *files)
    assert status == 1 and cli["verdict"]["first_disagreeing_term"] == "gravity"
    assert cli["verdict"]["hidden_by_model_values"] is True


def _tree(root: Path, skip: tuple[str, ...] = ()) -> dict[str, tuple[int, int]]:
    """Every file under `root` (but the folders named in `skip`): its size and modification time."""
    out = {}
    for folder, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if d not in skip]
        for name in files:
            st = os.lstat(os.path.join(folder, name))
            out[os.path.relpath(os.path.join(folder, name), root)] = (st.st_size, st.st_mtime_ns)
    return out


def test_check_leaves_the_package_and_the_working_folder_unchanged(tmp_path):
    """lx.check on a wrong derivation (whose explanation a cache would keep), in a fresh interpreter
    (bytecode off: the interpreter's own writes are not the harness's) with no cache configured: the
    package folder, the working folder and the user's cache folder are as they were."""
    model, module = _copy(tmp_path / "in", mutated_source(HIDDEN))
    work, xdg = tmp_path / "work", tmp_path / "xdg"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "LAGRANGE_XVAL_CACHE"}
    env |= {"PYTHONDONTWRITEBYTECODE": "1", "XDG_CACHE_HOME": str(xdg)}
    code = (
        "import lagrange_xval as lx, sys\n"
        f"r = lx.check(lx.System.from_files({str(model)!r}, {str(module)!r}), n_states=20, probes=2)\n"
        "sys.exit(0 if not r.passed and 'gravity' in r.statement else 3)\n"
    )
    # what the tools write, never the harness: git, the venv, bytecode, and (the test files run in parallel)
    # pytest's and hypothesis's own folders
    skip = (".git", ".venv", "__pycache__", ".pytest_cache", ".hypothesis")
    package, inputs = _tree(PACKAGE_ROOT, skip), _tree(tmp_path / "in")
    done = subprocess.run([sys.executable, "-c", code], cwd=work, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert _tree(PACKAGE_ROOT, skip) == package
    assert list(work.iterdir()) == [] and not xdg.exists()
    assert _tree(tmp_path / "in") == inputs


def test_a_cache_given_keeps_the_explanations_and_stays_within_its_bound(tmp_path, own_cache):
    """With a Cache, the wrong entry's explanation is kept there (and read back the same); a bound
    of 0 bytes trims every entry."""
    model, module = _copy(tmp_path / "in", mutated_source(HIDDEN))
    system = lx.System.from_files(model, module)
    first = lx.check(system, n_states=20, probes=2, cache=own_cache)
    kept = own_cache.entries()
    assert kept and {p.parent.name for p in kept} == {"explain"}
    assert lx.check(system, n_states=20, probes=2, cache=own_cache).statement == first.statement
    assert Cache.at(own_cache.root, max_bytes=0).trim() > 0 and own_cache.entries() == []


def test_trim_removes_the_least_recently_used_entries_first(tmp_path):
    cache = Cache.at(tmp_path, max_bytes=250)
    (tmp_path / "reference").mkdir()
    for i, name in enumerate(("old", "mid", "new")):
        path = tmp_path / "reference" / f"{name}.npz"
        path.write_bytes(b"x" * 100)
        os.utime(path, (1_000_000 + i, 1_000_000 + i))
    (tmp_path / "reference" / "notes.txt").write_bytes(b"y" * 1000)  # not an entry: never removed
    assert cache.trim() == 100
    assert sorted(p.name for p in (tmp_path / "reference").iterdir()) == ["mid.npz", "new.npz", "notes.txt"]
    assert Cache.off().trim() == 0 and Cache.off().folder("reference") is None

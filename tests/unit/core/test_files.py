"""A person's input cannot make the harness write through a link or present forged data, and every
error names its cause (issue 28): files are created with O_EXCL | O_NOFOLLOW, cache entries are signed
with a key of the user's, and each refusal is one `lagrange-xval: error:` line before any work."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess

import numpy as np
import pytest
from lagrange_xval import cli, systems
from lagrange_xval.cli import main
from lagrange_xval.core import cache
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.core.files import replace_files
from lagrange_xval.results import atomic_write_many

from tests.unit.core.test_errors import CLI, _one_error_line, _simulate

EXAMPLES = systems.PACKAGE_ROOT / "examples"
FAST = ["--states", "50", "--probes", "0", "--no-replay"]  # simple_pendulum: a few seconds


def _run(out, *more):
    return main(["run", "simple_pendulum", *FAST, "--out", str(out), *more])


# --- no write through a link ---------------------------------------------------------------------


def test_new_does_not_write_through_a_planted_link(tmp_path, capsys):
    """A link at the name `new` used to stage through (`.mine.py.tmp`) is left alone; mine.py is a file."""
    shutil.copy(systems.MODELS_DIR / "simple_pendulum.xml", tmp_path / "arm.xml")
    victim = tmp_path / "victim"
    victim.write_text("keep")
    (tmp_path / ".mine.py.tmp").symlink_to(victim)
    assert main(["new", "mine", "--model", str(tmp_path / "arm.xml")]) == 0
    mine = tmp_path / "mine.py"
    assert not mine.is_symlink() and "def parameters" in mine.read_text()
    assert victim.read_text() == "keep" and mine.stat().st_mode & 0o777 == 0o644


def test_new_refuses_a_dangling_link_where_its_module_goes(tmp_path, capsys):
    shutil.copy(systems.MODELS_DIR / "simple_pendulum.xml", tmp_path / "arm.xml")
    (tmp_path / "mine.py").symlink_to(tmp_path / "nowhere.py")
    assert main(["new", "mine", "--model", str(tmp_path / "arm.xml")]) == 2
    _one_error_line(capsys, "exists already")
    assert not (tmp_path / "nowhere.py").exists()


def test_a_cache_folder_linked_out_of_out_is_refused_before_work(tmp_path, capsys):
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (out / ".cache").symlink_to(elsewhere)
    assert _run(out) == 2
    _one_error_line(capsys, "outside --out")
    assert list(elsewhere.iterdir()) == [] and sorted(p.name for p in out.iterdir()) == [".cache"]


def test_a_linked_out_is_written_into_and_stays_a_link(tmp_path, capsys):
    """The folder the link points to is exchanged; no `.staging-*` is left beside either. With
    --probes 0 the verdict does not claim probe parameter sets."""
    real, out = tmp_path / "real", tmp_path / "out"
    real.mkdir()
    out.symlink_to(real)
    assert _run(out) == 0
    assert out.is_symlink() and (real / "results.json").is_file() and (real / "report.html").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "real"]
    report = (real / "report.md").read_text()
    assert "probe parameter sets" not in report.replace("no probe parameter sets", ""), "--probes 0 claims probes"


def test_simulate_replaces_a_link_at_its_out_never_its_target(tmp_path, capsys):
    victim, out = tmp_path / "victim", tmp_path / "run.csv"
    victim.write_text("keep")
    out.symlink_to(victim)
    assert main(_simulate(tmp_path, out)) == 0
    assert victim.read_text() == "keep" and not out.is_symlink() and out.read_text().startswith("#")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv", "victim"], "a temporary file left behind"


def test_entries_are_never_written_through_a_link(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("keep")
    (tmp_path / "x.npz").symlink_to(victim)
    assert cache.store(tmp_path / "x.npz", "k", {"a": np.arange(3.0)}, {"n": 1})
    assert victim.read_text() == "keep" and not (tmp_path / "x.npz").is_symlink()


def test_a_link_planted_for_an_entry_folder_is_not_followed(tmp_path, capsys):
    """In a shared cache, `reference -> somewhere` would send entries elsewhere: not written, one warning."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (tmp_path / "cache").mkdir()
    (tmp_path / "cache" / "reference").symlink_to(elsewhere)
    assert not cache.store(tmp_path / "cache" / "reference" / "x.npz", "k", {"a": np.arange(3.0)}, {})
    assert list(elsewhere.iterdir()) == [] and "a link, not a folder" in capsys.readouterr().err


# --- cache entries the harness can trust ---------------------------------------------------------


def _old_checksum(key, info, arrays):
    """The previous scheme: a SHA-256 anyone can recompute."""
    h = hashlib.sha256()
    h.update(key.encode() + b"\0" + json.dumps(info, sort_keys=True).encode() + b"\0")
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name} {a.dtype.str} {a.shape}".encode() + b"\0" + a.tobytes() + b"\0")
    return h.hexdigest()


@pytest.mark.parametrize("kind", ["chaos", "derive", "explain"])
def test_a_forged_entry_is_recomputed_with_a_warning_never_a_finding(tmp_path, capsys, kind):
    """A value flipped and the plain checksum recomputed (what anyone can do) is not trusted."""
    path, key = tmp_path / kind / "entry.npz", "k" * 24
    info = {"lyapunov": {"lambda": 0.1}} if kind == "chaos" else {"value": "M = m*l**2"}
    assert cache.store(path, key, {}, info)
    assert cache.load(path, key) == ({}, info)
    forged = {"lyapunov": {"lambda": 2.5}} if kind == "chaos" else {"value": "M = 2*m*l**2"}
    digest = _old_checksum(key, forged, {})
    header = {"schema": cache.SCHEMA, "key": key, "info": forged, "sha256": digest, "hmac": digest}
    with open(path, "wb") as f:
        np.savez(f, **{cache.HEADER: np.array(json.dumps(header))})
    assert cache.load(path, key) is None
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "signature mismatch" in err[0] and "recomputing" in err[0], err


def test_the_signing_key_is_private_and_made_once(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv(cache.PROCESS_KEY_ENV, raising=False)
    cache.signing_key.cache_clear()
    try:
        key = cache.signing_key()
        path = tmp_path / "lagrange-xval" / "key"
        assert path.read_bytes() == key and path.stat().st_mode & 0o777 == 0o600
        cache.signing_key.cache_clear()
        assert cache.signing_key() == key, "a second process reads the same key"
    finally:
        cache.signing_key.cache_clear()


def test_a_key_that_is_a_link_is_not_used(tmp_path, monkeypatch, capsys):
    """A key file planted as a link (to a key someone else knows) is not followed: a key of this run."""
    (tmp_path / "lagrange-xval").mkdir()
    known = tmp_path / "known"
    known.write_bytes(b"k" * cache.KEY_BYTES)
    known.chmod(0o600)
    (tmp_path / "lagrange-xval" / "key").symlink_to(known)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv(cache.PROCESS_KEY_ENV, raising=False)
    cache.signing_key.cache_clear()
    try:
        assert cache.signing_key() != known.read_bytes()
    finally:
        cache.signing_key.cache_clear()
        os.environ.pop(cache.PROCESS_KEY_ENV, None)
    assert "no private cache key" in capsys.readouterr().err


def test_a_cache_that_cannot_be_written_is_one_line(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("a file where the cache goes")
    assert _run(tmp_path / "out", "--cache-dir", str(blocker / "cache")) == 0
    warnings = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert len(warnings) == 1 and "running without a cache" in warnings[0], warnings


# --- every error names its cause -----------------------------------------------------------------


def _arm_urdf(tmp_path, kind):
    text = (EXAMPLES / "urdf" / "spatial_arm.urdf").read_text().replace('"elbow"', '"pl"')
    path = tmp_path / "arm.urdf"
    path.write_text(text.replace('name="pl" type="revolute"', f'name="pl" type="{kind}"'))
    return path


@pytest.mark.parametrize("kind", ["planar", "floating"])
def test_an_unsupported_urdf_joint_is_refused_by_type_and_name(tmp_path, capsys, kind):
    model = _arm_urdf(tmp_path, kind)
    assert main(["run", "--model", str(model), *FAST, "--out", str(tmp_path / "out")]) == 2
    _one_error_line(capsys, f"joint 'pl' is a {kind} joint", "--lock pl")
    assert not (tmp_path / "out").exists()


def test_a_locked_unsupported_joint_is_out_of_the_way_and_all_locked_is_refused(tmp_path, capsys):
    model = _arm_urdf(tmp_path, "planar")
    assert systems.System.model_only(model, locked=("pl",)).nv == 2
    assert main(["run", "--model", str(model), "--lock", "pl,yaw,shoulder", *FAST, "--out", str(tmp_path / "o")]) == 2
    _one_error_line(capsys, "every joint locked", "nothing moves")


def test_a_system_whose_name_starts_with_an_underscore_is_paired(tmp_path):
    for suffix in (".xml", ".py"):
        shutil.copy(EXAMPLES / f"cart_pole{suffix}", tmp_path / f"_arm{suffix}")
    assert systems.pairs_in(tmp_path) == [(tmp_path / "_arm.xml", tmp_path / "_arm.py")]


def test_a_path_with_a_colon_finds_its_system_again(tmp_path):
    folder = tmp_path / "a:b"
    folder.mkdir()
    for suffix in (".xml", ".py"):
        shutil.copy(EXAMPLES / f"cart_pole{suffix}", folder / f"cart_pole{suffix}")
    system = systems.System.from_files(folder / "cart_pole.xml", folder / "cart_pole.py")
    again = systems.from_key(systems.key_of(system))
    assert (again.name, again.mjcf) == (system.name, system.mjcf.resolve())


@pytest.mark.parametrize("address", ["garbage", "tcp://host", "tcp://host:0", "ftp://host:8786"])
def test_a_dask_address_is_checked_before_connecting(capsys, address):
    with pytest.raises(SystemExit) as stop:
        main(["run", "simple_pendulum", "--executor", f"dask:{address}"])
    assert stop.value.code == 2
    assert "is not a dask scheduler address" in capsys.readouterr().err


@pytest.mark.parametrize("where", [".", "sub"])
def test_a_cache_dir_inside_out_is_refused_before_work(tmp_path, capsys, where):
    out = tmp_path / "out"
    assert _run(out, "--cache-dir", str(out / where)) == 2
    _one_error_line(capsys, "inside --out", ".cache (the default)")
    assert not out.exists()


def test_a_folder_where_report_html_goes_is_replaced_by_the_report(tmp_path, capsys):
    """The folder is one of the earlier set's names (tests/unit/cli/test_outputs.py): the new set replaces it."""
    out = tmp_path / "out"
    (out / "report.html").mkdir(parents=True)
    assert _run(out) == 0
    assert (out / "report.html").is_file() and "<html" in (out / "report.html").read_text()[:2000].lower()


def test_an_earlier_runs_files_are_gone_after_a_run_of_one_system(tmp_path, capsys):
    """The README: files of an earlier run that this run does not produce are gone; bench.json stays."""
    out = tmp_path / "out"
    (out / "img").mkdir(parents=True)
    stale = ["gimbal.rrd", "double_pendulum_point.rrd", "img/gimbal_energy.png", "report.md", "results.json"]
    for name in [*stale, "bench.json"]:
        (out / name).write_text("{}" if name == "bench.json" else "OLD")
    assert _run(out) == 0
    left = sorted(str(p.relative_to(out)) for p in out.rglob("*") if ".cache" not in p.parts)
    assert not {"gimbal.rrd", "double_pendulum_point.rrd", "img/gimbal_energy.png"} & set(left), left
    assert (out / "bench.json").read_text() == "{}" and (out / "results.json").read_text() != "OLD"


def test_a_repository_module_with_a_syntax_error_is_one_line_for_check(capsys, monkeypatch):
    real = systems.loader.importlib.import_module

    def broken(name, *args):
        if name.endswith(".simple_pendulum"):
            raise SyntaxError("invalid syntax", ("simple_pendulum.py", 3, 1, "x = = 1\n"))
        return real(name, *args)

    systems.loader.repository_module.cache_clear()
    monkeypatch.setattr(systems.loader.importlib, "import_module", broken)
    try:
        assert main(["check", "simple_pendulum", "--states", "5"]) == 2
    finally:
        systems.loader.repository_module.cache_clear()
    _one_error_line(capsys, "equations/simple_pendulum.py: syntax error at line 3")


def test_without_home_stdout_is_the_commands_and_stderr_has_no_colour(tmp_path):
    """heyoka's warnings (no HOME) go to stderr; the cache says once that it keeps nothing."""
    env = {k: v for k, v in os.environ.items() if k not in ("HOME", "XDG_CACHE_HOME", cache.PROCESS_KEY_ENV)}
    out = tmp_path / "out"
    proc = subprocess.run(
        [*CLI, "run", "simple_pendulum", *FAST, "--out", str(out)], capture_output=True, text=True, env=env, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    assert "heyoka" not in proc.stdout and "all systems pass" in proc.stdout, proc.stdout
    assert "\x1b[" not in proc.stderr and proc.stderr.count("no private cache key") == 1, proc.stderr


def test_libraries_are_told_not_to_colour_a_non_terminal_stderr(capsys, monkeypatch):
    for name in ("NO_COLOR", "RUST_LOG_STYLE"):
        monkeypatch.setenv(name, "")
        monkeypatch.delenv(name)  # unset here, restored after
    seen = {}
    monkeypatch.setitem(cli.COMMANDS, "list", lambda args: seen.update(os.environ) or 0)
    assert main(["list"]) == 0  # pytest's capture: stderr is no terminal
    assert seen.get("NO_COLOR") == "1" and seen.get("RUST_LOG_STYLE") == "never"


def test_a_set_of_files_that_fails_midway_leaves_no_temporary_file(tmp_path):
    """`results.atomic_write_many`: a writer failing on the second file replaces nothing, leaves nothing."""
    (tmp_path / "a.json").write_text("OLD")

    def full(f):
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="No space"):
        replace_files({tmp_path / "a.json": "new", tmp_path / "b.json": full})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"] and (tmp_path / "a.json").read_text() == "OLD"
    with pytest.raises(HarnessError, match="b.json"):
        atomic_write_many({tmp_path / "a.json": "new", tmp_path / "b.json": full})

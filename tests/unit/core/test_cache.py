"""The cache is never trusted blindly: every kind of damaged or forged entry is found, said once on
stderr and recomputed; entries are shared (0644); the key covers the harness's own source."""

from __future__ import annotations

import json
import os
import shutil
import zipfile

import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.core import cache
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.dynamics import chaos, reference
from lagrange_xval.dynamics.integrate import time_grid
from lagrange_xval.model.start import Start

POINT = systems.load("double_pendulum_point")
START = (np.array([0.0, 3.0]), np.zeros(2), np.zeros(2))
GRID = time_grid(2.0, 0.01)


def _reference(folder):
    return reference.reference_trajectory(POINT, Start.of(*START), GRID, cache_dir=folder, check=None)


@pytest.fixture(scope="module")
def fresh(tmp_path_factory):
    """A reference computed once and its cache file, copied per test before damaging it."""
    folder = tmp_path_factory.mktemp("reference")
    traj, info = _reference(folder)
    assert info["cache"] == "miss"
    return traj, info["cache_file"]


def _entry(path):
    with np.load(path) as z:
        return {name: z[name] for name in z.files}


def _rewrite(path, **changes):
    """The entry with some arrays changed and the header left as it was (its signature now stale)."""
    arrays = {**_entry(path), **changes}
    with open(path, "wb") as f:
        np.savez(f, **arrays)


def _forge(path, **changes):
    """The entry changed and signed again with this user's key: only the content checks can tell."""
    arrays = _entry(path)
    header = json.loads(str(arrays.pop(cache.HEADER)))
    arrays.update(changes)
    assert cache.store(path, header["key"], arrays, header["info"])


def _truncate(path):
    path.write_bytes(path.read_bytes()[:1000])


def _nan(path):
    q = _entry(path)["q"].copy()
    q[50] = np.nan
    _rewrite(path, q=q)


def _shift(path):
    _rewrite(path, q=_entry(path)["q"] + 0.3)


def _forged_shift(path):
    q = _entry(path)["q"].copy()
    q[1:] += 0.3  # the start kept, so only the windows can tell
    _forge(path, q=q)


def _forged_nan(path):
    q = _entry(path)["q"].copy()
    q[-1] = np.nan
    _forge(path, q=q)


def _forged_splice(path):
    """The second half from another start: every sample finite, the start right, one window wrong."""
    other, _ = reference.reference_trajectory(
        POINT, Start.of([0.0, 2.9], [0.0, 0.0], [0.0, 0.0]), GRID, cache_dir=None, check=None
    )
    q, v = _entry(path)["q"].copy(), _entry(path)["v"].copy()
    q[100:], v[100:] = other.q[100:], other.v[100:]
    _forge(path, q=q, v=v)


def _old_schema(path):
    arrays = _entry(path)
    header = json.loads(str(arrays.pop(cache.HEADER)))
    header["schema"] = cache.SCHEMA - 1
    _rewrite(path, **{cache.HEADER: np.array(json.dumps(header))})


def _other_key(path):
    arrays = _entry(path)
    header = json.loads(str(arrays.pop(cache.HEADER)))
    cache.store(path, "0" * 24, arrays, header["info"])


def _legacy(path):
    """An entry of the previous layout (no header at all)."""
    arrays = _entry(path)
    del arrays[cache.HEADER]
    with open(path, "wb") as f:
        np.savez(f, **arrays)


def _garbage(path):
    path.write_bytes(os.urandom(4096))


def _folder(path):
    path.unlink()
    path.mkdir()


DAMAGE = {
    "truncated": (_truncate, "unreadable"),
    "random bytes": (_garbage, "unreadable"),
    "a folder in its place": (_folder, "unreadable"),
    "NaN written in": (_nan, "signature mismatch"),
    "shifted by 0.3 rad": (_shift, "signature mismatch"),
    "old schema": (_old_schema, "schema"),
    "no header (previous layout)": (_legacy, "unreadable"),
    "another entry's key": (_other_key, "another key"),
    "forged shift, valid signature": (_forged_shift, "windows disagree"),
    "forged NaN, valid signature": (_forged_nan, "non-finite"),
    "forged splice, valid signature": (_forged_splice, "windows disagree"),
}


@pytest.mark.parametrize("case", sorted(DAMAGE))
def test_a_damaged_or_forged_reference_is_recomputed_with_one_warning(fresh, tmp_path, capsys, case):
    traj, cached = fresh
    folder = tmp_path / "reference"
    folder.mkdir()
    path = folder / os.path.basename(cached)
    shutil.copy(cached, path)
    damage, why = DAMAGE[case]
    damage(path)
    again, info = _reference(folder)
    assert info["cache"] == "miss", f"{case}: the damaged entry was used"
    assert np.array_equal(again.q, traj.q) and np.array_equal(again.v, traj.v)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("lagrange-xval: warning: cache entry") and why in err[0], err
    third, info = _reference(folder)
    assert info["cache"] == "hit", f"{case}: the recomputed entry was not written back"
    assert capsys.readouterr().err == ""


def test_an_intact_entry_passes_its_content_checks(fresh, tmp_path, capsys):
    """The checks that catch forgeries do not reject the real thing (and they can fail: see above)."""
    traj, cached = fresh
    shutil.copy(cached, tmp_path / os.path.basename(cached))
    again, info = _reference(tmp_path)
    assert info["cache"] == "hit" and capsys.readouterr().err == ""
    assert reference.window_check(POINT, again, START[2]) < 1e-10


def test_the_self_check_runs_on_cached_entries(fresh, tmp_path, monkeypatch):
    """A trace that stopped matching the module is refused even when the reference comes from the cache."""
    _, cached = fresh
    shutil.copy(cached, tmp_path / os.path.basename(cached))
    monkeypatch.setattr(reference, "rhs_check", lambda system: 1e-3)
    with pytest.raises(HarnessError, match="symbolic trace is wrong"):
        _reference(tmp_path)


def test_entries_are_readable_by_everyone(tmp_path):
    old = os.umask(0o077)
    try:
        assert cache.store(tmp_path / "x.npz", "k", {"a": np.arange(3.0)}, {"n": 1})
    finally:
        os.umask(old)
    assert (tmp_path / "x.npz").stat().st_mode & 0o777 == 0o644
    arrays, info = cache.load(tmp_path / "x.npz", "k")
    assert np.array_equal(arrays["a"], np.arange(3.0)) and info == {"n": 1}


def test_a_cache_that_cannot_be_written_costs_a_warning_not_the_result(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("a file where the cache folder goes")
    traj, info = _reference(blocker / "reference")
    assert info["cache"] == "miss" and info["cache_file"] is None and np.all(np.isfinite(traj.q))
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot write the cache entry" in err[0]


def test_the_key_covers_the_harness_source(tmp_path, monkeypatch):
    """Editing any harness file (the tracing code that builds the reference, say) changes every key."""
    copies = {package: tmp_path / package for package in cache.SOURCE_DIRS}
    for package, folder in cache.SOURCE_DIRS.items():
        shutil.copytree(folder, copies[package])
    monkeypatch.setattr(cache, "SOURCE_DIRS", copies)
    cache.harness_hash.cache_clear()
    try:
        before = reference.cache_key(POINT, *START, GRID, check=None)
        tracing = tmp_path / "validate" / "handwritten" / "tracing.py"
        tracing.write_text(tracing.read_text() + "\n# changed\n")
        cache.harness_hash.cache_clear()
        after = reference.cache_key(POINT, *START, GRID, check=None)
    finally:
        cache.harness_hash.cache_clear()
    assert before != after


def test_the_configured_folder_and_no_cache(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path / "c"))
    assert cache.folder(cache.DEFAULT, "reference") == tmp_path / "c" / "reference"
    monkeypatch.setenv(cache.CACHE_ENV, "")
    assert cache.folder(cache.DEFAULT, "reference") is None
    _, info = _reference(cache.DEFAULT)
    assert info["cache"] == "off"


@pytest.fixture(scope="module")
def summary(tmp_path_factory):
    folder = tmp_path_factory.mktemp("chaos") / "reference"
    system = systems.load("simple_pendulum")
    args = (system, Start.of([0.5], [0.0], [0.0]))
    first = chaos.chaos_summary(*args, cache_dir=folder)
    assert first["cache"] == "miss"
    (path,) = (folder.parent / "chaos").iterdir()
    return args, folder, path, first


def test_a_chaos_summary_is_verified_on_read(summary, capsys):
    args, folder, path, first = summary
    second = chaos.chaos_summary(*args, cache_dir=folder)
    assert second["cache"] == "hit" and {**second, "cache": "miss"} == first
    original = path.read_bytes()
    try:
        # an edited exponent: the signature no longer matches
        arrays = _entry(path)
        header = json.loads(str(arrays[cache.HEADER]))
        header["info"]["lyapunov"]["lambda"] += 1.0
        _rewrite(path, **{cache.HEADER: np.array(json.dumps(header))})
        assert chaos.chaos_summary(*args, cache_dir=folder)["cache"] == "miss"
        assert "signature mismatch" in capsys.readouterr().err
        # a forged exponent with a valid signature (the key is this user's): the summary no longer ties together
        forged = json.loads(json.dumps(first))
        del forged["cache"]
        forged["lyapunov"]["lambda"] = 0.123
        assert cache.store(path, header["key"], {}, forged)
        assert chaos.chaos_summary(*args, cache_dir=folder)["cache"] == "miss"
        assert "do not match their stored agreement" in capsys.readouterr().err
    finally:
        path.write_bytes(original)


def test_a_zip_bomb_of_a_header_is_not_trusted(tmp_path, capsys):
    """A zip with a header member that is not the harness's JSON is unreadable, not a crash."""
    path = tmp_path / "x.npz"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr(f"{cache.HEADER}.npy", b"not an array")
    assert cache.load(path, "k") is None
    assert "unreadable" in capsys.readouterr().err


def test_run_uses_the_cache_dir_and_the_report_says_what_came_from_it(tmp_path, capsys):
    """`--cache-dir` holds the entries (not the checkout, not OUT); a second run loads them and its
    report names them; the setting does not outlive the command."""
    from lagrange_xval.cli import main

    before = os.environ.get(cache.CACHE_ENV)
    args = ["run", "simple_pendulum", "--states", "10", "--no-replay", "--out", str(tmp_path / "r")]
    assert main([*args, "--cache-dir", str(tmp_path / "c")]) == 0
    assert "from the cache | nothing" in (tmp_path / "r" / "report.md").read_text()
    assert sorted(p.name for p in (tmp_path / "c").iterdir()) == ["chaos", "derive", "figures", "reference"]
    assert not (tmp_path / "r" / ".cache").exists()
    assert main([*args, "--cache-dir", str(tmp_path / "c")]) == 0
    report = (tmp_path / "r" / "report.md").read_text()
    assert "from the cache | simple_pendulum (reference solution, chaos and mirrors, experiments)" in report
    assert os.environ.get(cache.CACHE_ENV) == before
    capsys.readouterr()


def test_no_cache_turns_reading_and_writing_off(tmp_path):
    """--no-cache is a Cache value that is off (no environment variable is set); --cache-dir's
    default is OUT/.cache."""
    import argparse

    from lagrange_xval.cli.commands import cache_of

    before = os.environ.get(cache.CACHE_ENV)
    off = cache_of(argparse.Namespace(no_cache=True, cache_dir=None, out=tmp_path))
    assert off.folder("reference") is None and os.environ.get(cache.CACHE_ENV) == before
    _, info = _reference(off.folder("reference"))
    assert info["cache"] == "off" and not list(tmp_path.iterdir())
    default = cache_of(argparse.Namespace(no_cache=False, cache_dir=None, out=tmp_path / "r"))
    assert default.folder("chaos") == (tmp_path / "r" / ".cache" / "chaos").absolute()


def test_a_cache_dir_that_is_a_file_is_one_warning_line(tmp_path, capsys):
    """Issue 47: `--cache-dir FILE` gave a warning per entry (17 lines); it is one, and the command runs."""
    from lagrange_xval.cli import main

    plain = tmp_path / "not_a_folder"
    plain.write_text("")
    assert main(["check", "double_pendulum_point", "--cache-dir", str(plain), "--states", "10", "--probes", "0"]) == 0
    warnings = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert warnings == [
        f"lagrange-xval: warning: cannot write the cache in {plain} (not a folder); running without a cache."
    ]

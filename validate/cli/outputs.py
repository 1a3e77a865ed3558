"""Writes what `run` and `report` produce, as one set: a failure at any point leaves the previous set whole.

Every file is rendered in memory, written into a new folder beside the reports folder (a full disk
fails here, with nothing replaced), the files the command does not produce (the cache, bench.json,
stress.json, .gitkeep) are carried over as hard links, and the new folder takes the old one's place in one
rename (Linux: renameat2 RENAME_EXCHANGE, atomic; elsewhere two renames, the old folder restored if
the second fails). Files of an earlier run that this run does not produce (the .rrd and plots of
systems not in it) are gone with the old folder.
"""

from __future__ import annotations

import ctypes
import errno
import hashlib
import os
import shutil
import sys
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import cast

from ..core.cache import harness_hash, load_bytes, store_bytes
from ..core.cachedir import Cache
from ..core.errors import HarnessError
from ..core.files import folder, new_file
from ..replay import render_system as render_rrd
from ..report import ReplayHint, render, system_section
from ..report.document import Document
from ..report.figstore import kept_in
from ..results import dumps, system_json
from ..results.schema import Provenance, ReportInput, RunResults, SystemResult
from ..verdict import reproduce

OPTIONAL_RESULTS = {"bench": "bench.json", "stress": "stress.json", "chains": "chains.json"}  # bench, stress
CACHE_FOLDER = ".cache"
KEPT = (CACHE_FOLDER, ".gitkeep", *OPTIONAL_RESULTS.values())  # not written by `run`: carried over
REPORT_FILES = ("report.md", "report.html", "img")  # what `report` produces
RUN_FILES = ("results.json", reproduce.FOLDER, *REPORT_FILES)  # what `run` produces, with <system>.rrd


def _from_run(name: str) -> bool:
    return name in RUN_FILES or name.endswith(".rrd")


def _from_report(name: str) -> bool:
    return name in REPORT_FILES


SURVEY_FILES = (
    "survey.json",
    "survey.jsonl",
    "survey.html",
    "survey.md",
)  # what `survey` produces, with the reproducers


def _ours(name: str) -> bool:
    return _from_run(name) or name in KEPT or name in SURVEY_FILES


def real_out(out: Path) -> Path:
    """The folder `out` names: itself, or the folder a link there points to (written into, the link
    kept); a link to nothing or to a file is refused."""
    out = Path(out)
    if not out.is_symlink():
        return out
    target = out.resolve()
    if not target.is_dir():
        raise HarnessError(f"--out {out} is a link to {target}, which is not a folder; give a folder.")
    return target


def check_out(out: Path) -> None:
    """Refuses a reports folder that is a file, or a folder holding anything the harness did not write
    (the folder is replaced as a whole: `--out .` must not replace a checkout), or whose cache folder
    is a link out of it (the cache would be written elsewhere)."""
    shown, out = Path(out), real_out(out)
    if out.exists() and not out.is_dir():
        raise HarnessError(f"--out {shown} is a file, not a folder.")
    for where in (out, out.absolute().parent) if out.is_dir() else ():
        if not os.access(where, os.W_OK | os.X_OK):
            raise HarnessError(f"--out {shown}: {where} is not writable; give a folder you can write.")
    cache = out / CACHE_FOLDER
    if cache.is_symlink() and not cache.resolve().is_relative_to(out.resolve()):
        raise HarnessError(
            f"{shown / CACHE_FOLDER} is a link to {cache.resolve()}, outside --out: the cache is written only "
            "inside --out; remove the link, or give that folder as --cache-dir."
        )
    if out.is_dir():
        try:
            foreign = sorted(p.name for p in out.iterdir() if not _ours(p.name))
        except OSError as exc:
            raise HarnessError(f"cannot read {out}: {exc.strerror or exc}.") from None
        if foreign:
            more = f" and {len(foreign) - 3} more" if len(foreign) > 3 else ""
            raise HarnessError(
                f"--out {out} holds files the harness does not write ({', '.join(foreign[:3])}{more}); "
                "give an empty folder or a reports folder."
            )


def check_cache_dir(cache_dir: Path | None, out: Path) -> None:
    """Refuses a --cache-dir inside --out other than OUT/.cache (the default): the rest of OUT is
    replaced as a whole by each run, a cache there would be thrown away or refused at the end."""
    if cache_dir is None:
        return
    cache, real = Path(cache_dir).resolve(), real_out(out).resolve()
    if cache.is_relative_to(real) and not cache.is_relative_to(real / CACHE_FOLDER):
        raise HarnessError(
            f"--cache-dir {cache_dir} is inside --out {out}, which each run replaces as a whole; "
            f"give {Path(out) / CACHE_FOLDER} (the default) or a folder outside --out."
        )


def with_optional_results(results: Mapping[str, object], out: Path) -> ReportInput:
    """The results plus the benchmark and stress results found in the reports folder, for rendering."""
    import json

    merged = dict(results)
    for key, name in OPTIONAL_RESULTS.items():
        path = Path(out) / name
        if key not in merged and path.is_file():
            try:
                merged[key] = json.loads(path.read_text())
            except (OSError, ValueError):
                pass  # a damaged optional file: its section says "not run"
    return cast(ReportInput, merged)  # results.json's shape (results/schema.py), and the studies found beside it


def write_reports(results: Mapping[str, object], out: Path, *, hint: ReplayHint | None = None) -> None:
    """report.md, report.html and their plots, replacing those of the folder as one set."""

    files = render(with_optional_results(results, out), hint=hint)  # may fail: nothing written yet
    replace_set(out, files, replaces=_from_report)


@dataclass
class SystemFiles:
    """What one system contributes to the reports, rendered from its results alone."""

    section: Document  # the system's section of the report
    rrd: bytes | None  # its rerun recording (None: no trajectories, or replays not asked for)
    json: str | None = None  # its results as results.json holds them (results.system_json)


def render_system(
    name: str, result: SystemResult, meta: Provenance, *, replay: bool = True, cache: Cache | None = None
) -> SystemFiles | None:
    """A system's report section and recording, from its results alone: `run` calls this in the
    worker that computed them, so rendering overlaps the other systems' work. None if rendering
    fails (the final render then tries again in the parent and reports the failure there). `cache`:
    where its figures are kept by content (report/figstore.py; None: drawn every time)."""

    try:
        rrd = render_rrd(name, result, meta=meta) if replay and result.get("trajectories") else None
        with kept_in(CachedFigures(cache) if cache is not None and cache.enabled else None):
            proofs = reproduce.scripts(result.get("reproducers", []))[0]
            shown: SystemResult = {**result, "reproducers": proofs} if "reproducers" in result else result
            return SystemFiles(system_section(name, shown), rrd, system_json(shown))
    except Exception:  # noqa: BLE001 - rendered again, with its error, by write_all
        return None


@dataclass(frozen=True)
class CachedFigures:
    """The report's figures kept in a cache's `figures` folder (verified entries, core/cache.py),
    keyed by the figure's own key and the harness's source."""

    cache: Cache

    def _where(self, key: str) -> tuple[Path, str] | None:
        base = self.cache.folder("figures")
        full = hashlib.sha256((harness_hash() + key).encode()).hexdigest()
        return None if base is None else (base / f"{full[:32]}.npz", full)

    def get(self, key: str) -> bytes | None:
        where = self._where(key)
        return None if where is None else load_bytes(*where)

    def put(self, key: str, png: bytes) -> None:
        where = self._where(key)
        if where is not None:
            store_bytes(where[0], where[1], png)


def write_all(
    results: RunResults,
    out: Path,
    *,
    replay: bool = True,
    rendered: dict[str, SystemFiles | None] | None = None,
    hint: ReplayHint | None = None,
) -> None:
    """Everything `run` produces, replacing the previous run's files (all of them) as one set.
    `rendered`: systems already rendered from these results (`render_system`), the rest is rendered here."""

    results, proofs = without_scripts(results)
    done = {name: f for name, f in (rendered or {}).items() if f is not None and name in results.get("systems", {})}
    sections = {name: f.section for name, f in done.items()}
    files = {
        **proofs,
        "results.json": dumps(results, {name: f.json for name, f in done.items() if f.json}).encode(),
        **render(with_optional_results(results, out), sections, hint=hint or ReplayHint(written=replay)),
    }
    if replay:
        meta = results.get("meta")
        for name, s in results["systems"].items():
            if s.get("trajectories"):
                pre = done[name].rrd if name in done else None
                files[f"{name}.rrd"] = pre if pre is not None else render_rrd(name, s, meta=meta)
    replace_set(out, files, replaces=_from_run)


def without_scripts(results: RunResults) -> tuple[RunResults, dict[str, bytes]]:
    """The results without the reproducers' texts, and the texts by their file under the out folder
    (verdict/reproduce.py: results.json keeps each one's path, the folder holds the script)."""
    systems: dict[str, SystemResult] = {}
    texts: dict[str, bytes] = {}
    for name, s in results.get("systems", {}).items():
        kept, found = reproduce.scripts(s.get("reproducers", []))
        systems[name] = {**s, "reproducers": kept} if "reproducers" in s else s
        texts.update(found)
    return {**results, "systems": systems}, texts


def replace_set(out: Path, files: dict[str, bytes], *, replaces: Callable[[str], bool]) -> None:
    """Makes `out` hold `files` (names relative to it) and whatever it held that `replaces` says is
    not replaced, in one switch; on any failure the previous folder is left as it was."""
    check_out(out)
    out = real_out(out)  # a link to the reports folder stays a link: its target is exchanged
    staging: Path | None = None
    try:
        out.absolute().parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.staging-", dir=out.absolute().parent))
        for name, data in files.items():
            _write_new(staging / name, data)
        if out.is_dir():
            for entry in out.iterdir():
                if not replaces(entry.name) and entry.name not in files:
                    _carry(entry, staging / entry.name)
        os.chmod(staging, out.stat().st_mode & 0o7777 if out.is_dir() else 0o755)
        _switch(staging, out)
    except OSError as exc:
        raise HarnessError(f"cannot write {out}: {exc.strerror or exc}; previous files left as they were.") from None
    finally:
        if staging is not None:
            shutil.rmtree(staging, ignore_errors=True)  # after the switch: the previous set


def _write_new(path: Path, data: bytes | str) -> None:
    """A new file (O_EXCL | O_NOFOLLOW) in the staging folder, 0644 whatever the umask: a report is for reading."""
    with folder(path.parent) as fd:
        new_file(path.name, data, dir_fd=fd)


def _carry(src: Path, dst: Path) -> None:
    """`src` at `dst` without copying data: hard links (files are only ever replaced, never edited)."""

    def link(a: str, b: str) -> None:
        try:
            os.link(a, b)
        except OSError:  # a file system without hard links
            shutil.copy2(a, b)

    if src.is_symlink():  # carried as the link it is, never as what it points to
        os.symlink(os.readlink(src), dst)
    elif src.is_dir():
        shutil.copytree(src, dst, copy_function=link, symlinks=True)
    else:
        link(str(src), str(dst))


def _exchange(a: Path, b: Path) -> bool:
    """Swaps two paths atomically (Linux renameat2 RENAME_EXCHANGE); False where that is unavailable."""
    if not sys.platform.startswith("linux"):
        return False
    renameat2 = getattr(ctypes.CDLL(None, use_errno=True), "renameat2", None)
    if renameat2 is None:
        return False
    at_fdcwd, rename_exchange = -100, 2
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL):  # old kernel, or a file system that cannot exchange
        return False
    raise OSError(err, os.strerror(err), str(b))


def _switch(new: Path, out: Path) -> None:
    """`new` becomes `out`; the previous `out` (if any) is left at `new`."""
    if not out.exists():
        os.rename(new, out)
        return
    if _exchange(new, out):
        return
    old = new.with_name(new.name + "-old")
    os.rename(out, old)
    try:
        os.rename(new, out)
    except BaseException:
        os.rename(old, out)
        raise
    os.rename(old, new)

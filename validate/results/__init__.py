"""Results as data: provenance, atomic writes. Reports are rendered from these files only."""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import subprocess
import sys
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from ..core.errors import HarnessError
from ..core.files import replace_files
from ..core.inputs import parse_json, regular_file
from ..core.package import PACKAGE_ROOT, installed_version
from .schema import Provenance, RunResults

__all__ = [
    "MAX_RESULTS_BYTES",
    "atomic_write",
    "atomic_write_many",
    "dumps",
    "harness_version",
    "load",
    "provenance",
    "schema_problem",
    "system_json",
    "to_jsonable",
]

PACKAGES = ("lagrange-xval", "numpy", "scipy", "mujoco", "pin", "rerun-sdk", "matplotlib", "jinja2")


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return f"{line.split(':', 1)[1].strip()} ({os.cpu_count()} cores)"
    except OSError:
        pass
    return f"{platform.processor() or platform.machine()} ({os.cpu_count()} cores)"


def _git_commit() -> str:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "--short=12", "HEAD"], cwd=PACKAGE_ROOT, capture_output=True, text=True, timeout=5
        )
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=PACKAGE_ROOT,
            capture_output=True,
            text=True,
            timeout=5,
        )
        return out.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "") if out.returncode == 0 else "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def harness_version() -> str:
    """The installed package's version (importlib.metadata), or a sentence saying it is not installed."""
    return installed_version("lagrange-xval") or "unknown (not installed: pip install -e .)"


def provenance(seed: int | None = None) -> Provenance:
    versions = {pkg: installed_version(pkg) or "not installed" for pkg in PACKAGES}
    return {
        "harness_version": versions["lagrange-xval"],
        "git_commit": _git_commit(),
        "date": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "command": " ".join(["lagrange-xval", *sys.argv[1:]]),
        "cpu": _cpu(),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "versions": versions,
        "seed": seed,
    }


def to_jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): to_jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [to_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        if x.dtype.kind == "f" and np.isfinite(x).all():
            return x.tolist()  # floats only: no call per element (time series are long)
        return to_jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        f = float(x)
        return f if np.isfinite(f) else str(f)  # JSON has no inf or nan
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    return x


def atomic_write(path: Path, data: bytes | str | Iterable[str]) -> None:
    """Writes `path` through a temporary file in the same folder and a rename: a reader sees the
    old file or the new one, never half of one; a link at `path` is replaced, never written through
    (`files.replace_file`). `data` may be text produced in pieces (an iterable of strings), so that a
    long file is never held in memory whole."""
    atomic_write_many({Path(path): data})


def atomic_write_many(files: Mapping[Path, bytes | str | Iterable[str]]) -> None:
    """Writes several files so that either all are replaced or none: every file is staged as a
    temporary file first (a full disk fails here, with nothing replaced), then each is renamed."""
    try:
        replace_files({Path(path): data for path, data in files.items()})
    except OSError as exc:
        where = exc.filename or ", ".join(str(p) for p in files)
        raise HarnessError(f"cannot write {where}: {exc.strerror or exc}; previous files left as they were.") from None


def dumps(results: Mapping[str, Any], systems_text: Mapping[str, str] | None = None) -> str:
    """The results as JSON text: every object indented one space a level, keys sorted; every list on
    one line (a time series is one line, not one line per number) by the json module's C encoder,
    which `indent` would turn off (0.34 s for the five systems' results where indent=1 took 0.95 s).
    `systems_text`: systems' results already written by `system_json` (in `run`'s workers, while the
    other systems still ran), used as they are; the text is the same as without them."""
    if not systems_text:
        return _dumps(to_jsonable(results), 0) + "\n"
    texts = {str(n): systems_text.get(n) or system_json(s) for n, s in results["systems"].items()}
    return _dumps(to_jsonable({**results, "systems": _Written(texts)}), 0) + "\n"


def system_json(result: Mapping[str, object]) -> str:
    """One system's results as `dumps` writes them inside results.json (at their depth there)."""
    return _dumps(to_jsonable(result), SYSTEM_DEPTH)


SYSTEM_DEPTH = 2  # results.json: {"systems": {name: <here>}}


@dataclass(frozen=True)
class _Written:
    """An object whose values are JSON text already written at the depth below it (not a dict, so that
    `to_jsonable` passes it through)."""

    texts: Mapping[str, str]


def _dumps(x: object, depth: int) -> str:
    if isinstance(x, _Written):
        if not x.texts:
            return "{}"
        pad = "\n" + " " * (depth + 1)
        return "{" + ",".join(f"{pad}{json.dumps(k)}: {x.texts[k]}" for k in sorted(x.texts)) + "\n" + " " * depth + "}"
    if isinstance(x, dict) and x:
        pad = "\n" + " " * (depth + 1)
        items = [f"{pad}{json.dumps(k)}: {_dumps(x[k], depth + 1)}" for k in sorted(x)]
        return "{" + ",".join(items) + "\n" + " " * depth + "}"
    return json.dumps(x, sort_keys=True, allow_nan=False, separators=(", ", ": "))


MAX_RESULTS_BYTES = 512 * 2**20  # results.json of the five systems is ~30 MB


def load(path: Path) -> RunResults:
    """The results `run` wrote, checked for the layout the reports are rendered from."""

    path = Path(path)
    if not path.exists():
        raise HarnessError(f"{path} not found: run `lagrange-xval run` first.")
    results = parse_json(regular_file(path, "results file", max_bytes=MAX_RESULTS_BYTES), path)
    problem = schema_problem(results)
    if problem:
        raise HarnessError(
            f"{path} is not a results file of `lagrange-xval run` ({problem}); rerun `lagrange-xval run`."
        )
    return cast(RunResults, results)  # its top checked here, the rest as `run` wrote it


def schema_problem(results: object) -> str | None:
    """What is wrong with the top of a results document, or None (the parts the report reads first)."""
    if not isinstance(results, dict):
        return f"a JSON {type(results).__name__}, expected an object"
    for key, kind in (("meta", dict), ("systems", dict), ("passed", bool)):
        if key not in results:
            return f'no "{key}"'
        if not isinstance(results[key], kind):
            return f'"{key}" is a JSON {type(results[key]).__name__}'
    for name, system in results["systems"].items():
        if not isinstance(system, dict):
            return f'system "{name}" is a JSON {type(system).__name__}'
        for key in ("name", "passed"):
            if key not in system:
                return f'system "{name}" has no "{key}"'
    return None

"""The on-disk cache of reference solutions and chaos summaries, verified on every read.

An entry is one `.npz` file: the arrays, and a JSON header with the schema version, the entry's key
(a hash of everything the result depends on, the harness's own source included) and a SHA-256
checksum over the key, the info and every array's dtype, shape and bytes. A read that finds a
truncated, edited, mismatched or foreign file says so on one stderr line and returns None: the caller
recomputes and the entry is rewritten. Files are readable by everyone (0644), so a checkout shared by
several users shares its cache; a cache that cannot be written costs time, never the run.

Where: the folder of the `Cache` value a caller passes down (dynamics/cachedir.py: `run` and `check`);
for `cache_dir=DEFAULT`, `$LAGRANGE_XVAL_CACHE` (`bench` sets it from `--cache-dir`, default
`OUT/.cache`, and to the empty string for `--no-cache`; pool workers inherit it), else the user's cache
folder, never a folder inside the installed package.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ..systems import PACKAGE_ROOT
from .cachedir import user_folder

SCHEMA = 2  # bump when an entry's layout or meaning changes
CACHE_ENV = "LAGRANGE_XVAL_CACHE"
DEFAULT = "default"  # the `cache_dir` argument meaning "the configured cache"
HEADER = "__cache__"


def root() -> Path | None:
    """The cache folder in use, or None when caching is off."""
    value = os.environ.get(CACHE_ENV)
    if value is None:
        return user_folder()
    return Path(value) if value else None


def folder(cache_dir: Any, kind: str) -> Path | None:
    """The folder for entries of `kind` ("reference", "chaos"): `cache_dir` as given, None for no
    cache, or DEFAULT for the configured cache."""
    if cache_dir is None:
        return None
    if isinstance(cache_dir, str) and cache_dir == DEFAULT:
        base = root()
        return None if base is None else base / kind
    return Path(cache_dir)


@functools.cache
def harness_hash() -> str:
    """SHA-256 of the harness's and the equations' source files: any code change is a new key."""
    h = hashlib.sha256()
    for package in ("validate", "equations"):
        base = PACKAGE_ROOT / package
        for path in sorted(base.rglob("*.py")):
            h.update(str(path.relative_to(PACKAGE_ROOT)).encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


def _checksum(key: str, info: dict[str, Any], arrays: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    h.update(key.encode() + b"\0" + json.dumps(info, sort_keys=True).encode() + b"\0")
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name} {a.dtype.str} {a.shape}".encode() + b"\0" + a.tobytes() + b"\0")
    return h.hexdigest()


def warn(message: str) -> None:
    print(f"lagrange-xval: warning: {message}", file=sys.stderr, flush=True)


def load(path: Path, key: str) -> tuple[dict[str, np.ndarray], dict[str, Any]] | None:
    """The arrays and info stored under `key` at `path`, or None (missing, or bad: then one warning)."""
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            header = json.loads(str(z[HEADER]))
            arrays = {name: z[name] for name in z.files if name != HEADER}
    except Exception as exc:  # noqa: BLE001 - any unreadable entry (truncated zip, a folder, ...) is recomputed
        warn(f"cache entry {path} is unreadable ({type(exc).__name__}: {exc}); recomputing.")
        return None
    problem = None
    if not isinstance(header, dict) or header.get("schema") != SCHEMA:
        problem = f"schema {header.get('schema') if isinstance(header, dict) else '?'}, expected {SCHEMA}"
    elif header.get("key") != key:
        problem = "stored under another key"
    elif not isinstance(header.get("info"), dict) or header.get("sha256") != _checksum(key, header["info"], arrays):
        problem = "checksum mismatch: the file was changed after it was written"
    if problem:
        warn(f"cache entry {path} is not valid ({problem}); recomputing.")
        return None
    return arrays, header["info"]


def store(path: Path, key: str, arrays: dict[str, np.ndarray], info: dict[str, Any]) -> bool:
    """Writes an entry atomically (temporary file and rename), mode 0644; False (and one warning)
    if the cache cannot be written."""
    header = {"schema": SCHEMA, "key": key, "info": info, "sha256": _checksum(key, info, arrays)}
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.is_dir() and not path.is_symlink():  # a folder where the entry goes: not the harness's
            import shutil

            shutil.rmtree(path)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            payload: dict[str, Any] = {**arrays, HEADER: np.array(json.dumps(header))}
            np.savez(f, **payload)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)  # a concurrent reader sees the old entry or the new one
        tmp = None
        return True
    except OSError as exc:
        warn(f"cannot write the cache entry {path} ({exc.strerror or exc}); continuing without it.")
        return False
    finally:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)


def invalid(path: Path, why: str) -> None:
    """A verified entry whose content fails the caller's own checks: said once, then recomputed."""
    warn(f"cache entry {path} fails its content check ({why}); recomputing.")

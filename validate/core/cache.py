"""The on-disk cache of reference solutions, chaos summaries, derivations and explanations, verified
on every read.

An entry is one `.npz` file: the arrays, and a JSON header with the schema version, the entry's key
(a hash of everything the result depends on, the harness's own source included), the info, every
array's dtype, shape and SHA-256, and an HMAC-SHA256 signature over all of that. A read checks the
header (at most MAX_HEADER_BYTES) and its signature before anything else is inflated, refuses an entry
whose arrays would pass MAX_ENTRY_BYTES, reads an array only when its own .npy header states the signed
dtype and shape, and keeps it only when its bytes have the signed digest: a small file claiming
gigabytes is refused unread. The signing key is a
secret of the user's (`$XDG_CACHE_HOME/lagrange-xval/key`, else `~/.cache/lagrange-xval/key`: 32
random bytes, created 0600 on first use); where that cannot be had (no HOME, a folder that cannot be
written), a random key of this process and its workers, so that nothing cached is kept but nothing
written by anyone else is trusted. A checksum anyone can recompute would let an edited entry pass:
a signature only the key's owner can make does not. A read that finds a truncated, edited, forged,
mismatched or foreign file says so on one stderr line and returns None: the caller recomputes and
the entry is rewritten. Files are readable by everyone (0644); an entry another user wrote (another
key) is recomputed like a forged one. A cache that cannot be written costs time, never the run.

Where: the folder of the `Cache` value a caller passes down (core/cachedir.py: `run` and `check`);
for `cache_dir=DEFAULT` (`bench`, `derive`), `$LAGRANGE_XVAL_CACHE` when the user sets it (the empty
string: no cache; pool workers inherit it; the harness never writes it), else the user's cache folder,
never a folder inside the installed package.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import hashlib
import hmac
import json
import math
import os
import stat
import sys
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import IO, Any, TypedDict

import numpy as np

from .cachedir import user_folder
from .errors import console, shown
from .files import create_file, replace_file, stage
from .files import folder as open_folder
from .package import SOURCE_DIRS

SCHEMA = 4  # bump when an entry's layout or meaning changes (4: the signed header holds each array's shape)
CACHE_ENV = "LAGRANGE_XVAL_CACHE"
PROCESS_KEY_ENV = "LAGRANGE_XVAL_PROCESS_KEY"  # a key of this process, handed to its workers (no user key)
KEY_BYTES = 32
DEFAULT = "default"  # the `cache_dir` argument meaning "the configured cache"
HEADER = "__cache__"
MAX_HEADER_BYTES = 2**20  # the header member (JSON: key, info, manifest); an explanation's info is ~10 kB
MAX_ENTRY_BYTES = 2**30  # the arrays of one entry, as their signed shapes say (a reference: ~1 MB)


BYTES = "bytes"  # the one array of an entry written by store_bytes


def root() -> Path | None:
    """The cache folder in use, or None when caching is off."""
    value = os.environ.get(CACHE_ENV)
    if value is None:
        return user_folder()
    return Path(value) if value else None


def folder(cache_dir: str | os.PathLike[str] | None, kind: str) -> Path | None:
    """The folder for entries of `kind` ("reference", "chaos"): `cache_dir` as given, None for no
    cache, or DEFAULT for the configured cache."""
    if cache_dir is None:
        return None
    if isinstance(cache_dir, str) and cache_dir == DEFAULT:
        base = root()
        return None if base is None else base / kind
    return Path(cache_dir)


@functools.cache  # one value per process (no arguments)
def harness_hash() -> str:
    """SHA-256 of the harness's and the equations' source files: any code change is a new key."""
    h = hashlib.sha256()
    for package, base in sorted(SOURCE_DIRS.items()):
        for path in sorted(base.rglob("*.py")):
            h.update(f"{package}/{path.relative_to(base)}".encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


class _Spec(TypedDict):
    """One array as the signed header states it."""

    dtype: str  # numpy's dtype.str, "<f8"
    shape: list[int]
    sha256: str


def _manifest(arrays: dict[str, np.ndarray]) -> dict[str, _Spec]:
    """Each array's dtype, shape and SHA-256: what the signed header says the entry holds."""
    out: dict[str, _Spec] = {}
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        out[name] = {"dtype": a.dtype.str, "shape": list(a.shape), "sha256": hashlib.sha256(a.tobytes()).hexdigest()}
    return out


def _signature(header: Mapping[str, object]) -> str:
    """HMAC-SHA256 of the header without its signature: the schema, the key, the info and the manifest
    (every array's dtype, shape and digest), so the header alone says whether the rest can be trusted."""
    unsigned = {k: v for k, v in header.items() if k != "hmac"}
    return hmac.new(signing_key(), json.dumps(unsigned, sort_keys=True).encode(), hashlib.sha256).hexdigest()


def key_file() -> Path | None:
    """Where the user's signing key is kept, or None (no absolute XDG_CACHE_HOME and no HOME)."""
    folder = user_folder()
    return None if folder is None else folder / "key"


def _read_key(path: Path) -> bytes | None:
    """The key at `path` if it is the user's own private regular file of KEY_BYTES bytes, else None."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | os.O_NONBLOCK)
    with os.fdopen(fd, "rb") as f:
        st = os.fstat(f.fileno())
        private = st.st_uid == os.getuid() and not st.st_mode & 0o077
        data = f.read(KEY_BYTES + 1) if stat.S_ISREG(st.st_mode) and private else b""
    return data if len(data) == KEY_BYTES else None


def _user_key() -> bytes | None:
    """The user's key, created on first use (0600, never through a link); None if it cannot be had."""
    path = key_file()
    if path is None:
        return None
    try:
        path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        with contextlib.suppress(FileExistsError):  # another process made it first: read theirs
            create_file(path, os.urandom(KEY_BYTES), mode=0o600)
        found = _read_key(path)
    except OSError:
        return None
    if found is None:
        warn(f"the cache key {path} is not a private file of {KEY_BYTES} bytes; nothing cached is kept after this run.")
    return found


@functools.cache  # one value per process (no arguments)
def signing_key() -> bytes:
    """The key entries are signed with: the user's, or one of this process (set in the environment
    for the workers it starts, so that they share it)."""
    handed = os.environ.get(PROCESS_KEY_ENV, "")
    if len(handed) == 2 * KEY_BYTES:
        with contextlib.suppress(ValueError):
            return bytes.fromhex(handed)
    key = _user_key()
    if key is None:
        key = os.urandom(KEY_BYTES)
        os.environ[PROCESS_KEY_ENV] = key.hex()
        warn(
            "no private cache key (HOME unset, or its cache folder not writable): entries are signed with a key "
            "of this run only; entries of earlier runs are not trusted and are recomputed."
        )
    return key


def _ephemeral() -> bool:
    """Whether entries are signed with a key of this run only (then every earlier entry fails, said once)."""
    return len(os.environ.get(PROCESS_KEY_ENV, "")) == 2 * KEY_BYTES


def warn(message: str) -> None:
    print(console([f"lagrange-xval: warning: {message}"]), file=sys.stderr, flush=True)


class _Refused(Exception):
    """An entry that is not what its signed header says, or says more than an entry may hold."""


def load(path: Path, key: str) -> tuple[dict[str, np.ndarray], dict[str, Any]] | None:
    """The arrays and info stored under `key` at `path`, or None (missing, or bad: then one warning).
    The header is read first, within MAX_HEADER_BYTES, and its signature checked; an array is read only
    when its member's own header states the dtype and shape the signed header does (nothing larger than
    MAX_ENTRY_BYTES in all), and kept only when its bytes have the signed digest."""
    if not os.path.lexists(path):
        return None
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | os.O_NONBLOCK)  # a link or FIFO: no
        with os.fdopen(fd, "rb") as f, zipfile.ZipFile(f) as z:
            header = json.loads(str(_member(z, HEADER, None)[()]))
            problem = _problem(header, key)
            if problem is None:
                arrays = {name: _member(z, name, spec) for name, spec in header["arrays"].items()}
    except _Refused as exc:
        problem = str(exc)
    except Exception as exc:  # noqa: BLE001 - any unreadable entry (truncated zip, a folder, ...) is recomputed
        warn(f"cache entry {path} is unreadable ({type(exc).__name__}: {shown(exc)}); recomputing.")
        return None
    if problem and not (problem.startswith("signature") and _ephemeral()):  # else: said once, by signing_key
        warn(f"cache entry {path} is not valid ({problem}); recomputing.")
    if problem:
        return None
    return arrays, header["info"]


def _problem(header: object, key: str) -> str | None:
    """Why a header is not to be trusted (schema, key, signature, sizes), or None."""
    if not isinstance(header, dict) or header.get("schema") != SCHEMA:
        return f"schema {header.get('schema') if isinstance(header, dict) else '?'}, expected {SCHEMA}"
    if header.get("key") != key:
        return "stored under another key"
    if not isinstance(header.get("info"), dict) or not isinstance(header.get("arrays"), dict):
        return "signature mismatch: no info or manifest"
    if not hmac.compare_digest(str(header.get("hmac")), _signature(header)):
        return "signature mismatch: changed after it was written, or not written by this user's harness"
    claimed = sum(_nbytes(spec) for spec in header["arrays"].values())
    if claimed > MAX_ENTRY_BYTES:
        return f"its arrays would take {claimed:,} bytes, more than an entry may ({MAX_ENTRY_BYTES:,})"
    return None


def _nbytes(spec: _Spec) -> int:
    return int(np.dtype(spec["dtype"]).itemsize) * math.prod(int(n) for n in spec["shape"])


def _npy_header(m: IO[bytes]) -> tuple[tuple[int, ...], bool, np.dtype[np.generic]]:
    """A .npy member's shape, order and dtype, read without its data (numpy bounds the header's length)."""
    version = np.lib.format.read_magic(m)
    if version == (1, 0):
        return np.lib.format.read_array_header_1_0(m)
    if version == (2, 0):
        return np.lib.format.read_array_header_2_0(m)
    raise _Refused(f"an array in format {version}, not one numpy.savez writes")


def _member(z: zipfile.ZipFile, name: str, spec: _Spec | None) -> np.ndarray:
    """The array `name` of the entry, read only after its .npy header states what `spec` (the signed
    manifest) does; spec None: the header member, a 0-d string of at most MAX_HEADER_BYTES."""
    with z.open(f"{name}.npy") as m:
        shape, fortran, dtype = _npy_header(m)
        if spec is None:
            if shape != () or dtype.kind != "U" or dtype.itemsize > MAX_HEADER_BYTES:
                raise _Refused(f"its header is a {dtype} array of shape {shape}, not a string of under 1 MiB")
        elif dtype.str != spec["dtype"] or list(shape) != list(spec["shape"]) or dtype.hasobject:
            raise _Refused(
                f"signature mismatch: array {shown(name, 60)} is {dtype.str} {list(shape)}, "
                f"signed as {shown(spec['dtype'], 20)} {shown(spec['shape'], 60)}"
            )
        size = dtype.itemsize * math.prod(shape)
        data = m.read(size)
    if len(data) != size:
        raise _Refused(f"array {shown(name, 60)} is cut short ({len(data)} of {size} bytes)")
    if spec is not None and not hmac.compare_digest(hashlib.sha256(data).hexdigest(), str(spec.get("sha256"))):
        raise _Refused(f"signature mismatch: the bytes of array {shown(name, 60)} are not those signed")
    return np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C").copy()


def store(path: Path, key: str, arrays: dict[str, np.ndarray], info: Mapping[str, object]) -> bool:
    """Writes an entry atomically (`files.replace_file`: never through a link), mode 0644; False (and
    one warning per folder) if the cache cannot be written."""
    header: dict[str, object] = {"schema": SCHEMA, "key": key, "info": info, "arrays": _manifest(arrays)}
    header["hmac"] = _signature(header)
    payload: dict[str, Any] = {**arrays, HEADER: np.array(json.dumps(header))}  # arrays: Any, as numpy's savez
    # stub checks a **mapping's values against its own allow_pickle flag
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.parent.is_symlink():  # planted in a shared cache, it would send entries elsewhere
            raise OSError(errno.ELOOP, "a link, not a folder", str(path.parent))
        if path.is_dir() and not path.is_symlink():  # a folder where the entry goes: not the harness's
            import shutil

            shutil.rmtree(path)
        replace_file(path, lambda f: np.savez(f, **payload))  # a concurrent reader sees the old entry or the new
        return True
    except OSError as exc:
        _unwritable(path.parent, f"cannot write the cache entry {path} ({exc.strerror or exc}); continuing without it.")
        return False


def store_bytes(path: Path, key: str, data: bytes) -> bool:
    """`store` of one byte string (a PNG, a JSON text): held as an array, so that its digest is signed
    and it may be larger than the header's limit."""
    return store(path, key, {BYTES: np.frombuffer(data, dtype=np.uint8)}, {})


def load_bytes(path: Path, key: str) -> bytes | None:
    """The byte string `store_bytes` kept under `key` at `path`, or None (as `load`)."""
    found = load(path, key)
    return None if found is None or BYTES not in found[0] else found[0][BYTES].tobytes()


@functools.lru_cache(maxsize=256)  # once per folder and message, of the few folders a run writes
def _unwritable(where: Path, message: str) -> None:
    """`message`, once per folder: a cache that cannot be written is one line, not one per entry."""
    warn(message)


def usable(base: Path) -> str:
    """`base` as the cache setting (CACHE_ENV) if entries can be written there, else "" (no cache)
    after one warning line; nothing is created here (a command refused later leaves nothing behind).
    Also fixes the signing key before any worker starts, so that they share it."""
    signing_key()
    try:
        _check_writable(Path(base))
    except OSError as exc:
        warn(f"cannot write the cache in {base} ({exc.strerror or exc}); running without a cache.")
        return ""
    return str(base)


def _check_writable(base: Path) -> None:
    """Raises the OSError writing an entry under `base` would meet: a file on the way, or a folder
    that cannot be written (a temporary file is made and removed where `base` exists)."""
    if base.is_dir():
        with open_folder(base) as fd:
            os.unlink(stage("probe", b"", dir_fd=fd), dir_fd=fd)
        return
    existing = next(p for p in (base, *base.parents) if os.path.lexists(p))  # base itself a file: no folder
    if not existing.is_dir():
        raise OSError(errno.ENOTDIR, "not a folder", str(existing))
    if not os.access(existing, os.W_OK | os.X_OK):
        raise OSError(errno.EACCES, "permission denied", str(existing))


def invalid(path: Path, why: str) -> None:
    """A verified entry whose content fails the caller's own checks: said once, then recomputed."""
    warn(f"cache entry {path} fails its content check ({why}); recomputing.")

"""Where the harness keeps what it computed once: one explicit, bounded `Cache` value, passed down.

Nothing reads a cache folder from a global: `lagrange-xval run` builds a `Cache` from `--cache-dir`
(default `OUT/.cache`) or `--no-cache` and hands it, as a value, to every worker and every stage;
`lagrange_xval.check` caches nothing unless it is given one. The entries themselves (one verified
`.npz` file each) are written and read by `core/cache.py`; a `Cache` only says where, and keeps
the folder under its size bound by removing the least recently used entries.

    Cache.off()                  no cache: nothing read, nothing written
    Cache.at("my_cache")         the folder given
    Cache.user()                 the user's cache folder ($XDG_CACHE_HOME/lagrange-xval, else
                                 ~/.cache/lagrange-xval; a relative XDG_CACHE_HOME is ignored, and
                                 without HOME there is none: no cache): never inside the installed package
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

DEFAULT_MAX_BYTES = 2 * 1024**3  # 2 GiB: a `run` of the notes' systems keeps about 60 MB
KINDS = ("reference", "chaos", "derive", "explain", "figures")  # the folders a cache holds, one per kind of entry
ENTRY_SUFFIX = ".npz"


def cache_home() -> Path | None:
    """The user's cache base (XDG base directories): $XDG_CACHE_HOME when it is an absolute path (XDG
    says a relative one is ignored), else $HOME/.cache when HOME is an absolute path, else None."""
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    if os.path.isabs(xdg):
        return Path(xdg)
    home = os.environ.get("HOME", "")
    return Path(home) / ".cache" if os.path.isabs(home) else None


def user_folder() -> Path | None:
    """The user's cache folder for the harness, or None where the user has no cache base (`cache_home`)."""
    base = cache_home()
    return None if base is None else base / "lagrange-xval"


@functools.cache  # one setting per process
def heyoka() -> ModuleType:
    """heyoka, its on-disk JIT cache off where the user has no cache base (HOME unset: heyoka would try
    the working directory and warn on every compilation, 36 lines in one `run`)."""
    import heyoka as hy

    if cache_home() is None:
        hy.llvm_state.set_diskcache_enabled(False)
    return hy


@dataclass(frozen=True)
class Cache:
    """A cache folder (None: no cache) and the most bytes its entries may take."""

    root: Path | None = None
    max_bytes: int = DEFAULT_MAX_BYTES

    @classmethod
    def off(cls) -> Cache:
        return cls(None)

    @classmethod
    def at(cls, folder: str | os.PathLike[str], *, max_bytes: int = DEFAULT_MAX_BYTES) -> Cache:
        return cls(Path(folder).absolute(), max_bytes)

    @classmethod
    def user(cls, *, max_bytes: int = DEFAULT_MAX_BYTES) -> Cache:
        return cls(user_folder(), max_bytes)  # None (no HOME): off

    @property
    def enabled(self) -> bool:
        return self.root is not None

    def folder(self, kind: str) -> Path | None:
        """The folder of entries of `kind` (one of KINDS), or None when caching is off. Also the
        `cache_dir` argument of `reference_trajectory` and the chaos functions (kind "reference";
        they keep chaos summaries beside it, in "chaos")."""
        if kind not in KINDS:
            raise ValueError(f"unknown cache kind {kind!r}; valid: {', '.join(KINDS)}")
        return None if self.root is None else self.root / kind

    def entries(self) -> list[Path]:
        """Every entry file in the cache's folders (regular files only; links are not followed)."""
        out: list[Path] = []
        for kind in KINDS:
            where = self.folder(kind)
            if where is None or where.is_symlink() or not where.is_dir():
                continue
            with os.scandir(where) as it:
                out += [Path(e.path) for e in it if e.name.endswith(ENTRY_SUFFIX) and e.is_file(follow_symlinks=False)]
        return out

    def trim(self) -> int:
        """Removes the least recently used entries until the rest fit in `max_bytes`; the bytes
        removed. An entry another process removes first is skipped."""
        stats = []
        for path in self.entries():
            try:
                st = path.stat(follow_symlinks=False)
            except OSError:
                continue
            stats.append((max(st.st_atime, st.st_mtime), st.st_size, path))
        total = sum(size for _, size, _ in stats)
        removed = 0
        for _, size, path in sorted(stats, key=lambda x: (x[0], str(x[2]))):
            if total - removed <= self.max_bytes:
                break
            try:
                path.unlink()
            except OSError:
                continue
            removed += size
        return removed

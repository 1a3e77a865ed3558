"""Every file the harness writes, created without following a link.

A file is first written under a random name (`.NAME.<random>.tmp`) opened with O_CREAT | O_EXCL |
O_NOFOLLOW, mode 0644 whatever the umask: a link or file planted at any name the harness might use is
never opened, let alone written through. It then takes its place by a rename (`replace_file`, which
replaces a link at the destination by the file, never the link's target) or by a hard link that
fails if anything is there (`create_file`, for files that must not overwrite). All of it happens
relative to a descriptor of the folder, opened once: a folder swapped for a link midway is not
followed.
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import IO

Data = bytes | str | Iterable[str] | Callable[[IO[bytes]], None]  # a writer: called with the open file

NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
NEW = os.O_WRONLY | os.O_CREAT | os.O_EXCL | NOFOLLOW | getattr(os, "O_CLOEXEC", 0)


@contextlib.contextmanager
def folder(path: Path, *, follow: bool = True) -> Iterator[int]:
    """A descriptor of the folder `path` (created if missing); `follow=False` refuses a link there."""
    Path(path).mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY | (0 if follow else NOFOLLOW))
    try:
        yield fd
    finally:
        os.close(fd)


def _write(f: IO[bytes], data: Data) -> None:
    if isinstance(data, (bytes, str)):
        f.write(data.encode() if isinstance(data, str) else data)
    elif callable(data):
        data(f)
    else:
        for piece in data:
            f.write(piece.encode())


def new_file(name: str, data: Data, *, dir_fd: int, mode: int = 0o644) -> None:
    """Creates `name` in the folder `dir_fd` with O_EXCL | O_NOFOLLOW (an existing name, link or not,
    is FileExistsError) and writes `data`; removed again if writing fails."""
    fd = os.open(name, NEW, mode, dir_fd=dir_fd)
    try:
        with os.fdopen(fd, "wb") as f:
            os.fchmod(f.fileno(), mode)  # whatever the umask
            _write(f, data)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(name, dir_fd=dir_fd)
        raise


def stage(name: str, data: Data, *, dir_fd: int, mode: int = 0o644) -> str:
    """`data` written to a new file of a random name beside `name`; returns that name."""
    tmp = f".{name[:200]}.{secrets.token_hex(8)}.tmp"
    new_file(tmp, data, dir_fd=dir_fd, mode=mode)
    return tmp


def replace_file(path: Path, data: Data) -> None:
    """Writes `path` atomically (a reader sees the old file or the new one); a link at `path` is
    replaced by the file, its target left alone."""
    replace_files({Path(path): data})


def replace_files(files: Mapping[Path, Data]) -> None:
    """Several files replaced all or none: each is staged first (a full disk fails here, with
    nothing replaced), then each is renamed into place."""
    with contextlib.ExitStack() as stack:  # the folders' descriptors, closed last
        staged: list[tuple[int, str, str]] = []
        try:
            for path, data in files.items():
                try:
                    fd = stack.enter_context(folder(Path(path).parent))
                    staged.append((fd, stage(Path(path).name, data, dir_fd=fd), Path(path).name))
                except OSError as exc:  # named after the file asked for, not its temporary name
                    raise OSError(exc.errno, exc.strerror, str(path)) from None
            for fd, tmp, name in staged:
                os.replace(tmp, name, src_dir_fd=fd, dst_dir_fd=fd)
        finally:
            _unlink_all(staged)  # what was not renamed (a failure): no temporary file is left


def _unlink_all(staged: list[tuple[int, str, str]]) -> None:
    for fd, tmp, _ in staged:
        with contextlib.suppress(OSError):
            os.unlink(tmp, dir_fd=fd)


def create_file(path: Path, data: Data, *, mode: int = 0o644) -> None:
    """Writes `path`, which must not exist (not even as a link: FileExistsError), whole or not at all."""
    path = Path(path)
    with folder(path.parent) as fd:
        tmp = stage(path.name, data, dir_fd=fd, mode=mode)
        try:
            os.link(tmp, path.name, src_dir_fd=fd, dst_dir_fd=fd, follow_symlinks=False)
        except OSError as exc:
            if exc.errno not in (errno.EPERM, errno.EOPNOTSUPP):  # not: a file system without hard links
                raise
            new_file(path.name, data, dir_fd=fd, mode=mode)  # there: created in place, still O_EXCL
        finally:
            os.unlink(tmp, dir_fd=fd)

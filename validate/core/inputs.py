"""Strict input: files are what they claim to be, sizes are limited before reading, JSON types are
checked and never coerced. Every refusal is one HarnessError line naming the problem."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path
from typing import NoReturn

from .arrays import Json
from .errors import HarnessError


def regular_file(path: Path, what: str, *, max_bytes: int) -> bytes:
    """The bytes of `path`, which must be a regular file of at most `max_bytes`; anything else
    (missing, a directory, a FIFO, a device, too big) is named as what it is, before any reading."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise HarnessError(f"{what} not found: {path}.") from None
    except OSError as exc:
        raise HarnessError(f"cannot read {what} {path}: {exc.strerror or exc}.") from None
    kinds = {
        stat.S_ISDIR: "a directory",
        stat.S_ISFIFO: "a FIFO (named pipe)",
        stat.S_ISCHR: "a character device",
        stat.S_ISBLK: "a block device",
        stat.S_ISSOCK: "a socket",
    }
    for test, kind in kinds.items():
        if test(st.st_mode):
            raise HarnessError(f"{what} {path} is {kind}, not a regular file.")
    if st.st_size > max_bytes:
        raise HarnessError(f"{what} {path} has {st.st_size} bytes; at most {max_bytes} are accepted.")
    try:
        with open(path, "rb") as f:
            data = f.read(max_bytes + 1)  # the file may have grown since stat
    except OSError as exc:
        raise HarnessError(f"cannot read {what} {path}: {exc.strerror or exc}.") from None
    if len(data) > max_bytes:
        raise HarnessError(f"{what} {path} has more than {max_bytes} bytes; at most {max_bytes} are accepted.")
    return data


def _reject_constant(name: str) -> NoReturn:
    raise ValueError(f"{name} is not finite; give finite numbers")


def parse_json(data: bytes, path: Path) -> Json:
    """Strict JSON: UTF-8, no NaN or Infinity, no integers too long to be numbers, bounded nesting."""
    try:
        return json.loads(data.decode("utf-8"), parse_constant=_reject_constant)
    except UnicodeDecodeError as exc:
        raise HarnessError(f"{path} is not valid JSON: not UTF-8 text (byte {exc.start}).") from None
    except json.JSONDecodeError as exc:
        raise HarnessError(f"{path} is not valid JSON: {exc}.") from None
    except RecursionError:
        raise HarnessError(f"{path} is not valid JSON for the harness: nested too deeply.") from None
    except ValueError as exc:  # the NaN literal above, or an integer of more than 4300 digits
        raise HarnessError(f"{path} is not valid JSON for the harness: {exc}.") from None

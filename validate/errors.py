"""Errors the harness reports to a person: one line, what is wrong and what is valid."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class HarnessError(Exception):
    """A user-facing error. The CLI prints its message on one line and exits non-zero."""

    exit_code = 2


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that it unwinds like Ctrl-C (workers stopped, staged
    output removed, previous reports intact); the CLI exits with 143."""


def unknown_name(kind: str, name: str, valid: Iterable[str]) -> HarnessError:
    """Builds "Unknown system 'x'. Did you mean 'y'? Valid: a, b, c." for a name not in `valid`."""
    valid = sorted(valid)
    close = difflib.get_close_matches(name, valid, n=1, cutoff=0.5)
    hint = f" Did you mean '{close[0]}'?" if close else ""
    return HarnessError(f"Unknown {kind} '{name}'.{hint} Valid: {', '.join(valid) or '(none)'}.")

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


class IntegrationStopped(HarnessError):
    """An integration that could not go on: the equations blew up, failed or spent their budget.

    A finding about the equations, raised where no partial result can stand in for the whole (the
    Taylor reference, the variational flow); the message names the source, method, time and reason.
    """

    def __init__(self, *, source: str, method: str, t: float, reason: str) -> None:
        self.source, self.method, self.t, self.reason = source, method, float(t), reason
        super().__init__(f"{source} ({method}) stopped at t = {self.t:.6g} s: {reason}")

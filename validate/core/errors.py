"""Errors the harness reports to a person: one line, what is wrong and what is valid."""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable

SHOWN_CHARS = 300  # the most of a person's text (a message, a name, a path) one console line shows
# C0 and C1 control characters (ESC and CSI start terminal sequences), DEL, the Unicode line and paragraph
# separators and the bidirectional overrides: none reaches a terminal as it is.
_CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069]")


def escaped(text: object) -> str:
    """`text` as data on one line: every control character written as repr writes it (`\\n`, `\\x1b`),
    so that no text a person controls can start a line, move the cursor or colour the terminal."""
    return _CONTROL.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), str(text))


def shown(text: object, limit: int = SHOWN_CHARS) -> str:
    """`text` escaped (`escaped`) and cut to `limit` characters, saying how many were left out: what the
    console and one-line errors show of a person's text (`--json` keeps it whole)."""
    out = escaped(text)
    if len(out) <= limit:
        return out
    return f"{out[:limit]}... ({len(out) - limit} more characters)"


LINE_CHARS = 1000  # the most of one console line that holds a person's text (a verdict, an error)


def console(lines: Iterable[str], *, verdict: bool = False) -> str:
    """Lines for the console, each `shown` (escaped, cut to LINE_CHARS): a person's text inside a line
    cannot start another (no `verdict:` line forged by an exception message), colour or move the cursor.
    Only the last line may start with `verdict:`, and only with `verdict` (check's own verdict line): any
    other (a system named `verdict: x: pass` at the start of a title) is indented by a space."""
    out = [shown(line, LINE_CHARS) for line in lines]
    return "\n".join(
        f" {line}" if line.startswith("verdict:") and not (verdict and i == len(out) - 1) else line
        for i, line in enumerate(out)
    )


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

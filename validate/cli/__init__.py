"""The `lagrange-xval` command line. Heavy imports (engines, plotting) happen inside subcommands.

Modules: parser (arguments, their help and units), commands (what each subcommand does), simulate
(one trajectory written as a self-describing file), outputs (the reports folder written as one
set), progress (the console lines of `run`); this module runs a command and turns every error into
one line and an exit status.
"""

from __future__ import annotations

import contextlib
import errno
import os
import signal
import sys
from collections.abc import Callable, Iterator
from types import FrameType

from ..core.errors import HarnessError, Terminated, console
from ..core.guard import Stopped
from .commands import COMMANDS
from .parser import MAX_STATES_FILE_BYTES, build_parser, one_line

__all__ = ["COMMANDS", "MAX_STATES_FILE_BYTES", "main"]


Handler = Callable[[int, FrameType | None], None]  # a signal handler


def _handlers(owner: int) -> tuple[Handler, Handler]:
    """SIGINT and SIGTERM handlers for the process `owner`. A pool worker forked before its initializer
    ran inherits them: there SIGINT is ignored (the parent reports it) and SIGTERM kills silently."""

    def interrupt(signum: int, frame: FrameType | None) -> None:
        if os.getpid() == owner:
            raise KeyboardInterrupt

    def terminate(signum: int, frame: FrameType | None) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_DFL if os.getpid() != owner else signal.SIG_IGN)
        if os.getpid() != owner:
            os.kill(os.getpid(), signal.SIGTERM)
            return
        raise Terminated  # SIGTERM ignored from here: a second one must not interrupt the clean-up

    return interrupt, terminate


@contextlib.contextmanager
def _stop_on_signals() -> Iterator[None]:
    """Ctrl-C and SIGTERM stop a command the same way (workers terminated, nothing half-written)."""
    interrupt, terminate = _handlers(os.getpid())
    try:
        previous = {signal.SIGINT: signal.signal(signal.SIGINT, interrupt)}
        previous[signal.SIGTERM] = signal.signal(signal.SIGTERM, terminate)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


@contextlib.contextmanager
def _only_own_output() -> Iterator[None]:
    """Nothing but the command's own output on stdout: while it runs, file descriptor 1 points at
    stderr (C++ libraries log there: heyoka warns on stdout when HOME is unset) and `sys.stdout`
    writes to the real stdout through a descriptor of its own."""
    stream = sys.stdout
    fd = -1
    if stream is sys.__stdout__ and stream is not None:
        with contextlib.suppress(OSError, ValueError):  # a closed stdout stays as it is
            fd = stream.fileno()
    if stream is None or fd < 0:  # no stdout, or a test's capture in its place
        yield
        return
    stream.flush()
    saved = os.dup(fd)
    buffering = 1 if os.isatty(saved) else -1  # line by line to a terminal, as Python's own stdout
    own = os.fdopen(os.dup(saved), "w", buffering=buffering, encoding=stream.encoding, errors=stream.errors)
    os.dup2(2, fd)  # stderr
    sys.stdout = own
    try:
        yield
        own.flush()
    finally:
        sys.stdout = stream
        with contextlib.suppress(OSError):  # a broken pipe was reported already
            own.close()
        os.dup2(saved, fd)
        os.close(saved)


def _plain_logs() -> None:
    """No colour codes in libraries' logs on a stderr that is not a terminal (rerun's viewer logs
    through Rust's tracing, which honours NO_COLOR; env_logger reads RUST_LOG_STYLE)."""
    if sys.stderr is None or not sys.stderr.isatty():
        os.environ.setdefault("NO_COLOR", "1")
        os.environ.setdefault("RUST_LOG_STYLE", "never")


def _error(message: str) -> int:
    print(console([f"lagrange-xval: error: {message}"]), file=sys.stderr)
    return 2


def main(argv: list[str] | None = None) -> int:
    """The command's exit status. The one error boundary: every failure is one line on stderr
    (`--debug` adds the traceback) and status 2; Ctrl-C is 130, SIGTERM 143."""
    args = build_parser().parse_args(argv)
    _plain_logs()
    try:
        with _stop_on_signals(), _only_own_output():
            return COMMANDS[args.command](args)
    except HarnessError as exc:
        print(console([f"lagrange-xval: error: {exc}"]), file=sys.stderr)
        return exc.exit_code
    except Stopped as stop:  # a person's module that hung or tried to exit (validate/core/guard.py)
        return _error(str(stop))
    except Terminated:
        print("lagrange-xval: terminated; nothing half-written (previous reports are intact).", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("lagrange-xval: interrupted; nothing half-written (previous reports are intact).", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return _error("the output was closed before it was all written (broken pipe).")
    except OSError as exc:
        if args.debug:
            import traceback

            traceback.print_exc()
        where = f" ({exc.filename})" if exc.filename else ""
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            return _error(f"no space left on device{where}; previous reports are intact.")
        return _error(f"{exc.strerror or one_line(exc)}{where}.")
    except Exception as exc:  # noqa: BLE001 - the boundary: one line, never a traceback unless asked
        if args.debug:
            import traceback

            traceback.print_exc()
        hint = "" if args.debug else "; rerun with --debug for the traceback"
        return _error(f"unexpected {type(exc).__name__}: {one_line(exc)}{hint}.")

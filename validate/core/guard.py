"""A guard around each call into an equations module in this process: a time limit, no exit, no stdout.

A person's own module (a file given with `--equations`, `--systems` or `System.from_files`) is run in a
worker process of its own instead (validate/handwritten/worker.py): a guard in the process can be switched off by
the code it guards (an ignored or blocked SIGALRM, one long C call). This guard serves the repository's
own modules (`equations/`, part of the harness), and `Stopped` and `describe` serve both.

An equations module may loop, sleep, call `sys.exit` or `os._exit`, or print. Every call into it (its
import, `parameters`, `assumptions`, the dynamics, the optional functions and the printed forms'
functions) goes through `call`, which

- enforces a time limit per call (`DEFAULT_TIME_LIMIT`, `--time-limit SECONDS`, `time_limit=` of
  `load`): SIGALRM, armed with `signal.setitimer`, raises `Stopped` inside the module's Python (a
  `time.sleep` is interrupted too), repeating every `REPEAT` s while the call goes on; a module that
  swallows even these (a bare `except:` in a loop) past `GRACE` more seconds has the process ended
  with one line on stderr (status 2; in `run`, its own worker: its system fails);
- turns `sys.exit` (SystemExit) and `os._exit` (replaced while the person's code runs) into `Stopped`,
  naming the function: "mass_matrix called sys.exit(0)";
- sends what the person's code prints to stderr (`sys.stdout` is stderr while it runs; the command
  line already points file descriptor 1 at stderr), so `check --json`'s stdout carries only JSON.

`Stopped` is a BaseException, like KeyboardInterrupt: no `except Exception` (the module's or the
harness's) swallows it on its way to the system's boundary, where it becomes that system's one-line
finding (`run`: the system fails and the others' results are kept; `check`: one error line; the API:
a failing row). After a stop the module is spent: every later call raises the same `Stopped` at once,
so a module that sleeps in every function costs one time limit, not one per call.

Why in-process for the repository's modules: the harness calls the dynamics thousands of times per
system (batched states, probes, traced code, per-step mirrors); its own modules need no worker. What a
guard in the process cannot catch (a process ended from C, a signal
sent to itself, `posix._exit`) `run` catches one level up:
each system runs in a worker process of its own (validate/core/parallel.py `executor_for`), so a worker
that dies fails its own system alone (pipeline.run). The alarm works in a process's main thread,
where the command line, the API and the local pool's workers call the module; in another thread
(dask's thread workers) exits and printing are still guarded, but there is no time limit.
"""

from __future__ import annotations

import _signal
import contextlib
import functools
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from types import FrameType, ModuleType
from typing import Any, NoReturn, ParamSpec, TypeVar

P = ParamSpec("P")
R = TypeVar("R")

DEFAULT_TIME_LIMIT = 30.0  # s per call into a person's module (and for its import)
REPEAT = 0.5  # s between further alarms while a stopped call has not returned
GRACE = 5.0  # s of further alarms a stopped call may swallow before the process is ended
HINT = "the time limit per call into an equations module; --time-limit SECONDS sets it"


class Stopped(BaseException):  # noqa: N818 - a stop, like KeyboardInterrupt, not an error of the harness
    """A person's code that was stopped: it did not return in time, or it tried to end the process.

    `where` is the module's file, `why` what happened ("mass_matrix did not return within 30 s")."""

    def __init__(self, where: str, why: str) -> None:
        self.where, self.why = where, why
        super().__init__(where, why)  # both, so that it crosses a process boundary (pickled by its args)

    def __str__(self) -> str:
        return f"{self.where}: {self.why}" if self.where else self.why


@dataclass
class Guard:
    """The guard of one module: its time limit, its label (the file) and, once stopped, why."""

    where: str
    time_limit: float = DEFAULT_TIME_LIMIT
    stopped: str | None = None

    def call(self, name: str, fn: Callable[P, R], *args: P.args, **kwargs: P.kwargs) -> R:
        """fn(*args, **kwargs), the person's code called `name`, under the guard; an exception coming
        out of it is marked with `name` (`describe`). Plain try/finally, no context managers: the
        mirrors call the dynamics once per step."""
        if self.stopped is not None:
            raise Stopped(self.where, self.stopped)
        if _ACTIVE.current is not None:  # the person's code calling its own functions: the outer call guards it
            return fn(*args, **kwargs)
        _ACTIVE.current = (self, name)
        _isolate(True)
        timer = _arm(self, name) if self.time_limit and threading.current_thread() is _MAIN else None
        try:
            out = fn(*args, **kwargs)
        except SystemExit as exc:
            self.stop(f"{name} called sys.exit({'' if exc.code is None else repr(exc.code)})")
        except Exception as exc:
            _note_function(exc, name)
            raise
        finally:
            if timer is not None:
                _disarm(timer)
            _isolate(False)
            _ACTIVE.current = None
        if self.stopped is not None:  # stopped, but the module caught it and returned
            raise Stopped(self.where, self.stopped)
        return out

    def stop(self, why: str) -> NoReturn:
        if self.stopped is None:
            self.stopped = why
        raise Stopped(self.where, self.stopped)


class _Active(threading.local):
    current: tuple[Guard, str] | None = None  # the guarded call running in this thread


_ACTIVE = _Active()
_MAIN = threading.main_thread()


@dataclass(frozen=True)
class _Timer:
    guard: Guard
    name: str
    start: float
    previous: Callable[[int, FrameType | None], object] | int | None  # the SIGALRM handler before
    delay: float  # someone else's timer (pytest-timeout's, say): its remaining seconds and interval
    interval: float


_timer: _Timer | None = None  # the main thread's armed call


def _arm(guard: Guard, name: str) -> _Timer:
    """SIGALRM after `guard.time_limit` seconds, then every REPEAT s, raising Stopped in the main thread."""
    global _timer
    previous = _signal.getsignal(signal.SIGALRM)  # signal.getsignal's enum conversion costs 5 us
    if previous is not _expired:  # installed once (6 us a call), unless another handler is to be restored
        signal.signal(signal.SIGALRM, _expired)
    start = time.monotonic()
    delay, interval = signal.setitimer(signal.ITIMER_REAL, guard.time_limit, REPEAT)
    _timer = _Timer(guard, name, start, previous, delay, interval)
    return _timer


def _disarm(timer: _Timer) -> None:
    """The alarm off; the previous handler and timer restored, less the time spent here."""
    global _timer
    signal.setitimer(signal.ITIMER_REAL, 0)
    _timer = None
    if timer.previous not in (_expired, signal.SIG_DFL, None):  # someone else's handler (with no timer of ours
        signal.signal(signal.SIGALRM, timer.previous)  # left, ours is inert: it stays where there was none)
    if timer.delay > 0:
        left = max(timer.delay - (time.monotonic() - timer.start), 1e-3)
        signal.setitimer(signal.ITIMER_REAL, left, timer.interval)


def _expired(signum: int, frame: FrameType | None) -> None:
    timer = _timer
    if timer is None:  # disarmed as it fired
        return
    guard, limit = timer.guard, timer.guard.time_limit
    if time.monotonic() - timer.start > limit + GRACE:  # every Stopped swallowed: nothing else stops it
        sys.stderr.write(f"lagrange-xval: error: {guard.where}: {guard.stopped}, and would not stop.\n")
        sys.stderr.flush()
        _REAL_EXIT(2)
    guard.stop(f"{timer.name} did not return within {limit:g} s ({HINT})")


_REAL_EXIT = os._exit
_LOCK = threading.Lock()
_running = 0  # guarded calls running, in every thread: os._exit replaced and stdout on stderr while any
_stdout: Any = None  # sys.stdout before the first of them


def _refused(code: int) -> None:
    """os._exit while a person's code runs: Stopped, naming the function (in a thread with no guarded
    call, the real os._exit)."""
    current = _ACTIVE.current
    if current is None:
        _REAL_EXIT(code)
        return
    guard, name = current
    guard.stop(f"{name} called os._exit({code!r})")


def _isolate(on: bool) -> None:
    """While a person's code runs (in any thread): os._exit raises Stopped, and sys.stdout is stderr;
    both restored after the last such call (counted, so that two threads' calls never restore the
    other's replacement)."""
    global _running, _stdout
    with _LOCK:
        if on and not _running:
            _stdout, sys.stdout = sys.stdout, sys.stderr
            os._exit = _refused  # type: ignore[assignment]
        _running += 1 if on else -1
        if not on and not _running:
            sys.stdout, _stdout = _stdout, None
            os._exit = _REAL_EXIT


def guarded(guard: Guard, name: str, fn: Callable[P, R]) -> Callable[P, R]:
    """`fn` called under `guard` (its name, signature and attributes kept: `not_provided` stubs stay
    stubs, `inspect.signature` reads the person's parameter names)."""
    if getattr(fn, "__guarded__", None) is guard:
        return fn
    if getattr(fn, "__guarded__", None) is not None:  # a module imported again under another guard
        fn = fn.__wrapped__  # type: ignore[attr-defined]

    @functools.wraps(fn)
    def call(*args: P.args, **kwargs: P.kwargs) -> R:
        return guard.call(name, fn, *args, **kwargs)

    call.__guarded__ = guard  # type: ignore[attr-defined]
    return call


# The contract's functions (equations/__init__.py); the printed forms' functions are found in VARIANTS.
CONTRACT_FUNCTIONS = (
    "parameters",
    "assumptions",
    "mass_matrix",
    "bias",
    "residual",
    "qacc",
    "kinetic_energy",
    "potential_energy",
    "hamiltonian",
    "passive",
    "body_positions",
    "body_rotations",
)


def guard_module(module: ModuleType, guard: Guard) -> ModuleType:
    """`module` with each contract function and each printed form's function called under `guard`
    (replaced in place: the module's own calls of its functions go through the guard as well)."""
    import dataclasses

    for name in CONTRACT_FUNCTIONS:
        fn = getattr(module, name, None)
        if callable(fn):
            setattr(module, name, guarded(guard, name, fn))
    variants = getattr(module, "VARIANTS", None)
    if isinstance(variants, (tuple, list)):
        wrapped = []
        for v in variants:
            if dataclasses.is_dataclass(v) and not isinstance(v, type):
                label = getattr(v, "name", type(v).__name__)
                changes = {
                    f.name: guarded(guard, f"{label}: {f.name}", getattr(v, f.name))
                    for f in dataclasses.fields(v)
                    if callable(getattr(v, f.name)) and not isinstance(getattr(v, f.name), type)
                }
                v = dataclasses.replace(v, **changes) if changes else v
            wrapped.append(v)
        module.__dict__["VARIANTS"] = tuple(wrapped)  # a module's attributes are its __dict__'s entries
    module.__dict__["GUARD"] = guard
    return module


def describe(exc: BaseException) -> str:
    """An exception from a hand source as one phrase, naming the person's function where it was
    raised inside one ("mass_matrix raised ZeroDivisionError: division by zero")."""
    name = getattr(exc, "_lagrange_xval_function", None)
    said = str(exc).strip()
    text = f"{type(exc).__name__}: {said}" if said else type(exc).__name__
    return f"{name} raised {text}" if name else text


def _note_function(exc: BaseException, name: str) -> None:
    """Marks `exc` with the outermost person's function it came out of (for `describe`)."""
    with contextlib.suppress(AttributeError, TypeError):
        exc._lagrange_xval_function = name  # type: ignore[attr-defined]

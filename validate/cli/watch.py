"""`lagrange-xval watch`: the verdict of `check` again on every save of the equations module or the model.

One warm process: MuJoCo, Pinocchio, Drake, heyoka and sympy are imported once, and what the harness
compiles and caches (models of the probe parameter sets, traced code, explanations of wrong entries)
is kept between verdicts; only the person's module is imported again, from its source, on each save.

Each verdict is `decide` (verdict/decide.py), as `check` gives it: the statement line exactly as
`check` prints its last line, then the failing terms, then the seconds it took, stage by stage. A save
while a verdict is being computed abandons it at the next stage boundary (results/stages.py) and the
saved files are judged again. A module that cannot be imported, or a model that does not compile,
prints its one-line error and the watch waits for the next save. Ctrl-C ends it (status 130).
`--once` judges once and exits with `check`'s status (0 pass, 1 fail, 2 an error), for scripts and tests.

Saves are seen by `watchfiles` (a thread watching the files' folders, each save debounced) and handed
to the main thread, which computes the verdicts: the guard's time limit (validate/core/guard.py) needs it.
"""

from __future__ import annotations

import argparse
import os
import sys
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from ..core.errors import HarnessError, Terminated
from ..core.guard import DEFAULT_TIME_LIMIT, Stopped
from ..core.memo import Memo
from ..results.stages import Cancelled, Clock
from ..systems import EQUATIONS_PACKAGE, MODELS_DIR, System, load, pairs_in
from ..verdict.decide import Decision, decide, left_out_line
from . import check as checking
from .parser import one_line

STEP_MS = 30  # a save is reported once no further change came for this long
DEBOUNCE_MS = 300  # at most this long after the first change of a burst
WAIT_S = 0.2  # the main thread wakes this often while it waits (Ctrl-C is seen at once either way)
RETRY_S = 1.0  # a watch the file system ended starts again after this long


@dataclass(frozen=True)
class Target:
    """One system watched: its model and equations files, judged as `check` judges them."""

    name: str
    model: Path
    equations: Path
    locked: tuple[str, ...] = ()
    time_limit: float = DEFAULT_TIME_LIMIT

    @property
    def files(self) -> frozenset[Path]:
        return frozenset({resolved(self.model), resolved(self.equations)})

    def system(self) -> System:
        """The system with its module imported afresh from its source (validate/systems load_module)."""
        return System.from_files(
            self.model, self.equations, name=self.name, locked=self.locked, time_limit=self.time_limit
        )


@dataclass(frozen=True)
class Options:
    """What every verdict is computed with (the options `check` takes)."""

    n_states: int
    seed: int
    probes: int


def targets_of(args: argparse.Namespace) -> list[Target]:
    """The systems to watch: the SYSTEM named, --model and --equations, or every pair of --systems DIR."""
    locked = tuple(args.lock or ())
    if locked and args.model is None:
        raise HarnessError("--lock takes joints of the --model URDF; give --model PATH.")
    given = [
        args.system is not None,
        args.model is not None or args.equations is not None,
        args.systems_dir is not None,
    ]
    if sum(given) != 1:
        raise HarnessError("watch one thing: a SYSTEM, or --model PATH --equations PATH, or --systems DIR.")
    limit = args.time_limit
    if args.system is not None:
        load(args.system, time_limit=limit)  # an unknown name lists the valid ones
        equations = Path(sys.modules[EQUATIONS_PACKAGE].__path__[0]) / f"{args.system}.py"
        return [Target(args.system, MODELS_DIR / f"{args.system}.xml", equations, time_limit=limit)]
    if args.systems_dir is not None:
        return [Target(e.stem, m, e, time_limit=limit) for m, e in pairs_in(args.systems_dir)]
    if args.model is None or args.equations is None:
        raise HarnessError("watch takes --model PATH and --equations PATH together (the files it re-judges).")
    for path, what in ((args.model, "model file"), (args.equations, "equations file")):
        if not path.is_file():
            raise HarnessError(f"{what} not found: {path} (watch needs both files to exist).")
    return [Target(args.equations.stem, args.model, args.equations, locked, limit)]


def failing_lines(decision: Decision) -> list[str]:
    """What failed, under the statement: the model's mismatches, then the failing terms (or, with none,
    the failing pointwise rows)."""
    lines = [f"model: {m['key']} ({m['check']}): {m['why']}" for m in checking.mismatches(decision)]
    terms = checking.term_lines(decision)
    failing = [line for line in terms[2:] if line.endswith("FAIL")]
    if failing:
        return [*lines, *terms[1:2], *failing]
    rows = [] if decision.pointwise is None else [r for r in decision.pointwise["rows"] if not r["passed"]]
    return lines + checking.table_lines(rows, "pointwise, failing:")[1:] if rows else lines


def stage_text(clock: Clock) -> str:
    """`verdict in 0.31 s (model checks 0.02, pointwise 0.05, ...)`."""
    parts = ", ".join(f"{stage} {s:.2f}" for stage, s in clock.seconds.items())
    return f"verdict in {clock.total:.2f} s ({parts})"


def judge(target: Target, options: Options, cancel: threading.Event | None) -> Decision:
    """`check`'s verdict on the target's files as they are now; Cancelled once `cancel` is set."""
    clock = Clock(cancel=cancel)
    system = target.system()
    clock.lap("import")
    decision = decide(system, n_states=options.n_states, seed=options.seed, probes=options.probes, clock=clock)
    left = left_out_line(decision.model_checks)
    said = [left] if left and (target.model, left) not in _SAID else []  # once per model, until it changes
    if left:
        _SAID.set((target.model, left), True)
    print("\n".join([*said, checking.verdict_line(decision), *failing_lines(decision), stage_text(clock)]), flush=True)
    return decision


_SAID = Memo(maxsize=64)  # (model, left-out line) this watch has said: once each


def error_line(exc: BaseException) -> str:
    """One line for what kept a verdict from being computed (the module's import, the model's compile)."""
    if isinstance(exc, HarnessError | Stopped):
        return f"lagrange-xval: error: {one_line(exc)}"
    return f"lagrange-xval: error: unexpected {type(exc).__name__}: {one_line(exc)}"


def resolved(path: str | Path) -> Path:
    """The file `path` names, its links followed; where they cannot be (a loop of links, a link to itself,
    a folder that went away) its absolute path: a watch never stops for the file system."""
    try:
        return Path(path).resolve()
    except (OSError, RuntimeError):  # RuntimeError: a symlink loop (Python 3.11's Path.resolve)
        return Path(os.path.abspath(path))


class Saves:
    """The watched files saved since they were last taken, and an event set by every save."""

    def __init__(self, watched: Iterable[Path]) -> None:
        self.watched = frozenset(watched)
        self.event = threading.Event()
        self._lock = threading.Lock()
        self._files: set[Path] = set()

    def add(self, paths: Iterable[str]) -> None:
        saved = {resolved(p) for p in paths} & self.watched
        if saved:
            with self._lock:
                self._files |= saved
            self.event.set()

    def take(self) -> set[Path]:
        with self._lock:
            files, self._files = self._files, set()
            self.event.clear()
        return files


def watch_files(saves: Saves, stop: threading.Event) -> threading.Thread:
    """A daemon thread feeding `saves` with every change in the watched files' folders."""
    import watchfiles

    folders = sorted({str(p.parent) for p in saves.watched})

    def watched() -> None:
        for changes in watchfiles.watch(
            *folders,
            watch_filter=None,
            debounce=DEBOUNCE_MS,
            step=STEP_MS,
            stop_event=stop,
            recursive=False,
            raise_interrupt=False,
        ):
            saves.add(path for _, path in changes)

    def run() -> None:
        while not stop.is_set():  # whatever the file system does, one line and the watch goes on
            try:
                watched()
            except Exception as exc:  # noqa: BLE001 - a folder deleted, a loop of links: said, then watched again
                print(f"lagrange-xval: watch: {type(exc).__name__}: {one_line(exc)}; watching again", file=sys.stderr)
                stop.wait(RETRY_S)
                saves.add(str(f) for f in saves.watched)  # judged again: the files may have changed meanwhile

    thread = threading.Thread(target=run, name="lagrange-xval-watch", daemon=True)
    thread.start()
    return thread


def judge_all(targets: list[Target], options: Options, cancel: threading.Event | None) -> list[Target]:
    """Judges each target in turn; returns those left unjudged (the one a save cancelled, and the rest)."""
    for i, target in enumerate(targets):
        try:
            judge(target, options, cancel)
        except Cancelled:
            print(f"{target.name}: saved during the verdict; judging again", flush=True)
            return targets[i:]
        except Exception as exc:  # noqa: BLE001 - one line, then the next save (Stopped is caught below)
            print(error_line(exc), file=sys.stderr, flush=True)
        except Stopped as stop:
            print(error_line(stop), file=sys.stderr, flush=True)
    return []


def loop(targets: list[Target], options: Options) -> None:
    """Judges every target, then the targets of each save, until Ctrl-C."""
    saves = Saves(f for t in targets for f in t.files)
    stop = threading.Event()
    thread = watch_files(saves, stop)
    names = ", ".join(sorted({str(f) for t in targets for f in (t.model, t.equations)}))
    print(f"watching {names}; Ctrl-C stops", flush=True)
    try:
        todo = list(targets)
        while True:
            todo = judge_all(todo, options, saves.event)
            while not saves.event.wait(WAIT_S):
                pass
            saved = saves.take()
            todo += [t for t in targets if t.files & saved and t not in todo]
    finally:
        stop.set()
        thread.join(timeout=2.0)


def cmd_watch(args: argparse.Namespace) -> int:
    """`watch`: status 0/1/2 as `check` with --once; otherwise runs until Ctrl-C (130)."""
    targets = targets_of(args)
    options = Options(n_states=args.states, seed=args.seed, probes=args.probes)
    if args.once:
        passed = [judge(t, options, None).passed for t in targets]
        return 0 if all(passed) else 1
    started = time.perf_counter()
    try:
        loop(targets, options)
    except Terminated:
        raise
    except KeyboardInterrupt:
        print(f"lagrange-xval: watch stopped after {time.perf_counter() - started:.0f} s.", file=sys.stderr)
        return 130
    return 0

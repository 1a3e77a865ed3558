"""The wall seconds of each stage of a system's work, and a way to abandon it between stages.

Stages, in the order `run` meets them: the verdict's model checks, pointwise, probes and terms; the
printed forms, equivalence, derived equations; the trajectories (the reference, each source's run, the
perturbed start, the error estimates); experiments, chaos; the audit.

`decide` and `pipeline.run_system` call `Clock.lap(stage)` at the end of every stage: the seconds
since the previous lap are added to that stage (results.json's per-system `stages`, `run --verbose`,
the report's folded table, `bench --run-time`). `watch` hands `decide` a clock with a `cancel` event
that a save sets: the next lap raises `Cancelled`, so a verdict on a file that changed while it was
computed is dropped at the next stage boundary instead of finished and printed.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import TypedDict

# The order stages run in (results.json's keys are sorted: tables and lines are put back in this order).
ORDER = (
    "import",
    "model checks",
    "pointwise",
    "probes",
    "terms",
    "printed forms",
    "equivalence",
    "derived equations",
    "trajectories: reference",
    *(f"trajectories: {source}" for source in ("hand", "mujoco", "pinocchio", "symbolic", "drake")),
    "trajectories: perturbed start",
    "estimates",
    "trajectories",
    "divergence run",
    "experiments",
    "chaos",
    "audit",
)


def ordered(names: Iterable[str]) -> list[str]:
    """`names` in the order the stages run (ORDER), any other after them, alphabetically."""
    rank = {name: i for i, name in enumerate(ORDER)}
    return sorted(dict.fromkeys(names), key=lambda n: (rank.get(n, len(ORDER)), n))


class Stage(TypedDict, total=False):
    """One stage of a system's work in results.json."""

    seconds: float  # wall seconds (absent: the stage was not run)
    outcome: str  # why it was not run or failed (absent: it ran)


class Cancelled(Exception):  # noqa: N818 - an outcome asked for, not an error
    """The work was abandoned at a stage boundary because its `Clock.cancel` event was set."""


@dataclass
class Clock:
    """Stage name -> wall seconds (s), in the order the stages ended; a stage lapped twice adds up.

    Attributes:
        cancel: once set, the next `lap` raises Cancelled (None: never).
        seconds: each stage's wall seconds so far.
    """

    cancel: threading.Event | None = None
    seconds: dict[str, float] = field(default_factory=dict)
    _last: float = field(default_factory=time.perf_counter, repr=False)

    def lap(self, stage: str) -> None:
        """Ends `stage`: the seconds since the previous lap (or the clock's start) are added to it."""
        now = time.perf_counter()
        self.seconds[stage] = self.seconds.get(stage, 0.0) + (now - self._last)
        self._last = now
        self.check()

    def skip(self) -> None:
        """Starts the next stage now: the time since the last lap belongs to no stage."""
        self._last = time.perf_counter()

    def check(self) -> None:
        """Raises Cancelled once the cancel event is set."""
        if self.cancel is not None and self.cancel.is_set():
            raise Cancelled("abandoned: what it judged changed while it ran")

    @property
    def total(self) -> float:
        return sum(self.seconds.values())


def lap(clock: Clock | None, stage: str) -> None:
    """`clock.lap(stage)`, for code whose clock is optional."""
    if clock is not None:
        clock.lap(stage)


def records(seconds: Mapping[str, float], notes: Mapping[str, str]) -> dict[str, Stage]:
    """results.json's per-system `stages`: every stage's wall seconds, in the order they ran, and, for a
    stage that did not run or failed, `outcome` saying why (a stage that was not run has no seconds)."""
    out: dict[str, Stage] = {name: {"seconds": float(s)} for name, s in seconds.items()}
    for name, why in notes.items():
        out.setdefault(name, {})["outcome"] = why
    return out


def outcome(stage: Stage | str | None) -> str:
    """Why a stage did not run or failed ("" when it ran); results written before the stages had seconds
    held the outcome as the stage's whole value."""
    return stage if isinstance(stage, str) else str((stage or {}).get("outcome", ""))


def seconds_of(stage: Stage | str | None) -> float | None:
    """A stage's wall seconds, or None (not run, or results written before the stages had seconds)."""
    value = None if isinstance(stage, str) else (stage or {}).get("seconds")
    return None if value is None else float(value)


def stage_line(stages: Mapping[str, Stage | str]) -> str:
    """`model checks 0.02 s, pointwise 0.05 s, ...` (`run --verbose`), with the total."""
    timed = [(name, s) for name in ordered(stages) if (s := seconds_of(stages[name])) is not None]
    total = sum(s for _, s in timed)
    return f"{total:.2f} s: " + ", ".join(f"{name} {s:.2f}" for name, s in timed)

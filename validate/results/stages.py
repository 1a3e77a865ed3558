"""The wall seconds of each stage of a system's work, and a way to abandon it between stages.

`decide` and `pipeline.run_system` call `Clock.lap(stage)` at the end of every stage: the seconds
since the previous lap are added to that stage (results.json's per-system `stages`, `run --verbose`,
the report's folded table, `bench --run-time`). `watch` hands `decide` a clock with a `cancel` event
that a save sets: the next lap raises `Cancelled`, so a verdict on a file that changed while it was
computed is dropped at the next stage boundary instead of finished and printed.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field


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

"""Progress while `run` works: a live bar in a terminal, one plain line per system elsewhere (CI)."""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Iterator
from typing import TYPE_CHECKING

from ..core.errors import console
from ..report.findings import is_user, system_headline
from ..results.schema import SystemResult

if TYPE_CHECKING:  # the pipeline's engines are imported by `run`, not by this module
    from ..stages.pipeline import Progress


@contextlib.contextmanager
def reporter() -> Iterator[Progress]:
    start = time.perf_counter()
    if sys.stderr.isatty():
        from rich.console import Console
        from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

        with Progress(
            SpinnerColumn(),
            TextColumn("{task.description}"),
            TimeElapsedColumn(),
            console=Console(stderr=True),
            transient=True,
        ) as bar:
            task = bar.add_task("validating", total=None)

            def live(name: str, stage: str, result: SystemResult | None = None) -> None:
                if stage == "start":
                    bar.update(task, description=f"validating {name}")
                else:
                    assert result is not None  # "done" comes with the system's results
                    line = console([_line(name, result, time.perf_counter() - start)])
                    bar.console.print(line, markup=False, highlight=False, emoji=False)

            yield live
    else:

        def plain(name: str, stage: str, result: SystemResult | None = None) -> None:
            elapsed = time.perf_counter() - start
            if stage == "done":
                assert result is not None  # "done" comes with the system's results
                line = _line(name, result, elapsed)
            else:
                line = f"[{elapsed:6.1f} s] {name}: started"
            # One write with its newline: a signal handled between print's two writes would glue its
            # own line to this one.
            sys.stderr.write(console([line]) + "\n")
            sys.stderr.flush()

        yield plain


def _line(name: str, result: SystemResult, elapsed: float) -> str:
    """One line per system: the verdict on its derivation first (a failing one with the failing term,
    the pair and why), then the printed forms of the notes, if it has any."""
    variants = result.get("variants", [])
    wrong = sum(v["verdict"] == "disagrees" for v in variants)
    head = f"[{elapsed:6.1f} s] {name}: {'pass' if result['passed'] else 'FAIL'}"
    if not result["passed"]:
        head += f"; {system_headline(result)[1]}"
    if variants:
        return f"{head}; {len(variants)} printed forms of the notes, {wrong} wrong"
    return head if is_user(result) else f"{head}; no printed forms in the notes"

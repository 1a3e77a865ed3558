"""Progress while `run` works: a live bar in a terminal, one plain line per system elsewhere (CI)."""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Iterator
from typing import Any


@contextlib.contextmanager
def reporter() -> Iterator[Any]:
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

            def live(name: str, stage: str, result: Any = None) -> None:
                if stage == "start":
                    bar.update(task, description=f"validating {name}")
                else:
                    bar.console.print(_line(name, result, time.perf_counter() - start))

            yield live
    else:

        def plain(name: str, stage: str, result: Any = None) -> None:
            elapsed = time.perf_counter() - start
            line = _line(name, result, elapsed) if stage == "done" else f"[{elapsed:6.1f} s] {name}: started"
            # One write with its newline: a signal handled between print's two writes would glue its
            # own line to this one.
            sys.stderr.write(line + "\n")
            sys.stderr.flush()

        yield plain


def _line(name: str, result: dict[str, Any], elapsed: float) -> str:
    """One line per system: the verdict on its derivation first (the failing term and why), then
    the printed forms."""
    variants = result.get("variants", [])
    wrong = sum(v["verdict"] == "disagrees" for v in variants)
    mark = "pass" if result["passed"] else "FAIL"
    head = f"[{elapsed:6.1f} s] {name}: {mark}"
    if not result["passed"] and result.get("failed"):
        head += f"; {'; '.join(result['failed'])}"
    forms = f"{len(variants)} printed forms, {wrong} disagree with the engines" if variants else "no printed forms"
    return f"{head}; {forms}"

"""Writes what `run` produces. Everything is rendered in memory first, then each file is replaced
atomically, so an interrupted or failed run leaves the previous reports intact."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .results import atomic_write_many, dumps


def write_reports(results: dict[str, Any], out: Path) -> None:
    from .report import render

    files = render(results)  # may fail: nothing written yet
    atomic_write_many({out / name: data for name, data in files.items()})


def write_all(results: dict[str, Any], out: Path, *, replay: bool = True) -> None:
    from .report import render

    files = {"results.json": dumps(results).encode(), **render(results)}
    if replay:
        from .replay import render_replays

        files.update(render_replays(results))
    atomic_write_many({out / name: data for name, data in files.items()})

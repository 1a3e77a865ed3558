"""Writes what `run` produces. Everything is rendered in memory first, then each file is replaced
atomically, so an interrupted or failed run leaves the previous reports intact."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .results import atomic_write_many, dumps

OPTIONAL_RESULTS = {"bench": "bench.json", "stress": "stress.json"}  # written by `bench` and `stress`


def with_optional_results(results: dict[str, Any], out: Path) -> dict[str, Any]:
    """The results plus the benchmark and stress results found in the reports folder, for rendering."""
    import json

    merged = dict(results)
    for key, name in OPTIONAL_RESULTS.items():
        path = Path(out) / name
        if key not in merged and path.is_file():
            try:
                merged[key] = json.loads(path.read_text())
            except (OSError, ValueError):
                pass  # a damaged optional file: its section says "not run"
    return merged


def write_reports(results: dict[str, Any], out: Path) -> None:
    from .report import render

    files = render(with_optional_results(results, out))  # may fail: nothing written yet
    atomic_write_many({out / name: data for name, data in files.items()})


def write_all(results: dict[str, Any], out: Path, *, replay: bool = True) -> None:
    from .report import render

    files = {"results.json": dumps(results).encode(), **render(with_optional_results(results, out))}
    if replay:
        from .replay import render_replays

        files.update(render_replays(results))
    atomic_write_many({out / name: data for name, data in files.items()})

"""Rerun recordings of the trajectories (first version: placeholder until the replay module lands)."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def render_replays(results: dict[str, Any]) -> dict[str, bytes]:
    return {}


def replay_command(system: str, save: Path | None) -> int:
    from .errors import HarnessError

    raise HarnessError("replay is not available in this build yet.")

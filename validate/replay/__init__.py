"""Rerun recordings of the trajectories: one `.rrd` per system, rendered from the results data.

A recording holds every trajectory run of one system (the hand equations, MuJoCo, Pinocchio and
whatever runs later work adds), overlaid, each run in its own colour. Entity paths (one timeline,
"time", in seconds; everything time-varying is sent whole with `send_columns`, styling is static):

    /<system>/description                 TextDocument (markdown): system, runs, how to read it
    /<system>/events                      TextLog: the first time each run's error exceeds the threshold
    /<system>/threshold                   Scalars, two rows: log10 of the trajectory threshold
    /<system>/anchors                     Points3D, static: where the root bodies hang
    /<system>/<run>/bodies/<body>         Points3D: the body's centre of mass
    /<system>/<run>/links/<body>          LineStrips3D: parent's centre of mass -> joint anchor -> centre of mass
    /<system>/<run>/axes/<body>           LineStrips3D: the body's axes x, y, z (bodies whose centre of mass
                                          never moves, e.g. gimbals, show their motion only by turning)
    /<system>/<run>/trail/<body>          LineStrips3D: the last TRAIL_SECONDS of a tip body's path, per sample
    /<system>/<run>/q/<coordinate>        Scalars: the coordinate (rad or m)
    /<system>/<run>/log10_error           Scalars: log10 of error_vs_hand (zeros clipped to ERROR_FLOOR)
    /<system>/<run>/log10_envelope        Scalars: log10 of the run's "envelope" array, when it has one per sample
    /<system>/<run>/energy_change         Scalars: E(t) - E(0), J
    /<system>/<run>/exceeds_threshold     Scalars, one row (SeriesPoints): the first sample above the threshold

`<run>` is the run's source ("hand", "mujoco", "pinocchio"); a second run of the same source gets
`<source>_<label or method>` so that every run has its own subtree. Body positions come from the
equations module's kinematics (`body_positions`, `body_rotations`) at the recorded q, with the
parameters recorded in the results; the joint anchors from the compiled MJCF's body offsets.

Modules: scene (the arrays and text of a recording, pure numpy), recording (rerun logging,
blueprint, description); this module renders, saves and shows.
"""

from __future__ import annotations

import hashlib
import json
import os
import socket
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..core.errors import HarnessError
from ..results import atomic_write
from ..results import load as load_results
from ..results.stages import outcome
from .recording import ERROR_FLOOR, TIMELINE, blueprint, describe, log_scene
from .scene import build_scene, run_colours, run_keys

__all__ = [
    "APPLICATION_ID",
    "ERROR_FLOOR",
    "TIMELINE",
    "blueprint",
    "build_scene",
    "describe",
    "log_scene",
    "recording_id",
    "render_replays",
    "render_system",
    "replay_command",
    "shown_path",
    "viewer_command",
    "run_colours",
    "run_keys",
]

APPLICATION_ID = "lagrange_xval"


DEFAULT_RESULTS = Path("reports") / "results.json"


VIEWER_PORT = 9876  # rerun's default


def render_replays(results: dict[str, Any]) -> dict[str, bytes]:
    """The bytes of "<system>.rrd" for every system in `results` (nothing is written here).

    Args:
        results: the `run` results (numpy arrays or their JSON form; non-finite numbers as strings).

    Returns:
        {"<system>.rrd": rrd bytes}, one entry per system that has trajectories, in the results' order.
    """
    meta = results.get("meta")
    return {
        f"{name}.rrd": render_system(name, sys_results, meta=meta)
        for name, sys_results in results["systems"].items()
        if sys_results.get("trajectories")
    }


def render_system(name: str, sys_results: Mapping[str, Any], *, meta: Mapping[str, object] | None = None) -> bytes:
    """The .rrd bytes of one system's recording (recording and default blueprint).

    Args:
        name: the system.
        sys_results: results["systems"][name].
        meta: results["meta"] (provenance), quoted in the text document.
    """
    import rerun as rr

    scene = build_scene(name, sys_results, meta=meta)
    # No default properties: they carry the wall-clock start time, and the file should not.
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id(name, meta), send_properties=False)
    stream = rr.binary_stream(recording=rec)
    rec.send_recording_name(name)
    rec.send_blueprint(blueprint(scene), make_active=True, make_default=True)
    log_scene(rec, scene)
    data = stream.read()
    rec.disconnect()
    if not data:
        raise HarnessError(f"rerun produced an empty recording for {name}.")
    return data


def recording_id(name: str, meta: Mapping[str, object] | None) -> str:
    """Same results, same id; another run's results, another id (the viewer merges recordings that share one)."""
    digest = hashlib.sha256(json.dumps([name, meta], sort_keys=True, default=str).encode()).hexdigest()[:16]
    return f"{name}-{digest}"


def replay_command(system: str, save: Path | None, results_path: Path = DEFAULT_RESULTS) -> int:
    """The recording of `system` from the results a `run` wrote (`results_path`), saved to `save` or
    shown in a viewer. Nothing is recomputed: the trajectories are the run's.

    Raises:
        HarnessError: no results file, a system not in it or without trajectories, `save` not an .rrd
            path, or no viewer can be shown (all checked before anything is drawn).
    """
    if save is not None and Path(save).suffix.lower() != ".rrd":
        raise HarnessError(f"--save must name an .rrd file; got '{Path(save).name}'.")
    results = load_results(Path(results_path))
    held = results["systems"]
    if system not in held:
        raise HarnessError(
            f"{results_path} holds no system '{system}' (it holds {', '.join(sorted(held)) or 'none'}); "
            f"run `lagrange-xval run {system}` first."
        )
    if not held[system].get("trajectories"):
        why = outcome(held[system].get("stages", {}).get("trajectories")) or "no trajectories were recorded"
        raise HarnessError(f"{results_path}: {system} has no trajectories to replay ({why}).")
    if save is None:
        _check_display(system)
    if save is not None:
        atomic_write(Path(save), render_system(system, held[system], meta=results.get("meta")))
        print(f"wrote {save} (open it with `{viewer_command()} {save}`)")
        return 0
    _show(system, held[system], meta=results.get("meta"))
    return 0


def shown_path(path: Path) -> str:
    """A path as a command run from the working folder reaches it: relative under it, else absolute."""
    path = Path(os.path.abspath(path))
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def viewer_command() -> str:
    """The rerun viewer that came with this Python's rerun-sdk: `.venv/bin/rerun` after the README's
    set-up (the wheel installs it beside the interpreter), else `python -m rerun` with this Python."""
    import shlex

    beside = Path(sys.executable).with_name("rerun")
    if beside.is_file():
        shown = shown_path(beside)
        return shlex.quote(shown if "/" in shown else "./" + shown)
    python = shown_path(Path(sys.executable))
    return f"{shlex.quote(python if '/' in python else './' + python)} -m rerun"


def _save_hint(name: str) -> str:
    return f"use `lagrange-xval replay {name} --save {name}.rrd` and open the file where a display is."


def _check_display(name: str) -> None:
    """A viewer window needs a display; on Linux without one, say so before running anything."""
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise HarnessError(
            f"cannot spawn a rerun viewer: no display (DISPLAY and WAYLAND_DISPLAY unset); {_save_hint(name)}"
        )


def _viewer_listening(port: int) -> bool:
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=1.0):
            return True
    except OSError:
        return False


def _show(name: str, sys_results: Mapping[str, Any], *, meta: Mapping[str, object] | None) -> None:
    """Spawns a rerun viewer (or reuses one on VIEWER_PORT) and streams the recording to it."""
    import rerun as rr

    hint = _save_hint(name)
    scene = build_scene(name, sys_results, meta=meta)
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id(name, meta))
    beside = Path(sys.executable).with_name("rerun")  # the viewer the rerun-sdk wheel installs in the venv
    try:  # connect only once a viewer listens, so a failed start leaves no sink retrying
        rr.spawn(
            port=VIEWER_PORT, connect=False, recording=rec, executable_path=str(beside) if beside.is_file() else None
        )
    except Exception as exc:  # rerun raises RuntimeError when it finds no viewer executable
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise HarnessError(f"cannot spawn a rerun viewer ({first}); {hint}") from None
    # A viewer that cannot open a window exits; rerun only warns, so check that one listens.
    if not _viewer_listening(VIEWER_PORT):
        raise HarnessError(f"the rerun viewer did not start (nothing listens on port {VIEWER_PORT}); {hint}")
    rec.connect_grpc(f"rerun+http://127.0.0.1:{VIEWER_PORT}/proxy", default_blueprint=blueprint(scene))
    log_scene(rec, scene)
    rec.flush()
    print(f"sent {name} to the rerun viewer on port {VIEWER_PORT}")

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
"""

from __future__ import annotations

import colorsys
import hashlib
import json
import os
import re
import socket
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import HarnessError

TIMELINE = "time"  # s
TRAIL_SECONDS = 1.0  # s of the tip's path drawn behind it
ERROR_FLOOR = 1e-17  # rad; errors of exactly zero are drawn at log10(ERROR_FLOOR)
APPLICATION_ID = "lagrange_xval"
VIEWER_PORT = 9876  # rerun's default

# The three sources keep their colours across systems; further runs take the next free colour.
SOURCE_COLOURS: dict[str, tuple[int, int, int]] = {
    "hand": (31, 119, 180),  # blue
    "mujoco": (255, 127, 14),  # orange
    "pinocchio": (44, 160, 44),  # green
}
EXTRA_COLOURS: tuple[tuple[int, int, int], ...] = (
    (214, 39, 40),  # red
    (148, 103, 189),  # purple
    (227, 119, 194),  # pink
    (188, 189, 34),  # olive
    (23, 190, 207),  # cyan
    (140, 86, 75),  # brown
)
_THRESHOLD_COLOUR = (200, 200, 200)
_ANCHOR_COLOUR = (230, 230, 230)


# ---------------------------------------------------------------------------------------------
# Public interface


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


def render_system(name: str, sys_results: Mapping[str, Any], *, meta: Mapping[str, Any] | None = None) -> bytes:
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


def recording_id(name: str, meta: Mapping[str, Any] | None) -> str:
    """Same results, same id; another run's results, another id (the viewer merges recordings that share one)."""
    digest = hashlib.sha256(json.dumps([name, meta], sort_keys=True, default=str).encode()).hexdigest()[:16]
    return f"{name}-{digest}"


def replay_command(system: str, save: Path | None) -> int:
    """Runs the trajectories of `system` and saves the recording to `save` or shows it in a viewer.

    Raises:
        HarnessError: unknown system, `save` not an .rrd path, or no viewer can be shown (checked
            before any work is done, where that is possible).
    """
    from ..pipeline import run
    from ..systems import load

    load(system)  # an unknown name fails here, before any work, listing the valid ones
    if save is not None and Path(save).suffix.lower() != ".rrd":
        raise HarnessError(f"--save must name an .rrd file; got '{Path(save).name}'.")
    if save is None:
        _check_display(system)
    results = run([system], n_states=10, seed=0)
    if save is not None:
        from ..results import atomic_write

        atomic_write(Path(save), render_system(system, results["systems"][system], meta=results.get("meta")))
        print(f"wrote {save} (open it with `rerun {save}`)")
        return 0
    _show(system, results["systems"][system], meta=results.get("meta"))
    return 0


# ---------------------------------------------------------------------------------------------
# The scene: everything the recording shows, as plain numpy data


def _floats(x: Any) -> np.ndarray:
    """A float array from numpy or JSON data (JSON keeps inf and nan as strings)."""
    return np.asarray(x, dtype=float) if not isinstance(x, np.ndarray) else x.astype(float, copy=False)


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", str(text).lower()).strip("_") or "run"


def run_keys(runs: list[dict[str, Any]]) -> list[str]:
    """Unique entity-path names for the runs: the source, then source_<label or method> for repeats."""
    keys: list[str] = []
    for run in runs:
        source = _slug(run.get("source", "run"))
        key = source
        if key in keys:
            key = f"{source}_{_slug(run.get('label') or run.get('name') or run.get('method', ''))}"
        base, i = key, 2
        while key in keys:
            key, i = f"{base}_{i}", i + 1
        keys.append(key)
    return keys


def run_colours(runs: list[dict[str, Any]]) -> list[tuple[int, int, int]]:
    """A distinct colour per run: the source's colour for its first run, then the next unused colour."""
    spare = iter(EXTRA_COLOURS)
    golden = 0
    taken: list[tuple[int, int, int]] = []
    for run in runs:
        colour = SOURCE_COLOURS.get(str(run.get("source")))
        if colour is None or colour in taken:
            colour = next(spare, None)
        if colour is None:  # past the palette: golden-angle hues, still deterministic
            golden += 1
            r, g, b = colorsys.hsv_to_rgb((golden * 0.618033988749895) % 1.0, 0.65, 0.95)
            colour = (round(r * 255), round(g * 255), round(b * 255))
        taken.append(colour)
    return taken


def _shade(colour: tuple[int, int, int], towards: float, amount: float) -> tuple[int, int, int]:
    return tuple(round(c + (towards - c) * amount) for c in colour)  # type: ignore[return-value]


def _unit(view: Any, joint: str) -> str:
    try:
        return "m" if view[f"joint/{joint}/type"] == "slide" else "rad"
    except HarnessError:
        return "rad"


def _params(system: Any, sys_results: Mapping[str, Any]) -> Any:
    """The parameters the results were computed with (the model's when they do not fit Params)."""
    recorded = sys_results.get("parameters")
    if recorded:
        try:
            return system.equations.Params(**{k: float(v) for k, v in recorded.items()})
        except (TypeError, ValueError):
            pass
    return system.params


def build_scene(name: str, sys_results: Mapping[str, Any], *, meta: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The arrays and text of one system's recording. Pure numpy; no rerun calls."""
    from ..systems import System, load, system_names

    model, equations = sys_results.get("mjcf", ""), sys_results.get("equations", "")
    if name in system_names() and str(model).startswith("models/"):
        system = load(name)
    else:  # a system from the user's own files, recorded by their paths
        system = System.from_files(model, equations, name=name)
    view = system.view
    params = _params(system, sys_results)
    traj = sys_results["trajectories"]
    t = _floats(traj["t"])
    K = len(t)
    runs_in = list(traj["runs"])
    if not runs_in:
        raise HarnessError(f"{name}: the results hold no trajectory runs to replay.")
    keys, colours = run_keys(runs_in), run_colours(runs_in)
    bodies = list(sys_results.get("bodies") or system.bodies)
    parent = {b: view[f"body/{b}/parent"] for b in bodies}
    children = {b for b in bodies if any(parent[c] == b for c in bodies)}
    tips = [b for b in bodies if b not in children]
    body_joint: dict[str, str] = {}
    for j in system.joints:
        body_joint.setdefault(view[f"joint/{j}/body"], j)
    depth = {b: 0 for b in bodies}
    for b in bodies:
        p = parent[b]
        while p in parent:
            depth[b] += 1
            p = parent[p]

    runs = []
    for key, colour, run in zip(keys, colours, runs_in, strict=True):
        q = _floats(run["q"]).reshape(K, -1)
        positions = system.equations.body_positions(params, q)
        rotations = system.equations.body_rotations(params, q)
        com = {b: np.asarray(x, dtype=float).reshape(K, 3) for b, x in positions.items()}
        rot = {b: np.asarray(x, dtype=float).reshape(K, 3, 3) for b, x in rotations.items()}
        anchor = {}
        for b in bodies:
            origin = com[b] - rot[b] @ view[f"body/{b}/com"]
            joint = body_joint.get(b)
            anchor[b] = origin + rot[b] @ view[f"joint/{joint}/pos"] if joint else origin
        links = {
            b: np.stack([com[parent[b]] if parent[b] in com else anchor[b], anchor[b], com[b]], axis=1) for b in bodies
        }
        energy = _floats(run["energy"]) if "energy" in run else None
        error = _floats(run["error_vs_hand"]) if "error_vs_hand" in run else None
        envelope = _floats(run["envelope"]) if "envelope" in run else None
        runs.append(
            {
                "key": key,
                "colour": colour,
                "run": run,
                "q": q,
                "com": com,
                "rot": rot,
                "anchor": anchor,
                "links": links,
                "energy": energy,
                "error": error,
                "envelope": envelope if envelope is not None and envelope.shape == (K,) else None,
            }
        )

    # Scene size: how far anything drawn reaches from the origin (1 m when everything sits there);
    # samples of a diverged run (non-finite q) do not count.
    norms = np.concatenate(
        [np.linalg.norm(r[kind][b], axis=-1) for r in runs for kind in ("com", "anchor") for b in bodies]
    )
    reach = float(norms[np.isfinite(norms)].max(initial=0.0))
    scale = reach if reach > 1e-9 else 1.0
    # Bodies whose centre of mass never moves show their motion by their axes only.
    still = [b for b in bodies if all(np.ptp(r["com"][b], axis=0).max() <= 1e-9 * scale for r in runs)]
    dt = float(np.median(np.diff(t))) if K > 1 else 1.0
    window = max(2, int(round(TRAIL_SECONDS / dt)) + 1) if K > 1 else 1
    trail_index = np.clip(np.arange(K)[:, None] + np.arange(1 - window, 1)[None, :], 0, K - 1)
    for r in runs:
        r["axes"] = {}
        for b in still:
            length = 0.5 * scale * (0.8 ** depth[b])
            ends = r["com"][b][:, None, :] + length * np.swapaxes(r["rot"][b], 1, 2)  # (K, 3 axes, 3)
            r["axes"][b] = np.stack([np.broadcast_to(r["com"][b][:, None, :], ends.shape), ends], axis=2)
        # The tip's path: its centre of mass, or the end of its x axis when that stays still (line of sight).
        r["trails"] = {b: (r["axes"][b][:, 0, 1] if b in still else r["com"][b])[trail_index] for b in tips}
    # A link whose three points coincide throughout (a body turning about its own centre) is not drawn.
    for b in bodies:
        if all(np.ptp(r["links"][b].reshape(-1, 3), axis=0).max() <= 1e-9 * scale for r in runs):
            for r in runs:
                del r["links"][b]

    # Up is against gravity; a scene that disables gravity still says in the MJCF where down is.
    gravity = np.asarray(view["gravity"], dtype=float)
    if not gravity.any():
        gravity = np.asarray(system.mujoco_model().opt.gravity, dtype=float)
    up = _up_axis(gravity)
    return {
        "name": name,
        "sys": sys_results,
        "t": t,
        "runs": runs,
        "bodies": bodies,
        "tips": tips,
        "still": still,
        "parent": parent,
        "scale": scale,
        "window": window,
        "up": up,
        "coordinates": list(sys_results.get("coordinates") or system.coordinates),
        "units": [_unit(view, j) for j in system.joints],
        "roots": [b for b in bodies if parent[b] not in parent],
        "threshold": float(traj["threshold"]) if traj.get("threshold") is not None else None,
        "plane_normal": _plane_normal(runs, bodies, scale),
        "meta": _provenance(meta),
    }


def _provenance(meta: Mapping[str, Any] | None) -> str:
    if not meta:
        return ""
    command = meta.get("command", "lagrange-xval run")
    return (
        f"Results of `{command}` (lagrange-xval {meta.get('harness_version', '?')}, "
        f"commit {meta.get('git_commit', '?')}, {meta.get('date', '?')}, seed {meta.get('seed')})."
    )


def _up_axis(gravity: np.ndarray) -> tuple[int, int]:
    """(axis, sign) of the world axis opposite to gravity; (z, +1) when there is no gravity along an axis."""
    g = float(np.linalg.norm(gravity))
    if g > 0:
        i = int(np.argmax(np.abs(gravity)))
        if abs(gravity[i]) > 0.999 * g:
            return i, -1 if gravity[i] > 0 else 1
    return 2, 1


def _plane_normal(runs: list[dict[str, Any]], bodies: list[str], scale: float) -> int | None:
    """The world axis all motion is perpendicular to, if the motion is planar (to look along it)."""
    pts = np.concatenate([r[kind][b] for r in runs for kind in ("com", "anchor") for b in bodies])
    spread = np.ptp(pts, axis=0)
    flat = [i for i in range(3) if spread[i] <= 1e-9 * scale]
    return flat[0] if len(flat) == 1 else None


# ---------------------------------------------------------------------------------------------
# Logging


def _plottable(x: np.ndarray) -> np.ndarray:
    """Non-finite samples (a diverged run) become NaN, which the plots leave as gaps."""
    return np.where(np.isfinite(x), x, np.nan)


def _log10_error(error: np.ndarray) -> np.ndarray:
    """log10 of an error series, zeros clipped to ERROR_FLOOR."""
    with np.errstate(invalid="ignore"):
        return _plottable(np.log10(np.maximum(error, ERROR_FLOOR)))


def _time_column(seconds: np.ndarray) -> Any:
    """The "time" timeline at these instants. Rounded to whole nanoseconds here: rerun truncates
    float seconds (2.11 s would become 2.109999999 s)."""
    import rerun as rr

    return rr.TimeColumn(TIMELINE, duration=np.rint(np.asarray(seconds, dtype=float) * 1e9).astype("timedelta64[ns]"))


def log_scene(rec: Any, scene: dict[str, Any]) -> None:
    """Sends the scene to a recording stream: static styling and text first, then whole columns."""
    import rerun as rr

    name, t = scene["name"], scene["t"]
    root = f"/{name}"
    times = [_time_column(t)]
    radius = 0.03 * scene["scale"]

    def send(path: str, columns: Any, index: Any = None) -> None:
        rec.send_columns(path, indexes=index or times, columns=columns, strict=True)

    def static(path: str, *archetypes: Any) -> None:
        rec.log(path, *archetypes, static=True, strict=True)

    axis, sign = scene["up"]
    static(root, getattr(rr.ViewCoordinates, f"RIGHT_HAND_{'XYZ'[axis]}_{'UP' if sign > 0 else 'DOWN'}"))
    static(f"{root}/description", rr.TextDocument(describe(scene), media_type=rr.MediaType.MARKDOWN))
    first = scene["runs"][0]
    static(
        f"{root}/anchors",
        rr.Points3D([first["anchor"][b][0] for b in scene["roots"]], radii=0.6 * radius, colors=_ANCHOR_COLOUR),
    )
    if scene["threshold"] is not None and len(t):
        static(f"{root}/threshold", rr.SeriesLines(colors=_THRESHOLD_COLOUR, names="threshold", widths=1.0))
        send(
            f"{root}/threshold",
            rr.Scalars.columns(scalars=np.full(2, np.log10(scene["threshold"]))),
            [_time_column(np.array([t[0], t[-1]]))],
        )

    events = []
    for r in scene["runs"]:
        base, colour, run = f"{root}/{r['key']}", r["colour"], r["run"]
        for b in scene["bodies"]:
            static(f"{base}/bodies/{b}", rr.Points3D.from_fields(colors=colour, radii=radius))
            send(f"{base}/bodies/{b}", rr.Points3D.columns(positions=r["com"][b]))
        for b, strips in r["links"].items():
            static(f"{base}/links/{b}", rr.LineStrips3D.from_fields(colors=colour, radii=0.25 * radius))
            send(f"{base}/links/{b}", rr.LineStrips3D.columns(strips=strips))
        for b, strips in r["trails"].items():
            static(f"{base}/trail/{b}", rr.LineStrips3D.from_fields(colors=colour, radii=0.12 * radius))
            send(f"{base}/trail/{b}", rr.LineStrips3D.columns(strips=strips))
        for b, segments in r["axes"].items():
            shades = [colour, _shade(colour, 255, 0.55), _shade(colour, 0, 0.45)]  # x, y, z
            static(f"{base}/axes/{b}", rr.LineStrips3D.from_fields(colors=shades, radii=0.3 * radius))
            send(
                f"{base}/axes/{b}",
                rr.LineStrips3D.columns(strips=segments.reshape(-1, 2, 3)).partition(np.full(len(t), 3)),
            )
        for i, c in enumerate(scene["coordinates"]):
            static(f"{base}/q/{c}", rr.SeriesLines(colors=colour, names=f"{r['key']}: {c}"))
            send(f"{base}/q/{c}", rr.Scalars.columns(scalars=_plottable(r["q"][:, i])))
        if r["error"] is not None:
            static(f"{base}/log10_error", rr.SeriesLines(colors=colour, names=r["key"]))
            send(f"{base}/log10_error", rr.Scalars.columns(scalars=_log10_error(r["error"])))
        if r["envelope"] is not None:
            static(
                f"{base}/log10_envelope",
                rr.SeriesLines(colors=_shade(colour, 255, 0.5), widths=1.0, names=f"{r['key']} envelope"),
            )
            send(f"{base}/log10_envelope", rr.Scalars.columns(scalars=_log10_error(r["envelope"])))
        if r["energy"] is not None:
            static(f"{base}/energy_change", rr.SeriesLines(colors=colour, names=r["key"]))
            send(f"{base}/energy_change", rr.Scalars.columns(scalars=_plottable(r["energy"] - r["energy"][0])))
        first_time = run.get("first_exceeds_threshold")
        if first_time is not None and r["error"] is not None and np.isfinite(float(first_time)):
            k = int(np.argmin(np.abs(t - float(first_time))))
            static(
                f"{base}/exceeds_threshold",
                rr.SeriesPoints(
                    colors=colour, markers="cross", marker_sizes=8.0, names=f"{r['key']} exceeds threshold"
                ),
            )
            send(
                f"{base}/exceeds_threshold",
                rr.Scalars.columns(scalars=_log10_error(r["error"][k : k + 1])),
                [_time_column(t[k : k + 1])],
            )
            events.append(
                (
                    float(t[k]),
                    f"{r['key']}: error vs hand first exceeds {scene['threshold']:g} "
                    f"at t = {t[k]:g} s ({r['error'][k]:.3g})",
                    colour,
                )
            )
    if events:
        events.sort(key=lambda e: e[0])
        send(
            f"{root}/events",
            rr.TextLog.columns(text=[e[1] for e in events], level=["WARN"] * len(events), color=[e[2] for e in events]),
            [_time_column(np.array([e[0] for e in events]))],
        )


def blueprint(scene: dict[str, Any]) -> Any:
    """The default layout: the 3D view left; q, log10 error and energy plots stacked right; text below."""
    import rerun.blueprint as rrb

    name = scene["name"]
    root = f"/{name}"
    keys = [r["key"] for r in scene["runs"]]
    spatial = [f"+ {root}/anchors"] + [
        f"+ {root}/{k}/{part}/**" for k in keys for part in ("bodies", "links", "axes", "trail")
    ]
    scale, (up, sign) = scene["scale"], scene["up"]
    position = np.full(3, 2.0 * scale)  # oblique, from above
    position[up] = 1.5 * scale * sign
    if scene["plane_normal"] is not None:  # planar motion: look straight at the plane
        position = np.zeros(3)
        position[scene["plane_normal"]] = 2.5 * scale
    eye_up = np.zeros(3)
    eye_up[up] = sign
    view3d = rrb.Spatial3DView(
        name=f"{name}: bodies and {TRAIL_SECONDS:g} s trails",
        origin=root,
        contents=spatial,
        eye_controls=rrb.EyeControls3D(position=position, look_target=np.zeros(3), eye_up=eye_up),
    )

    q_views = [
        rrb.TimeSeriesView(name=f"q: {c} ({u})", origin=root, contents=[f"+ {root}/{k}/q/{c}" for k in keys])
        for c, u in zip(scene["coordinates"], scene["units"], strict=True)
    ]
    error_view = rrb.TimeSeriesView(
        name=f"log10 error vs hand (zeros at {np.log10(ERROR_FLOOR):g})",
        origin=root,
        contents=[f"+ {root}/threshold"]
        + [f"+ {root}/{k}/{part}" for k in keys for part in ("log10_error", "log10_envelope", "exceeds_threshold")],
    )
    energy_view = rrb.TimeSeriesView(
        name="energy E(t) - E(0) (J)", origin=root, contents=[f"+ {root}/{k}/energy_change" for k in keys]
    )
    plots = rrb.Vertical(*q_views, error_view, energy_view)
    text = rrb.Tabs(
        rrb.TextDocumentView(name="description", origin=f"{root}/description"),
        rrb.TextLogView(name="events", origin=f"{root}/events"),
    )
    return rrb.Blueprint(
        rrb.Vertical(rrb.Horizontal(view3d, plots, column_shares=[1, 1]), text, row_shares=[3, 1]),
        rrb.TimePanel(state="collapsed", timeline=TIMELINE, play_state="playing", loop_mode="all"),
        rrb.SelectionPanel(state="collapsed"),
    )


def describe(scene: dict[str, Any]) -> str:
    """The markdown text document: the system, the runs, and how each plot was made."""
    s, t = scene["sys"], scene["t"]
    traj = s["trajectories"]
    units = dict(zip(scene["coordinates"], scene["units"], strict=True))

    def vec(x: Any) -> str:
        return "(" + ", ".join(f"{float(v):.6g}" for v in np.ravel(_floats(x))) + ")"

    lines = [f"# {scene['name']}", "", str(s.get("description", "")), ""]
    lines += ["Coordinates: " + ", ".join(f"{c} ({units[c]})" for c in scene["coordinates"]) + ".", ""]
    params = s.get("parameters") or {}
    if params:
        lines += ["| parameter | value |", "|---|---|"]
        lines += [f"| {k} | {float(v):.6g} |" for k, v in sorted(params.items())] + [""]
    lines += [
        f"Initial state: q0 = {vec(traj['q0'])}, v0 = {vec(traj['v0'])}"
        + (f", tau = {vec(traj['tau'])}" if "tau" in traj else "")
        + "; "
        f"{len(t)} samples from {t[0]:g} to {t[-1]:g} s.",
        "",
    ]
    unit = " or ".join(sorted(set(scene["units"])))
    threshold = "none" if scene["threshold"] is None else f"{scene['threshold']:g} {unit}"
    lines += [f"Reference: {traj.get('reference', 'hand')}. Threshold on the error: {threshold}.", ""]
    lines += [
        "| run | colour | source | method | q(0) | v(0) | max error | first above threshold | max abs(E - E(0)) (J) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in scene["runs"]:
        run = r["run"]
        colour = "#{:02x}{:02x}{:02x}".format(*r["colour"])
        v = _floats(run["v"]).reshape(len(t), -1) if "v" in run else None
        first_time = run.get("first_exceeds_threshold")
        max_error = f"{float(np.max(r['error'])):.3g}" if r["error"] is not None else "-"
        drift = f"{float(np.max(np.abs(r['energy'] - r['energy'][0]))):.3g}" if r["energy"] is not None else "-"
        lines.append(
            f"| {r['key']} | {colour} | {run.get('source', '?')} | {run.get('method', '?')} | "
            f"{vec(r['q'][0])} | {vec(v[0]) if v is not None else '-'} | {max_error} | "
            f"{'never' if first_time is None else f'{float(first_time):g} s'} | {drift} |"
        )
    zeros = {r["key"]: int(np.sum(r["error"] == 0)) for r in scene["runs"] if r["error"] is not None}
    lines += [
        "",
        "## How to read the views",
        "",
        "- **3D**: each run's bodies at their centres of mass (equations module's `body_positions` at the run's q),"
        " links drawn parent centre of mass -> joint anchor -> centre of mass, and the last "
        f"{TRAIL_SECONDS:g} s of each tip body's path ({scene['window']} samples)."
        + (
            f" Bodies {', '.join(scene['still'])} keep their centre of mass still, so their axes are drawn"
            " (x in the run's colour, y lighter, z darker) and a still tip's trail follows the end of its x axis."
            if scene["still"]
            else ""
        ),
        "- **q**: one plot per coordinate, one line per run.",
        "- **log10 error**: log10 of the run's error against the reference (max over coordinates of"
        f" |q - q_ref| per sample). Errors of exactly 0 are clipped to {ERROR_FLOOR:g}, drawn at"
        f" {np.log10(ERROR_FLOOR):g}; samples clipped: "
        + ", ".join(f"{k} {n}/{len(t)}" for k, n in zeros.items())
        + "."
        + " The grey line is the threshold; a cross marks the first sample above it.",
        "- **energy**: E(t) - E(0) per run, E = T + V by the hand equations (J).",
    ]
    meta = scene.get("meta")
    if meta:
        lines += ["", meta]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------
# Viewer


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


def _show(name: str, sys_results: Mapping[str, Any], *, meta: Mapping[str, Any] | None) -> None:
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

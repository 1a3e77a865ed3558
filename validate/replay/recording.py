"""A scene logged to a rerun recording stream: one timeline, time-varying data sent whole with
`send_columns`, static styling; the default blueprint and the description document.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from .scene import TRAIL_SECONDS, Colour, Scene, SceneRun, as_floats, first_exceeds, shade

if TYPE_CHECKING:
    from rerun import AsComponents, ComponentColumn, RecordingStream, TimeColumn
    from rerun.blueprint import Blueprint

TIMELINE = "time"  # s


ERROR_FLOOR = 1e-17  # rad; errors of exactly zero are drawn at log10(ERROR_FLOOR)


THRESHOLD_COLOUR = (200, 200, 200)


ANCHOR_COLOUR = (230, 230, 230)


def part(name: str) -> str:
    """`name` as one part of an entity path: `/`, `:` and spaces escaped (a body `fore/arm` is one
    entity, not two levels)."""
    import rerun as rr

    return str(rr.escape_entity_path_part(str(name)))


def plottable(x: np.ndarray) -> np.ndarray:
    """Non-finite samples (a diverged run) become NaN, which the plots leave as gaps."""
    return np.where(np.isfinite(x), x, np.nan)


def log10_error(error: np.ndarray) -> np.ndarray:
    """log10 of an error series, zeros clipped to ERROR_FLOOR."""
    with np.errstate(invalid="ignore"):
        return plottable(np.log10(np.maximum(error, ERROR_FLOOR)))


def time_column(seconds: np.ndarray) -> TimeColumn:
    """The "time" timeline at these instants. Rounded to whole nanoseconds here: rerun truncates
    float seconds (2.11 s would become 2.109999999 s)."""
    import rerun as rr

    return rr.TimeColumn(TIMELINE, duration=np.rint(np.asarray(seconds, dtype=float) * 1e9).astype("timedelta64[ns]"))


def _static(rec: RecordingStream, path: str, *archetypes: AsComponents) -> None:
    """Logs styling or text that does not change with time."""
    rec.log(path, *archetypes, static=True, strict=True)


def _send(rec: RecordingStream, path: str, columns: Iterable[ComponentColumn], times: list[TimeColumn]) -> None:
    """Sends a whole time series at the instants `times` (one time column)."""
    rec.send_columns(path, indexes=times, columns=columns, strict=True)


def _log_frame(rec: RecordingStream, scene: Scene, radius: float) -> None:
    """The scene's axes (which way is up), description, anchors and the error threshold."""
    import rerun as rr

    root, t = f"/{part(scene['name'])}", scene["t"]
    axis, sign = scene["up"]
    _static(rec, root, getattr(rr.ViewCoordinates, f"RIGHT_HAND_{'XYZ'[axis]}_{'UP' if sign > 0 else 'DOWN'}"))
    _static(rec, f"{root}/description", rr.TextDocument(describe(scene), media_type=rr.MediaType.MARKDOWN))
    first = scene["runs"][0]
    _static(
        rec,
        f"{root}/anchors",
        rr.Points3D([first["anchor"][b][0] for b in scene["roots"]], radii=0.6 * radius, colors=ANCHOR_COLOUR),
    )
    if scene["threshold"] is not None and len(t):
        _static(rec, f"{root}/threshold", rr.SeriesLines(colors=THRESHOLD_COLOUR, names="threshold", widths=1.0))
        _send(
            rec,
            f"{root}/threshold",
            rr.Scalars.columns(scalars=np.full(2, np.log10(scene["threshold"]))),
            [time_column(np.array([t[0], t[-1]]))],
        )


def _log_bodies(rec: RecordingStream, scene: Scene, r: SceneRun, radius: float) -> None:
    """One run's 3D view: centres of mass, links, trails and body axes."""
    import rerun as rr

    base, colour, times = f"/{part(scene['name'])}/{part(r['key'])}", r["colour"], [time_column(r["t"])]
    for b in scene["bodies"]:
        _static(rec, f"{base}/bodies/{part(b)}", rr.Points3D.from_fields(colors=colour, radii=radius))
        _send(rec, f"{base}/bodies/{part(b)}", rr.Points3D.columns(positions=r["com"][b]), times)
    for b, strips in r["links"].items():
        _static(rec, f"{base}/links/{part(b)}", rr.LineStrips3D.from_fields(colors=colour, radii=0.25 * radius))
        _send(rec, f"{base}/links/{part(b)}", rr.LineStrips3D.columns(strips=strips), times)
    for b, strips in r["trails"].items():
        _static(rec, f"{base}/trail/{part(b)}", rr.LineStrips3D.from_fields(colors=colour, radii=0.12 * radius))
        _send(rec, f"{base}/trail/{part(b)}", rr.LineStrips3D.columns(strips=strips), times)
    for b, segments in r["axes"].items():
        shades = [colour, shade(colour, 255, 0.55), shade(colour, 0, 0.45)]  # x, y, z
        _static(rec, f"{base}/axes/{part(b)}", rr.LineStrips3D.from_fields(colors=shades, radii=0.3 * radius))
        _send(
            rec,
            f"{base}/axes/{part(b)}",
            rr.LineStrips3D.columns(strips=segments.reshape(-1, 2, 3)).partition(np.full(len(r["t"]), 3)),
            times,
        )


def _log_plots(rec: RecordingStream, scene: Scene, r: SceneRun) -> None:
    """One run's time series: its coordinates, log10 error and envelope vs hand, and energy change."""
    import rerun as rr

    base, colour, times = f"/{part(scene['name'])}/{part(r['key'])}", r["colour"], [time_column(r["t"])]
    for i, c in enumerate(scene["coordinates"]):
        _static(rec, f"{base}/q/{part(c)}", rr.SeriesLines(colors=colour, names=f"{r['key']}: {c}"))
        _send(rec, f"{base}/q/{part(c)}", rr.Scalars.columns(scalars=plottable(r["q"][:, i])), times)
    if r["error"] is not None:
        _static(rec, f"{base}/log10_error", rr.SeriesLines(colors=colour, names=r["key"]))
        _send(rec, f"{base}/log10_error", rr.Scalars.columns(scalars=log10_error(r["error"])), times)
    if r["envelope"] is not None:
        _static(
            rec,
            f"{base}/log10_envelope",
            rr.SeriesLines(colors=shade(colour, 255, 0.5), widths=1.0, names=f"{r['key']} envelope"),
        )
        _send(rec, f"{base}/log10_envelope", rr.Scalars.columns(scalars=log10_error(r["envelope"])), times)
    if r["energy"] is not None:
        _static(rec, f"{base}/energy_change", rr.SeriesLines(colors=colour, names=r["key"]))
        _send(rec, f"{base}/energy_change", rr.Scalars.columns(scalars=plottable(r["energy"] - r["energy"][0])), times)


def _log_exceedance(rec: RecordingStream, scene: Scene, r: SceneRun) -> tuple[float, str, Colour] | None:
    """Where one run's error vs hand first exceeds the threshold, marked on the error plot; the event
    (time, text, colour) for the log, or None where it never does."""
    import rerun as rr

    t, base, colour = scene["t"], f"/{part(scene['name'])}/{part(r['key'])}", r["colour"]
    first_time = first_exceeds(r["run"])
    if first_time is None or r["error"] is None or not np.isfinite(float(first_time)):
        return None
    k = int(np.argmin(np.abs(t - float(first_time))))
    _static(
        rec,
        f"{base}/exceeds_threshold",
        rr.SeriesPoints(colors=colour, markers="cross", marker_sizes=8.0, names=f"{r['key']} exceeds threshold"),
    )
    _send(
        rec,
        f"{base}/exceeds_threshold",
        rr.Scalars.columns(scalars=log10_error(r["error"][k : k + 1])),
        [time_column(t[k : k + 1])],
    )
    return (
        float(t[k]),
        f"{r['key']}: error vs hand first exceeds {scene['threshold']:g} at t = {t[k]:g} s ({r['error'][k]:.3g})",
        colour,
    )


def log_scene(rec: RecordingStream, scene: Scene) -> None:
    """Sends the scene to a recording stream: static styling and text first, then whole columns."""
    import rerun as rr

    radius = 0.03 * scene["scale"]
    _log_frame(rec, scene, radius)
    events = []
    for r in scene["runs"]:
        _log_bodies(rec, scene, r, radius)
        _log_plots(rec, scene, r)
        event = _log_exceedance(rec, scene, r)
        if event is not None:
            events.append(event)
    if events:
        events.sort(key=lambda e: e[0])
        _send(
            rec,
            f"/{part(scene['name'])}/events",
            rr.TextLog.columns(text=[e[1] for e in events], level=["WARN"] * len(events), color=[e[2] for e in events]),
            [time_column(np.array([e[0] for e in events]))],
        )


def blueprint(scene: Scene) -> Blueprint:
    """The default layout: the 3D view left; q, log10 error and energy plots stacked right; text below."""
    import rerun.blueprint as rrb

    name = scene["name"]
    root = f"/{part(name)}"
    keys = [part(r["key"]) for r in scene["runs"]]
    spatial = [f"+ {root}/anchors"] + [
        f"+ {root}/{k}/{leaf}/**" for k in keys for leaf in ("bodies", "links", "axes", "trail")
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
        rrb.TimeSeriesView(name=f"q: {c} ({u})", origin=root, contents=[f"+ {root}/{k}/q/{part(c)}" for k in keys])
        for c, u in zip(scene["coordinates"], scene["units"], strict=True)
    ]
    error_view = rrb.TimeSeriesView(
        name=f"log10 error vs hand (zeros at {np.log10(ERROR_FLOOR):g})",
        origin=root,
        contents=[f"+ {root}/threshold"]
        + [f"+ {root}/{k}/{leaf}" for k in keys for leaf in ("log10_error", "log10_envelope", "exceeds_threshold")],
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


def describe(scene: Scene) -> str:
    """The markdown text document: the system, the runs, and how each plot was made."""
    s, t = scene["sys"], scene["t"]
    traj = s["trajectories"]
    units = dict(zip(scene["coordinates"], scene["units"], strict=True))

    def vec(x: object) -> str:
        return "(" + ", ".join(f"{float(v):.6g}" for v in np.ravel(as_floats(x))) + ")"

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
        v = as_floats(run["v"]).reshape(len(r["t"]), -1) if "v" in run else None
        first_time = first_exceeds(run)
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
        "- **q**: one plot per coordinate, one line per run."
        + (
            " Runs named `printed_...` are wrong printed forms of the notes from the same start (their own"
            " time grid; no error or energy is recorded for them): the motion they predict, beside the engines'."
            if any(r["run"].get("wrong_form") for r in scene["runs"])
            else ""
        ),
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

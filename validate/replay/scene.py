"""The scene of one system's recording: every run's bodies, links, axes and trails at the recorded
q, placed by the equations' kinematics at the recorded parameters. Pure numpy; no rerun calls.
"""

from __future__ import annotations

import colorsys
import re
from collections.abc import Mapping
from typing import Any, NotRequired, TypedDict

import numpy as np

from ..core.errors import HarnessError
from ..handwritten.forms import not_provided_in
from ..systems import System, load, system_names

TRAIL_SECONDS = 1.0  # s of the tip's path drawn behind it

Colour = tuple[int, int, int]  # RGB, 0-255


class PlacedRun(TypedDict):
    """One run's samples and its bodies placed by the equations' kinematics (`_placed_run`)."""

    run: Mapping[str, object]  # the run as recorded (results.json's, or a wrong form's)
    t: np.ndarray  # (K,) s
    q: np.ndarray  # (K, n)
    com: dict[str, np.ndarray]  # per body: (K, 3) centre of mass
    rot: dict[str, np.ndarray]  # per body: (K, 3, 3)
    anchor: dict[str, np.ndarray]  # per body: (K, 3) joint anchor
    links: dict[str, np.ndarray]  # per body: (K, 3 points, 3)
    energy: np.ndarray | None
    error: np.ndarray | None
    envelope: np.ndarray | None


class SceneRun(PlacedRun):
    """A placed run with its entity name, colour, body axes and tips' trails (`build_scene`)."""

    key: str
    colour: Colour
    axes: NotRequired[dict[str, np.ndarray]]  # per still body: (K, 3 axes, 2 points, 3)
    trails: NotRequired[dict[str, np.ndarray]]  # per tip: (K, window, 3)


class Scene(TypedDict):
    """The arrays and text of one system's recording (`build_scene`)."""

    name: str
    sys: Mapping[str, Any]  # results["systems"][name], JSON or numpy as `run` wrote it
    t: np.ndarray
    runs: list[SceneRun]
    bodies: list[str]
    tips: list[str]
    still: list[str]
    parent: dict[str, str]
    scale: float
    window: int
    up: tuple[int, int]
    coordinates: list[str]
    units: list[str]
    roots: list[str]
    threshold: float | None
    plane_normal: int | None
    meta: str


SOURCE_COLOURS: dict[str, tuple[int, int, int]] = {
    "hand": (31, 119, 180),  # blue
    "mujoco": (255, 127, 14),  # orange
    "pinocchio": (44, 160, 44),  # green
    "symbolic": (140, 86, 75),  # brown
}


EXTRA_COLOURS: tuple[tuple[int, int, int], ...] = (
    (214, 39, 40),  # red
    (148, 103, 189),  # purple
    (227, 119, 194),  # pink
    (188, 189, 34),  # olive
    (23, 190, 207),  # cyan
)


def as_floats(x: object) -> np.ndarray:
    """A float array from numpy or JSON data (JSON keeps inf and nan as strings)."""
    return np.asarray(x, dtype=float) if not isinstance(x, np.ndarray) else x.astype(float, copy=False)


def first_exceeds(run: Mapping[str, object]) -> float | None:
    """When a run's error first exceeds its threshold (s; JSON keeps inf and nan as strings), or None."""
    first = run.get("first_exceeds_threshold")
    return None if first is None else float(as_floats(first))


def slug(text: object) -> str:
    return re.sub(r"[^a-z0-9]+", "_", str(text).lower()).strip("_") or "run"


def run_keys(runs: list[Mapping[str, object]]) -> list[str]:
    """Unique entity-path names for the runs: the source, then source_<label or method> for repeats."""
    keys: list[str] = []
    for run in runs:
        source = slug(run.get("source", "run"))
        key = f"{source}_{slug(run.get('label', ''))}" if run.get("wrong_form") else source
        if key in keys:
            key = f"{source}_{slug(run.get('label') or run.get('name') or run.get('method', ''))}"
        base, i = key, 2
        while key in keys:
            key, i = f"{base}_{i}", i + 1
        keys.append(key)
    return keys


def run_colours(runs: list[Mapping[str, object]]) -> list[Colour]:
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


def shade(colour: Colour, towards: float, amount: float) -> Colour:
    return tuple(round(c + (towards - c) * amount) for c in colour)  # type: ignore[return-value]


def joint_unit(view: Mapping[str, object], joint: str) -> str:
    try:
        return "m" if view[f"joint/{joint}/type"] == "slide" else "rad"
    except HarnessError:
        return "rad"


def recorded_params(system: System, sys_results: Mapping[str, Any]) -> object:
    """The parameters the results were computed with (the model's when they do not fit Params)."""
    recorded = sys_results.get("parameters")
    if recorded:
        try:
            return type(system.params)(**{k: float(v) for k, v in recorded.items()})
        except (TypeError, ValueError):
            pass
    return system.params


def _recorded_system(name: str, sys_results: Mapping[str, Any]) -> System:
    """The system the results were computed for: the repository's, a person's own files, or a model alone."""
    model, equations = sys_results.get("mjcf", ""), sys_results.get("equations", "")
    if name in system_names() and str(model).startswith("models/"):
        return load(name)
    if equations:  # a system from the user's own files, recorded by their paths
        return System.from_files(model, equations, name=name, locked=tuple(sys_results.get("locked") or ()))
    # the model alone: no derivation places the bodies
    return System.model_only(model, name=name, locked=tuple(sys_results.get("locked") or ()))


def _placed_bodies(system: System, sys_results: Mapping[str, Any]) -> list[str]:
    """The bodies the derivation places (none where it gives no body positions and rotations)."""
    bodies = list(sys_results.get("bodies") or system.bodies)
    if system.equations is None or {"body_positions", "body_rotations"} & set(not_provided_in(system.equations)):
        return []  # the derivation does not place its bodies: the recording shows q, energy and errors only
    return bodies


def _depths(parent: dict[str, str]) -> dict[str, int]:
    """How many of the bodies are above each body in the tree."""
    depth = {b: 0 for b in parent}
    for b in parent:
        p = parent[b]
        while p in parent:
            depth[b] += 1
            p = parent[p]
    return depth


def _placed_run(
    system: System, params: object, parent: dict[str, str], run: Mapping[str, object], t: np.ndarray
) -> PlacedRun:
    """One run's samples and its bodies (`parent`'s keys) placed by the equations' kinematics: centres
    of mass, rotations, joint anchors and links (parent's centre of mass, anchor, centre of mass)."""
    view, bodies = system.view, list(parent)
    body_joint: dict[str, str] = {}
    for j in system.joints:
        body_joint.setdefault(view[f"joint/{j}/body"], j)
    t_run = as_floats(run["t"]) if "t" in run else t
    q = as_floats(run["q"]).reshape(len(t_run), -1)
    K_run = len(t_run)
    positions = system.derivation.body_positions(params, q) if bodies else {}
    rotations = system.derivation.body_rotations(params, q) if bodies else {}
    com = {b: np.asarray(x, dtype=float).reshape(K_run, 3) for b, x in positions.items()}
    rot = {b: np.asarray(x, dtype=float).reshape(K_run, 3, 3) for b, x in rotations.items()}
    anchor = {}
    for b in bodies:
        origin = com[b] - rot[b] @ view[f"body/{b}/com"]
        joint = body_joint.get(b)
        anchor[b] = origin + rot[b] @ view[f"joint/{joint}/pos"] if joint else origin
    links = {
        b: np.stack([com[parent[b]] if parent[b] in com else anchor[b], anchor[b], com[b]], axis=1) for b in bodies
    }
    envelope = as_floats(run["envelope"]) if "envelope" in run else None
    return {
        "run": run,
        "t": t_run,
        "q": q,
        "com": com,
        "rot": rot,
        "anchor": anchor,
        "links": links,
        "energy": as_floats(run["energy"]) if "energy" in run else None,
        "error": as_floats(run["error_vs_hand"]) if "error_vs_hand" in run else None,
        "envelope": envelope if envelope is not None and envelope.shape == (K_run,) else None,
    }


def _scale(runs: list[SceneRun], bodies: list[str]) -> float:
    """Scene size: how far anything drawn reaches from the origin (1 m when everything sits there);
    samples of a diverged run (non-finite q) do not count."""
    norms = np.concatenate(
        [np.linalg.norm(r[kind][b], axis=-1) for r in runs for kind in ("com", "anchor") for b in bodies]
        or [np.zeros(1)]
    )
    reach = float(norms[np.isfinite(norms)].max(initial=0.0))
    return reach if reach > 1e-9 else 1.0


def _axes_and_trails(
    runs: list[SceneRun], still: list[str], tips: list[str], depth: dict[str, int], scale: float
) -> None:
    """Each run's body axes (for the bodies whose centre of mass stays still) and its tips' trails."""
    for r in runs:
        n, w = len(r["t"]), _window(r["t"])
        trail_index = np.clip(np.arange(n)[:, None] + np.arange(1 - w, 1)[None, :], 0, n - 1)
        r["axes"] = {}
        for b in still:
            length = 0.5 * scale * (0.8 ** depth[b])
            ends = r["com"][b][:, None, :] + length * np.swapaxes(r["rot"][b], 1, 2)  # (K, 3 axes, 3)
            r["axes"][b] = np.stack([np.broadcast_to(r["com"][b][:, None, :], ends.shape), ends], axis=2)
        # The tip's path: its centre of mass, or the end of its x axis when that stays still (line of sight).
        r["trails"] = {b: (r["axes"][b][:, 0, 1] if b in still else r["com"][b])[trail_index] for b in tips}


def _drop_still_links(runs: list[SceneRun], bodies: list[str], scale: float) -> None:
    """A link whose three points coincide throughout (a body turning about its own centre) is not drawn."""
    for b in bodies:
        if all(np.ptp(r["links"][b].reshape(-1, 3), axis=0).max() <= 1e-9 * scale for r in runs):
            for r in runs:
                del r["links"][b]


def _up(system: System) -> tuple[int, int]:
    """Up is against gravity; a scene that disables gravity still says in the MJCF where down is."""
    gravity = np.asarray(system.view["gravity"], dtype=float)
    if not gravity.any():
        gravity = np.asarray(system.mujoco_model().opt.gravity, dtype=float)
    return up_axis(gravity)


def build_scene(name: str, sys_results: Mapping[str, Any], *, meta: Mapping[str, object] | None = None) -> Scene:
    """The arrays and text of one system's recording. Pure numpy; no rerun calls."""
    system = _recorded_system(name, sys_results)
    view = system.view
    params = recorded_params(system, sys_results) if system.equations is not None else None
    traj = sys_results["trajectories"]
    t = as_floats(traj["t"])
    runs_in = list(traj["runs"])
    if not runs_in:
        raise HarnessError(f"{name}: the results hold no trajectory runs to replay.")
    runs_in += wrong_form_runs(sys_results)
    bodies = _placed_bodies(system, sys_results)
    parent = {b: view[f"body/{b}/parent"] for b in bodies}
    children = {b for b in bodies if any(parent[c] == b for c in bodies)}
    tips = [b for b in bodies if b not in children]
    runs: list[SceneRun] = [
        {"key": key, "colour": colour, **_placed_run(system, params, parent, run, t)}
        for key, colour, run in zip(run_keys(runs_in), run_colours(runs_in), runs_in, strict=True)
    ]
    scale = _scale(runs, bodies)
    # Bodies whose centre of mass never moves show their motion by their axes only.
    still = [b for b in bodies if all(np.ptp(r["com"][b], axis=0).max() <= 1e-9 * scale for r in runs)]
    _axes_and_trails(runs, still, tips, _depths(parent), scale)
    _drop_still_links(runs, bodies, scale)
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
        "window": _window(t),
        "up": _up(system),
        "coordinates": list(sys_results.get("coordinates") or system.coordinates),
        "units": [joint_unit(view, j) for j in system.joints],
        "roots": [b for b in bodies if parent[b] not in parent],
        "threshold": float(traj["threshold"]) if traj.get("threshold") is not None else None,
        "plane_normal": plane_normal(runs, bodies, scale),
        "meta": provenance_text(meta),
    }


def _window(t: np.ndarray) -> int:
    """Samples in TRAIL_SECONDS of a time grid."""
    if len(t) < 2:
        return 1
    return max(2, int(round(TRAIL_SECONDS / float(np.median(np.diff(t))))) + 1)


def wrong_form_runs(sys_results: Mapping[str, Any]) -> list[Mapping[str, object]]:
    """The runs of the wrong printed forms from the experiment's unperturbed start at its tightest
    tolerance (the same start as the trajectories'), on the experiment's own time grid: the motion
    a wrong form predicts, beside the engines'."""
    ex = sys_results.get("experiments") or {}
    wrong = {v.get("name") for v in sys_results.get("variants") or [] if v.get("verdict") == "disagrees"}
    runs = [r for r in ex.get("runs") or [] if r.get("form") in wrong and "q" in r]
    if not runs or "t" not in ex:
        return []
    tight = min(float(r["rtol"]) for r in runs)
    start = (sys_results.get("trajectories") or {}).get("q0")
    if start is not None and not np.allclose(as_floats(ex.get("q0", start)), as_floats(start)):
        return []  # another start: not comparable with the trajectories
    return [
        {
            "source": "printed",
            "label": r["form"],
            "method": f"{ex.get('method', 'scipy RK45')}, rtol {float(r['rtol']):g}; a wrong printed form",
            "t": ex["t"],
            "q": r["q"],
            "wrong_form": True,
        }
        for r in runs
        if float(r["rtol"]) == tight
    ]


def provenance_text(meta: Mapping[str, object] | None) -> str:
    if not meta:
        return ""
    command = meta.get("command", "lagrange-xval run")
    return (
        f"Results of `{command}` (lagrange-xval {meta.get('harness_version', '?')}, "
        f"commit {meta.get('git_commit', '?')}, {meta.get('date', '?')}, seed {meta.get('seed')})."
    )


def up_axis(gravity: np.ndarray) -> tuple[int, int]:
    """(axis, sign) of the world axis opposite to gravity; (z, +1) when there is no gravity along an axis."""
    g = float(np.linalg.norm(gravity))
    if g > 0:
        i = int(np.argmax(np.abs(gravity)))
        if abs(gravity[i]) > 0.999 * g:
            return i, -1 if gravity[i] > 0 else 1
    return 2, 1


def plane_normal(runs: list[SceneRun], bodies: list[str], scale: float) -> int | None:
    """The world axis all motion is perpendicular to, if the motion is planar (to look along it)."""
    if not bodies:
        return None
    pts = np.concatenate([r[kind][b] for r in runs for kind in ("com", "anchor") for b in bodies])
    spread = np.ptp(pts, axis=0)
    flat = [i for i in range(3) if spread[i] <= 1e-9 * scale]
    return flat[0] if len(flat) == 1 else None

"""Do the three sources describe the same model? Checked before any dynamics is compared.

1. The equations' stated assumptions against every key of the compiled MJCF (a key the equations
   do not state is a failure too: a parameter they silently ignore).
2. Pinocchio's model of the same file against MuJoCo's: masses, centres of mass, inertias of every
   compared body (Pinocchio drops collision-free geoms' mass and gives mesh geoms 1 kg, so a model
   that relies on geoms for its inertia differs between the engines), each compared joint's anchor
   and axis in world coordinates at q = 0, and for a URDF, which both engines read on their own,
   the joint damping each read. What the harness aligned between the two readings of a URDF
   (validate/model/urdf.py) is listed as `alignments`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..model.modelview import ModelView, names, parallel_axis, quat_to_mat, welded
from ..results.schema import Mismatch, ModelChecks
from ..sources.base import Source, engine_of
from ..sources.frames import mujoco_joint_frames
from ..systems import System

LEFT_OUT = ("/frictionloss",)  # keys of forces every comparison leaves out: what a derivation assumes of them is moot
RTOL = 1e-12  # both sides are the same compiled numbers, possibly through a few operations


def _same(expected: object, actual: object, floor: float = 0.0) -> bool:
    if isinstance(expected, str) or isinstance(actual, str):
        return bool(expected == actual)
    e, a = np.asarray(expected, dtype=float), np.asarray(actual, dtype=float)
    if e.shape != a.shape:
        return False
    care = ~np.isnan(e)
    if not care.any():
        return True
    # Relative to the array's largest entry: an inertia's 1e-14 element carries the rounding of its 0.08 ones.
    # `floor`: the scale below which entries are zero (an anchor at the origin is 1e-17 m away from it).
    scale = max(np.abs(a[care]).max(), np.abs(e[care]).max(), floor)
    return bool(np.all(np.abs(e[care] - a[care]) <= RTOL * scale))


def _fmt(x: Any) -> Any:
    if isinstance(x, str):
        return x
    arr = np.asarray(x, dtype=float)
    return [None if np.isnan(y) else float(y) for y in arr.ravel()] if arr.ndim else float(arr)


def states_every_key(system: System) -> bool:
    """Whether the derivation's `assumptions()` state the whole model (every key of it): then every
    number it reads is one of its stated parameters, and a key it leaves out is a parameter it silently
    ignores. A module without `assumptions()`, or with only the relations its formulas bake in, reads
    the rest from the model, and the probes move what it reads (validate/verdict/probes.py)."""
    if not getattr(system.equations, "STATES_ASSUMPTIONS", True):
        return False
    return set(system.view) <= set(system.derivation.assumptions(system.params))


def equations_vs_model(system: System) -> list[Mismatch]:
    """Rows for every key of the compiled model and every assumption; `passed` False where they differ.
    Where the assumptions are partial (or absent), a key they do not state is read from the model, not
    assumed: no row."""
    assumed = system.derivation.assumptions(system.params)
    view = system.view
    strict = set(view) <= set(assumed)
    rows: list[Mismatch] = []
    for key in sorted(set(view) | set(assumed)):
        if key not in assumed and not strict:
            continue
        if key.endswith(LEFT_OUT):  # a constraint's parameter: its force is in no comparison (model/scope.py)
            continue
        if key not in assumed:
            rows.append(
                {
                    "check": "equations~mjcf",
                    "key": key,
                    "expected": "(not stated)",
                    "actual": _fmt(view[key]),
                    "passed": False,
                    "why": "the equations do not state what they assume of this parameter",
                }
            )
        elif key not in view:
            rows.append(
                {
                    "check": "equations~mjcf",
                    "key": key,
                    "expected": _fmt(assumed[key]),
                    "actual": "(absent)",
                    "passed": False,
                    "why": "the equations assume something the model does not have",
                }
            )
        else:
            ok = _same(assumed[key], view[key])
            rows.append(
                {
                    "check": "equations~mjcf",
                    "key": key,
                    "expected": _fmt(assumed[key]),
                    "actual": _fmt(view[key]),
                    "passed": ok,
                    "why": "" if ok else "the compiled MJCF differs from what the equations assume",
                }
            )
    return rows


def pinocchio_vs_mujoco(system: System, pin_source: Source) -> list[Mismatch]:
    """Mass, centre of mass and inertia of each compared body, as each engine compiled it."""
    from ..sources.pinocchio import PinocchioSource

    pn = engine_of(pin_source, PinocchioSource)  # a MappedSource's engine: its model is the same
    model, view = pn.model, system.view
    rows: list[Mismatch] = []
    carried = welded(view)
    for body, jid, fid in _carriers(system, pn.joint_of_body, pn.frames, pn.model):
        # Pinocchio keeps one inertia per joint, in the joint's frame, with the bodies welded to it
        # added; MuJoCo one per body, in the body's frame: both brought to the body's frame and content.
        inertia = model.inertias[jid]
        R, p = model.frames[fid].placement.rotation, model.frames[fid].placement.translation
        mass, com, rot = _rigid(view, body, carried)
        # welded bodies' centres move the sum's: it carries the rounding of their distances
        extent = max(
            [
                float(np.abs(view[f"body/{c}/pos"]).max() + np.abs(view[f"body/{c}/com"]).max())
                for c in carried.get(body, [])
            ]
            + [0.0]
        )
        pairs = {
            "mass": (mass, inertia.mass),
            "com": (com, R.T @ (inertia.lever - p)),
            "inertia": (rot, R.T @ inertia.inertia @ R),
        }
        for what, (mj, pn) in pairs.items():
            # a centre of mass moved into the body's frame carries the rounding of the move's size
            floor = max(float(np.abs(p).max()), extent) if what == "com" else 0.0
            rows.append(_engine_row(f"body/{body}/{what}", mj, pn, _same(mj, pn, floor), "compiled this body"))
    return rows


def _carriers(system: System, joints: list[int], frames: list[int], model: Any) -> list[tuple[str, int, int]]:
    """(body, Pinocchio joint, frame) of each compared body's rigid group, once: a compared body welded to
    its parent (no joint of its own: reacher's `finger` on `hand`) has no inertia of its own in Pinocchio,
    whose joint holds the group's; its group is compared at the body the joint moves, MuJoCo's sum of the
    group (`_rigid`) against Pinocchio's joint inertia."""
    view = system.view
    parent = {b: str(view[f"body/{b}/parent"]) for b in names(view, "body", "parent")}
    moved = {str(view[f"joint/{j}/body"]) for j in names(view, "joint", "body")}
    out: dict[str, tuple[str, int, int]] = {}
    for body, jid, fid in zip(system.bodies, joints, frames, strict=True):
        top = body
        while top not in moved and parent.get(top, "world") != "world":
            top = parent[top]
        if top not in moved:  # welded to the world: compared as it stands
            top = body
        elif top != body:
            fid = model.getBodyId(top)
        out.setdefault(top, (top, jid, fid))
    return list(out.values())


def _rigid(view: ModelView, body: str, welded: dict[str, list[str]]) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre of mass and inertia about it, in `body`'s frame, of `body` and the bodies welded to
    it (no joint between them) as MuJoCo compiled them."""
    parts = [
        (
            float(view[f"body/{body}/mass"]),
            np.asarray(view[f"body/{body}/com"], dtype=float),
            view[f"body/{body}/inertia"],
        )
    ]
    for child in welded.get(body, []):
        m, c, inertia = _rigid(view, child, welded)
        R = quat_to_mat(np.asarray(view[f"body/{child}/quat"], dtype=float))
        parts.append((m, np.asarray(view[f"body/{child}/pos"], dtype=float) + R @ c, R @ inertia @ R.T))
    if len(parts) == 1:
        return parts[0]
    mass = sum(m for m, _, _ in parts)
    com = sum((m * c for m, c, _ in parts), np.zeros(3)) / mass if mass > 0 else np.zeros(3)
    total = np.zeros((3, 3))
    for m, c, inertia in parts:
        d = c - com
        total += inertia + parallel_axis(m, d)
    return mass, com, total


def _engine_row(key: str, mujoco_value: object, pinocchio_value: object, ok: bool, what: str) -> Mismatch:
    """One pinocchio~mujoco row: MuJoCo's reading expected, Pinocchio's actual."""
    return {
        "check": "pinocchio~mujoco",
        "key": key,
        "expected": _fmt(mujoco_value),
        "actual": _fmt(pinocchio_value),
        "passed": ok,
        "why": "" if ok else f"Pinocchio {what} differently from MuJoCo",
    }


def view_type(system: System, joint: str) -> str:
    return str(system.view[f"joint/{joint}/type"])


def _at_origin(anchor: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """A joint's motion per unit velocity (linear, angular) at `anchor`, moved to the world origin: the
    same for every anchor on a hinge's axis line, and for every anchor of a slide."""
    return np.concatenate([motion[:3] - np.cross(motion[3:], anchor), motion[3:]])


def joints_pinocchio_vs_mujoco(system: System, pin_source: Source) -> list[Mismatch]:
    """Axis line (a hinge's `anchor`: where its axis passes, as the motion of the world origin) and
    motion axis of each compared joint at q = 0, and for a URDF the damping, as each engine read them.
    Anchors are compared as lines, not points: a reader may put a hinge's frame anywhere on its axis
    (Pinocchio's composite of several joints in one body, a joint off its body's origin)."""
    from ..sources.pinocchio import PinocchioSource

    engine = engine_of(pin_source, PinocchioSource)
    mj, pn = mujoco_joint_frames(system), engine.joint_frames()
    damping = engine.read_damping() if system.reads_urdf else None
    # anchors are compared relative to the chain's extent: one at the origin may be read as 1e-17 m
    extent = max([float(np.abs(f[0]).max()) for f in (*mj.values(), *pn.values())] + [1e-300])
    rows: list[Mismatch] = []
    for i, j in enumerate(system.joints):
        pairs = {
            "motion": (mj[j][1][3:] if view_type(system, j) == "hinge" else mj[j][1][:3], _axis(system, j, pn[j][1]))
        }
        if view_type(system, j) == "hinge":  # a slide's anchor is any point on its line
            pairs["anchor"] = (_at_origin(*mj[j])[:3], _at_origin(*pn[j])[:3])
        if damping is not None:
            pairs["damping"] = (system.view[f"joint/{j}/damping"], damping[i])
        for what, (a, b) in pairs.items():
            ok = _same(a, b, floor=extent if what == "anchor" else 1.0 if what == "motion" else 0.0)
            rows.append(_engine_row(f"joint/{j}/{what}", a, b, ok, "read this joint"))
    return rows


def _axis(system: System, joint: str, motion: np.ndarray) -> np.ndarray:
    """A reader's joint axis from its motion (linear, angular): the angular half of a hinge's, the
    linear half of a slide's."""
    return motion[3:] if view_type(system, joint) == "hinge" else motion[:3]


def check(system: System, pin_source: Source | None) -> ModelChecks:
    """What the equations assume of the compiled model, and Pinocchio's reading against MuJoCo's (none
    where Pinocchio cannot read the file: `pin_source` None, the reader left out)."""
    rows = equations_vs_model(system) if system.equations is not None else []
    if pin_source is not None:
        rows += pinocchio_vs_mujoco(system, pin_source) + joints_pinocchio_vs_mujoco(system, pin_source)
    failed = [_of_the_file(r, system) for r in rows if not r["passed"]]
    out: ModelChecks = {
        "n_checked": len(rows),
        "passed": not failed,
        "mismatches": failed,
        "alignments": system.alignments,
    }
    if system.left_out:
        out["left_out"] = system.left_out
    if system.defects:
        out["defects"] = system.defects
    if system.floors:
        out["floors"] = system.floors
    return out


def _of_the_file(row: Mismatch, system: System) -> Mismatch:
    """A pinocchio~mujoco mismatch of a body whose link the file gets wrong (an inertia that violates
    A + B >= C, say): MuJoCo was given the balanced numbers and Pinocchio the file's, so the row names the
    file's defect (`defect`), not a misreading by Pinocchio."""
    parts = row["key"].split("/")
    bodies = system.defective_bodies
    if row["check"] != "pinocchio~mujoco" or parts[0] != "body" or "/".join(parts[1:-1]) not in bodies:
        return row
    link = bodies["/".join(parts[1:-1])]
    why = f"the file's defect: link '{link}' was given to MuJoCo balanced and to Pinocchio as written"
    return {**row, "why": why, "defect": link}

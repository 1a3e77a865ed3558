"""Do the three sources describe the same model? Checked before any dynamics is compared.

1. The equations' stated assumptions against every key of the compiled MJCF (a key the equations
   do not state is a failure too: a parameter they silently ignore).
2. Pinocchio's model of the same file against MuJoCo's: masses, centres of mass, inertias of every
   compared body (Pinocchio drops collision-free geoms' mass and gives mesh geoms 1 kg, so a model
   that relies on geoms for its inertia differs between the engines), each compared joint's anchor
   and axis in world coordinates at q = 0, and for a URDF, which both engines read on their own,
   the joint damping each read. What the harness aligned between the two readings of a URDF
   (validate/systems/urdf.py) is listed as `alignments`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..engines.base import Source, engine_of
from ..results.schema import Mismatch, ModelChecks
from ..systems import System
from ..systems.modelview import quat_to_mat

RTOL = 1e-12  # both sides are the same compiled numbers, possibly through a few operations


def _same(expected: Any, actual: Any, floor: float = 0.0) -> bool:
    if isinstance(expected, str) or isinstance(actual, str):
        return expected == actual
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
    the rest from the model, and the probes move what it reads (validate/checks/probes.py)."""
    if not getattr(system.equations, "STATES_ASSUMPTIONS", True):
        return False
    return set(system.view) <= set(system.equations.assumptions(system.params))


def equations_vs_model(system: System) -> list[Mismatch]:
    """Rows for every key of the compiled model and every assumption; `passed` False where they differ.
    Where the assumptions are partial (or absent), a key they do not state is read from the model, not
    assumed: no row."""
    assumed = system.equations.assumptions(system.params)
    view = system.view
    strict = set(view) <= set(assumed)
    rows: list[Mismatch] = []
    for key in sorted(set(view) | set(assumed)):
        if key not in assumed and not strict:
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
    from ..engines.pinocchio import PinocchioSource

    pn = engine_of(pin_source, PinocchioSource)  # a MappedSource's engine: its model is the same
    model, view = pn.model, system.view
    rows: list[Mismatch] = []
    for body, jid in zip(system.bodies, pn.joint_of_body, strict=True):
        inertia = model.inertias[jid]
        pairs = {
            "mass": (view[f"body/{body}/mass"], inertia.mass),
            "com": (view[f"body/{body}/com"], inertia.lever),
            "inertia": (view[f"body/{body}/inertia"], inertia.inertia),
        }
        for what, (mj, pn) in pairs.items():
            rows.append(_engine_row(f"body/{body}/{what}", mj, pn, _same(mj, pn), "compiled this body"))
    return rows


def _engine_row(key: str, mujoco_value: Any, pinocchio_value: Any, ok: bool, what: str) -> Mismatch:
    """One pinocchio~mujoco row: MuJoCo's reading expected, Pinocchio's actual."""
    return {
        "check": "pinocchio~mujoco",
        "key": key,
        "expected": _fmt(mujoco_value),
        "actual": _fmt(pinocchio_value),
        "passed": ok,
        "why": "" if ok else f"Pinocchio {what} differently from MuJoCo",
    }


def mujoco_joint_frames(system: System) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """MuJoCo's reading of the same (`PinocchioSource.joint_frames`), from its compiled bodies and joints."""
    view = system.view
    poses: dict[str, tuple[np.ndarray, np.ndarray]] = {"world": (np.zeros(3), np.eye(3))}

    def pose(body: str) -> tuple[np.ndarray, np.ndarray]:
        if body not in poses:
            p, R = pose(view[f"body/{body}/parent"])
            local = quat_to_mat(np.asarray(view[f"body/{body}/quat"], dtype=float))
            poses[body] = (p + R @ np.asarray(view[f"body/{body}/pos"], dtype=float), R @ local)
        return poses[body]

    out = {}
    for j in system.joints:
        p, R = pose(view[f"joint/{j}/body"])
        axis = R @ np.asarray(view[f"joint/{j}/axis"], dtype=float)
        axis = axis / np.linalg.norm(axis)
        zero = np.zeros(3)
        motion = np.concatenate([zero, axis] if view[f"joint/{j}/type"] == "hinge" else [axis, zero])
        out[j] = (p + R @ np.asarray(view[f"joint/{j}/pos"], dtype=float), motion)
    return out


def joints_pinocchio_vs_mujoco(system: System, pin_source: Source) -> list[Mismatch]:
    """Anchor (hinges) and motion axis of each compared joint at q = 0, and for a URDF the damping,
    as each engine read them."""
    from ..engines.pinocchio import PinocchioSource

    engine = engine_of(pin_source, PinocchioSource)
    mj, pn = mujoco_joint_frames(system), engine.joint_frames()
    damping = engine.read_damping() if system.reads_urdf else None
    # anchors are compared relative to the chain's extent: one at the origin may be read as 1e-17 m
    extent = max([float(np.abs(f[0]).max()) for f in (*mj.values(), *pn.values())] + [1e-300])
    rows: list[Mismatch] = []
    for i, j in enumerate(system.joints):
        pairs = {"motion": (mj[j][1], pn[j][1])}
        if system.view[f"joint/{j}/type"] == "hinge":  # a slide's anchor is any point on its line
            pairs["anchor"] = (mj[j][0], pn[j][0])
        if damping is not None:
            pairs["damping"] = (system.view[f"joint/{j}/damping"], damping[i])
        for what, (a, b) in pairs.items():
            ok = _same(a, b, floor=extent if what == "anchor" else 1.0 if what == "motion" else 0.0)
            rows.append(_engine_row(f"joint/{j}/{what}", a, b, ok, "read this joint"))
    return rows


def check(system: System, pin_source: Source) -> ModelChecks:
    rows = (
        (equations_vs_model(system) if system.equations is not None else [])
        + pinocchio_vs_mujoco(system, pin_source)
        + joints_pinocchio_vs_mujoco(system, pin_source)
    )
    failed = [r for r in rows if not r["passed"]]
    return {"n_checked": len(rows), "passed": not failed, "mismatches": failed, "alignments": system.alignments}

"""Which numbers of a compiled model its equations of motion depend on, for `lagrange-xval new`'s `Params`.

The kinetic and potential energy of the chain are computed with numpy, as the symbolic derivation builds
them (validate/symbolic/derivation.py: each body's frame from its parent's, a hinge turning it about its
axis through its anchor by q - ref, a slide moving it along its axis; T = sum (m |v_c|^2 + w_b^T I w_b) / 2,
V = -sum m g . r_c), at a few seeded states, once with the model's numbers and once with one number moved.
A number the dynamics depend on changes T or V at some state; one they do not (the inertia about an axis
no body turns about, a centre of mass's offset along a planar chain's hinge axis, an anchor's position
along its hinge) leaves both as they were, to rounding. M, C v and G are derived from T and V, so the
energies say what the dynamics read. The joints' damping, armature and stiffness and the actuators' gears
enter M, the passive forces and B directly; a springref only where its joint has a stiffness.

A model with a joint other than a hinge or a slide (a ball or a free joint) is not analysed: every
number is taken as depended on.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeAlias

import numpy as np

from ..model.modelview import ModelView, names, quat_to_mat

Entry: TypeAlias = int | tuple[int, int] | str | None  # as field_of and the derivation read an entry
Number: TypeAlias = tuple[str, Entry]  # (model key, entry)
INERTIA_ENTRIES = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
BODY_ENTRIES: dict[str, tuple[Entry, ...]] = {
    "mass": (None,),
    "com": (0, 1, 2),
    "inertia": INERTIA_ENTRIES,
    "pos": (0, 1, 2),
}
STATES = 8  # seeded states at which the energies are compared
RTOL = 1e-11  # a change of T or V below this, relative to its size, is rounding
ZERO_RTOL = 1e-14  # a product of inertia this small beside the inertia's largest entry is zero (as derive reads it)


def entry_value(view: Mapping[str, object], key: str, entry: Entry) -> float:
    """The model's number at `entry` of `key` (an inertia's symmetrized; "norm": the vector's length)."""
    x = np.asarray(view[key], dtype=float)
    if entry is None:
        return float(x)
    if entry == "norm":
        return float(np.linalg.norm(x))
    if isinstance(entry, tuple):
        return float(0.5 * (x[entry] + x[entry[::-1]]))
    return float(x[entry])


def is_zero(view: Mapping[str, object], key: str, entry: Entry) -> bool:
    """Whether the number is zero as the derivation reads it (a structural zero, not a parameter)."""
    value = entry_value(view, key, entry)
    if key.endswith("/inertia"):
        return abs(value) <= ZERO_RTOL * max(float(np.abs(np.asarray(view[key], dtype=float)).max()), 1e-300)
    return value == 0.0


def _rotation(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(S, 3, 3): Rodrigues' rotation about the unit `axis` by each angle."""
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


Frame: TypeAlias = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]  # origin, rotation, its velocity, omega


def _through_joint(values: Mapping[str, Any], j: str, frame: Frame, q: np.ndarray, v: np.ndarray) -> Frame:
    """The body frame moved by joint `j` (coordinate q, rate v, one per state), with its velocities (world)."""
    x, R, vx, w = frame
    axis = values[f"joint/{j}/axis"] / np.linalg.norm(values[f"joint/{j}/axis"])
    moved = q - float(values.get(f"joint/{j}/ref", 0.0))
    k = R @ axis  # (S, 3) the axis in the world
    if values[f"joint/{j}/type"] == "slide":
        x2 = x + k * moved[:, None]
        return x2, R, vx + np.cross(w, x2 - x) + k * v[:, None], w
    s = values[f"joint/{j}/pos"]
    Rj = _rotation(axis, moved)
    x2 = x + np.einsum("sij,sj->si", R, s - Rj @ s)
    turn = k * v[:, None]
    return x2, R @ Rj, vx + np.cross(w, x2 - x) + np.cross(turn, x2 - (x + R @ s)), w + turn


def _frames(values: Mapping[str, Any], q: np.ndarray, v: np.ndarray) -> dict[str, Frame]:
    """Every body's frame and its velocities at the states (q, v), parents before children."""
    n = q.shape[0]
    world: Frame = (np.zeros((n, 3)), np.broadcast_to(np.eye(3), (n, 3, 3)), np.zeros((n, 3)), np.zeros((n, 3)))
    frames = {"world": world}
    joints = names(values, "joint", "type")
    index = {j: i for i, j in enumerate(joints)}
    remaining = names(values, "body", "mass")
    while remaining:
        b = next(b for b in remaining if values[f"body/{b}/parent"] in frames)
        remaining.remove(b)
        x, R, vx, w = frames[str(values[f"body/{b}/parent"])]
        offset = R @ values[f"body/{b}/pos"]
        frame: Frame = (x + offset, R @ quat_to_mat(values[f"body/{b}/quat"]), vx + np.cross(w, offset), w)
        for j in (j for j in joints if values[f"joint/{j}/body"] == b):
            frame = _through_joint(values, j, frame, q[:, index[j]], v[:, index[j]])
        frames[b] = frame
    return frames


def energies(values: Mapping[str, Any], q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(T, V): (S, 1) kinetic energy and (S, bodies) potential energy of each body at the states (q, v)."""
    frames = _frames(values, q, v)
    T, V = np.zeros(q.shape[0]), []
    for b in names(values, "body", "mass"):
        x, R, vx, w = frames[b]
        m, arm = float(values[f"body/{b}/mass"]), R @ values[f"body/{b}/com"]
        vc, wb = vx + np.cross(w, arm), np.einsum("sji,sj->si", R, w)
        T = T + 0.5 * (
            m * np.einsum("si,si->s", vc, vc) + np.einsum("si,ij,sj->s", wb, values[f"body/{b}/inertia"], wb)
        )
        V.append(-m * (x + arm) @ values["gravity"])
    return T[:, None], np.stack(V, axis=-1) if V else np.zeros((q.shape[0], 0))


def _scales(view: ModelView) -> dict[str, float]:
    """The model's size of each kind of number (length, mass, inertia), a moved number's least step: a
    number the dynamics read changes the energies visibly however small it is (a point mass's 1e-14 inertia)."""
    lengths = [np.abs(np.asarray(view[k], dtype=float)).max() for k in view if k.endswith(("/pos", "/com"))]
    L = float(max(lengths, default=0.0)) or 1.0
    M = float(max((float(view[k]) for k in view if k.endswith("/mass")), default=0.0)) or 1.0
    inertias = [np.abs(np.asarray(view[k], dtype=float)).max() for k in view if k.endswith("/inertia")]
    return {"length": L, "mass": M, "inertia": max(float(max(inertias, default=0.0)), M * L * L)}


def _moved(values: Mapping[str, Any], number: Number, scales: Mapping[str, float]) -> dict[str, Any]:
    """The values with one number moved by half its size or, if larger, the model's size of its kind."""
    key, entry = number
    out = dict(values)
    x = np.array(values[key], dtype=float)
    if entry == "norm":
        out[key] = 1.5 * x
        return out
    where = () if entry is None else entry
    kind = "mass" if key.endswith("/mass") else "inertia" if key.endswith("/inertia") else "length"
    x[where] += max(0.5 * abs(float(x[where])), scales[kind])
    if isinstance(entry, tuple):
        x[entry[::-1]] = x[entry]
    out[key] = x
    return out


def _differs(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> bool:
    """Whether T or V differ beyond rounding at some state."""
    for x, y in zip(a, b, strict=True):
        scale = max(float(np.abs(x).sum(axis=-1).max(initial=0.0)), float(np.abs(y).sum(axis=-1).max(initial=0.0)))
        if float(np.abs(x - y).max(initial=0.0)) > RTOL * max(scale, 1e-300):
            return True
    return False


def _states(view: ModelView, joints: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Seeded states: hinges anywhere on the circle, slides within a metre, rates of order one."""
    rng = np.random.default_rng(0)
    q = rng.uniform(-np.pi, np.pi, (STATES, len(joints)))
    slides = [i for i, j in enumerate(joints) if view[f"joint/{j}/type"] == "slide"]
    q[:, slides] /= np.pi
    return q, rng.normal(size=(STATES, len(joints)))


def _kinematic_numbers(view: ModelView) -> list[Number]:
    """Every number the energies are built from: each body's mass, centre, inertia and position, each
    hinge's anchor, gravity's magnitude."""
    out: list[Number] = [("gravity", "norm")]
    for b in names(view, "body", "mass"):
        out += [(f"body/{b}/{what}", e) for what, entries in BODY_ENTRIES.items() for e in entries]
    for j in names(view, "joint", "type"):
        out += [(f"joint/{j}/pos", i) for i in range(3)] if view[f"joint/{j}/type"] == "hinge" else []
    return out


def _direct_numbers(view: ModelView) -> list[Number]:
    """The numbers that enter M, the passive forces or B as they are: armature, damping, stiffness,
    a springref where its joint has a stiffness, each actuator's gear."""
    out: list[Number] = []
    for j in names(view, "joint", "type"):
        out += [(f"joint/{j}/{what}", None) for what in ("damping", "armature", "stiffness")]
        if f"joint/{j}/springref" in view and float(view[f"joint/{j}/stiffness"]) != 0.0:
            out.append((f"joint/{j}/springref", None))
    return out + [(f"actuator/{a}/gear", None) for a in names(view, "actuator", "gear")]


def depended_on(view: ModelView) -> frozenset[Number]:
    """The numbers of the compiled model `view` its equations of motion depend on (zero or not)."""
    joints = names(view, "joint", "type")
    kinematic = _kinematic_numbers(view)
    if any(view[f"joint/{j}/type"] not in ("hinge", "slide") for j in joints):
        return frozenset(kinematic + _direct_numbers(view))
    keys = {k for k, _ in kinematic} | {k for k in view if k.endswith(("/parent", "/quat", "/axis", "/type", "/body"))}
    values = {k: view[k] if isinstance(view[k], str) else np.asarray(view[k], dtype=float) for k in keys}
    values |= {k: np.asarray(view[k], dtype=float) for k in view if k.endswith("/ref")}
    q, v = _states(view, joints)
    base = energies(values, q, v)
    scales = _scales(view)
    used = [n for n in kinematic if _differs(base, energies(_moved(values, n, scales), q, v))]
    return frozenset(used + _direct_numbers(view))

"""Free and ball joints in coordinates every source shares: slides and hinges in the same body.

A free joint (a floating base) and a ball joint keep a quaternion in MuJoCo (nq != nv), Pinocchio
(FreeFlyer, Spherical) and Drake (QuaternionFloatingJoint, BallRpyJoint), each with its own order of
the quaternion and its own frame for the velocity. The harness compares one coordinate per degree of
freedom, so it gives every reader the same body with the same freedom in other coordinates: a free
joint becomes three slides along the body's axes and three hinges about them (z, then y, then x, each
about the axis the previous ones turned: intrinsic Z-Y-X Euler angles), a ball joint the three hinges
alone, at its anchor. The mechanics are unchanged (the same bodies, masses and forces); the
coordinates are a chart with its own singularity (the middle angle at +-90 degrees), and a person's
module writes its equations in them. Each converted joint is listed in the alignments.

An unnamed body or joint is named by MuJoCo's own id (`body#3`, `joint#5`), shown as such.

A `<keyframe>`'s `<key qpos qvel>` are converted with the coordinates (from MuJoCo's compiled keys): a
free joint's position and quaternion become the slides' displacement in the body's frame and the
Z-Y-X angles of its turn from the body's orientation, its world linear and body angular velocity the
slides' and angles' rates; a ball joint's quaternion and angular velocity likewise.

Joint names: `<name>_tx`, `_ty`, `_tz`, `_rz`, `_ry`, `_rx` (an unnamed free joint is called `free#<k>`,
a ball `ball#<k>`, by its order in the file).
"""

from __future__ import annotations

import functools
import math
import xml.etree.ElementTree as ET
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    import numpy as np

SLIDES = (("tx", "1 0 0"), ("ty", "0 1 0"), ("tz", "0 0 1"))
HINGES = (("rz", "0 0 1"), ("ry", "0 1 0"), ("rx", "1 0 0"))
KEPT = ("damping", "armature", "stiffness", "frictionloss", "group")  # what each part keeps
CHART_LIMIT = 1.2  # rad: the middle angle's range random states are drawn in (cos 1.2 = 0.36: M stays well posed)
ZEROED = ("damping", "armature", "stiffness", "frictionloss", "ref", "springref")


def _unnamed(text: str) -> bool:
    """Whether a <body> or <joint> tag of the text has no name (a quick look before parsing)."""
    import re

    return any("name=" not in tag for tag in re.findall(r"<(?:body|joint|freejoint)\b[^>]*>", text))


def _kind(element: ET.Element, stated: dict[str, str]) -> str | None:
    """ "free" or "ball" for such a joint (its type stated by itself or its default class), else None."""
    if element.tag == "freejoint":
        return "free"
    if element.tag == "joint" and stated.get("type") in ("free", "ball"):
        return stated.get("type")
    return None


def _joint_defaults(root: ET.Element) -> dict[str, tuple[dict[str, str], str | None]]:
    """class -> (the `<joint>` attributes its `<default>` states, its parent class); the top is "main"."""
    out: dict[str, tuple[dict[str, str], str | None]] = {}

    def walk(default: ET.Element, parent: str | None) -> None:
        name = default.get("class", "main")
        joint = default.find("joint")
        out[name] = (dict(joint.attrib) if joint is not None else {}, parent)
        for child in default.findall("default"):
            walk(child, name)

    for top in root.findall("default"):
        walk(top, None)
    return out


def _stated(root: ET.Element) -> dict[int, dict[str, str]]:
    """id(element) -> the attributes of each `<joint>` in the bodies, its default classes' under its own
    (its `class`, else the nearest `childclass` around it, else the top class), as MuJoCo reads them."""
    classes, out = _joint_defaults(root), {}

    def chain(name: str) -> dict[str, str]:
        attributes: dict[str, str] = {}
        seen: set[str] = set()
        while name in classes and name not in seen:
            seen.add(name)
            attributes = classes[name][0] | attributes
            name = classes[name][1] or ""
        return attributes

    def walk(node: ET.Element, active: str) -> None:
        for child in node:
            if child.tag == "joint":
                out[id(child)] = chain(child.get("class", active)) | dict(child.attrib)
            elif child.tag in ("body", "frame", "replicate"):
                walk(child, child.get("childclass", active))

    for world in root.findall("worldbody"):
        walk(world, "main")
    return out


def _parts(element: ET.Element, kind: str, name: str, stated: dict[str, str]) -> list[ET.Element]:
    """The slides and hinges that stand for one free or ball joint (`stated`: its attributes, its
    default classes' included; a `<freejoint>` takes none from a class)."""
    # What the joint states, and zero for the rest: a default class's joint attributes (armature, ref,
    # a range) must not reach the parts where MuJoCo did not give them to the free joint.
    stated = dict(element.attrib) if element.tag == "freejoint" else stated
    kept = {k: stated.get(k, "0") for k in ZEROED} | {k: v for k, v in stated.items() if k in KEPT}
    pos = {"pos": stated.get("pos", "0 0 0")} if kind == "ball" else {}
    out = []
    for suffix, axis in (SLIDES if kind == "free" else ()) + HINGES:
        kind_of = "slide" if suffix.startswith("t") else "hinge"
        attrib = {"name": f"{name}_{suffix}", "type": kind_of, "axis": axis, "limited": "false", **pos, **kept}
        out.append(ET.Element("joint", attrib))
    return out


def _name_unnamed(root: ET.Element) -> list[str]:
    """Names every unnamed body and joint by MuJoCo's own id ("body#3", "joint#5": bodies in the order
    MuJoCo numbers them, from 1, and each body's joints in turn), so that every reader can be mapped by
    name; one line if any was named."""
    named: list[str] = []
    joints = 0
    for b, body in enumerate(root.iter("body"), start=1):
        if not body.get("name"):
            body.set("name", f"body#{b}")
            named.append(f"body#{b}")
        for element in body:
            if element.tag in ("joint", "freejoint"):
                if not element.get("name"):
                    element.set("name", f"joint#{joints}")
                    named.append(f"joint#{joints}")
                joints += 1
    return [f"unnamed bodies and joints called by MuJoCo's ids: {', '.join(named)}"] if named else []


class Converted(NamedTuple):
    """What `convert` made: the text every reader parses, one line per change, and the middle hinge
    (`_ry`) of each converted joint, whose chart is singular at +-pi/2 (the first and last hinges align,
    M loses rank): random states keep it within +-CHART_LIMIT."""

    text: str
    lines: list[str]
    middle: frozenset[str] = frozenset()


def convert(text: str) -> Converted:
    """The MJCF with its free and ball joints as slides and hinges (module docstring) and its unnamed
    bodies and joints named by MuJoCo's ids, and one line per change; the text unchanged where it needs none."""
    if "free" not in text and "ball" not in text and not _unnamed(text):
        return Converted(text, [])
    root = ET.fromstring(text)
    lines: list[str] = _name_unnamed(root)
    count = {"free": 0, "ball": 0}
    middle: set[str] = set()
    stated = _stated(root)
    for body in root.iter("body"):
        for i, element in reversed(list(enumerate(body))):
            kind = _kind(element, stated.get(id(element), {}))
            if kind is None:
                continue
            count[kind] += 1
            name = element.get("name") or f"{kind}#{count[kind]}"
            parts = _parts(element, kind, name, stated.get(id(element), {}))
            middle.add(f"{name}_ry")
            body.remove(element)
            for k, part in enumerate(parts):
                body.insert(i + k, part)
            lines.append(
                f"{kind} joint '{name}' compared in the coordinates "
                f"{', '.join(p.get('name', '') for p in parts)} (slides along and hinges about the body's axes, "
                "intrinsic Z-Y-X angles; the same body and freedom, one coordinate per degree of freedom)"
            )
    if not lines:
        return Converted(text, [])
    if sum(count.values()):
        _convert_keys(root, text)
    return Converted(ET.tostring(root, encoding="unicode"), lines, frozenset(middle))


def _convert_keys(root: ET.Element, text: str) -> None:
    """Each `<key>`'s qpos and qvel (those it states) in the converted coordinates (module docstring)."""
    keys = [key for frame in root.findall("keyframe") for key in frame.findall("key")]
    if not any(key.get("qpos") or key.get("qvel") for key in keys):
        return
    converted = _key_values(text)
    if converted is None or len(converted) != len(keys):
        return  # MuJoCo does not compile the model: its own error says why, at the compile that follows
    for key, (qpos, qvel) in zip(keys, converted, strict=True):
        for attribute, values in (("qpos", qpos), ("qvel", qvel)):
            if key.get(attribute):
                key.set(attribute, " ".join(repr(float(x)) for x in values))


@functools.lru_cache(maxsize=8)
def _key_values(text: str) -> tuple[tuple[tuple[float, ...], tuple[float, ...]], ...] | None:
    """(qpos, qvel) of each key of the (self-contained) MJCF `text` in the converted coordinates; None
    where MuJoCo does not compile it."""
    import mujoco
    import numpy as np

    try:
        m = mujoco.MjModel.from_xml_string(text)
    except Exception:  # mujoco raises ValueError with the model's error
        return None
    out = []
    for k in range(m.nkey):
        qpos, qvel = [], []
        for j in range(m.njnt):
            a, d, kind = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j]), int(m.jnt_type[j])
            if kind == int(mujoco.mjtJoint.mjJNT_FREE):
                b = int(m.jnt_bodyid[j])
                base = _rotation(m.body_quat[b])
                turn = base.T @ _rotation(m.key_qpos[k, a + 3 : a + 7])
                qpos += [*(base.T @ (m.key_qpos[k, a : a + 3] - m.body_pos[b])), *_angles(turn)]
                qvel += [*(base.T @ m.key_qvel[k, d : d + 3]), *_rates(turn, m.key_qvel[k, d + 3 : d + 6])]
            elif kind == int(mujoco.mjtJoint.mjJNT_BALL):
                turn = _rotation(m.key_qpos[k, a : a + 4])
                qpos += _angles(turn)
                qvel += _rates(turn, m.key_qvel[k, d : d + 3])
            else:
                qpos.append(float(m.key_qpos[k, a]))
                qvel.append(float(m.key_qvel[k, d]))
        out.append((tuple(map(float, qpos)), tuple(map(float, np.asarray(qvel, dtype=float)))))
    return tuple(out)


def _rotation(quat: np.ndarray) -> np.ndarray:
    """The rotation matrix of a MuJoCo quaternion (w, x, y, z), normalized as MuJoCo normalizes it."""
    import numpy as np

    w, x, y, z = np.asarray(quat, dtype=float) / np.linalg.norm(quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _angles(turn: np.ndarray) -> list[float]:
    """(rz, ry, rx) with turn = Rz(rz) Ry(ry) Rx(rx): the hinges' angles, intrinsic Z-Y-X."""
    ry = math.asin(max(-1.0, min(1.0, -float(turn[2, 0]))))
    return [math.atan2(float(turn[1, 0]), float(turn[0, 0])), ry, math.atan2(float(turn[2, 1]), float(turn[2, 2]))]


def _rates(turn: np.ndarray, omega: np.ndarray) -> list[float]:
    """The hinges' rates whose angular velocity, in the turned (child) frame, is `omega`."""
    import numpy as np

    _, ry, rx = _angles(turn)
    cx, sx, cy, sy = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry)
    # columns: the z, y and x hinges' axes in the child frame (Rx^T Ry^T e_z, Rx^T e_y, e_x)
    axes = np.array([[-sy, 0.0, 1.0], [sx * cy, cx, 0.0], [cx * cy, -sx, 0.0]])
    return [float(x) for x in np.linalg.solve(axes, np.asarray(omega, dtype=float))]

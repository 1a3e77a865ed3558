"""What a model file has that a catalogue entry (validate/audit/importers.py) is about, read from its
text alone with xml.etree: compiler options, what default classes pass on, geoms weighed otherwise,
joints with springs, friction, armature or ref, several joints in one body, rotated fixed joints, rpy on
an inertial, invalid inertias, mimics, transmissions. A feature on one element is scoped to its name
("inertial rpy:tool"), so that an entry explains the difference on that element first.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path


def _compiler(root: ET.Element) -> dict[str, str]:
    out: dict[str, str] = {}
    for c in root.iter("compiler"):  # MuJoCo merges every <compiler>, the last one winning
        out.update(c.attrib)
    return out


def _body_features(body: ET.Element, balancing: bool) -> set[str]:
    """The features of one MJCF body, scoped to its name (or its joints' names)."""
    name, out = body.get("name", ""), set()
    inertial = body.find("inertial")
    if balancing and inertial is not None and _unbalanced(inertial.get("diaginertia")):
        out.add(f"balanced inertia:{name}")
    if len(body.findall("joint")) > 1:
        out |= {f"several joints in one body:{j.get('name', '')}" for j in body.findall("joint")}
    if body.get("gravcomp") not in (None, "0"):
        out.add(f"gravcomp:{name}")
    if any(g.get("type") == "mesh" or g.get("mesh") for g in body.findall("geom")):
        out.add(f"mesh geom:{name}")
    if any(g.get("contype") == "0" and g.get("conaffinity") == "0" for g in body.findall("geom")):
        out.add(f"collision-free geom:{name}")
    return out


JOINT_FEATURES = (
    ("stiffness", "joint spring"),
    ("springref", "joint spring"),
    ("frictionloss", "joint friction"),
    ("armature", "joint armature"),
    ("ref", "joint ref"),
    ("springdamper", "springdamper"),
)


def _default_features(root: ET.Element) -> set[str]:
    """What default classes pass on: geom masses, collision-free geoms, nesting two deep."""
    geoms = [g for d in root.iter("default") for g in d.findall("geom")]
    out = {"default geom mass"} if any(g.get("mass") is not None for g in geoms) else set()
    if any(g.get("contype") == "0" and g.get("conaffinity") == "0" for g in geoms):
        out.add("collision-free geom")
    if any(d.find("default/default") is not None for d in root.iter("default") if d.get("class")):
        out.add("nested default class")
    return out


def _mjcf_features(root: ET.Element) -> set[str]:
    out = {f"compiler {k}" for k in _compiler(root)}
    if any(o.get("gravity") for o in root.iter("option")):
        out.add("option gravity")
    if {"compiler boundmass", "compiler boundinertia"} & out:
        out.add("compiler bounds")
    for body in root.iter("body"):
        out |= _body_features(body, "compiler balanceinertia" in out)
    joints = [j for j in root.iter("joint")] + [j for d in root.iter("default") for j in d.findall("joint")]
    out |= {feature for attr, feature in JOINT_FEATURES if any(j.get(attr) not in (None, "0") for j in joints)}
    out |= _default_features(root)
    if any(True for _ in root.iter("frame")):
        out.add("frame element")
    if any(g.get("shellinertia") == "true" for g in root.iter("geom")) or any(
        m.get("inertia") == "shell" for m in root.iter("mesh")
    ):
        out.add("shell inertia")
    if any(_unnormalized(el.get("axisangle")) for el in root.iter()):
        out.add("unnormalized axisangle")
    world = root.find("worldbody")
    if world is not None and len(world.findall("body")) > 1:
        out.add("several root bodies")
    for body in world.findall("body") if world is not None else []:
        posed = any(body.get(a) for a in ("pos", "quat", "euler", "axisangle", "xyaxes", "zaxis"))
        free = body.find("freejoint") is not None or any(j.get("type") == "free" for j in body.findall("joint"))
        if body.find("joint") is None and not free and posed:
            out.add("fixed root pose")
        if free and posed:
            out.add("free root pose")
    return out


def _rpy(el: ET.Element | None) -> bool:
    o = el.find("origin") if el is not None else None
    return o is not None and any(float(x) != 0.0 for x in (o.get("rpy") or "0").split())


def _urdf_features(root: ET.Element) -> set[str]:
    out = {f"compiler {k}" for k in _compiler(root)}
    for j in root.findall("joint"):
        found = j.find("child")
        child = found.get("link", "") if found is not None else ""
        if j.get("type") == "fixed" and _rpy(j):
            out |= {f"fixed joint rpy:{child}", f"welded rotated body:{child}"}
        if j.find("mimic") is not None:
            out.add("mimic")
        if j.get("type") in ("revolute", "prismatic") and j.find("limit") is None:
            out.add("joint without limit")
        limit = j.find("limit")
        if j.get("type") == "continuous" and limit is not None and (limit.get("lower") or limit.get("upper")):
            out.add("continuous with limit")
        dyn = j.find("dynamics")
        if dyn is not None and dyn.get("friction") not in (None, "0", "0.0"):
            out.add("joint friction")
    if root.find("transmission") is not None:
        out.add("transmission")
    for link in root.findall("link"):
        inertial = link.find("inertial")
        if inertial is not None and _rpy(inertial):
            out.add(f"inertial rpy:{link.get('name', '')}")
        if inertial is None and link.find("collision/geometry") is not None:
            out.add(f"geometry without inertial:{link.get('name', '')}")
        if inertial is not None and _invalid(inertial):
            out |= {"invalid inertia", f"invalid inertia:{link.get('name', '')}"}
            if "compiler balanceinertia" in out:
                out.add(f"balanced inertia:{link.get('name', '')}")
    return out


def _unnormalized(axisangle: str | None) -> bool:
    """An axisangle whose axis is not a unit vector to 1e-12."""
    try:
        x, y, z = (float(v) for v in (axisangle or "").split()[:3])
    except ValueError:
        return False
    return abs((x * x + y * y + z * z) ** 0.5 - 1.0) > 1e-12


def _unbalanced(diagonal: str | None) -> bool:
    """An MJCF diaginertia that violates A + B >= C."""
    try:
        a, b, c = sorted(float(x) for x in (diagonal or "1 1 1").split())
    except ValueError:
        return False
    return a + b < c


def _invalid(inertial: ET.Element) -> bool:
    """Zero mass with an inertia, a negative moment, or a violated triangle inequality (diagonal)."""
    import numpy as np

    try:
        found = inertial.find("mass")
        mass = float(found.get("value", "0")) if found is not None else 0.0
        i = inertial.find("inertia")
        k = {a: float(i.get(a, "0")) if i is not None else 0.0 for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    except ValueError:
        return True
    tensor = np.array([[k["ixx"], k["ixy"], k["ixz"]], [k["ixy"], k["iyy"], k["iyz"]], [k["ixz"], k["iyz"], k["izz"]]])
    moments = np.linalg.eigvalsh(tensor)
    if mass <= 0.0:
        return bool(np.any(moments != 0.0))
    return bool(moments[0] < 0.0 or moments[0] + moments[1] < moments[2] * (1 - 1e-9))


INCLUDE = re.compile(r"<include\s+file\s*=\s*[\"']([^\"']+)[\"']\s*/>")
MAX_INCLUDES = 64  # files spliced at most (an include that includes itself stops here)


def spliced(text: str, folder: Path | None) -> str:
    """The MJCF with each <include file> replaced by the included file's content, as MuJoCo splices it
    (files that cannot be read are left as they are)."""
    for _ in range(MAX_INCLUDES):
        match = INCLUDE.search(text)
        if match is None or folder is None:
            return text
        try:
            inner = (folder / match.group(1)).read_text()
        except OSError:
            return text
        inner = re.sub(r"<\?xml[^>]*\?>|</?mujocoinclude[^>]*>|</?mujoco\b[^>]*>", "", inner)
        text = text[: match.start()] + inner + text[match.end() :]
    return text


def features(text: str, fmt: str, folder: Path | None = None) -> set[str]:
    """The features of a model file that catalogue entries are about (empty where it does not parse);
    `folder`: where an MJCF's includes are read from (their elements count as the file's)."""
    if fmt == "mjcf" and INCLUDE.search(text):
        found = {"include"}
        text = spliced(text, folder)
    else:
        found = set()
    try:
        root = ET.fromstring(re.sub(r"<\?xml[^>]*\?>", "", text, count=1))
    except ET.ParseError:
        return found
    return found | (_urdf_features(root) if fmt == "urdf" else _mjcf_features(root))

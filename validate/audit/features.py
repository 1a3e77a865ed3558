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


def _mjcf_limits(root: ET.Element) -> set[str]:
    """What decides a joint's limits and couplings, scoped to the joint: a slide joint's range where the
    compiler's angles are degrees (MuJoCo's default; a length is not converted), a range that
    limited="false" switches off, a joint equality coupling two joints (MJCF's mimic)."""
    degrees = _compiler(root).get("angle", "degree") != "radian"
    ranged = any(j.get("range") for d in root.iter("default") for j in d.findall("joint"))
    off = any(j.get("limited") == "false" for d in root.iter("default") for j in d.findall("joint"))
    out: set[str] = set()
    for body in root.iter("body"):
        for j in body.findall("joint"):
            name, has_range = j.get("name", ""), bool(j.get("range")) or ranged
            if degrees and j.get("type") == "slide" and has_range:
                out |= {"slide range in degrees", f"slide range in degrees:{name}"}
            if has_range and (j.get("limited") == "false" or (off and j.get("limited") is None)):
                out |= {"limited false", f"limited false:{name}"}
    for eq in root.iter("equality"):
        for j in eq.findall("joint"):
            if j.get("joint1") and j.get("joint2") and j.get("active") != "false":
                out |= {"joint equality", f"joint equality:{j.get('joint1')}"}
    return out


def _late_compiler(root: ET.Element) -> set[str]:
    """A <compiler> that sets the angle unit or eulerseq after a <worldbody> (document order), scoped to
    the bodies and joints above it: a parser that applies each element as it meets it reads them otherwise."""
    children = list(root)
    late = [i for i, c in enumerate(children) if c.tag == "compiler" and {"angle", "eulerseq"} & set(c.attrib)]
    worlds = [c for i, c in enumerate(children) if c.tag == "worldbody" and late and i < late[-1]]
    if not worlds:
        return set()
    names = {el.get("name", "") for w in worlds for el in w.iter() if el.tag in ("body", "joint")}
    return {"late compiler"} | {f"late compiler:{n}" for n in names if n}


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
    out |= _default_features(root) | _mjcf_limits(root)
    if any(g.get("shellinertia") == "true" for g in root.iter("geom")) or any(
        m.get("inertia") == "shell" for m in root.iter("mesh")
    ):
        out.add("shell inertia")
    if any(_unnormalized(el.get("axisangle")) for el in root.iter()):
        out.add("unnormalized axisangle")
    world = root.find("worldbody")
    out |= _late_compiler(root)
    if world is not None and len(world.findall("body")) > 1:
        out.add("several root bodies")
    for body in world.findall("body") if world is not None else []:
        posed = any(body.get(a) for a in (*POSE, FRAMED))
        free = body.find("freejoint") is not None or any(j.get("type") == "free" for j in body.findall("joint"))
        if body.find("joint") is None and not free and posed:
            out.add("fixed root pose")
        if free and posed:
            out.add("free root pose")
    return out


def _urdf_limits(j: ET.Element) -> set[str]:
    """A URDF joint's <limit> as urdfdom rules it: required on a revolute or prismatic joint, with effort and
    velocity wherever it is given ("joint without limit": urdfdom refuses the file); lower and upper default
    to 0 ("limit without bounds", also where they are equal: a range a reader may read as no limit)."""
    limit, kind, name = j.find("limit"), j.get("type"), j.get("name", "")
    if limit is None:
        return {"joint without limit", f"joint without limit:{name}"} if kind in ("revolute", "prismatic") else set()
    out = set()
    if limit.get("effort") is None or limit.get("velocity") is None:
        out |= {"joint without limit", f"joint without limit:{name}"}
    bounds = (limit.get("lower"), limit.get("upper"))
    if kind in ("revolute", "prismatic") and (None in bounds or _same_numbers(*bounds)):
        out |= {"limit without bounds", f"limit without bounds:{name}"}
    return out


def _same_numbers(a: str | None, b: str | None) -> bool:
    try:
        return float(a or "0") == float(b or "0")
    except ValueError:
        return False


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
            out |= {"mimic", f"mimic:{j.get('name', '')}"}
        out |= _urdf_limits(j)
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


# <include file="..."/> in any spelling MuJoCo accepts: other attributes, either quote, an empty element with
# its closing tag
INCLUDE = re.compile(r"<include\b[^>]*?\bfile\s*=\s*[\"']([^\"']+)[\"'][^>]*?(?:/>|>\s*</include\s*>)")
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
        inner = re.sub(r"<\?xml[^>]*\?>|<!--.*?-->|</?mujocoinclude[^>]*>|</?mujoco\b[^>]*>", "", inner, flags=re.S)
        text = text[: match.start()] + f"<{INCLUDED}>{inner}</{INCLUDED}>" + text[match.end() :]
    return text


INCLUDED = "lagrange_xval_included"  # marks what an <include> brought in, unwrapped after the features are read


def _included(root: ET.Element) -> set[str]:
    """The bodies and joints an <include> brought in ("include:<name>"), and "included root" where the file's
    own <worldbody> has no body of its own (a scene that includes its robot); the markers are then unwrapped
    so that the rest reads the text MuJoCo compiles."""
    out: set[str] = set()
    for marker in root.iter(INCLUDED):
        out |= {f"include:{name}" for name in _names(marker)}
    brought = {id(b) for m in root.iter(INCLUDED) for b in m.iter("body")}
    own = any(id(b) not in brought for w in root.findall("worldbody") for b in w.iter("body"))
    if brought and not own:
        out.add("included root")
    _unwrap(root, INCLUDED)
    worlds = root.findall("worldbody")  # MuJoCo merges every <worldbody> (the file's and its includes')
    for extra in worlds[1:]:
        worlds[0].extend(list(extra))
        root.remove(extra)
    return out


def _names(el: ET.Element) -> set[str]:
    """The names of the bodies and joints at or under `el` (what a feature on it is scoped to)."""
    return {str(e.get("name")) for e in el.iter() if e.tag in ("body", "joint") and e.get("name")}


POSE = ("pos", "quat", "euler", "axisangle", "xyaxes", "zaxis")
FRAMED = "lagrange_xval_framed"  # set on a body a posed <frame> moved (its pose is the frame's composed with its own)


def _frames(root: ET.Element) -> set[str]:
    """The MJCF's <frame> elements: "frame element", scoped to the body that holds one and to every body and
    joint inside it (what a reader that drops frames loses), and "frame root" where the <worldbody> has bodies
    inside frames only; then each frame is replaced by its children, a posed frame marking the bodies it
    moves, so that the rest reads the tree MuJoCo compiles (a frame composes its pose into its children)."""
    out: set[str] = set()
    parents = {child: parent for parent in root.iter() for child in parent}
    for frame in root.iter("frame"):
        out.add("frame element")
        holder = parents.get(frame)
        while holder is not None and holder.tag == "frame":
            holder = parents.get(holder)
        if holder is not None and holder.tag == "body":
            out.add(f"frame element:{holder.get('name', '')}")
        out |= {f"frame element:{name}" for name in _names(frame)}
        if any(frame.get(a) for a in POSE):
            for body in frame.findall("body"):
                body.set(FRAMED, "true")
    world = root.find("worldbody")
    if world is not None and world.find("body") is None and world.find(".//frame//body") is not None:
        out.add("frame root")
    _unwrap(root, "frame")
    return out


def _unwrap(root: ET.Element, tag: str) -> None:
    """Each `tag` element replaced by its children, in place (what MuJoCo splices or composes)."""
    for parent in list(root.iter()):
        while (i := next((k for k, el in enumerate(parent) if el.tag == tag), None)) is not None:
            marker = parent[i]
            parent.remove(marker)
            for k, child in enumerate(list(marker)):
                parent.insert(i + k, child)


def features(text: str, fmt: str, folder: Path | None = None) -> set[str]:
    """The features of a model file that catalogue entries are about (empty where it does not parse);
    `folder`: where an MJCF's includes are read from (their elements count as the file's)."""
    if fmt == "mjcf" and INCLUDE.search(text):
        found = {"include"}
        text = spliced(text, folder)
    else:
        found = set()
    try:
        root = ET.fromstring(re.sub(r"<\?xml[^>]*\?>", "", text.lstrip(), count=1))
    except ET.ParseError:
        return found
    if fmt == "urdf":
        return found | _urdf_features(root)
    found |= _included(root) | _frames(root)
    return found | _mjcf_features(root)

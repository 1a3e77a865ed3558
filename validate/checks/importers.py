"""The catalogue of known importer behaviours (issue 33): what MuJoCo, Pinocchio and Drake each do with
a model file that its format means otherwise, each entry with where it was reported and the reader
that shows it on the versions in requirements.lock (MuJoCo 4.0.0, Pinocchio 4.1.0, Drake 1.51.1;
each checked by a planted case in tests/test_audit.py, not assumed).

The audit (validate/checks/audit.py) names the entry that explains each difference between a reader
and the format's meaning: an entry applies when its reader, format and field match the difference and
the file has the feature the entry is about (`features`, read from the file's text alone). A
difference no entry explains is said to be unexplained.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

INERTIAL = ("mass", "com", "inertia")


@dataclass(frozen=True)
class Behaviour:
    """One known importer behaviour.

    Attributes:
        key: a short name, shown with the finding.
        readers: the readers that show it on the installed versions.
        formats: "mjcf", "urdf" or both.
        fields: the audited fields it changes ("joint": the joint is missing).
        feature: the file feature it needs (`features`).
        cause: what the reader does, one clause.
        refusals: for an entry that explains a refusal ("read"), the words of the reader's message it
            explains (an entry explains no other refusal).
        fixed: no reader shows it on the installed versions (reported on earlier ones; the tests plant it in
            one reader's input): it still explains what an older reader, or a converter, did.
        rotation: its inertia differs by a rotation only (the same principal moments): it explains no
            other inertia difference.
        reported: where it was reported: an issue or pull request of the tracker that shows it, or the
            closest report found (another importer with the same fault, the parser's list of what it
            supports) where none of the reader's own trackers has one.
    """

    key: str
    readers: tuple[str, ...]
    formats: tuple[str, ...]
    fields: tuple[str, ...]
    feature: str
    cause: str
    reported: str
    rotation: bool = False
    fixed: bool = False
    refusals: tuple[str, ...] = ()


CATALOGUE: tuple[Behaviour, ...] = (
    Behaviour(
        "<option gravity>",
        ("pinocchio",),
        ("mjcf",),
        ("gravity",),
        "option gravity",
        "ignores <option gravity> and keeps its own (0, 0, -9.81) m/s^2",
        "https://github.com/RobotControlStack/robot-control-stack/issues/201",
    ),
    Behaviour(
        "geom mass from a default class",
        ("pinocchio",),
        ("mjcf",),
        INERTIAL,
        "default geom mass",
        "ignores the mass a default class gives the geoms and weighs them by density (1000 kg/m^3)",
        "https://github.com/newton-physics/newton/pull/1744",
    ),
    Behaviour(
        "collision-free geoms",
        ("pinocchio",),
        ("mjcf",),
        INERTIAL,
        "collision-free geom",
        'leaves out the mass of geoms that collide with nothing (contype="0" conaffinity="0": visual geoms, '
        "which MuJoCo weighs like any other)",
        "https://github.com/newton-physics/mujoco-usd-converter/issues/67",
    ),
    Behaviour(
        "inertiafromgeom",
        ("pinocchio", "drake"),
        ("mjcf",),
        (*INERTIAL, "read"),
        "compiler inertiafromgeom",
        'does not apply the compiler\'s inertiafromgeom (Pinocchio and Drake refuse inertiafromgeom="false" where a '
        "body has no <inertial>; MuJoCo gives that body no mass)",
        "https://github.com/RobotLocomotion/drake/issues/20232",
        refusals=("inertia from geom", "inertiafromgeom=false"),
    ),
    Behaviour(
        "inertiagrouprange",
        ("pinocchio", "drake"),
        ("mjcf",),
        INERTIAL,
        "compiler inertiagrouprange",
        "ignores the compiler's inertiagrouprange and weighs geoms of every group",
        "https://github.com/newton-physics/newton/issues/3593",
    ),
    Behaviour(
        "settotalmass",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("mass", "inertia"),
        "compiler settotalmass",
        "ignores the compiler's settotalmass (MuJoCo scales every body's mass and inertia to that total)",
        "https://github.com/newton-physics/newton/issues/3689",
    ),
    Behaviour(
        "boundmass/boundinertia",
        ("drake",),
        ("mjcf",),
        INERTIAL,
        "compiler bounds",
        "ignores the compiler's boundmass/boundinertia (the lower bounds MuJoCo applies)",
        "https://github.com/newton-physics/newton/issues/3741",
    ),
    Behaviour(
        "balanceinertia",
        ("mujoco", "pinocchio", "drake"),
        ("mjcf", "urdf"),
        ("inertia", "read"),
        "balanced inertia",
        "balanceinertia: MuJoCo replaces an inertia that violates A + B >= C (its compiler option, in a URDF's "
        "<mujoco> element too); Pinocchio keeps it, Drake refuses or replaces it",
        "https://github.com/google-deepmind/mujoco/issues/375",
        refusals=("A + B >= C", "IsPhysicallyValid", "rotational inertia"),
    ),
    Behaviour(
        "eulerseq",
        ("pinocchio",),
        ("mjcf",),
        (*INERTIAL, "anchor", "axis"),
        "compiler eulerseq",
        "reads euler angles in another sequence than the compiler's eulerseq",
        "https://github.com/stack-of-tasks/pinocchio/pull/2526",
    ),
    Behaviour(
        "fusestatic",
        ("mujoco",),
        ("urdf",),
        ("inertia",),
        "welded rotated body",
        "sums the inertia of a link fused across a rotated fixed joint in the wrong frame (fusestatic)",
        "https://github.com/google-deepmind/mujoco/issues/2982",
        rotation=True,
        fixed=True,
    ),
    Behaviour(
        "an axisangle's axis",
        ("pinocchio",),
        ("mjcf",),
        ("com", "inertia", "anchor", "axis"),
        "unnormalized axisangle",
        "does not normalize an axisangle's axis (MuJoCo does), so the rotation it builds is not the file's",
        "https://github.com/stack-of-tasks/pinocchio/pull/2526",
    ),
    Behaviour(
        "a fixed joint's rpy",
        ("mujoco",),
        ("urdf",),
        ("com", "inertia", "anchor", "axis"),
        "fixed joint rpy",
        "drops the rotation (rpy) of a fixed joint when it fuses the child link",
        "https://github.com/google-deepmind/mujoco/issues/1176",
        fixed=True,
    ),
    Behaviour(
        "an inertial's rpy",
        ("mujoco",),
        ("urdf",),
        ("inertia",),
        "inertial rpy",
        "drops the rotation of an <inertial>'s <origin rpy>",
        "https://github.com/google-deepmind/mujoco/issues/3559",
        rotation=True,
        fixed=True,
    ),
    Behaviour(
        "mesh inertia and the 1 kg default",
        ("pinocchio", "drake"),
        ("mjcf",),
        (*INERTIAL, "read"),
        "mesh geom",
        "does not compute a mesh geom's inertia (Pinocchio gives it 1 kg and a unit inertia; Drake drops an "
        "inline mesh and refuses a mesh file other than .obj)",
        "https://github.com/newton-physics/newton/issues/3753",
        refusals=("mesh",),
    ),
    Behaviour(
        "shell inertia",
        ("pinocchio", "drake"),
        ("mjcf",),
        (*INERTIAL, "read"),
        "shell inertia",
        'does not weigh a geom as a shell (shellinertia, mesh inertia="shell"): Pinocchio refuses it, Drake '
        "weighs it solid",
        "https://github.com/newton-physics/newton/issues/3753",
        refusals=("shell",),
    ),
    Behaviour(
        "a joint without <limit>",
        ("pinocchio",),
        ("urdf",),
        ("read",),
        "joint without limit",
        "refuses a revolute or prismatic joint without <limit> (urdfdom's rule; MuJoCo and Drake read it)",
        "https://github.com/ros/urdfdom/issues/138",
        refusals=("valid URDF",),
    ),
    Behaviour(
        "a continuous joint's <limit>",
        ("drake",),
        ("urdf",),
        ("limits",),
        "continuous with limit",
        "reads the <limit> of a continuous joint as position limits (urdfdom ignores them: a continuous joint has "
        "none)",
        "https://github.com/RobotLocomotion/drake/pull/16953",
    ),
    Behaviour(
        "an invalid inertia replaced",
        ("drake", "mujoco", "pinocchio"),
        ("urdf", "mjcf"),
        (*INERTIAL, "read"),
        "invalid inertia",
        "replaces or refuses an inertia that is not physically valid (zero mass with inertia, the triangle "
        "inequality violated, not positive definite)",
        "https://github.com/RobotLocomotion/drake/issues/16992",
        refusals=("A + B >= C", "positive", "IsPhysicallyValid", "mass and inertia of moving", "rotational inertia"),
    ),
    Behaviour(
        "several joints in one body",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("joint", "anchor", "axis"),
        "several joints in one body",
        "reads a body's several joints otherwise: Pinocchio makes one composite joint of them (their names are not "
        "joints of its model); Drake places the first in the parent's frame, without the body's pos",
        "https://github.com/RobotLocomotion/drake/issues/20367",
    ),
    Behaviour(
        "<include>",
        ("pinocchio",),
        ("mjcf",),
        ("joint", "read", *INERTIAL, "damping", "armature", "stiffness", "frictionloss"),
        "include",
        "does not read <include>: the bodies, joints and default classes of an included file are not in its model",
        "https://github.com/RobotControlStack/robot-control-stack/issues/201",
        refusals=("unordered_map::at",),
    ),
    Behaviour(
        "several root bodies",
        ("pinocchio",),
        ("mjcf",),
        ("joint",),
        "several root bodies",
        "reads only the first body of <worldbody>: the joints of the others are not in its model",
        "https://github.com/stack-of-tasks/pinocchio/issues/2364",
    ),
    Behaviour(
        "a fixed root's pose",
        ("pinocchio",),
        ("mjcf",),
        ("com", "inertia", "anchor", "axis"),
        "fixed root pose",
        "drops the pose of a root body welded to the world (no joint), so the chain below it moves",
        "https://github.com/stack-of-tasks/pinocchio/issues/2782",
    ),
    Behaviour(
        "a free root's coordinates",
        ("pinocchio",),
        ("mjcf",),
        ("com", "inertia", "anchor", "axis"),
        "free root pose",
        "reads a free joint's coordinates relative to the root body's pose in the file (MuJoCo's are in the "
        "world), so at MuJoCo's qpos0 the root's pos and orientation are applied twice",
        "https://github.com/stack-of-tasks/pinocchio/issues/2066",
    ),
    Behaviour(
        "stiffness and springref",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("stiffness", "springref"),
        "joint spring",
        "has no joint spring: stiffness and springref are dropped (Drake warns)",
        "https://github.com/RobotLocomotion/drake/pull/22493",
    ),
    Behaviour(
        "springdamper",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("damping", "stiffness"),
        "springdamper",
        "ignores a joint's springdamper (the time constant and damping ratio MuJoCo turns into stiffness and "
        "damping from the joint's inertia)",
        "https://github.com/RobotLocomotion/drake/pull/22493",
    ),
    Behaviour(
        "frictionloss",
        ("drake",),
        ("mjcf", "urdf"),
        ("frictionloss",),
        "joint friction",
        "drops dry joint friction (MJCF frictionloss, URDF <dynamics friction>; Drake warns)",
        "https://github.com/RobotLocomotion/drake/pull/16953",
    ),
    Behaviour(
        "armature without a motor",
        ("drake",),
        ("mjcf",),
        ("armature",),
        "joint armature",
        "reads armature only as a motor's reflected inertia, so a joint without a motor loses it",
        "https://github.com/RobotLocomotion/drake/pull/22493",
    ),
    Behaviour(
        "gravcomp",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("gravcomp",),
        "gravcomp",
        "drops a body's gravity compensation (gravcomp)",
        "https://github.com/RobotControlStack/robot-control-stack/issues/201",
    ),
    Behaviour(
        "mimic",
        ("pinocchio", "drake", "mujoco"),
        ("urdf",),
        ("mimic", "read"),
        "mimic",
        "ignores the <mimic> coupling (Pinocchio's default reading, Drake's continuous plant)",
        "https://github.com/RobotLocomotion/drake/issues/21472",
        refusals=("mimic",),
    ),
    Behaviour(
        "<frame>",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("joint", *INERTIAL),
        "frame element",
        "drops the bodies inside an MJCF <frame> (mj_saveLastXML writes one for a URDF's rotated fixed joint; "
        "Drake warns 'frame ... unsupported')",
        "https://github.com/RobotLocomotion/drake/issues/16369",
    ),
    Behaviour(
        "nested default classes",
        ("drake",),
        ("mjcf",),
        ("damping", "armature", "stiffness", "frictionloss", "axis", *INERTIAL),
        "nested default class",
        "drops what a default class passes on to a class nested two deep under it",
        "https://github.com/RobotLocomotion/drake/pull/22625",
    ),
    Behaviour(
        "geometry weighed for a link without <inertial>",
        ("mujoco",),
        ("urdf",),
        INERTIAL,
        "geometry without inertial",
        "weighs the collision geometry of a link without <inertial> (1000 kg/m^3), where URDF means no mass",
        "https://github.com/ros/urdfdom/issues/138",
    ),
    Behaviour(
        "transmissions",
        ("mujoco",),
        ("urdf",),
        ("target", "gear"),
        "transmission",
        "ignores a URDF's <transmission> elements: it makes no actuator (the harness adds them as motors in its "
        "own model)",
        "https://github.com/google-deepmind/mujoco_menagerie/issues/24",
    ),
    Behaviour(
        "joint ref",
        ("drake", "pinocchio"),
        ("mjcf",),
        ("ref",),
        "joint ref",
        "ignores a joint's ref: its q = 0 is the file's pose, so its coordinate is MuJoCo's minus ref (Drake before "
        "1.37)",
        "https://github.com/RobotLocomotion/drake/pull/22446",
        fixed=True,
    ),
)


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


def _scoped(feature: str, found: set[str], names: tuple[str, ...] | None) -> int:
    """2: the feature is on one of `names` (a body, link or joint); 1: on the file; 0: absent.
    `names` None: anywhere in the file."""
    if names is None:
        return 1 if any(f == feature or f.startswith(feature + ":") for f in found) else 0
    if any(f"{feature}:{n}" in found for n in names):
        return 2
    return 1 if feature in found else 0


def explain(
    reader: str,
    fmt: str,
    field: str,
    found: set[str],
    names: tuple[str, ...] | None = None,
    *,
    rotated: bool = True,
) -> list[Behaviour]:
    """The entries that explain `reader` differing from the format's meaning on `field` of the
    elements `names` (the group's links and joint) in a file with the features `found`: an entry on
    one of those elements first, then the more specific (fewer fields, then fewer readers). `rotated`: an
    inertia that differs by a rotation only (entries about a lost rotation explain nothing else)."""
    hits = [
        (score, b)
        for b in CATALOGUE
        if reader in b.readers
        and fmt in b.formats
        and field in b.fields
        and (rotated or not b.rotation or field != "inertia")
        and (score := _scoped(b.feature, found, names))
    ]
    return [b for _, b in sorted(hits, key=lambda h: (-h[0], len(h[1].fields), len(h[1].readers)))]

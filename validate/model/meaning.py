"""What a model file means, field by field, in one frame every reader can be put in (issue 33).

The audit (validate/audit/audit.py) judges each reader of a file against its format's meaning: for
an MJCF, MuJoCo's compiled model (the compiler's options applied); for a URDF, urdfdom's reading,
which `urdf_meaning` below writes out with `xml.etree` (no engine involved):

- a link without `<inertial>` has no mass; an `<inertial>`'s `<origin rpy>` rotates its inertia
  (R = Rz(yaw) Ry(pitch) Rx(roll), fixed axes X, Y, Z);
- a joint's `<origin>` places its frame in the parent link's frame; its `<axis>` (default 1 0 0) is in
  the joint frame, made a unit vector; a revolute or prismatic joint's `<limit lower upper>` default 0
  each (a `<limit effort velocity>` alone is the range [0, 0]), a continuous joint has no position limit
  whatever its `<limit>` says; `<dynamics damping friction>` default 0, friction being dry friction
  (MuJoCo's frictionloss); `<mimic joint multiplier offset>` default 1 and 0, a coupling
  q = multiplier q_leader + offset (MuJoCo's joint equality), counted among the model's couplings;
- the root link sits at the world origin (a link named `world` is the world);
- a `<transmission>` drives its joint with its `<mechanicalReduction>` as gear.

The common frame (`Reading`): every joint at the model's reference configuration (a URDF's q = 0,
MuJoCo's qpos0, so that a joint `ref` moves nothing), every quantity in world coordinates. Each joint
carries the rigid group it moves (its child body and every body welded to it, up to the next joint):
mass, centre of mass and inertia about it, so that a joint off its body origin (Pinocchio expresses the
inertia in the joint frame), a welded tool kept as its own body (`fusestatic="false"`) and a fused one
read alike.
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import TypeAlias

import numpy as np

from ..core.errors import HarnessError
from .modelview import parallel_axis

MOVING = {"revolute": "hinge", "continuous": "hinge", "prismatic": "slide"}


@dataclass(frozen=True)
class Inertial:
    """A rigid group's mass (kg), centre of mass (3,) m and inertia about it (3, 3) kg m^2, world axes."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


ZERO = Inertial(0.0, np.zeros(3), np.zeros((3, 3)))


@dataclass(frozen=True)
class JointRead:
    """One joint as a reader read it, at the reference configuration, world coordinates.

    Attributes:
        kind: "hinge" or "slide".
        body: the body (link) it moves, as that reader names it.
        anchor: (3,) m; axis: (3,) unit.
        limits: (2,) rad or m (+-inf: none).
        mimic: (leader joint, multiplier, offset) or None.
        parent: the nearest moving joint above it ("" : the world).
    """

    kind: str
    body: str
    anchor: np.ndarray
    axis: np.ndarray
    ref: float = 0.0
    limits: np.ndarray = field(default_factory=lambda: np.array([-np.inf, np.inf]))
    damping: float = 0.0
    stiffness: float = 0.0
    springref: float = 0.0
    frictionloss: float = 0.0
    armature: float = 0.0
    gravcomp: float = 0.0
    mimic: tuple[str, float, float] | None = None
    parent: str = ""


@dataclass
class Reading:
    """One reader's model of a file: joints by name, the group each moves, actuators, its warnings.

    Attributes:
        reader: "meaning", "mujoco", "pinocchio" or "drake".
        joints: name -> JointRead; groups: joint name -> Inertial of what it moves.
        actuators: name -> (joint, gear), or None where the reader has no actuators.
        warnings: the reader's own warnings while reading; notes: what the harness did to read it.
        members: joint -> the bodies (links) of the group it moves; gravity: (3,) m/s^2.
        couplings: how many joint couplings (a URDF's <mimic>, an MJCF's <equality><joint>) it holds; None
            where the reader cannot say.
        unread: the joint fields its library does not expose ("mimic": pydrake binds no coupler constraint's
            joints), left out of the comparison rather than read as neutral.
    """

    reader: str
    joints: dict[str, JointRead]
    groups: dict[str, Inertial]
    actuators: dict[str, tuple[str, float]] | None = None
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    members: dict[str, tuple[str, ...]] = field(default_factory=dict)
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    couplings: int | None = None
    unread: tuple[str, ...] = ()


# One field of a reading (`fields`): a number, an array (a vector, an inertia, limits), a text (a joint's
# kind, an actuator's target), a mimic coupling (leader, multiplier, offset), or None (no mimic).
FieldValue: TypeAlias = np.ndarray | float | str | tuple[str, float, float] | None


def composite(parts: list[Inertial]) -> Inertial:
    """The rigid sum of `parts` (each in world coordinates): mass, centre of mass, inertia about it."""
    mass = sum(p.mass for p in parts)
    if mass <= 0.0:  # no centre of mass; an inertia without mass (a defect of the file) is kept as given
        inertia = sum((p.inertia for p in parts), np.zeros((3, 3)))
        return Inertial(0.0, parts[0].com if parts else np.zeros(3), inertia)
    com = sum((p.mass * p.com for p in parts), np.zeros(3)) / mass
    inertia = np.zeros((3, 3))
    for p in parts:
        d = p.com - com
        inertia += p.inertia + parallel_axis(p.mass, d)
    return Inertial(mass, com, inertia)


def rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF's rpy: Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _floats(text: str | None, n: int, default: float, where: str) -> np.ndarray:
    if text is None or not text.split():
        return np.full(n, default)
    try:
        out = np.array([float(x) for x in text.split()])
    except ValueError:
        raise HarnessError(f"{where}: {text!r} is not {n} numbers.") from None
    if out.shape != (n,):
        raise HarnessError(f"{where}: {text!r} is not {n} numbers.")
    return out


def _origin(el: ET.Element | None, where: str) -> tuple[np.ndarray, np.ndarray]:
    """(R, p) of an <origin> (identity where absent)."""
    o = el.find("origin") if el is not None else None
    if o is None:
        return np.eye(3), np.zeros(3)
    return rpy_matrix(_floats(o.get("rpy"), 3, 0.0, f"{where} <origin rpy>")), _floats(
        o.get("xyz"), 3, 0.0, f"{where} <origin xyz>"
    )


def _number(el: ET.Element | None, attr: str, default: float, where: str) -> float:
    if el is None or el.get(attr) is None:
        return default
    return float(_floats(el.get(attr), 1, default, f"{where} {attr}")[0])


def link_inertial(link: ET.Element, R: np.ndarray, p: np.ndarray) -> Inertial:
    """A link's <inertial> in the world, its link frame at (R, p); none: massless (urdfdom)."""
    name = f"link '{link.get('name', '?')}'"
    el = link.find("inertial")
    if el is None:
        return ZERO
    Ri, pi = _origin(el, f"{name} <inertial>")
    mass = _number(el.find("mass"), "value", 0.0, f"{name} <mass>")
    i = el.find("inertia")
    k = {a: _number(i, a, 0.0, f"{name} <inertia>") for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    local = np.array([[k["ixx"], k["ixy"], k["ixz"]], [k["ixy"], k["iyy"], k["iyz"]], [k["ixz"], k["iyz"], k["izz"]]])
    Rw = R @ Ri
    return Inertial(mass, R @ pi + p, Rw @ local @ Rw.T)


def _joint_read(j: ET.Element, R: np.ndarray, p: np.ndarray, parent: str) -> JointRead:
    """A moving joint whose frame is at (R, p) in the world."""
    name = f"joint '{j.get('name', '?')}'"
    given = j.find("axis")
    axis = np.array([1.0, 0.0, 0.0]) if given is None else _floats(given.get("xyz"), 3, 0.0, f"{name} <axis>")
    norm = float(np.linalg.norm(axis))
    if norm == 0.0:
        raise HarnessError(f"{name}: <axis xyz> is zero; a joint needs a direction.")
    limit, dyn, mimic = j.find("limit"), j.find("dynamics"), j.find("mimic")
    kind = j.get("type", "")
    limits = (
        np.array([_number(limit, "lower", 0.0, name), _number(limit, "upper", 0.0, name)])
        if kind != "continuous" and limit is not None
        else np.array([-np.inf, np.inf])
    )
    coupling = None
    if mimic is not None:
        coupling = (
            mimic.get("joint", "?"),
            _number(mimic, "multiplier", 1.0, name),
            _number(mimic, "offset", 0.0, name),
        )
    return JointRead(
        kind=MOVING[kind],
        body=j.find("child").get("link", "?"),  # type: ignore[union-attr]
        anchor=p,
        axis=R @ axis / norm,
        limits=limits,
        damping=_number(dyn, "damping", 0.0, name),
        frictionloss=_number(dyn, "friction", 0.0, name),
        mimic=coupling,
        parent="" if parent == "world" else parent,
    )


def _tree(root: ET.Element, source: str) -> tuple[dict[str, ET.Element], dict[str, ET.Element], list[str]]:
    links = {link.get("name", "?"): link for link in root.findall("link")}
    by_child = {}
    for j in root.findall("joint"):
        child, parent = j.find("child"), j.find("parent")
        if child is None or parent is None or child.get("link") not in links or parent.get("link") not in links:
            raise HarnessError(f"{source}: joint '{j.get('name', '?')}' needs a <parent> and a <child> link it names.")
        by_child[child.get("link", "")] = j
    roots = [name for name in links if name not in by_child]
    if not links:
        raise HarnessError(f"{source}: no <link> element: not a robot description (a xacro macro file, say).")
    if len(roots) != 1:
        raise HarnessError(f"{source}: {len(roots)} root links ({', '.join(roots)}); a URDF has one tree.")
    return links, by_child, roots


def urdf_meaning(text: str, source: str) -> Reading:
    """urdfdom's reading of a URDF, at q = 0, in world coordinates (see the module docstring)."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise HarnessError(f"{source}: not well-formed XML ({exc}).") from None
    links, by_child, _ = _tree(root, source)
    pose: dict[str, tuple[np.ndarray, np.ndarray, str]] = {}  # link -> (R, p, the joint moving it)

    def place(link: str) -> tuple[np.ndarray, np.ndarray, str]:
        if link not in pose:
            j = by_child.get(link)
            if j is None:
                pose[link] = (np.eye(3), np.zeros(3), "world")
            else:
                Rp, pp, group = place(j.find("parent").get("link", ""))  # type: ignore[union-attr]
                Ro, po = _origin(j, f"joint '{j.get('name', '?')}'")
                moving = j.get("type") in MOVING
                pose[link] = (Rp @ Ro, Rp @ po + pp, j.get("name", "?") if moving else group)
        return pose[link]

    joints: dict[str, JointRead] = {}
    parts: dict[str, list[Inertial]] = {}
    members: dict[str, list[str]] = {}
    for link in links:
        R, p, group = place(link)
        parts.setdefault(group, []).append(link_inertial(links[link], R, p))
        members.setdefault(group, []).append(link)
        j = by_child.get(link)
        if j is not None and j.get("type") in MOVING:
            above = place(j.find("parent").get("link", ""))[2]  # type: ignore[union-attr]
            joints[j.get("name", "?")] = _joint_read(j, R, p, above)
    for name, r in joints.items():  # a <mimic> of a joint that does not move (or is not in the file) couples nothing
        if r.mimic is not None and r.mimic[0] not in joints:
            joints[name] = dataclasses.replace(r, mimic=None)
    groups = {name: composite(parts.get(name, [])) for name in joints}
    return Reading(
        "meaning",
        joints,
        groups,
        actuators=_transmissions(root),
        members={name: tuple(members.get(name, ())) for name in joints},
        couplings=sum(1 for r in joints.values() if r.mimic is not None),
    )


def _transmissions(root: ET.Element) -> dict[str, tuple[str, float]]:
    out = {}
    for tr in root.iter("transmission"):
        joints, actuators = tr.findall("joint"), tr.findall("actuator")
        if len(joints) != 1 or len(actuators) != 1:
            continue  # a differential: several joints per actuator, compared by no reader
        reduction = actuators[0].findtext("mechanicalReduction") or tr.findtext("mechanicalReduction") or "1"
        try:
            gear = float(reduction)
        except ValueError:
            continue
        out[actuators[0].get("name") or tr.get("name") or "?"] = (joints[0].get("name") or "?", gear)
    return out


def fields(reading: Reading, labels: dict[str, str]) -> dict[str, FieldValue]:
    """The reading flattened: 'model/world/gravity', 'body/<link>/mass', ..., 'joint/<name>/<field>',
    'actuator/<name>/gear';
    `labels`: joint -> the link its group is shown as (the reference's)."""
    out: dict[str, FieldValue] = {"model/world/gravity": reading.gravity}
    if reading.couplings is not None:
        out["model/world/couplings"] = float(reading.couplings)
    for j, g in reading.groups.items():
        b = labels.get(j, j)
        out |= {f"body/{b}/mass": g.mass, f"body/{b}/com": g.com, f"body/{b}/inertia": g.inertia}
    for j, r in reading.joints.items():
        for k in ("anchor", "axis", "ref", "limits", "damping", "stiffness", "springref"):
            out[f"joint/{j}/{k}"] = getattr(r, k)
        out |= {
            f"joint/{j}/frictionloss": r.frictionloss,
            f"joint/{j}/armature": r.armature,
            f"joint/{j}/gravcomp": r.gravcomp,
            f"joint/{j}/kind": r.kind,
        }
        if "mimic" not in reading.unread:
            out[f"joint/{j}/mimic"] = r.mimic
    for a, (joint, gear) in (reading.actuators or {}).items():
        out |= {f"actuator/{a}/target": joint, f"actuator/{a}/gear": gear}
    return out

"""Each engine as a plain reader of a model file (issue 33): MuJoCo (`MjSpec`), Pinocchio
(`buildModelFromXML` / `buildModelFromMJCF`) and Drake (`Parser`), each on the file as given (a
URDF's `<visual>`/`<collision>` removed, so that no mesh file is needed: urdfdom's dynamics are its
`<inertial>` elements; MuJoCo keeps the primitive ones, which it weighs for a link without
`<inertial>`), nothing aligned, every quantity put in the common frame of
validate/model/meaning.py: the reader's own reference configuration (MuJoCo's qpos0, the others'
q = 0 or neutral), world coordinates, each joint with the rigid group it moves.

What a reader has no field for is read as its neutral value (no stiffness, no gravcomp, no mimic), so
that a reader that drops a field is seen dropping it. A reader that refuses the file raises
HarnessError naming the reader, the element where the library says, and a likely cause
(`failure`): no raw library message (a C++ `unordered_map::at`) reaches the screen alone.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import re
import tempfile
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from ..core.arrays import Vector
from ..core.errors import HarnessError
from ..model.meaning import Inertial, JointRead, Reading, composite
from ..model.urdf import without_geometry
from .drakeparse import abort_line, likely_cause

if TYPE_CHECKING:  # each library is imported when its reader runs
    import mujoco
    import pinocchio as pin

T = TypeVar("T")

LABEL = {"meaning": "the format", "mujoco": "MuJoCo", "pinocchio": "Pinocchio", "drake": "Drake"}
# Library messages and what usually causes them (the element is quoted from the message when it names one).
CAUSES = (
    ("hfields are not supported", "a height-field geom (hfield), which it does not read"),
    ("No such node", "an element it requires and the file does not have (a body under <worldbody>, say)"),
    ("missing element", "an element the format requires is missing (an <inertial> without <mass> or <inertia>)"),
    ("repeated element", "an element given twice where one is allowed (two <inertial> in one link)"),
    ("does not contain a valid URDF", "urdfdom refuses the file (a revolute or prismatic joint without <limit>, say)"),
    ("Shell inertia", 'a geom weighed as a shell (shellinertia, mesh inertia="shell")'),
    ("Error opening file", "a file it names is missing (a mesh, a texture or an include)"),
    ("cannot mimic", "a <mimic> it cannot apply (on a joint without degrees of freedom)"),
    ("mimic element specifies", "a <mimic> that names a joint the file does not have"),
    ("inertia from geom", 'inertiafromgeom="false" with a body that has no <inertial>'),
    ("inertiafromgeom=false", 'inertiafromgeom="false" with a body that has no <inertial>'),
    (
        "IsPhysicallyValid",
        "an inertia that is not physically valid (the triangle inequality, a zero mass with inertia)",
    ),
    (
        "unordered_map::at",
        'an element or attribute it does not know (a default class such as class="main", '
        "a mesh or an include it cannot resolve)",
    ),
    ("mesh", "a mesh file missing or in a format it cannot read"),
    ("mass and inertia of moving bodies", "a moving body without mass (a link without <inertial>)"),
    ("A + B >= C", "an inertia that violates the triangle inequality (balanceinertia would fix it)"),
    ("positive", "an inertia that is not positive definite"),
    ("model name", "the <mujoco> element has no model name"),
    ("frame", "a <frame> or a pose it cannot place"),
    ("joint", "a joint type or attribute it does not support"),
)


def _classes(text: str) -> str:
    """A default class the MJCF's elements name but do not define in this file, and where it is."""
    defined = set(re.findall(r"<default\b[^>]*\bclass\s*=\s*[\"']([^\"']+)", text))
    used = re.findall(r"<(\w+)\b[^>]*\b(?:child)?class\s*=\s*[\"']([^\"']+)", text)
    unknown = [(tag, name) for tag, name in used if tag != "default" and name not in defined]
    if not unknown:
        return ""
    tag, name = unknown[0]
    if name == "main":
        where = "the file defines only as MuJoCo's unnamed top class"
    elif "<include" in text:
        where = "defined in an included file (Pinocchio reads no <include>)"
    else:
        where = "that no <default> defines"
    return f'<{tag} class="{name}"> names a default class {where}'


def failure(reader: str, source: str, exc: BaseException, text: str = "") -> HarnessError:
    """One line: the reader, the element where the message (or the file) names one, the likely cause,
    and the library's own first line."""
    said = str(exc).strip()
    lines = said.splitlines()
    # Pinocchio's C++ errors begin with the source file and function; what it says follows "message:"
    first = lines[lines.index("message:") + 1] if "message:" in lines[:-1] else (lines[0] if lines else "")
    first = first or type(exc).__name__
    element = re.search(r"Element '([^']+)', line (\d+)", said) or re.search(r"\.(?:xml|urdf):(\d+)", said)
    where = ""
    if element is not None and element.lastindex == 2:
        where = f" at <{element.group(1)}> (line {element.group(2)})"
    elif element is not None:
        where = f" at line {element.group(1)}"
    cause = next((why for key, why in CAUSES if key.lower() in first.lower()), "")
    if "unordered_map::at" in said and _classes(text):
        cause = _classes(text)
    because = f"; likely {cause}" if cause else ""
    return HarnessError(
        f"{source}: {LABEL[reader]} cannot read it{where}{because} ({LABEL[reader]} says: {first[:160]})"
    )


def _guarded(reader: str, source: str, fn: Callable[[], T], text: str) -> T:
    try:
        return fn()
    except HarnessError:
        raise
    except Exception as exc:  # each library raises its own types (ValueError, RuntimeError, std::exception)
        raise failure(reader, source, exc, text) from None


def read(reader: str, path: Path, text: str, fmt: str, *, parts: bool = False) -> Reading:
    """`reader`'s Reading of the model (`text` of `path`, format "urdf" or "mjcf"). `parts`: Pinocchio's
    composite joint (several joints in one body) read as its parts, as the harness's source maps it by
    name (`pinocchio_reading`); else it has none of their names, as a user of the raw library sees it."""
    if reader == "pinocchio":
        return _guarded(reader, path.name, lambda: pinocchio_reading(path, text, fmt, parts=parts), text)
    fn = {"mujoco": mujoco_reading, "drake": drake_reading}[reader]
    return _guarded(reader, path.name, lambda: fn(path, text, fmt), text)


def _primitives_kept(text: str) -> str:
    """The URDF with only its mesh geometry removed (mesh files may be absent): MuJoCo then weighs a
    link's primitive collision geometry as it does on the file (inertiafromgeom), which urdfdom does not."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(text)
    for link in root.iter("link"):
        for el in [*link.findall("visual"), *link.findall("collision")]:
            if el.find("geometry/mesh") is not None:
                link.remove(el)
    return ET.tostring(root, encoding="unicode")


def _model_text(text: str, fmt: str) -> str:
    return without_geometry(text) if fmt == "urdf" else text


@contextlib.contextmanager
def _as_file(path: Path, text: str) -> Iterator[str]:
    """The MJCF file itself where `text` is its content, else a temporary copy with its file names made
    absolute (so that its includes and meshes resolve as from `path`), removed afterwards."""
    if path.is_file() and path.read_text() == text:
        yield str(path)
        return
    fd, name = tempfile.mkstemp(suffix=".xml", prefix="audit_")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(_absolute(text, path))
        yield name
    finally:
        os.unlink(name)


# --- MuJoCo ---------------------------------------------------------------------------------------


def mujoco_model(path: Path, text: str, fmt: str) -> tuple[mujoco.MjModel, list[str]]:
    """MuJoCo's compiled model of the file and its warnings."""
    import mujoco

    said: list[str] = []
    mujoco.set_mju_user_warning(lambda msg: said.append(msg.strip()))
    try:
        with warnings.catch_warnings(record=True) as caught:  # the bindings' own (a deprecated attribute)
            warnings.simplefilter("always")
            if fmt == "urdf":
                model = mujoco.MjSpec.from_string(_primitives_kept(text)).compile()
            else:
                with _as_file(path, text) as name:
                    model = mujoco.MjSpec.from_file(name).compile()
    finally:
        mujoco.set_mju_user_warning(None)
    return model, said + [str(w.message).splitlines()[0] for w in caught]


def _absolute(text: str, path: Path) -> str:
    """The MJCF with its `file=` and `meshdir`/`texturedir` attributes made absolute (read from elsewhere)."""

    def fix(m: re.Match[str]) -> str:
        value = m.group(2)
        return m.group(0) if os.path.isabs(value) else f'{m.group(1)}="{(path.parent / value).resolve()}"'

    return re.sub(r'\b(file|meshdir|texturedir|assetdir)="([^"]*)"', fix, text)


def _mujoco_group(m: mujoco.MjModel, b: int) -> int:
    """The id of the joint that moves body b (its last joint, else its parent's), -1: the world."""
    while b > 0:
        if m.body_jntnum[b]:
            return int(m.body_jntadr[b] + m.body_jntnum[b] - 1)
        b = int(m.body_parentid[b])
    return -1


def _namer(m: mujoco.MjModel) -> Callable[[mujoco.mjtObj, int], str]:
    """An element's name, or MuJoCo's id for an unnamed one ("joint 3")."""
    import mujoco

    return lambda obj, i: mujoco.mj_id2name(m, obj, i) or f"{obj.name[6:].lower()} {i}"


def _mujoco_joint(
    m: mujoco.MjModel,
    d: mujoco.MjData,
    j: int,
    name: Callable[[mujoco.mjtObj, int], str],
    mimic: tuple[str, float, float] | None,
) -> JointRead | None:
    """Hinge or slide joint j at qpos0, in the world (None for a ball or free joint)."""
    import mujoco

    kinds = {int(mujoco.mjtJoint.mjJNT_HINGE): "hinge", int(mujoco.mjtJoint.mjJNT_SLIDE): "slide"}
    kind = kinds.get(int(m.jnt_type[j]))
    if kind is None:
        return None
    dof, qadr, b = int(m.jnt_dofadr[j]), int(m.jnt_qposadr[j]), int(m.jnt_bodyid[j])
    return JointRead(
        kind=kind,
        body=name(mujoco.mjtObj.mjOBJ_BODY, b),
        anchor=np.array(d.xanchor[j]),
        axis=np.array(d.xaxis[j]),
        ref=float(m.qpos0[qadr]),
        limits=np.array(m.jnt_range[j], dtype=float) if m.jnt_limited[j] else np.array([-np.inf, np.inf]),
        damping=float(m.dof_damping[dof]),
        stiffness=float(m.jnt_stiffness[j]),
        springref=float(m.qpos_spring[qadr]),
        frictionloss=float(m.dof_frictionloss[dof]),
        armature=float(m.dof_armature[dof]),
        gravcomp=float(m.body_gravcomp[b]),
        mimic=mimic,
        parent=_mujoco_parent(m, j, name),
    )


def _mujoco_actuators(m: mujoco.MjModel, name: Callable[[mujoco.mjtObj, int], str]) -> dict[str, tuple[str, float]]:
    """Each actuator on a joint: (joint, gear)."""
    import mujoco

    return {
        name(mujoco.mjtObj.mjOBJ_ACTUATOR, a): (
            name(mujoco.mjtObj.mjOBJ_JOINT, int(m.actuator_trnid[a, 0])),
            float(m.actuator_gear[a, 0]),
        )
        for a in range(m.nu)
        if int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT)
    }


def mujoco_reading(path: Path, text: str, fmt: str) -> Reading:
    """MuJoCo's compiled model at qpos0 (its reference: the frames as the file writes them)."""
    import mujoco

    m, said = mujoco_model(path, text, fmt)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    name = _namer(m)
    parts: dict[int, list[Inertial]] = {}
    members: dict[int, list[str]] = {}
    for b in range(1, m.nbody):
        R = d.ximat[b].reshape(3, 3)
        inertial = Inertial(float(m.body_mass[b]), np.array(d.xipos[b]), R @ np.diag(m.body_inertia[b]) @ R.T)
        parts.setdefault(_mujoco_group(m, b), []).append(inertial)
        members.setdefault(_mujoco_group(m, b), []).append(name(mujoco.mjtObj.mjOBJ_BODY, b))
    joints, groups = {}, {}
    couplings = _mujoco_mimics(m, name)
    for j in range(m.njnt):
        jn = name(mujoco.mjtObj.mjOBJ_JOINT, j)
        read_joint = _mujoco_joint(m, d, j, name, couplings.get(jn))
        if read_joint is not None:
            joints[jn], groups[jn] = read_joint, composite(parts.get(j, []))
    body_names = {name(mujoco.mjtObj.mjOBJ_JOINT, j): tuple(members.get(j, ())) for j in range(m.njnt)}
    return Reading(
        "mujoco",
        joints,
        groups,
        _mujoco_actuators(m, name),
        warnings=said,
        members=body_names,
        gravity=np.array(m.opt.gravity),
        couplings=len(couplings),
    )


def _mujoco_parent(m: mujoco.MjModel, j: int, name: Callable[[mujoco.mjtObj, int], str]) -> str:
    """The joint above joint j: the previous joint of its body, else the joint moving its parent body."""
    import mujoco

    b = int(m.jnt_bodyid[j])
    above = j - 1 if j > int(m.body_jntadr[b]) else _mujoco_group(m, int(m.body_parentid[b]))
    return "" if above < 0 else name(mujoco.mjtObj.mjOBJ_JOINT, above)


def _mujoco_mimics(m: mujoco.MjModel, name: Callable[[mujoco.mjtObj, int], str]) -> dict[str, tuple[str, float, float]]:
    """joint -> (leader, multiplier, offset) of every joint equality q1 = offset + multiplier q2 that is active
    at the start (active="false" couples nothing until a controller switches it on)."""
    import mujoco

    out = {}
    for e in range(m.neq):
        coupled = int(m.eq_type[e]) == int(mujoco.mjtEq.mjEQ_JOINT) and int(m.eq_obj2id[e]) >= 0
        if coupled and bool(m.eq_active0[e]):
            follower = name(mujoco.mjtObj.mjOBJ_JOINT, int(m.eq_obj1id[e]))
            leader = name(mujoco.mjtObj.mjOBJ_JOINT, int(m.eq_obj2id[e]))
            out[follower] = (leader, float(m.eq_data[e, 1]), float(m.eq_data[e, 0]))
    return out


# --- Pinocchio ------------------------------------------------------------------------------------


def pinocchio_model(path: Path, text: str, fmt: str) -> pin.Model:
    import pinocchio as pin

    if fmt == "urdf":
        return pin.buildModelFromXML(_model_text(text, fmt))
    with _as_file(path, text) as name:
        return pin.buildModelFromMJCF(name)


def _reference(model: pin.Model) -> Vector:
    """Pinocchio's reference configuration: the MJCF's qpos0 (its joints' `ref`) where it read one."""
    import pinocchio as pin

    try:
        return model.referenceConfigurations["qpos0"]
    except (KeyError, IndexError):
        return pin.neutral(model)


def _part_names(text: str, fmt: str, body: str, n: int) -> list[str]:
    """The names of the n joints of MJCF body `body`, in the file's order: the parts of the composite joint
    Pinocchio makes of them ([] where the file does not name them all, or is a URDF)."""
    import xml.etree.ElementTree as ET

    if fmt == "urdf":
        return []
    try:
        root = ET.fromstring(text)
    except ET.ParseError:
        return []
    for el in root.iter("body"):
        if el.get("name") == body:
            names = [j.get("name") or "" for j in el.findall("joint")]
            return names if len(names) == n and all(names) else []
    return []


def _anchor(origin: Vector, motion: Vector) -> Vector:
    """The point of a hinge's axis line nearest `origin`, from its motion (linear velocity at `origin`,
    angular) per unit velocity: v = w x (origin - p) gives p - origin = (w x v) / |w|^2."""
    w, v = motion[3:], motion[:3]
    return np.asarray(origin + np.cross(w, v) / max(float(w @ w), 1e-300), dtype=float)


def _pinocchio_parts(
    model: pin.Model, jid: int, text: str, fmt: str, body: str, parts: bool
) -> list[tuple[str, int, int]]:
    """Joint jid as (MJCF name, q index, v index) per one-coordinate part: itself, or (with `parts`) each
    part of a composite joint (several joints in one body), named by the body's joints; [] otherwise."""
    jm = model.joints[jid]
    if jm.nv == 1:
        return [(model.names[jid], jm.idx_q, jm.idx_v)]
    if not parts or "Composite" not in jm.shortname() or jm.nq != jm.nv:
        return []
    names = _part_names(text, fmt, body, jm.nv)
    joints = jm.extract().joints
    if not names or any(p.nv != 1 or p.nq != 1 for p in joints):
        return []
    return [(name, jm.idx_q + k, jm.idx_v + k) for k, name in enumerate(names)]


def pinocchio_reading(path: Path, text: str, fmt: str, *, parts: bool = False) -> Reading:
    """Pinocchio's model at its neutral configuration: each joint's inertia (its body and the links
    welded to it, in the joint frame) put in the world; with `parts`, a composite joint (several joints in
    one body) read as its parts, the body's inertia with the last, as MuJoCo groups it."""
    import pinocchio as pin

    model = pinocchio_model(path, text, fmt)
    data = model.createData()
    q = _reference(model)
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    bodies: dict[int, str] = {}
    for f in model.frames:
        if f.type == pin.FrameType.BODY:
            bodies.setdefault(int(f.parentJoint), f.name)
    joints, groups, last = {}, {}, {0: ""}
    for jid in range(1, model.njoints):
        oMi = data.oMi[jid]
        ones = _pinocchio_parts(model, jid, text, fmt, bodies.get(jid, model.names[jid]), parts)
        J = np.reshape(pin.getJointJacobian(model, data, jid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED), (6, -1))
        parent = last.get(int(model.parents[jid]), _pinocchio_parent(model, jid))
        for jn, iq, iv in ones:
            motion = np.array(J[:, iv], dtype=float)
            kind = "hinge" if np.linalg.norm(motion[3:]) > 0.5 else "slide"
            origin = np.array(oMi.translation, dtype=float)
            joints[jn] = _pinocchio_joint(
                model,
                kind,
                bodies.get(jid, jn),
                origin if model.joints[jid].nv == 1 else _anchor(origin, motion),
                motion,
                q,
                iq,
                iv,
                parent,
            )
            groups[jn] = composite([])
            parent = jn
        if ones:
            I, R = model.inertias[jid], oMi.rotation
            groups[ones[-1][0]] = Inertial(float(I.mass), np.array(oMi.act(I.lever)), R @ np.array(I.inertia) @ R.T)
            last[jid] = ones[-1][0]
        else:
            last[jid] = last.get(int(model.parents[jid]), "")
    gravity = np.array(model.gravity.linear, dtype=float)
    return Reading("pinocchio", joints, groups, None, gravity=gravity, couplings=_pinocchio_couplings(model))


def _pinocchio_joint(
    model: pin.Model, kind: str, body: str, anchor: Vector, motion: Vector, q: Vector, iq: int, iv: int, parent: str
) -> JointRead:
    """One one-coordinate joint (or part of a composite) as Pinocchio read it."""
    jm_unbounded = any(
        ("Unbounded" in j.shortname() or "RUB" in j.shortname()) and j.idx_q <= iq < j.idx_q + j.nq
        for j in model.joints
    )
    lo, hi = float(model.lowerPositionLimit[iq]), float(model.upperPositionLimit[iq])
    return JointRead(
        kind=kind,
        body=body,
        anchor=anchor,
        axis=motion[3:] if kind == "hinge" else motion[:3],
        ref=float(q[iq]) if not jm_unbounded else 0.0,
        limits=np.array([-np.inf, np.inf]) if jm_unbounded or hi >= 1e10 else np.array([lo, hi]),
        damping=float(model.damping[iv]),
        frictionloss=float(model.friction[iv]),
        armature=float(model.armature[iv]),
        parent=parent,
    )


def _pinocchio_couplings(model: pin.Model) -> int:
    """The joints Pinocchio made mimic another (JointModelMimic: only where the model was built with
    mimic=True; the default reading of a URDF's <mimic> is a joint that moves on its own)."""
    return sum(1 for j in model.joints if "Mimic" in j.shortname())


def _pinocchio_parent(model: pin.Model, jid: int) -> str:
    """The nearest one-degree-of-freedom joint above joint jid ("": the world)."""
    k = int(model.parents[jid])
    while k > 0 and model.joints[k].nv != 1:
        k = int(model.parents[k])
    return model.names[k] if k > 0 else ""


# --- Drake ----------------------------------------------------------------------------------------


class _Collect(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage().split("warning: ", 1)[-1].strip().splitlines()[0]
        if text not in self.lines:
            self.lines.append(text)


def drake_plant(path: Path, text: str, fmt: str) -> tuple[Any, list[str]]:
    """Drake's finalized continuous plant of the file and its parser's warnings."""
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(time_step=0.0)
    log, handler = logging.getLogger("drake"), _Collect()
    log.addHandler(handler)
    propagate, log.propagate = log.propagate, False
    try:
        if died := abort_line(_model_text(text, fmt), "urdf" if fmt == "urdf" else "xml"):
            raise HarnessError(f"{path.name}: Drake cannot read it: {died}; {likely_cause(died)}")
        if fmt == "urdf":
            Parser(plant).AddModelsFromString(_model_text(text, fmt), "urdf")
        else:
            with _as_file(path, text) as name:
                Parser(plant).AddModels(Path(name))
        plant.Finalize()
    finally:
        log.removeHandler(handler)
        log.propagate = propagate
    return plant, handler.lines


def _drake_groups(plant: Any) -> dict[int, str]:
    """body index -> the name of the joint that moves it ('' for the world or a floating root)."""
    from pydrake.multibody.tree import JointIndex

    moving = {}
    for i in plant.GetJointIndices():
        joint = plant.get_joint(JointIndex(int(i)))
        moving[int(joint.child_body().index())] = joint
    out: dict[int, str] = {}
    for i in range(plant.num_bodies()):
        b = i
        while b in moving and moving[b].num_velocities() == 0:
            b = int(moving[b].parent_body().index())
        joint = moving.get(b)
        out[i] = joint.name() if joint is not None and joint.num_velocities() == 1 else ""
    return out


def drake_reading(path: Path, text: str, fmt: str) -> Reading:
    """Drake's plant at its default configuration (a URDF's free root left where it is by default)."""
    from pydrake.multibody.tree import BodyIndex

    plant, said = drake_plant(path, text, fmt)
    ctx = plant.CreateDefaultContext()
    group = _drake_groups(plant)
    parts: dict[str, list[Inertial]] = {}
    for i in range(1, plant.num_bodies()):
        body = plant.get_body(BodyIndex(i))
        X = plant.EvalBodyPoseInWorld(ctx, body)
        M = body.CalcSpatialInertiaInBodyFrame(ctx)
        mass = float(M.get_mass())
        if not np.isfinite(mass) or mass <= 0.0:
            continue
        com = np.array(M.get_com(), dtype=float)
        R = X.rotation().matrix()
        inertia = np.array(M.Shift(com).CalcRotationalInertia().CopyToFullMatrix3(), dtype=float)
        parts.setdefault(group[i], []).append(Inertial(mass, X @ com, R @ inertia @ R.T))
    motors = {
        plant.get_joint_actuator(a).joint().name(): plant.get_joint_actuator(a) for a in plant.GetJointActuatorIndices()
    }
    joints, groups = {}, {}
    for i in plant.GetJointIndices():
        joint = plant.get_joint(i)
        if joint.num_velocities() != 1 or not (hasattr(joint, "revolute_axis") or hasattr(joint, "translation_axis")):
            continue
        read_joint = _drake_joint(plant, ctx, joint, motors.get(joint.name()))
        joints[joint.name()] = dataclasses.replace(read_joint, parent=group[int(joint.parent_body().index())])
        groups[joint.name()] = composite(parts.get(joint.name(), []))
    actuators = {
        plant.get_joint_actuator(a).name(): (
            plant.get_joint_actuator(a).joint().name(),
            float(plant.get_joint_actuator(a).default_gear_ratio()),
        )
        for a in plant.GetJointActuatorIndices()
    }
    gravity = np.array(plant.gravity_field().gravity_vector(), dtype=float)
    reading = Reading("drake", joints, groups, actuators, warnings=said, gravity=gravity)
    return _drake_couplings(reading, plant, fmt)


def _drake_couplings(reading: Reading, plant: Any, fmt: str) -> Reading:
    """Drake's couplings: its URDF parser makes a coupler constraint of each <mimic> (its continuous plant
    then refuses to compute dynamics with it), whose joints, gear ratio and offset pydrake does not expose:
    a URDF's couplings are counted and its joints' mimic left unread. Its MJCF parser reads no
    <equality><joint> (it warns), so there a joint's mimic is read as none."""
    if fmt != "urdf":
        return reading
    return dataclasses.replace(reading, couplings=int(plant.num_constraints()), unread=("mimic",))


def _drake_joint(plant: Any, ctx: Any, joint: Any, motor: Any) -> JointRead:

    X = joint.frame_on_child().CalcPoseInWorld(ctx)
    R = joint.frame_on_parent().CalcPoseInWorld(ctx).rotation().matrix()
    hinge = hasattr(joint, "revolute_axis")
    axis = np.asarray(joint.revolute_axis() if hinge else joint.translation_axis(), dtype=float)
    lo, hi = float(joint.position_lower_limits()[0]), float(joint.position_upper_limits()[0])
    return JointRead(
        kind="hinge" if hinge else "slide",
        body=joint.child_body().name(),
        anchor=np.array(X.translation(), dtype=float),
        axis=R @ axis,
        ref=float(joint.default_positions()[0]),  # an MJCF joint's ref (its default position)
        limits=np.array([lo, hi]),
        damping=float(joint.default_damping()),
        armature=0.0 if motor is None else float(motor.default_reflected_inertia()),
    )

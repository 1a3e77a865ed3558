"""URDF as well as MJCF: both engines read the same file, each with its own parser.

MuJoCo compiles the URDF with its own URDF reader; Pinocchio reads it with `buildModelFromXML`. What
each reader does on its own, and what the harness does so that the two readings describe the same
chain, is stated here and listed in the results (`alignments`), never done silently:

- **geometry**: `<visual>` and `<collision>` elements are removed before either engine reads the file.
  A URDF's dynamics are its `<inertial>` elements; meshes would have to be found and parsed (MuJoCo
  cannot read .dae files), and collision geometry would bring contacts, which the harness refuses.
  A link without `<inertial>` is massless in both readings (URDF's rule; MuJoCo would otherwise
  infer a mass from its geoms).
- **fixed joints**: MuJoCo fuses a link on a fixed joint into its parent body (`fusestatic`, its URDF
  default); Pinocchio keeps it as a frame and adds its inertia to the parent joint's. Both give the
  same inertia per moving body; the fused link's name is not a MuJoCo body.
- **joint limits**: MuJoCo enforces `<limit lower upper>` as constraint forces, Pinocchio's
  algorithms ignore them; the harness compares the chain's equations of motion, so MuJoCo's limits
  are disabled (`<flag limit="disable"/>`).
- **effort limits**: MuJoCo turns `<limit effort>` into a clamp of the actuator force on that joint
  (`actuatorfrcrange`); Pinocchio has none; the clamp is removed.
- **continuous joints**: Pinocchio represents them by (cos q, sin q), MuJoCo by q; the harness hands
  Pinocchio a revolute joint with unbounded limits instead (the same dynamics, one coordinate).
- **transmissions**: a URDF declares its motors as `<transmission>` elements, which MuJoCo's reader
  ignores; each becomes a MuJoCo motor named after its `<actuator>`, on its joint, with its
  `<mechanicalReduction>` as gear (Pinocchio has no actuators: the inputs are applied as
  generalized forces, as for an MJCF model).
- **what URDF does not say**: gravity (-9.81 m/s^2 along z, MuJoCo's default, copied into Pinocchio),
  MuJoCo's timestep (0.002 s) and integrator (Euler), no armature, no springs.
"""

from __future__ import annotations

import importlib.metadata
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ..core.errors import HarnessError
from .bounds import check_numbers
from .inertia import repair_urdf

if TYPE_CHECKING:  # MuJoCo is imported when a URDF is first compiled
    import mujoco

ROOT = "robot"
UNBOUNDED = 1e10  # the limits of a continuous joint handed to Pinocchio as revolute, in rad
_GEOMETRY = re.compile(r"<(visual|collision)\b[^>]*?/>|<(visual|collision)\b.*?</\2\s*>", re.S)


@dataclass(frozen=True)
class Transmission:
    actuator: str
    joint: str
    gear: float


def robots_folder() -> Path | None:
    """example-robot-data's robots folder (its URDFs: UR5, Panda, Kinova, ...), or None where that
    package is not installed (it is in requirements.lock and the `robots` extra)."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return None
    return Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))


def _root(text: str, source: str) -> ET.Element:
    try:
        return ET.fromstring(text)
    except ET.ParseError as exc:
        raise HarnessError(f"{source}: not well-formed XML ({exc}).") from None


def without_geometry(text: str) -> str:
    """The URDF with every <visual> and <collision> element removed (comments and layout kept)."""
    return _GEOMETRY.sub("", text)


def coupled_transmissions(text: str, source: str) -> list[str]:
    """One line per <transmission> that is not one actuator on one joint (a differential wrist): not read."""
    out = []
    for tr in _root(text, source).iter("transmission"):
        joints, actuators = tr.findall("joint"), tr.findall("actuator")
        if len(joints) != 1 or len(actuators) != 1:
            out.append(
                f"transmission '{tr.get('name', '?')}' ({len(joints)} joint(s), {len(actuators)} actuator(s): "
                f"{', '.join(j.get('name', '?') for j in joints)}) not read: no input goes through it"
            )
    return out


def transmissions(text: str, source: str) -> list[Transmission]:
    """The URDF's <transmission> elements of one actuator on one joint each (`coupled_transmissions`
    lists the others, which are not read)."""
    out = []
    for tr in _root(text, source).iter("transmission"):
        name = tr.get("name", "?")
        joints, actuators = tr.findall("joint"), tr.findall("actuator")
        if len(joints) != 1 or len(actuators) != 1:
            continue
        gear = _reduction(tr)
        if gear is None:
            continue  # not read (`unread_transmissions`): a field no check uses never refuses the file
        out.append(Transmission(actuators[0].get("name") or name, joints[0].get("name", ""), gear))
    return out


def _reduction(tr: ET.Element) -> float | None:
    """A one-joint transmission's mechanicalReduction (1 where it states none), None where it is not a
    finite number: urdfdom reads no transmission, and MuJoCo's reader ignores them."""
    import math

    actuator = tr.find("actuator")
    found = actuator.findtext("mechanicalReduction") if actuator is not None else None
    text = (found or tr.findtext("mechanicalReduction") or "1").strip()
    try:
        gear = float(text)
    except ValueError:
        return None
    return gear if math.isfinite(gear) else None


def unread_transmissions(text: str, source: str) -> list[str]:
    """One line per one-joint transmission whose mechanicalReduction is not a number: no motor is made
    of it (a model-only check uses none; an input through it is then not found, by name)."""
    out = []
    for tr in _root(text, source).iter("transmission"):
        if len(tr.findall("joint")) == 1 and len(tr.findall("actuator")) == 1 and _reduction(tr) is None:
            said = (tr.findtext("actuator/mechanicalReduction") or tr.findtext("mechanicalReduction") or "").strip()
            out.append(
                f"transmission '{tr.get('name', '?')}' not read: its mechanicalReduction {said[:40]!r} is not a "
                "number (no motor made of it)"
            )
    return out


def fixed_joints(text: str, source: str) -> list[str]:
    return [j.get("name", "?") for j in _root(text, source).iter("joint") if j.get("type") == "fixed"]


def lock(text: str, joints: tuple[str, ...], source: str) -> str:
    """The URDF with `joints` made fixed at their zero angle (a gripper's fingers, say): the named,
    listed step that takes a joint out of the chain both engines read. An unknown name is an error."""
    root = _root(text, source)
    found = {j.get("name"): j for j in root.findall("joint")}  # the robot's; not a <transmission>'s <joint>
    unknown = [j for j in joints if j not in found]
    if unknown:
        raise HarnessError(f"{source}: no joint '{unknown[0]}' to lock (joints: {', '.join(sorted(map(str, found)))}).")
    moving = sorted(str(n) for n, j in found.items() if j.get("type") != "fixed")
    if moving and set(moving) <= set(joints):
        raise HarnessError(
            f"{source}: every joint locked ({', '.join(moving)}): nothing moves; lock fewer joints (--lock)."
        )
    for name in joints:
        joint = found[name]
        joint.set("type", "fixed")
        for child in [
            *joint.findall("limit"),
            *joint.findall("mimic"),
            *joint.findall("axis"),
            *joint.findall("dynamics"),
        ]:
            joint.remove(child)
    for tr in list(root.iter("transmission")):
        if any(j.get("name") in joints for j in tr.findall("joint")):
            root.remove(tr)
    return ET.tostring(root, encoding="unicode")


def continuous_joints(text: str, source: str) -> list[str]:
    return [j.get("name", "?") for j in _root(text, source).iter("joint") if j.get("type") == "continuous"]


def _no_log(message: str) -> None:
    pass


def _spec(text: str, source: str) -> mujoco.MjSpec:
    """MuJoCo's MjSpec of the URDF `text`, with the alignments of the module docstring."""
    import mujoco

    from .scope import urdf_refusals

    joints = [(j.get("name") or "?", j.get("type") or "?") for j in _root(text, source).findall("joint")]
    refused = urdf_refusals(joints)  # before either engine reads the file
    text = repair_urdf(text)[0]  # a defective inertia, which MuJoCo refuses, as its balanceinertia gives it
    if refused:
        raise HarnessError(f"{source}: {refused[0]}" + (f" (and {len(refused) - 1} more)" if len(refused) > 1 else ""))
    mujoco.set_mju_user_warning(_no_log)  # MuJoCo would append to MUJOCO_LOG.TXT in the working directory
    try:
        spec = mujoco.MjSpec.from_string(without_geometry(text))
    except Exception as exc:  # mujoco raises ValueError with a multi-line message
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise HarnessError(f"{source}: MuJoCo cannot read this URDF: {first}") from None
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_LIMIT)
    for joint in spec.joints:
        joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
    names = {j.name for j in spec.joints}
    fixed = set(fixed_joints(text, source))
    for tr, name in motors(text, source):
        if tr.joint in fixed or tr.joint not in names:
            continue  # a motor on a fixed or absent joint moves nothing (listed in the alignments)
        motor = spec.add_actuator(name=name, target=tr.joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        motor.gear[0] = tr.gear
    return spec


def motors(text: str, source: str) -> list[tuple[Transmission, str]]:
    """Each one-joint transmission with the name of the MuJoCo motor made of it: its actuator's, or,
    where two transmissions name the same actuator, the actuator's name and the joint's
    ("thumb_motor@thumb_joint")."""
    found = transmissions(text, source)
    count = {tr.actuator: sum(t.actuator == tr.actuator for t in found) for tr in found}
    return [(tr, tr.actuator if count[tr.actuator] == 1 else f"{tr.actuator}@{tr.joint}") for tr in found]


def compile_urdf(text: str, source: str) -> mujoco.MjModel:
    """MuJoCo's model of the URDF `text`, with the alignments of the module docstring."""
    return _compiled(_spec(text, source), source)


def _compiled(spec: mujoco.MjSpec, source: str) -> mujoco.MjModel:
    try:
        model = spec.compile()
    except Exception as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise HarnessError(f"{source}: MuJoCo cannot compile this URDF: {first}") from None
    return check_numbers(model, source)


def for_pinocchio(text: str, source: str) -> str:
    """The URDF text Pinocchio reads: geometry removed, continuous joints as revolute (one angle)."""
    root = _root(without_geometry(text), source)
    for joint in root.iter("joint"):
        if joint.get("type") == "continuous":
            joint.set("type", "revolute")
            for old in joint.findall("limit"):
                joint.remove(old)
            ET.SubElement(joint, "limit", lower=repr(-UNBOUNDED), upper=repr(UNBOUNDED), effort="0", velocity="0")
    return ET.tostring(root, encoding="unicode")


def as_mjcf(text: str, source: str) -> str:
    """An MJCF document whose compiled model equals MuJoCo's reading of the URDF (every number of
    the model view written at full precision and read back): what probes and overrides edit."""
    from .modelview import from_mujoco
    from .set_values import set_values

    spec = _spec(text, source)
    view = from_mujoco(_compiled(spec, source), source)
    numeric = {k: v for k, v in view.items() if not isinstance(v, str)}
    return set_values(spec.to_xml(), numeric, model_view=view)


def alignments(text: str, source: str) -> list[str]:
    """What the harness did so that MuJoCo's and Pinocchio's readings of this URDF describe the same
    chain, one line each, naming the elements (the module docstring says why)."""
    root = _root(text, source)
    out = []
    geometry = [
        f"{link.get('name', '?')}"
        for link in root.iter("link")
        if link.find("visual") is not None or link.find("collision") is not None
    ]
    if geometry:
        out.append(
            f"visual and collision geometry removed from {len(geometry)} link(s) ({', '.join(geometry[:6])}"
            f"{', ...' if len(geometry) > 6 else ''}): a URDF's dynamics are its <inertial> elements"
        )
    massless = [link.get("name", "?") for link in root.iter("link") if link.find("inertial") is None]
    if massless:
        out.append(f"link(s) without <inertial>, massless in both readings: {', '.join(massless)}")
    fixed = [j.get("name", "?") for j in root.iter("joint") if j.get("type") == "fixed"]
    if fixed:
        out.append(
            f"fixed joint(s) {', '.join(fixed)}: MuJoCo fuses the child link into its parent body, Pinocchio "
            "adds its inertia to the parent joint's"
        )
    limited = [
        j.get("name", "?")
        for j in root.iter("joint")
        if j.get("type") in ("revolute", "prismatic") and j.find("limit") is not None
    ]
    if limited:
        out.append(
            f"joint limits of {', '.join(limited)} not enforced: MuJoCo's limit constraints disabled (Pinocchio's "
            "algorithms have none, nor do equations of motion)"
        )
    effort = []
    for joint in root.iter("joint"):
        limit = joint.find("limit")
        if limit is not None and limit.get("effort", "0").strip() not in ("0", "0.0", ""):
            effort.append(joint.get("name", "?"))
    if effort:
        out.append(f"MuJoCo's clamp of the actuator force at the URDF effort limit removed on {', '.join(effort)}")
    continuous = continuous_joints(text, source)
    if continuous:
        out.append(
            f"continuous joint(s) {', '.join(continuous)} handed to Pinocchio as revolute with unbounded limits "
            "(one angle, as MuJoCo reads them, instead of cos/sin)"
        )
    for ext in root.findall("mujoco"):
        inner = "".join(ET.tostring(child, encoding="unicode").strip() for child in ext)
        out.append(f"MuJoCo's own <mujoco> extension read by MuJoCo only (Pinocchio ignores it): {inner[:200]}")
    welded = set(fixed_joints(text, source))
    joints = {j.get("name") for j in root.iter("joint")}
    for tr, name in motors(text, source):
        if tr.joint in welded:
            out.append(f"transmission of '{tr.actuator}' on the fixed joint '{tr.joint}' ignored (it moves nothing)")
        elif tr.joint not in joints:
            out.append(f"transmission of '{tr.actuator}' on joint '{tr.joint}', which the file lacks, ignored")
        else:
            called = "" if name == tr.actuator else f" '{name}' (its actuator's name is taken twice)"
            out.append(
                f"transmission of '{tr.actuator}' on joint '{tr.joint}' made a MuJoCo motor{called}, gear {tr.gear:g}"
            )
    out += coupled_transmissions(text, source) + unread_transmissions(text, source)
    out.append(
        "not in URDF, MuJoCo's defaults used: gravity (0, 0, -9.81) m/s^2 (copied into Pinocchio), timestep "
        "0.002 s, Euler integrator, no armature, no springs"
    )
    return out

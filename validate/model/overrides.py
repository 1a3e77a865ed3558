"""Parameter overrides, applied to the MJCF text at full precision, so that MuJoCo, Pinocchio (both
parse the edited text) and the equations (which read the compiled model) see the same numbers.
(MuJoCo's MjSpec.to_xml writes 6 significant digits, which is why the text is edited instead.)

Keys (`--set KEY=VALUE`):
    scale/mass=k            every body's mass and inertia times k
    scale/length=k          every position, centre of mass and geom size times k, inertia times k^2
    scale/gravity=k         gravity times k
    body/<name>/mass=x      that body's mass, its inertia scaled alike (same radius of gyration)
    body/<name>/inertia=k   that body's inertia times k
    joint/<name>/damping=x  (also armature, frictionloss, stiffness)
    actuator/<name>/gear=x

`set_values(text, {key: value})` (validate/model/set_values.py) writes ModelView keys instead,
each to an absolute value: what the probes use to build a model at a derivation's own parameters.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from ..core.errors import HarnessError, unknown_name
from .modelview import key_parts

PATTERNS = (
    "scale/mass",
    "scale/length",
    "scale/gravity",
    "body/<name>/mass",
    "body/<name>/inertia",
    "joint/<name>/damping",
    "joint/<name>/armature",
    "joint/<name>/frictionloss",
    "joint/<name>/stiffness",
    "actuator/<name>/gear",
)
MUJOCO_DEFAULT_GRAVITY = "0 0 -9.81"
# Beyond these, products such as m l^2 v^2 leave the range where double precision compares anything.
SCALE_RANGE = (1e-6, 1e6)
MAX_VALUE = 1e9


def parse(items: list[str] | None) -> tuple[tuple[str, float], ...]:
    """Parses ["KEY=VALUE", ...]; the value must be a finite number."""
    out = []
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise HarnessError(f"--set takes KEY=VALUE; got '{item}'. Keys: {', '.join(PATTERNS)}.")
        try:
            number = float(value)
        except ValueError:
            raise HarnessError(f"--set {key}: '{value}' is not a number.") from None
        if not np.isfinite(number):
            raise HarnessError(f"--set {key}: the value must be finite; got {value}.")
        if abs(number) > MAX_VALUE or (key.startswith("scale/") and not SCALE_RANGE[0] <= number <= SCALE_RANGE[1]):
            raise HarnessError(
                f"--set {key}={value} is out of range: scales lie in [{SCALE_RANGE[0]:g}, "
                f"{SCALE_RANGE[1]:g}], other values within +-{MAX_VALUE:g}."
            )
        out.append((key.strip(), number))
    return tuple(out)


def _scale_attr(el: ET.Element, attr: str, k: float) -> None:
    if attr in el.attrib:
        el.set(attr, " ".join(repr(float(x) * k) for x in el.get(attr, "").split()))


def _named(root: ET.Element, tag: str, kind: str, name: str) -> ET.Element:
    found = (
        [e for e in root.iter(tag) if e.get("name") == name]
        if tag
        else [e for e in root.iter() if e.get("name") == name]
    )
    if not found:
        names = [e.get("name", "") for e in (root.iter(tag) if tag else root.iter()) if e.get("name")]
        raise unknown_name(kind, name, names)
    return found[0]


def _inertial(body: ET.Element, name: str) -> ET.Element:
    inertial = body.find("inertial")
    if inertial is None:
        raise HarnessError(f"body '{name}' has no explicit <inertial> to override.")
    return inertial


def _positive(key: str, value: float) -> None:
    if value <= 0:
        raise HarnessError(f"--set {key} must be positive; got {value}.")


def _scale_mass(root: ET.Element, key: str, k: float) -> None:
    """scale/mass: every body's mass and inertia times k."""
    _positive(key, k)
    for el in root.iter("inertial"):
        for attr in ("mass", "diaginertia", "fullinertia"):
            _scale_attr(el, attr, k)


def _scale_length(root: ET.Element, key: str, k: float) -> None:
    """scale/length: every position, centre of mass and geom size times k, inertia times k^2."""
    _positive(key, k)
    for el in root.iter():
        if el.tag in ("body", "inertial", "joint", "geom", "site", "camera", "light"):
            for attr in ("pos", "fromto", "size"):
                _scale_attr(el, attr, k)
        if el.tag == "inertial":
            for attr in ("diaginertia", "fullinertia"):
                _scale_attr(el, attr, k * k)


def _scale_gravity(root: ET.Element, k: float) -> None:
    """scale/gravity: gravity times k (MuJoCo's default gravity where the model gives none)."""
    option = root.find("option")
    if option is None:
        option = ET.SubElement(root, "option")
    option.set("gravity", option.get("gravity", MUJOCO_DEFAULT_GRAVITY))
    _scale_attr(option, "gravity", k)


def _set_body(root: ET.Element, key: str, name: str, field: str, value: float) -> None:
    """body/<name>/mass (its inertia scaled alike) or body/<name>/inertia (times value)."""
    _positive(key, value)
    inertial = _inertial(_named(root, "body", "body", name), name)
    ratio = value / float(inertial.get("mass", "0") or 1.0) if field == "mass" else value
    if field == "mass":
        inertial.set("mass", repr(value))
    for attr in ("diaginertia", "fullinertia"):
        _scale_attr(inertial, attr, ratio)


def _set_joint(root: ET.Element, key: str, name: str, field: str, value: float) -> None:
    """joint/<name>/damping, armature, frictionloss or stiffness: a non-negative value."""
    if value < 0:
        raise HarnessError(f"--set {key} must be non-negative; got {value}.")
    _named(root, "joint", "joint", name).set(field, repr(value))


def _set_gear(root: ET.Element, name: str, value: float) -> None:
    """actuator/<name>/gear: the gear's first entry."""
    section = root.find("actuator")
    if section is None:
        raise unknown_name("actuator", name, [])
    actuator = _named(section, "", "actuator", name)
    gear = (actuator.get("gear") or "1").split()
    gear[0] = repr(value)
    actuator.set("gear", " ".join(gear))


def _apply(root: ET.Element, key: str, value: float) -> None:
    """One override applied to the parsed model, by the kind of its key."""
    found = key_parts(key)
    parts = list(found) if found is not None else key.split("/")  # a name may hold "/"
    if key == "scale/mass":
        _scale_mass(root, key, value)
    elif key == "scale/length":
        _scale_length(root, key, value)
    elif key == "scale/gravity":
        _scale_gravity(root, value)
    elif len(parts) == 3 and parts[0] == "body" and parts[2] in ("mass", "inertia"):
        _set_body(root, key, parts[1], parts[2], value)
    elif len(parts) == 3 and parts[0] == "joint" and parts[2] in ("damping", "armature", "frictionloss", "stiffness"):
        _set_joint(root, key, parts[1], parts[2], value)
    elif len(parts) == 3 and parts[0] == "actuator" and parts[2] == "gear":
        _set_gear(root, parts[1], value)
    else:
        raise HarnessError(f"Unknown parameter '{key}'. Valid keys: {', '.join(PATTERNS)}.")


def apply_overrides(text: str, overrides: tuple[tuple[str, float], ...]) -> str:
    """The MJCF `text` with the overrides applied; an unknown key or name is a one-line error."""
    root = ET.fromstring(text)
    for key, value in overrides:
        _apply(root, key, value)
    return ET.tostring(root, encoding="unicode")

"""Parameter overrides applied to the MJCF through MuJoCo's model-editing API (MjSpec), so that
MuJoCo, Pinocchio (which reads the edited MJCF) and the equations (which read the compiled
model) all see the same numbers.

Keys (`--set KEY=VALUE`):
    scale/mass=k            every body's mass and inertia times k
    scale/length=k          every position, centre of mass and geom size times k, inertia times k^2
    scale/gravity=k         gravity times k
    body/<name>/mass=x      that body's mass, its inertia scaled alike (same radius of gyration)
    body/<name>/inertia=k   that body's inertia times k
    joint/<name>/damping=x  (also armature, frictionloss, stiffness)
    actuator/<name>/gear=x
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .errors import HarnessError, unknown_name

PATTERNS = ("scale/mass", "scale/length", "scale/gravity", "body/<name>/mass", "body/<name>/inertia",
            "joint/<name>/damping", "joint/<name>/armature", "joint/<name>/frictionloss",
            "joint/<name>/stiffness", "actuator/<name>/gear")


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
        out.append((key.strip(), number))
    return tuple(out)


def _scale_lengths(spec: Any, k: float) -> None:
    for b in spec.bodies[1:]:
        b.pos = np.asarray(b.pos) * k
        b.ipos = np.asarray(b.ipos) * k
        b.inertia = np.asarray(b.inertia) * k * k
        b.fullinertia = np.asarray(b.fullinertia) * k * k
    for j in spec.joints:
        j.pos = np.asarray(j.pos) * k
    for g in spec.geoms:
        g.pos = np.asarray(g.pos) * k
        g.size = np.asarray(g.size) * k
        g.fromto = np.asarray(g.fromto) * k
    for s in spec.sites:
        s.pos = np.asarray(s.pos) * k


def _named(items: Any, kind: str, name: str) -> Any:
    for x in items:
        if x.name == name:
            return x
    raise unknown_name(kind, name, [x.name for x in items if x.name])


def apply_overrides(spec: Any, overrides: tuple[tuple[str, float], ...]) -> None:
    """Edits `spec` in place; an unknown key or name is a one-line error naming the valid ones."""
    for key, value in overrides:
        parts = key.split("/")
        if key == "scale/mass":
            if value <= 0:
                raise HarnessError(f"--set scale/mass must be positive; got {value}.")
            for b in spec.bodies[1:]:
                b.mass *= value
                b.inertia = np.asarray(b.inertia) * value
                b.fullinertia = np.asarray(b.fullinertia) * value
        elif key == "scale/length":
            if value <= 0:
                raise HarnessError(f"--set scale/length must be positive; got {value}.")
            _scale_lengths(spec, value)
        elif key == "scale/gravity":
            spec.option.gravity = np.asarray(spec.option.gravity) * value
        elif len(parts) == 3 and parts[0] == "body" and parts[2] in ("mass", "inertia"):
            b = _named(spec.bodies[1:], "body", parts[1])
            if value <= 0:
                raise HarnessError(f"--set {key} must be positive; got {value}.")
            ratio = value / b.mass if parts[2] == "mass" else value
            if parts[2] == "mass":
                b.mass = value
            b.inertia = np.asarray(b.inertia) * ratio
            b.fullinertia = np.asarray(b.fullinertia) * ratio
        elif len(parts) == 3 and parts[0] == "joint" and parts[2] in ("damping", "armature", "frictionloss", "stiffness"):
            if value < 0:
                raise HarnessError(f"--set {key} must be non-negative; got {value}.")
            j = _named(spec.joints, "joint", parts[1])
            current = getattr(j, parts[2])
            if np.ndim(current):
                current = np.array(current, dtype=float)
                current[0] = value
                setattr(j, parts[2], current)
            else:
                setattr(j, parts[2], value)
        elif len(parts) == 3 and parts[0] == "actuator" and parts[2] == "gear":
            a = _named(spec.actuators, "actuator", parts[1])
            gear = np.array(a.gear, dtype=float)
            gear[0] = value
            a.gear = gear
        else:
            raise HarnessError(f"Unknown parameter '{key}'. Valid keys: {', '.join(PATTERNS)}.")

"""A plain-numpy snapshot of a compiled MJCF model, keyed by MJCF names.

The equations modules read their parameters from this view (never from the XML text, never from
defaults of their own), so the compiled MJCF is the single source of numbers. Keys:

    gravity                      (3,) m/s^2 (zero if the scene disables gravity)
    body/<name>/mass             kg
    body/<name>/com              (3,) centre of mass in the body frame, m
    body/<name>/inertia          (3, 3) inertia about the centre of mass, body axes, kg m^2
    body/<name>/pos              (3,) body frame origin in the parent body frame, m
    body/<name>/quat             (4,) body frame orientation in the parent frame (w, x, y, z)
    body/<name>/parent           parent body name ("world" for the root)
    joint/<name>/type            "hinge" | "slide" | "ball" | "free"
    joint/<name>/body            body the joint moves
    joint/<name>/axis            (3,) joint axis in the body frame
    joint/<name>/pos             (3,) joint anchor in the body frame, m
    joint/<name>/damping         N m s / rad (viscous, MJCF joint damping; 0 if dampers are disabled)
    joint/<name>/armature        kg m^2
    joint/<name>/frictionloss    N m (dry friction: a constraint, left out of every comparison)
    joint/<name>/stiffness       N m / rad
    joint/<name>/springref       rad (m): where the spring is relaxed; present only where it is not 0
    joint/<name>/ref             rad (m): the coordinate at which the body is where the file writes it
                                 (MuJoCo's qpos0; the joint turns by q - ref); present only where it is not 0
    actuator/<name>/joint        joint name the actuator drives (an unnamed actuator: "actuator#<id>")
    actuator/<name>/gear         transmission ratio (generalized force per unit control)

A name may hold `/`, `:`, spaces and any Unicode (a joint `arm/theta`): the kind is the key's first
part and the field its last, so a key is split only by `key_parts`, and names are listed by `names`.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.errors import HarnessError, unknown_name

if TYPE_CHECKING:  # MuJoCo is imported when a model is first compiled
    import mujoco

_JOINT_TYPES = {0: "free", 1: "ball", 2: "slide", 3: "hinge"}
KINDS = ("body", "joint", "actuator")


def key_parts(key: str) -> tuple[str, str, str] | None:
    """(kind, name, field) of a key `kind/<name>/field`, the name whole whatever it holds
    (`joint/arm/theta/damping` is the joint `arm/theta`); None for `gravity` or any other key."""
    kind, _, rest = key.partition("/")
    name, _, field = rest.rpartition("/")
    return (kind, name, field) if kind in KINDS and name and field else None


def names(keys: Iterable[str], kind: str, field: str) -> list[str]:
    """The names of every `kind` that has `field`, in the keys' order (`names(view, "joint", "type")`:
    the model's joints)."""
    out = []
    for key in keys:
        parts = key_parts(key)
        if parts is not None and parts[0] == kind and parts[2] == field:
            out.append(parts[1])
    return out


def welded(view: Mapping[str, Any]) -> dict[str, list[str]]:
    """The bodies no joint moves, by the body they are welded to (their parent): what a reader that keeps
    one inertia per joint (Pinocchio) adds to that body's."""
    moved = {str(view[f"joint/{j}/body"]) for j in names(view, "joint", "body")}
    out: dict[str, list[str]] = {}
    for body in names(view, "body", "parent"):
        if body not in moved:
            out.setdefault(str(view[f"body/{body}/parent"]), []).append(body)
    return out


class ModelView(Mapping[str, Any]):
    """Read-only mapping from the keys above to values; an unknown key names the close ones."""

    def __init__(self, values: dict[str, Any], source: str) -> None:
        self._values = values
        self.source = source

    def __getitem__(self, key: str) -> Any:
        try:
            return self._values[key]
        except KeyError:
            raise unknown_name(f"model key (in {self.source})", key, self._values) from None

    def __contains__(self, key: object) -> bool:
        return key in self._values

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)


def parallel_axis(mass: float, d: np.ndarray) -> np.ndarray:
    """m (|d|^2 1 - d d^T): what moving a body's inertia from its centre to a point d away adds."""
    return mass * (float(d @ d) * np.eye(3) - np.outer(d, d))


def quat_to_mat(quat: np.ndarray) -> np.ndarray:
    w, x, y, z = quat / np.linalg.norm(quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def from_mujoco(model: mujoco.MjModel, source: str) -> ModelView:
    """Snapshots a compiled `mujoco.MjModel` into a ModelView."""
    import mujoco

    from .scope import joint_actuators

    def name(obj: int, i: int) -> str:
        """The element's name; an unnamed one is called by MuJoCo's id: "actuator#0" (shown as such)."""
        n = mujoco.mj_id2name(model, obj, i)
        if n:
            return n
        if obj != mujoco.mjtObj.mjOBJ_ACTUATOR:
            raise HarnessError(f"{source}: every body and joint needs a name (unnamed id {i}).")
        return f"actuator#{i}"

    gravity_off = model.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY)
    # The gravity the dynamics see: zero when the scene disables it.
    values: dict[str, Any] = {"gravity": np.zeros(3) if gravity_off else np.array(model.opt.gravity, dtype=float)}
    # Likewise the damping the dynamics see: zero when the scene disables dampers.
    damper_off = model.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_DAMPER)
    for b in range(1, model.nbody):
        n = name(mujoco.mjtObj.mjOBJ_BODY, b)
        rot = quat_to_mat(np.array(model.body_iquat[b]))
        values[f"body/{n}/mass"] = float(model.body_mass[b])
        values[f"body/{n}/com"] = np.array(model.body_ipos[b], dtype=float)
        values[f"body/{n}/inertia"] = rot @ np.diag(model.body_inertia[b]) @ rot.T
        values[f"body/{n}/pos"] = np.array(model.body_pos[b], dtype=float)
        values[f"body/{n}/quat"] = np.array(model.body_quat[b], dtype=float)
        parent = int(model.body_parentid[b])
        values[f"body/{n}/parent"] = "world" if parent == 0 else name(mujoco.mjtObj.mjOBJ_BODY, parent)
    for j in range(model.njnt):
        n = name(mujoco.mjtObj.mjOBJ_JOINT, j)
        dof = int(model.jnt_dofadr[j])
        values[f"joint/{n}/type"] = _JOINT_TYPES[int(model.jnt_type[j])]
        values[f"joint/{n}/body"] = name(mujoco.mjtObj.mjOBJ_BODY, int(model.jnt_bodyid[j]))
        values[f"joint/{n}/axis"] = np.array(model.jnt_axis[j], dtype=float)
        values[f"joint/{n}/pos"] = np.array(model.jnt_pos[j], dtype=float)
        values[f"joint/{n}/damping"] = 0.0 if damper_off else float(model.dof_damping[dof])
        values[f"joint/{n}/armature"] = float(model.dof_armature[dof])
        values[f"joint/{n}/frictionloss"] = float(model.dof_frictionloss[dof])
        values[f"joint/{n}/stiffness"] = float(model.jnt_stiffness[j])
        if _JOINT_TYPES[int(model.jnt_type[j])] in ("hinge", "slide"):
            # compiled, so in radians whatever <compiler angle> the file uses
            qadr = int(model.jnt_qposadr[j])
            if model.qpos_spring[qadr]:
                values[f"joint/{n}/springref"] = float(model.qpos_spring[qadr])
            if model.qpos0[qadr]:
                values[f"joint/{n}/ref"] = float(model.qpos0[qadr])
    for a in joint_actuators(model):  # the others are never driven (model/scope.py)
        n = name(mujoco.mjtObj.mjOBJ_ACTUATOR, a)
        values[f"actuator/{n}/joint"] = name(mujoco.mjtObj.mjOBJ_JOINT, int(model.actuator_trnid[a, 0]))
        values[f"actuator/{n}/gear"] = float(model.actuator_gear[a, 0])
    return ModelView(values, source)

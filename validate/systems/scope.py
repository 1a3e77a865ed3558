"""What the harness can compare, read off the compiled model before any dynamics.

The equations a person derives by hand (and the three sources' common interface) describe a chain
of hinge and slide joints, one coordinate each, moved by gravity, joint damping, armature, springs
and motors. Anything that adds forces or coordinates outside that is refused by name, with why:

    free and ball joints      more than one coordinate per joint (a quaternion): no angle per joint
    contacts                  forces that switch on and off with the configuration (two geoms that can
                              collide, or a <contact><pair>), unless contacts are disabled in <option>
                              (contacts, limits, equality constraints and friction loss are all
                              constraints: <flag constraint="disable"/> turns every one off)
    equality constraints      constraint forces the hand equations do not have
    joint limits              constraint forces at the limits (unless limits are disabled)
    friction loss             dry friction: a constraint force, not a function of q and v
    tendons                   forces along paths the equations do not describe

`refusals(model)` lists every such element (empty when the model is in scope). A URDF is read first
by `urdf_refusals`: its planar and floating joints (and any other type than revolute, continuous,
prismatic and fixed) are refused by type and name before either engine reads the file, since the two
readers would split or drop them differently.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

DOF_OF = {"free": 6, "ball": 3}
URDF_JOINTS = ("revolute", "continuous", "prismatic", "fixed")  # one coordinate each, or none
URDF_DOF = {"planar": 3, "floating": 6}


def urdf_refusals(joints: list[tuple[str, str]]) -> list[str]:
    """One line per URDF joint (name, type) of a type the harness cannot compare."""
    return [
        f"joint '{name}' is a {kind} joint"
        + (f" ({URDF_DOF[kind]} degrees of freedom)" if kind in URDF_DOF else "")
        + f": only {', '.join(URDF_JOINTS[:3])} joints (one coordinate each) can be compared; make it fixed "
        f"or lock it (--lock {name})"
        for name, kind in joints
        if kind not in URDF_JOINTS
    ]


def _name(model: Any, obj: Any, i: int, kind: str) -> str:
    return mujoco.mj_id2name(model, obj, i) or f"{kind} {i}"


def _disabled(model: Any, bit: Any) -> bool:
    return bool(model.opt.disableflags & int(bit))


def _collide(model: Any, a: int, b: int) -> bool:
    """Whether geoms a and b can touch by MuJoCo's filters (contype/conaffinity, same body, parent)."""
    ba, bb = int(model.geom_bodyid[a]), int(model.geom_bodyid[b])
    if ba == bb:
        return False
    if not (model.geom_contype[a] & model.geom_conaffinity[b] or model.geom_contype[b] & model.geom_conaffinity[a]):
        return False
    parent_filter = not _disabled(model, mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    if parent_filter and (int(model.body_parentid[ba]) == bb or int(model.body_parentid[bb]) == ba):
        # MuJoCo skips parent-child pairs, except with the world body (id 0)
        return ba == 0 or bb == 0
    return True


def refusals(model: Any) -> list[str]:
    """One line per element the harness cannot compare, naming it and why (empty: in scope)."""
    out = [] if model.nv else ["no joint moves (every body is fixed): there are no equations of motion to compare"]
    for j in range(model.njnt):
        kind = {int(mujoco.mjtJoint.mjJNT_FREE): "free", int(mujoco.mjtJoint.mjJNT_BALL): "ball"}.get(
            int(model.jnt_type[j])
        )
        if kind:
            out.append(
                f"joint '{_name(model, mujoco.mjtObj.mjOBJ_JOINT, j, 'joint')}' is a {kind} joint "
                f"({DOF_OF[kind]} degrees of freedom): only hinge and slide joints, one coordinate each, "
                "can be compared"
            )
    constraints = not _disabled(model, mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)  # off: no constraint force at all
    if constraints and not _disabled(model, mujoco.mjtDisableBit.mjDSBL_CONTACT):
        if model.npair:
            out.append(
                f"the model has {model.npair} explicit contact pair(s) (<contact><pair>): contact forces cannot "
                "be compared"
            )
        pairs = [(a, b) for a in range(model.ngeom) for b in range(a + 1, model.ngeom) if _collide(model, a, b)]
        if pairs:
            a, b = pairs[0]
            geom = mujoco.mjtObj.mjOBJ_GEOM
            out.append(
                f"geoms '{_name(model, geom, a, 'geom')}' and '{_name(model, geom, b, 'geom')}' can collide"
                + (f" (and {len(pairs) - 1} more pairs)" if len(pairs) > 1 else "")
                + ': contact forces cannot be compared; set contype="0" conaffinity="0" on the geoms or '
                '<flag contact="disable"/> in <option>'
            )
    for e in range(model.neq if constraints else 0):
        what = f"equality constraint '{_name(model, mujoco.mjtObj.mjOBJ_EQUALITY, e, 'equality')}'"
        fix = ""
        if int(model.eq_type[e]) == int(mujoco.mjtEq.mjEQ_JOINT):  # a URDF <mimic> becomes one, unnamed
            joints = [
                _name(model, mujoco.mjtObj.mjOBJ_JOINT, int(i), "joint")
                for i in (model.eq_obj1id[e], model.eq_obj2id[e])
            ]
            what += f" coupling joint '{joints[0]}' to joint '{joints[1]}' (a URDF <mimic> is read as one)"
            fix = f"; lock it with --lock {joints[0]} (or both: --lock {joints[1]},{joints[0]}; locked= in Python)"
        out.append(f"{what}: constraint forces cannot be compared (the hand equations of a chain have none){fix}")
    if constraints and not _disabled(model, mujoco.mjtDisableBit.mjDSBL_LIMIT):
        for limited in np.nonzero(model.jnt_limited)[0]:
            out.append(
                f"joint '{_name(model, mujoco.mjtObj.mjOBJ_JOINT, int(limited), 'joint')}' is limited: the limit's "
                'constraint force cannot be compared; remove its range or set <flag limit="disable"/>'
            )
    if constraints and not _disabled(model, mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS):
        for dof in np.nonzero(model.dof_frictionloss > 0)[0]:
            d, joint = int(dof), int(model.dof_jntid[dof])
            out.append(
                f"joint '{_name(model, mujoco.mjtObj.mjOBJ_JOINT, joint, 'joint')}' has frictionloss "
                f"{float(model.dof_frictionloss[d]):g}: dry friction is a constraint force, not a function of q and v"
            )
    for t in range(model.ntendon):
        out.append(
            f"tendon '{_name(model, mujoco.mjtObj.mjOBJ_TENDON, t, 'tendon')}': forces along a tendon cannot be "
            "compared"
        )
    return out

"""What the harness compares, read off the compiled model before any dynamics.

A Lagrangian derivation gives the smooth dynamics M(q) q'' + C(q, q') q' + G(q) = tau + passive(q, q').
Constraints add forces on top of it that no derivation of the chain contains; a published model has
them (joint ranges, a floor, dry friction, a URDF <mimic>), and they are left out of every comparison,
never a reason to refuse the model:

    contacts                  two geoms that can collide, or a <contact><pair>
    joint and tendon limits   constraint forces at a range's ends
    equality constraints      welds, joint couplings (a URDF <mimic> is read as one), ...
    friction loss             dry friction: a constraint force, not a function of q and v

`unconstrained(model)` switches them off on the compiled model (MuJoCo's disable flags for contact,
limit, equality and friction loss: what it then computes is `qacc_smooth`, the smooth dynamics every
engine computes) and returns one line per kind the model has, naming its elements: the verdict and the
report say once what was left out. Two passive forces only MuJoCo computes are set to zero on the model
and listed the same way: a tendon's spring and damper and a body's gravity compensation (`gravcomp`).

`refusals(model)` lists what cannot be compared at all (empty when the model is in scope): free and ball
joints (a quaternion: no angle per joint). A URDF is read first
by `urdf_refusals`: its planar and floating joints are refused by type and name before either engine
reads the file, since the readers would split or drop them differently.
"""

from __future__ import annotations

import mujoco
import numpy as np

DOF_OF = {"free": 6, "ball": 3}
URDF_JOINTS = ("revolute", "continuous", "prismatic", "fixed")  # one coordinate each, or none
URDF_DOF = {"planar": 3, "floating": 6}
SHOWN = 3  # names listed per kind of constraint; the rest counted

# The constraints a model can add to its smooth dynamics, and the disable flag that removes each.
_OFF = mujoco.mjtDisableBit
CONSTRAINT_FLAGS = int(_OFF.mjDSBL_CONTACT | _OFF.mjDSBL_LIMIT | _OFF.mjDSBL_EQUALITY | _OFF.mjDSBL_FRICTIONLOSS)


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


def _name(model: mujoco.MjModel, obj: mujoco.mjtObj, i: int, kind: str) -> str:
    return mujoco.mj_id2name(model, obj, i) or f"{kind}#{i}"


def _disabled(model: mujoco.MjModel, bit: mujoco.mjtDisableBit) -> bool:
    return bool(model.opt.disableflags & int(bit))


def _collide(model: mujoco.MjModel, a: int, b: int) -> bool:
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


def _listed(names: list[str], *, quoted: bool = True) -> str:
    """'a', 'b', 'c' and 2 more."""
    shown = ", ".join(f"'{n}'" if quoted else n for n in names[:SHOWN])
    return shown + (f" and {len(names) - SHOWN} more" if len(names) > SHOWN else "")


NOTHING_MOVES = "no joint moves (every body is fixed): there are no equations of motion to derive"


def refusals(model: mujoco.MjModel) -> list[str]:
    """One line per element the harness cannot compare, naming it and why (empty: in scope)."""
    out: list[str] = []
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
    return out


def _contacts(model: mujoco.MjModel) -> list[str]:
    if _disabled(model, mujoco.mjtDisableBit.mjDSBL_CONTACT):
        return []
    geom = mujoco.mjtObj.mjOBJ_GEOM
    pairs = [(a, b) for a in range(model.ngeom) for b in range(a + 1, model.ngeom) if _collide(model, a, b)]
    named = [f"{_name(model, geom, a, 'geom')}~{_name(model, geom, b, 'geom')}" for a, b in pairs]
    named += [
        f"{_name(model, geom, int(model.pair_geom1[p]), 'geom')}~{_name(model, geom, int(model.pair_geom2[p]), 'geom')}"
        for p in range(model.npair)
    ]
    return [f"contacts between {len(named)} pair(s) of geoms ({_listed(named)})"] if named else []


def _limits(model: mujoco.MjModel) -> list[str]:
    if _disabled(model, mujoco.mjtDisableBit.mjDSBL_LIMIT):
        return []
    joints = [_name(model, mujoco.mjtObj.mjOBJ_JOINT, int(j), "joint") for j in np.nonzero(model.jnt_limited)[0]]
    tendons = [_name(model, mujoco.mjtObj.mjOBJ_TENDON, int(t), "tendon") for t in np.nonzero(model.tendon_limited)[0]]
    out = [f"the range of joint(s) {_listed(joints)}"] if joints else []
    return out + ([f"the range of tendon(s) {_listed(tendons)}"] if tendons else [])


def _equalities(model: mujoco.MjModel) -> list[str]:
    if _disabled(model, mujoco.mjtDisableBit.mjDSBL_EQUALITY):
        return []
    named = []
    for e in range(model.neq):
        what = f"'{_name(model, mujoco.mjtObj.mjOBJ_EQUALITY, e, 'equality')}'"
        if int(model.eq_type[e]) == int(mujoco.mjtEq.mjEQ_JOINT):  # a URDF <mimic> becomes one, unnamed
            a, b = (
                _name(model, mujoco.mjtObj.mjOBJ_JOINT, int(i), "joint")
                for i in (model.eq_obj1id[e], model.eq_obj2id[e])
            )
            what += f" (joint '{a}' coupled to joint '{b}')"
        named.append(what)
    return [f"equality constraint(s) {_listed(named, quoted=False)}"] if named else []


def _frictionloss(model: mujoco.MjModel) -> list[str]:
    if _disabled(model, mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS):
        return []
    dofs = np.nonzero(model.dof_frictionloss > 0)[0]
    joints = [_name(model, mujoco.mjtObj.mjOBJ_JOINT, int(model.dof_jntid[d]), "joint") for d in dofs]
    tendons = [
        _name(model, mujoco.mjtObj.mjOBJ_TENDON, int(t), "tendon") for t in np.nonzero(model.tendon_frictionloss > 0)[0]
    ]
    named = list(dict.fromkeys(joints)) + [f"tendon {t}" for t in tendons]
    return [f"the dry friction (frictionloss) of {_listed(named)}"] if named else []


def _only_mujoco(model: mujoco.MjModel) -> list[str]:
    """Passive forces MuJoCo alone computes, set to zero on `model` (one line per kind)."""
    out = []
    sprung = np.nonzero((model.tendon_stiffness > 0) | (model.tendon_damping > 0))[0]
    if len(sprung):
        names = [_name(model, mujoco.mjtObj.mjOBJ_TENDON, int(t), "tendon") for t in sprung]
        model.tendon_stiffness[sprung] = 0.0
        model.tendon_damping[sprung] = 0.0
        out.append(f"the spring and damper of tendon(s) {_listed(names)} (MuJoCo only, not compared)")
    if model.opt.density or model.opt.viscosity:
        medium = f"density {model.opt.density:g} kg/m^3, viscosity {model.opt.viscosity:g} Pa s"
        model.opt.density, model.opt.viscosity = 0.0, 0.0
        out.append(f"the fluid forces of the medium ({medium}) (MuJoCo only, not compared)")
    compensated = np.nonzero(model.body_gravcomp)[0]
    if len(compensated):
        names = [_name(model, mujoco.mjtObj.mjOBJ_BODY, int(b), "body") for b in compensated]
        model.body_gravcomp[compensated] = 0.0
        out.append(f"the gravity compensation (gravcomp) of body(ies) {_listed(names)} (MuJoCo only, not compared)")
    return out


def joint_actuators(model: mujoco.MjModel) -> list[int]:
    """The actuators whose force is gear x control on one joint (a joint transmission, no activation
    dynamics, a fixed unit gain: a motor): the inputs every source can be given. The others (a servo's
    gain kp, a tendon) are never driven."""
    return [
        a
        for a in range(model.nu)
        if int(model.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT)
        and int(model.actuator_dyntype[a]) == int(mujoco.mjtDyn.mjDYN_NONE)
        and int(model.actuator_gaintype[a]) == int(mujoco.mjtGain.mjGAIN_FIXED)
        and float(model.actuator_gainprm[a, 0]) == 1.0
    ]


def _actuators(model: mujoco.MjModel) -> list[str]:
    """Actuator forces at zero control (a servo's feedback, set to zero on `model`) and actuators no
    source can be given an input through, one line per kind."""
    out = []
    biased = [a for a in range(model.nu) if int(model.actuator_biastype[a]) != int(mujoco.mjtBias.mjBIAS_NONE)]
    if biased:
        names = [_name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a, "actuator") for a in biased]
        model.actuator_biastype[biased] = int(mujoco.mjtBias.mjBIAS_NONE)
        out.append(f"the feedback (bias force) of actuator(s) {_listed(names)}, a controller's, not the plant's")
    if not _disabled(model, mujoco.mjtDisableBit.mjDSBL_CLAMPCTRL) and np.any(model.actuator_ctrllimited):
        limited = [
            _name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, int(a), "actuator")
            for a in np.nonzero(model.actuator_ctrllimited)[0]
        ]
        model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CLAMPCTRL)
        out.append(f"the control range of actuator(s) {_listed(limited)} (an input is the torque asked for, unclamped)")
    capped = np.nonzero(model.actuator_forcelimited)[0]
    held = np.nonzero(model.jnt_actfrclimited)[0]
    if len(capped) or len(held):
        names = [_name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, int(a), "actuator") for a in capped]
        names += [f"joint {_name(model, mujoco.mjtObj.mjOBJ_JOINT, int(j), 'joint')}" for j in held]
        model.actuator_forcelimited[capped] = 0
        model.jnt_actfrclimited[held] = 0
        out.append(f"the force range of {_listed(names)} (an input is the torque asked for, unclamped)")
    plain = set(joint_actuators(model))
    other = [_name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a, "actuator") for a in range(model.nu) if a not in plain]
    if other:
        out.append(
            f"actuator(s) {_listed(other)} (a tendon or site transmission, activation dynamics or a gain other "
            "than 1: a servo): never driven, so no input goes through them"
        )
    return out


def constraints(model: mujoco.MjModel) -> list[str]:
    """One line per kind of constraint `model` has switched on, naming its elements (empty: none)."""
    if _disabled(model, mujoco.mjtDisableBit.mjDSBL_CONSTRAINT):  # every constraint off already
        return []
    return _contacts(model) + _limits(model) + _equalities(model) + _frictionloss(model)


def unconstrained(model: mujoco.MjModel) -> list[str]:
    """Switches `model`'s constraints off (and zeroes the passive forces only MuJoCo computes); returns
    one line per kind that was left out, naming its elements (module docstring)."""
    left = constraints(model)
    model.opt.disableflags |= CONSTRAINT_FLAGS
    return left + _only_mujoco(model) + _actuators(model)

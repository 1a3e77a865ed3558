"""MuJoCo's run of a model as published (its constraints switched back on) up to the first constraint
that acts, for `check --constraints` (validate/dynamics/constrained.py judges it)."""

from __future__ import annotations

import mujoco
import numpy as np

from ..core.arrays import Floats
from ..systems import System
from .base import SteppedSource

_WHAT = {
    int(mujoco.mjtConstraint.mjCNSTR_EQUALITY): "equality constraint '{}' acts",
    int(mujoco.mjtConstraint.mjCNSTR_FRICTION_DOF): "the dry friction of joint '{}' acts",
    int(mujoco.mjtConstraint.mjCNSTR_FRICTION_TENDON): "the dry friction of tendon '{}' acts",
    int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT): "joint '{}' reaches its range",
    int(mujoco.mjtConstraint.mjCNSTR_LIMIT_TENDON): "tendon '{}' reaches its range",
}


def _which(m: mujoco.MjModel, d: mujoco.MjData) -> str:
    """The first active constraint row, in words."""
    kind, i = int(d.efc_type[0]), int(d.efc_id[0])
    if kind in _WHAT:
        obj = {
            int(mujoco.mjtConstraint.mjCNSTR_EQUALITY): mujoco.mjtObj.mjOBJ_EQUALITY,
            int(mujoco.mjtConstraint.mjCNSTR_FRICTION_DOF): mujoco.mjtObj.mjOBJ_JOINT,
            int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT): mujoco.mjtObj.mjOBJ_JOINT,
        }.get(kind, mujoco.mjtObj.mjOBJ_TENDON)
        if kind == int(mujoco.mjtConstraint.mjCNSTR_FRICTION_DOF):
            i = int(m.dof_jntid[i])
        return _WHAT[kind].format(mujoco.mj_id2name(m, obj, i) or f"#{i}")
    a, b = (int(g) for g in d.contact.geom[i])
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom#{g}" for g in (a, b)]
    return f"geoms '{names[0]}' and '{names[1]}' touch"


def constrained_run(
    system: System, source: SteppedSource, t: np.ndarray, q0: Floats, v0: Floats
) -> tuple[np.ndarray, float | None, str]:
    """MuJoCo's run of the model as published (constraints on) sampled on `t` until the first active
    constraint: (samples (k, n) up to it, its time or None, what it was)."""
    m, d = source.m, source.d
    saved = m.opt.disableflags
    m.opt.disableflags = system.published_flags
    try:
        mujoco.mj_resetData(m, d)
        source.set_state(np.asarray(q0, dtype=float), np.asarray(v0, dtype=float))
        mujoco.mj_forward(m, d)
        steps = max(round(float(t[1] - t[0]) / m.opt.timestep), 1) if len(t) > 1 else 1
        out = [source.get_state()[0]]
        for _ in range(len(t) - 1):
            for _ in range(steps):
                if d.nefc:
                    return np.array(out), float(d.time), _which(m, d)
                mujoco.mj_step(m, d)
            out.append(source.get_state()[0])
        return np.array(out), None, ""
    finally:
        m.opt.disableflags = saved
        mujoco.mj_resetData(m, d)

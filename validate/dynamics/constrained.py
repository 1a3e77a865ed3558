"""`check --constraints`: the model's own constrained motion against the equations, up to the first
constraint that acts.

Every other comparison switches the model's constraints off (systems/scope.py): a derivation of the
chain has none of their forces. On request, MuJoCo runs the model as published (its ranges, contacts,
equality constraints and dry friction switched back on, its own integrator and timestep) from the start
the trajectories use, until the first constraint row appears in its solver (`d.nefc > 0`): a joint
reaching its range, a contact, an equality constraint, dry friction. Up to then the motion is the
smooth dynamics' and is compared with the reference solution of the person's equations, judged against
the run's own Richardson estimate (validate/dynamics/estimate.py). The result says when and which:
"agrees until 0.43 s, when joint 'slider' reaches its range".
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from ..engines.base import SteppedSource
from ..systems import System
from .estimate import threshold
from .integrate import initial_state, time_grid
from .reference import reference_trajectory
from .trust import TRUST

_WHAT = {
    int(mujoco.mjtConstraint.mjCNSTR_EQUALITY): "equality constraint '{}' acts",
    int(mujoco.mjtConstraint.mjCNSTR_FRICTION_DOF): "the dry friction of joint '{}' acts",
    int(mujoco.mjtConstraint.mjCNSTR_FRICTION_TENDON): "the dry friction of tendon '{}' acts",
    int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT): "joint '{}' reaches its range",
    int(mujoco.mjtConstraint.mjCNSTR_LIMIT_TENDON): "tendon '{}' reaches its range",
}


def _which(m: Any, d: Any) -> str:
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


def constrained_run(system: System, source: SteppedSource, t: np.ndarray, q0: Any, v0: Any) -> tuple[np.ndarray, float | None, str]:
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


def until_constraint(system: System, source: SteppedSource, *, t_end: float = 10.0, dt_out: float = 0.01) -> dict[str, Any]:
    """The comparison of the module docstring: {"until" (s or None: no constraint acted), "what",
    "max_error" (rad, before it), "passed", "statement"}."""
    q0, v0 = initial_state(system)
    t = time_grid(t_end, dt_out)
    q, when, what = constrained_run(system, source, t, q0, v0)
    tau = np.zeros(system.nv)
    ref, _ = reference_trajectory(system, q0, v0, tau, t[: len(q)], cache_dir=None)
    error = np.abs(q - ref.q).max(axis=1)
    from .estimate import mujoco_estimate
    from .integrate import Trajectory

    integrator = {0: "Euler", 1: "RK4", 2: "implicit", 3: "implicitfast"}.get(int(source.m.opt.integrator), "Euler")
    run = Trajectory("mujoco", f"MuJoCo {integrator}", t[: len(q)].copy(), q, np.zeros_like(q), {})
    estimate = mujoco_estimate(system, source, run, q0, v0, tau, integrator=integrator)[0] if len(q) > 1 else np.zeros(1)
    bound = threshold(estimate)
    # judged while the run's own threshold stays below TRUST: beyond, it cannot tell equations apart (trust.py)
    judged = np.cumprod(bound <= TRUST).astype(bool)
    end = float(run.t[judged][-1])
    passed = bool(np.all(error[judged] <= bound[judged]))
    verb = "agrees" if passed else "disagrees"
    if when is not None and judged.all():
        span = f"until {when:.3g} s, when {what}"
    elif when is not None:
        span = f"over the {end:g} s its own error estimate can judge (to {TRUST:g} rad); then, at {when:.3g} s, {what}"
    else:
        span = f"over the {end:g} s its own error estimate can judge (to {TRUST:g} rad); no constraint acted in {t_end:g} s"
    return {
        "until": when,
        "what": what,
        "judged_until": end,
        "max_error": float(error[judged].max()),
        "passed": passed,
        "statement": f"the model's constrained motion (MuJoCo {integrator}) {verb} with the equations {span}",
    }

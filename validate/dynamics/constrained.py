"""`check --constraints`: the model's own constrained motion against the equations, up to the first
constraint that acts.

Every other comparison switches the model's constraints off (model/scope.py): a derivation of the
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

import numpy as np

from ..model.start import Start
from ..sources.base import SteppedSource
from ..sources.constraints import constrained_run
from ..systems import System
from .estimate import threshold
from .integrate import initial_state, time_grid
from .reference import reference_trajectory
from .trust import TRUST


def until_constraint(
    system: System, source: SteppedSource, *, t_end: float = 10.0, dt_out: float = 0.01
) -> dict[str, Any]:
    """The comparison of the module docstring: {"until" (s or None: no constraint acted), "what",
    "max_error" (rad, before it), "passed", "statement"}."""
    q0, v0 = initial_state(system)
    t = time_grid(t_end, dt_out)
    q, when, what = constrained_run(system, source, t, q0, v0)
    start = Start.at_rest(q0, v0)
    ref, _ = reference_trajectory(system, start, t[: len(q)], cache_dir=None)
    error = np.abs(q - ref.q).max(axis=1)
    from .estimate import mujoco_estimate
    from .integrate import Trajectory

    integrator = {0: "Euler", 1: "RK4", 2: "implicit", 3: "implicitfast"}.get(int(source.m.opt.integrator), "Euler")
    run = Trajectory("mujoco", f"MuJoCo {integrator}", t[: len(q)].copy(), q, np.zeros_like(q), {})
    estimate = mujoco_estimate(system, source, run, start, integrator=integrator)[0] if len(q) > 1 else np.zeros(1)
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
        span = (
            f"over the {end:g} s its own error estimate can judge (to {TRUST:g} rad); "
            f"no constraint acted in {t_end:g} s"
        )
    return {
        "until": when,
        "what": what,
        "judged_until": end,
        "max_error": float(error[judged].max()),
        "passed": passed,
        "statement": f"the model's constrained motion (MuJoCo {integrator}) {verb} with the equations {span}",
    }

"""The largest stable timestep per integrator (bisection on the energy criterion), and stiff friction."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ...dynamics.integrate import initial_state, scipy_trajectory, time_grid
from ...dynamics.mirror import eulerdamp_active
from ...engines import make_sources
from ...engines.base import Source
from ...errors import HarnessError
from ...systems import System
from .energy import classify_energy
from .runs import minimum_potential, run_energy, simulate
from .settings import (
    BISECTION_RATIO,
    DT_RANGE,
    GROWTH,
    MIRROR_INTEGRATORS,
    MUJOCO_INTEGRATORS,
    NO_EULERDAMP,
    SAMPLES_PER_RUN,
    Settings,
)


def stability_trial(
    system: System,
    sources: Mapping[str, Source],
    engine: str,
    integrator: str,
    q0: Any,
    v0: Any,
    tau: Any,
    *,
    timestep: float,
    t_end: float,
    V_min: float,
    eulerdamp: bool = True,
    growth: float = GROWTH,
) -> dict[str, Any]:
    """One run at one timestep: stable or not, and why."""
    steps = max(1, math.ceil(t_end / timestep - 1e-9))
    run = simulate(
        system,
        sources,
        engine,
        integrator,
        q0,
        v0,
        tau,
        timestep=timestep,
        t_end=t_end,
        sample_steps=max(1, math.ceil(steps / SAMPLES_PER_RUN)),
        eulerdamp=eulerdamp,
    )
    c = classify_energy(
        run.t, run_energy(sources["hand"], run), V_min=V_min, failure=run.failure, t_fail=run.t_fail, growth=growth
    )
    return {
        "timestep": timestep,
        "stable": c["class"] != "unstable",
        "reason": c["reason"] if c["class"] == "unstable" else None,
        "t_fail": c["t_fail"],
        "relative_max": c["relative_max"],
    }


def max_stable_timestep(
    trial: Callable[[float], dict[str, Any]],
    *,
    dt_range: tuple[float, float] = DT_RANGE,
    ratio: float = BISECTION_RATIO,
) -> dict[str, Any]:
    """Bisection on log(dt): the largest stable timestep in `dt_range`, to within `ratio`.

    `trial(dt)` returns {"stable": bool, ...}. The top of the range is tried first (stable there: done);
    the bottom is assumed stable and tried only if the bisection ends on it.

    Returns:
        {"max_stable": dt or None (unstable at the bottom), "min_unstable": dt or None (stable at the top),
         "trials": [trial results in the order run], "reason": why min_unstable failed}
    """
    lo, hi = dt_range
    trials = [trial(hi)]
    if trials[-1]["stable"]:
        return {"max_stable": hi, "min_unstable": None, "trials": trials, "reason": None}
    failed = trials[-1]
    while hi / lo > ratio:
        mid = math.sqrt(lo * hi)
        trials.append(trial(mid))
        if trials[-1]["stable"]:
            lo = mid
        else:
            hi, failed = mid, trials[-1]
    if lo == dt_range[0]:
        trials.append(trial(lo))
        if not trials[-1]["stable"]:
            return {"max_stable": None, "min_unstable": lo, "trials": trials, "reason": trials[-1]["reason"]}
    return {"max_stable": lo, "min_unstable": hi, "trials": trials, "reason": failed["reason"]}


def criterion_name(growth: float) -> str:
    if math.isinf(growth):
        return "divergence"
    return f"energy x{1 + growth:g}"


def stability_rows(
    system: System, sources: Mapping[str, Source], settings: Settings, *, V_min: float
) -> list[dict[str, Any]]:
    """Per speed, engine, integrator and criterion (settings.growth_factors): the bisection's result."""
    q0, _ = initial_state(system)
    tau = np.zeros(system.nv)
    rows = []
    runs = [("mujoco", i) for i in MUJOCO_INTEGRATORS] + [("mirror", i) for i in MIRROR_INTEGRATORS]
    for speed in settings.speeds:
        v0 = np.full(system.nv, float(speed))
        for engine, integrator in runs:
            for growth in settings.growth_factors:

                def trial(
                    dt: float, e: str = engine, i: str = integrator, v: np.ndarray = v0, g: float = growth
                ) -> dict[str, Any]:
                    return stability_trial(
                        system,
                        sources,
                        e,
                        i,
                        q0,
                        v,
                        tau,
                        timestep=dt,
                        t_end=settings.stability_t_end,
                        V_min=V_min,
                        growth=g,
                    )

                found = max_stable_timestep(trial)
                rows.append(
                    {
                        "system": system.name,
                        "engine": engine,
                        "integrator": integrator,
                        "speed": float(speed),
                        "criterion": criterion_name(growth),
                        "growth_factor": None if math.isinf(growth) else growth,
                        "q0": q0,
                        "v0": v0,
                        "t_end": settings.stability_t_end,
                        "range": list(DT_RANGE),
                        "bisection_ratio": BISECTION_RATIO,
                        **found,
                    }
                )
    return rows


def stiff_rows(system: System, settings: Settings) -> list[dict[str, Any]]:
    """Every integrator at every timestep on the system with its joint damping times each factor."""
    q0, v0 = initial_state(system)
    tau = np.zeros(system.nv)
    t = time_grid(settings.stiff_t_end, settings.stiff_sample)
    rows = []
    for factor in settings.damping_factors:
        extra = tuple((f"joint/{j}/damping", float(system.view[f"joint/{j}/damping"]) * factor) for j in system.joints)
        damped = system.derive(overrides=(*system.overrides, *extra))
        sources = make_sources(damped)
        V_min = minimum_potential(damped, sources["hand"])
        ref = scipy_trajectory(damped, sources["hand"], q0, v0, tau, t, method="DOP853", rtol=1e-12, atol=1e-12)
        runs = [("mujoco", i, True) for i in MUJOCO_INTEGRATORS] + [("mirror", "Euler", True)]
        if eulerdamp_active(damped):
            runs.append(("mujoco", NO_EULERDAMP, False))
        for engine, integrator, eulerdamp in runs:
            for dt in settings.stiff_timesteps:
                steps = round(settings.stiff_sample / dt)
                if steps < 1 or not math.isclose(steps * dt, settings.stiff_sample, rel_tol=1e-9):
                    raise HarnessError(f"stiff timestep {dt} must divide the sample step {settings.stiff_sample}.")
                run = simulate(
                    damped,
                    sources,
                    engine,
                    "Euler" if integrator == NO_EULERDAMP else integrator,
                    q0,
                    v0,
                    tau,
                    timestep=dt,
                    t_end=settings.stiff_t_end,
                    sample_steps=steps,
                    eulerdamp=eulerdamp,
                )
                c = classify_energy(
                    run.t, run_energy(sources["hand"], run), V_min=V_min, failure=run.failure, t_fail=run.t_fail
                )
                k = len(run.t)
                err = np.abs(run.q - ref.q[:k]).max(axis=1) if k else np.array([np.inf])
                stable = c["class"] != "unstable"
                rows.append(
                    {
                        "system": system.name,
                        "damping_factor": float(factor),
                        "damping": {j: float(damped.view[f"joint/{j}/damping"]) for j in system.joints},
                        "engine": engine,
                        "integrator": integrator,
                        "eulerdamp": eulerdamp,
                        "timestep": dt,
                        "t_end": settings.stiff_t_end,
                        "stable": stable,
                        "reason": None if stable else c["reason"],
                        "t_fail": c["t_fail"],
                        "max_error": float(err.max()) if stable else None,
                        "final_error": float(err[-1]) if stable else None,
                        "reference": ref.method,
                        "energy_relative_max": c["relative_max"],
                    }
                )
    return rows

"""The largest stable timestep per integrator (bisection on the energy criterion), and stiff friction."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np

from ...core.errors import HarnessError
from ...dynamics.integrate import Trajectory, energy_missing, initial_state, scipy_trajectory, time_grid
from ...dynamics.mirror import compiled_steps, eulerdamp_active
from ...model.start import Scheme, Start
from ...results.schema import Found, Search, StabilityRow, StiffBase, StiffOutcome, StiffRow, StiffRun, Trial
from ...sources import make_sources
from ...sources.base import Source
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
    Run,
    Settings,
)


def stability_trial(
    system: System,
    sources: Mapping[str, Source],
    engine: str,
    start: Start,
    stepping: Scheme,
    *,
    t_end: float,
    V_min: float,
    eulerdamp: bool = True,
    growth: float = GROWTH,
) -> Trial:
    """One run at one timestep: stable or not, and why."""
    run, E = trial_run(system, sources, engine, start, stepping, t_end=t_end, eulerdamp=eulerdamp)
    return judged(run, E, timestep=stepping.timestep, V_min=V_min, growth=growth)


def trial_run(
    system: System,
    sources: Mapping[str, Source],
    engine: str,
    start: Start,
    stepping: Scheme,
    *,
    t_end: float,
    eulerdamp: bool = True,
) -> tuple[Run, np.ndarray | None]:
    """One stability run and its energy E = T + V by the hand equations (None where the module leaves
    T or V out: then divergence alone is judged)."""
    steps = max(1, math.ceil(t_end / stepping.timestep - 1e-9))
    run = simulate(
        system,
        sources,
        engine,
        start,
        stepping,
        t_end=t_end,
        sample_steps=sample_steps(engine, steps),
        eulerdamp=eulerdamp,
    )
    return run, None if energy_missing(sources["hand"]) else run_energy(sources["hand"], run)


def sample_steps(engine: str, steps: int) -> int:
    """Steps between the state checks of a stability run (SAMPLES_PER_RUN a run); a mirror's a multiple
    of MIRROR_BLOCK, so that its compiled RK4 is the same function at every timestep tried."""
    every = max(1, math.ceil(steps / SAMPLES_PER_RUN))
    return every if engine == "mujoco" else MIRROR_BLOCK * math.ceil(every / MIRROR_BLOCK)


def judged(run: Run, E: np.ndarray | None, *, timestep: float, V_min: float, growth: float) -> Trial:
    """A stability run judged under one criterion (`growth`; without an energy, divergence alone)."""
    if E is None:
        stable = run.failure is None
        return {
            "timestep": timestep,
            "stable": stable,
            "reason": run.failure,
            "t_fail": run.t_fail,
            "relative_max": None,
        }
    c = classify_energy(run.t, E, V_min=V_min, failure=run.failure, t_fail=run.t_fail, growth=growth)
    return {
        "timestep": timestep,
        "stable": c["class"] != "unstable",
        "reason": c["reason"] if c["class"] == "unstable" else None,
        "t_fail": c["t_fail"],
        "relative_max": c["relative_max"],
    }


def max_stable_timestep(
    trial: Callable[[float], Trial],
    *,
    dt_range: tuple[float, float] = DT_RANGE,
    ratio: float = BISECTION_RATIO,
) -> Search:
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


def search_range(engine: str, settings: Settings, step_cost: float = 0.0) -> tuple[float, float]:
    """DT_RANGE, its bottom raised to where one run of `stability_t_end` takes the settings' most steps
    for this engine (MuJoCo's C loop, or a mirror's compiled or Python steps), and for a mirror also
    where it would cost more than `mirror_trial_seconds` at `step_cost` (s a step)."""
    most = settings.mujoco_trial_steps if engine == "mujoco" else settings.mirror_trial_steps
    if engine != "mujoco" and step_cost > 0:
        most = min(most, max(1, int(settings.mirror_trial_seconds / step_cost)))
    return min(DT_RANGE[1], max(DT_RANGE[0], settings.stability_t_end / most)), DT_RANGE[1]


MIRROR_BLOCK = 10  # a mirror run's steps per sample are a multiple of this: one compiled RK4 per system


# Seconds a mirror step is taken to cost, by how it steps: what bounds its search (`search_range`) and the
# stiff runs left out. Nominal, not measured: a wall time made the rows depend on the machine's load (a
# stress run on a busy dask cluster searched other ranges than the same run in process).
NOMINAL_STEP_S = {"compiled": 2e-6, "python": 50e-6, "worker": 500e-6}


def mirror_step_kind(sources: Mapping[str, Source], integrator: str) -> str:
    """How the person's equations step in a mirror: "compiled" (MuJoCo's RK4 compiled by heyoka),
    "worker" (a person's module in its worker process: a round trip a step) or "python"."""
    hand = sources["hand"]
    if compiled_steps(hand, integrator, MIRROR_BLOCK) is not None:
        return "compiled"
    functions = getattr(hand, "eq", None)
    return "worker" if getattr(getattr(functions, "mass_matrix", None), "in_worker", None) is not None else "python"


def mirror_step_cost(sources: Mapping[str, Source], integrator: str) -> float:
    """Seconds one mirror step of `integrator` on the person's equations is taken to cost
    (NOMINAL_STEP_S of its kind): what bounds how far down its search goes (`search_range`)."""
    return NOMINAL_STEP_S[mirror_step_kind(sources, integrator)]


def stability_rows(
    system: System, sources: Mapping[str, Source], settings: Settings, *, V_min: float
) -> list[StabilityRow]:
    """Per speed, engine, integrator and criterion (settings.growth_factors; divergence alone where the
    module leaves out its energies): the bisection's result (`searches`)."""
    q0, _ = initial_state(system)
    rows: list[StabilityRow] = []
    runs = [("mujoco", i) for i in MUJOCO_INTEGRATORS] + [("mirror", i) for i in MIRROR_INTEGRATORS]
    growths = [math.inf] if energy_missing(sources["hand"]) else list(settings.growth_factors)
    for speed in settings.speeds:
        v0 = np.full(system.nv, float(speed))
        for engine, integrator in runs:
            for growth, found in zip(
                growths, searches(system, sources, engine, integrator, v0, settings, growths, V_min), strict=True
            ):
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
                        "bisection_ratio": BISECTION_RATIO,
                        **found,
                    }
                )
    return rows


def searches(
    system: System,
    sources: Mapping[str, Source],
    engine: str,
    integrator: str,
    v0: np.ndarray,
    settings: Settings,
    growths: list[float],
    V_min: float,
) -> list[Found]:
    """The bisection under each criterion of `growths`, from the system's q0 at speeds v0; a run at a
    timestep is made once and judged under every criterion."""
    q0, _ = initial_state(system)
    tau = np.zeros(system.nv)
    made: dict[float, tuple[Run, np.ndarray | None]] = {}

    def run_at(dt: float) -> tuple[Run, np.ndarray | None]:
        if dt not in made:
            made[dt] = trial_run(
                system, sources, engine, Start.of(q0, v0, tau), Scheme(integrator, dt), t_end=settings.stability_t_end
            )
        return made[dt]

    cost = mirror_step_cost(sources, integrator) if engine == "mirror" else 0.0
    out: list[Found] = []
    for growth in growths:

        def trial(dt: float, g: float = growth) -> Trial:
            return judged(*run_at(dt), timestep=dt, V_min=V_min, growth=g)

        found = max_stable_timestep(trial, dt_range=search_range(engine, settings, cost))
        out.append({**found, "range": list(search_range(engine, settings, cost)), "step_cost_s": cost or None})
    return out


def stiff_rows(system: System, settings: Settings, V_min: float | None = None) -> list[StiffRow]:
    """Every integrator at every timestep on the system with its joint damping times each factor
    (a mirror run that would cost more than `mirror_trial_seconds` is listed as not run, with why).
    `V_min`: the system's smallest potential, which damping does not change (None: found here)."""
    q0, v0 = initial_state(system)
    tau = np.zeros(system.nv)
    t = time_grid(settings.stiff_t_end, settings.stiff_sample)
    rows: list[StiffRow] = []
    if V_min is None:
        hand = make_sources(system)["hand"]
        V_min = float("nan") if energy_missing(hand) else minimum_potential(system, hand)
    for factor in settings.damping_factors:
        extra = tuple((f"joint/{j}/damping", float(system.view[f"joint/{j}/damping"]) * factor) for j in system.joints)
        damped = system.derive(overrides=(*system.overrides, *extra))
        sources = make_sources(damped)
        ref = scipy_trajectory(
            damped, sources["hand"], Start.of(q0, v0, tau), t, method="DOP853", rtol=1e-12, atol=1e-12
        )
        runs = [("mujoco", i, True) for i in MUJOCO_INTEGRATORS] + [("mirror", "Euler", True)]
        if eulerdamp_active(damped):
            runs.append(("mujoco", NO_EULERDAMP, False))
        cost = mirror_step_cost(sources, "Euler")
        base: StiffBase = {
            "system": system.name,
            "damping_factor": float(factor),
            "t_end": settings.stiff_t_end,
            "damping": {j: float(damped.view[f"joint/{j}/damping"]) for j in system.joints},
            "reference": ref.method,
        }
        for engine, integrator, eulerdamp in runs:
            for dt in settings.stiff_timesteps:
                steps = round(settings.stiff_sample / dt)
                if steps < 1 or not math.isclose(steps * dt, settings.stiff_sample, rel_tol=1e-9):
                    raise HarnessError(f"stiff timestep {dt} must divide the sample step {settings.stiff_sample}.")
                row: StiffRun = {
                    **base,
                    "engine": engine,
                    "integrator": integrator,
                    "eulerdamp": eulerdamp,
                    "timestep": dt,
                }
                total = settings.stiff_t_end / dt
                if engine == "mirror" and cost * total > settings.mirror_trial_seconds:
                    why = (
                        f"not run: {total:.0f} steps at {cost * 1e3:.2g} ms a step would take about "
                        f"{cost * total:.0f} s, more than {settings.mirror_trial_seconds:g} s"
                    )
                    rows.append({**row, "stable": None, "reason": why, "t_fail": None, "max_error": None})
                    continue
                run = simulate(
                    damped,
                    sources,
                    engine,
                    Start.of(q0, v0, tau),
                    Scheme("Euler" if integrator == NO_EULERDAMP else integrator, dt),
                    t_end=settings.stiff_t_end,
                    sample_steps=steps,
                    eulerdamp=eulerdamp,
                )
                E = None if energy_missing(sources["hand"]) else run_energy(sources["hand"], run)
                rows.append({**row, **_stiff_outcome(run, E, ref, V_min=V_min, timestep=dt)})
    return rows


def _stiff_outcome(run: Run, E: np.ndarray | None, ref: Trajectory, *, V_min: float, timestep: float) -> StiffOutcome:
    """A stiff-friction run judged: stable or not (by its energy, or by divergence alone without one),
    and its error against the reference."""
    verdict = judged(run, E, timestep=timestep, V_min=V_min, growth=GROWTH)
    k = len(run.t)
    err = np.abs(run.q - ref.q[:k]).max(axis=1) if k else np.array([np.inf])
    stable = verdict["stable"]
    return {
        "stable": stable,
        "reason": verdict["reason"],
        "t_fail": verdict["t_fail"],
        "max_error": float(err.max()) if stable else None,
        "final_error": float(err[-1]) if stable else None,
        "energy_relative_max": verdict["relative_max"],
    }

"""What a long run's energy does: conserved to rounding, bounded oscillation, secular drift,
numerical damping, energy injection, irregular.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ...core.arrays import Floats
from ...dynamics.integrate import initial_state
from ...model.start import Scheme, Start
from ...results.schema import DriftRow, EnergyClass
from ...sources.base import Source
from ...systems import System
from .runs import downsample, run_energy, simulate
from .settings import (
    ENVELOPE_GROWTH,
    GROWTH,
    LARGE_CHANGE,
    MIRROR_INTEGRATORS,
    MUJOCO_INTEGRATORS,
    ROUND_OFF,
    STEADY_R2,
    Settings,
)
from .shapes import Trend


def classify_energy(
    t: Floats,
    E: Floats,
    *,
    V_min: float,
    failure: str | None = None,
    t_fail: float | None = None,
    growth: float = GROWTH,
) -> EnergyClass:
    """The energy behaviour of one run (see the module docstring for the classes).

    Args:
        t: (K,) sample times, s, starting at the initial state.
        E: (K,) total energy, J; E[0] is the initial energy.
        V_min: J, the potential's minimum, so E0 - V_min is the energy available to the motion.
        failure: a failure seen while running (MuJoCo warning, non-finite state, overflow), or None.
        growth: the energy-gain factor beyond which the run is unstable (GROWTH).

    Returns:
        {"class", "direction", "reason", "max_abs", "final", "relative_max", "relative_final", "early_envelope",
         "late_envelope", "rate" (J/s, the slope of the line fitted to |dE| vs t), "r2", "E0", "available"}
    """
    t, E = np.asarray(t, dtype=float), np.asarray(E, dtype=float)
    dE = E - float(E[0])
    out = energy_extent(E, dE, V_min=V_min, t_fail=t_fail)
    unstable = instability(t, E, dE, out["available"], failure=failure, growth=growth)
    if unstable is not None:
        return {**out, **unstable}
    trend, late_mean = energy_trend(t, dE)
    return {**out, **trend, **steady_class(out, trend, late_mean)}


def energy_extent(E: np.ndarray, dE: np.ndarray, *, V_min: float, t_fail: float | None) -> EnergyClass:
    """The energy available to the motion and the largest and final change of E (dE = E - E[0]), absolute and
    relative to it; the trend's keys are None until energy_trend fills them."""
    E0 = float(E[0])
    available = max(E0 - V_min, np.finfo(float).tiny)
    out: EnergyClass = {
        "E0": E0,
        "V_min": float(V_min),
        "available": available,
        "direction": None,
        "t_fail": t_fail,
        "rate": None,
        "r2": None,
        "early_envelope": None,
        "late_envelope": None,
    }
    finite = np.isfinite(E)
    good = dE[finite]
    out["max_abs"] = float(np.abs(good).max()) if good.size else float("inf")
    out["final"] = float(dE[-1]) if finite[-1] else float("nan")
    out["relative_max"] = out["max_abs"] / available
    out["relative_final"] = out["final"] / available
    return out


def instability(
    t: np.ndarray, E: np.ndarray, dE: np.ndarray, available: float, *, failure: str | None, growth: float
) -> EnergyClass | None:
    """The class, reason (and, for an energy gain, the time it set in) of an unstable run; None if it is not."""
    finite = np.isfinite(E)
    good = dE[finite]
    gain = float(good.max()) if good.size else float("inf")
    if failure or not finite.all():
        return {"class": "unstable", "reason": failure or "non-finite energy"}
    if gain > growth * available:
        t_grow = float(t[np.argmax(dE > growth * available)])
        return {
            "class": "unstable",
            "t_fail": t_grow,
            "reason": f"energy gain {gain:.3g} J > {growth:g} x (E0 - V_min) = {growth * available:.3g} J",
        }
    return None


def energy_trend(t: np.ndarray, dE: np.ndarray) -> tuple[Trend, float]:
    """The |dE| envelopes of the first and last tenth of the run, the line fitted to |dE| against t (its
    slope and R^2), and the direction of the change; with the mean dE over the last tenth."""
    h = t[-1] - t[0]
    a = np.abs(dE)
    early = a[(t > t[0]) & (t <= t[0] + 0.1 * h)]
    late = a[t >= t[0] + 0.9 * h]
    early_env = float(early.max()) if early.size else 0.0
    late_env = float(late.max()) if late.size else 0.0
    slope, intercept = np.polyfit(t, a, 1)
    resid = a - (slope * t + intercept)
    var = float(np.sum((a - a.mean()) ** 2))
    r2 = 1.0 - float(np.sum(resid**2)) / var if var > 0 else 0.0
    late_mean = float(dE[t >= t[0] + 0.9 * h].mean())
    direction = "loss" if late_mean < 0 else "gain"
    trend: Trend = {
        "early_envelope": early_env,
        "late_envelope": late_env,
        "rate": float(slope),
        "r2": r2,
        "direction": direction,
    }
    return trend, late_mean


def steady_class(out: EnergyClass, trend: Trend, late_mean: float) -> EnergyClass:
    """The class and reason of a stable run (round-off, bounded oscillation, irregular, drift, damping or
    injection) from its extent (out), its trend and the mean dE over its last tenth."""
    available, early_env, late_env = out["available"], trend["early_envelope"], trend["late_envelope"]
    slope, r2, direction = trend["rate"], trend["r2"], trend["direction"]
    if out["relative_max"] <= ROUND_OFF:
        return {
            "class": "round-off",
            "direction": None,
            "reason": f"max |dE| = {out['relative_max']:.2g} of E0 - V_min <= {ROUND_OFF:g}",
        }
    if late_env <= ENVELOPE_GROWTH * early_env:
        return {
            "class": "bounded oscillation",
            "direction": None,
            "reason": f"late |dE| envelope {late_env:.2g} J <= {ENVELOPE_GROWTH:g} x early {early_env:.2g} J",
        }
    if r2 < STEADY_R2:
        return {
            "class": "irregular",
            "reason": f"|dE| envelope grows ({early_env:.2g} -> {late_env:.2g} J) but no line fits (R^2 {r2:.2f})",
        }
    large = abs(late_mean) >= LARGE_CHANGE * available
    cls = ("numerical damping" if direction == "loss" else "energy injection") if large else "secular drift"
    return {
        "class": cls,
        "reason": f"|dE| grows at {slope:.2g} J/s (R^2 {r2:.2f}); {direction} of {abs(late_mean) / available:.2g} "
        f"of E0 - V_min by the end",
    }


def conservative(system: System) -> bool:
    return not ({"damping", "actuation"} & set(system.uses))


def drift_rows(system: System, sources: Mapping[str, Source], settings: Settings, *, V_min: float) -> list[DriftRow]:
    """Energy over every horizon, for every MuJoCo integrator and mirror, at the MJCF timestep."""
    q0, v0 = initial_state(system)
    tau = np.zeros(system.nv)
    dt = float(system.mujoco_model().opt.timestep)
    sample_steps = max(1, round(settings.drift_sample / dt))
    horizon = max(settings.drift_horizons)
    rows: list[DriftRow] = []
    runs = [("mujoco", i) for i in MUJOCO_INTEGRATORS] + [("mirror", i) for i in MIRROR_INTEGRATORS]
    for engine, integrator in runs:
        run = simulate(
            system,
            sources,
            engine,
            Start.of(q0, v0, tau),
            Scheme(integrator, dt),
            t_end=horizon,
            sample_steps=sample_steps,
        )
        E = run_energy(sources["hand"], run)
        for h in settings.drift_horizons:
            keep = run.t <= h + 1e-9
            failed_within = run.failure is not None and run.t_fail is not None and run.t_fail <= h + 1e-9
            c = classify_energy(
                run.t[keep],
                E[keep],
                V_min=V_min,
                failure=run.failure if failed_within else None,
                t_fail=run.t_fail if failed_within else None,
            )
            series = downsample(run.t[keep], E[keep] - E[0])
            rows.append(
                {
                    "system": system.name,
                    "engine": engine,
                    "integrator": integrator,
                    "timestep": dt,
                    "horizon": h,
                    "q0": q0,
                    "v0": v0,
                    **c,
                    "series": {"t": series["t"], "dE": series["y"]},
                }
            )
    return rows

"""Stress tests of numerical stability: long horizons, high energy, ill-conditioning, stiff friction.

Four experiments, written as sorted long-format rows to `reports/stress.json` (series are downsampled
to at most SERIES_POINTS points, so the report can plot them without the raw runs):

  drift           Energy E = T + V (by the hand equations) along free runs of `drift_horizons` from the
                  notes' initial state, on the conservative systems (USES without "damping" and
                  "actuation"): MuJoCo's Euler (semi-implicit), RK4, implicit and implicitfast at the
                  MJCF timestep, and the mirrors (validate/mirror.py) of RK4 and Euler on the hand
                  equations. One run of the longest horizon gives every shorter one (its first part).
  stability       The largest timestep at which each MuJoCo integrator and each fixed-step mirror stays
                  stable for `stability_t_end` from the notes' q0 with every speed (in the notes'
                  coordinates) set to s rad/s: bisection on log(dt) in DT_RANGE until the bracket's
                  ratio is below BISECTION_RATIO, under each criterion below.
  conditioning    Sweeps of a mass (or, where the masses do not enter M, an inertia) ratio between the
                  first and the last body, pushing cond(M) from 1 to ~1e12; at every point cond(M) over
                  the sampled states and the disagreement of the sources in q'' and tau_inverse
                  (compare.evaluate + compare.compare, whose rows carry the tier's tolerance).
  stiff_friction  Joint damping of the damped systems times `damping_factors`; every MuJoCo integrator
                  (and Euler with eulerdamp disabled) and the Euler mirror at `stiff_timesteps`, against
                  a tight DOP853 run of the hand equations with the same overrides.

Instability, everywhere: a non-finite state, any MuJoCo warning (mjWARN_BADQACC and the like: MuJoCo
resets the state when it raises one, so a run would afterwards look calm), an overflow in a mirror's
Python floats, or, under the energy criterion, an energy gain max(E - E0) > GROWTH x (E0 - V_min) with
GROWTH = 1: the energy above the potential's minimum doubles, so the run has made up as much energy as
the motion had and no longer describes the system, whether or not it ever overflows. (The stable run
that wanders furthest, semi-implicit Euler on the chaotic double pendulums at 1 ms, reaches 63 % of
E0 - V_min in 1000 s.) V_min is the smallest potential on a 65-point-per-coordinate grid (which holds
q = 0, where the notes' systems have it). The factor matters for some schemes, so every bisection runs
twice, under the energy criterion and under divergence alone (GROWTH = inf): measured at 10 and 50 rad/s
on the double pendulums, RK4's boundary does not move between GROWTH = 1, 10 and inf (it diverges
abruptly), Euler's moves by up to 5.6x, and implicit's from ~5e-5 s to beyond 0.1 s (its failure within
10 s is bounded energy injection; at 1 ms it diverges only after 165-737 s).

Energy classification of a run (`classify_energy`), from dE = E - E0 over the horizon H:
  unstable              as above;
  round-off             max |dE| <= ROUND_OFF (1e-12) x (E0 - V_min): each energy evaluation rounds at ~10 eps
                        and 1e5-1e6 steps accumulate ~sqrt(N) eps of rounding, so nothing below says more;
  bounded oscillation   the envelope of |dE| over the last tenth of H is at most ENVELOPE_GROWTH times
                        that over the first tenth;
  secular drift         it grows and a straight line fits |dE| vs t (R^2 >= STEADY_R2): a steady trend,
                        below 1 % of E0 - V_min by the end; "direction" says loss or gain;
  numerical damping     a steady loss of 1 % of E0 - V_min or more;
  energy injection      a steady gain of 1 % or more (but below GROWTH);
  irregular             it grows but no line fits (a random walk: chaotic motion visiting states whose
                        per-step energy error differs in sign and size).

Ill-conditioning: the points of a sweep split a ratio r between the heavy body (mass or inertia times
min(r, 1e9), the largest value overrides.py accepts) and the light one (divided by the rest). The light
body keeps its inertia tensor (body/<light>/inertia is scaled up first): the point bobs carry 1e-14 kg m^2
and MuJoCo refuses principal inertias below mjMINVAL = 1e-15 ("mass and inertia of moving bodies must be
larger than mjMINVAL"), so body/link2/mass below 0.1 kg would not compile. A point MuJoCo still refuses is
recorded with its message. The seeded random states of compare.random_states rarely come near the
configurations where M is singular in the limit, so TARGETED_STATES states approach the worst
configuration found (grid, then Nelder-Mead on log cond(M)) at distances 1e-1 .. 1e-8 rad.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import HarnessError

EPS = float(np.finfo(float).eps)
GROWTH = 1.0  # unstable when the energy gain exceeds GROWTH x (E0 - V_min); see the module docstring
ENVELOPE_GROWTH = 2.0  # "bounded": the late |dE| envelope at most this times the early one
STEADY_R2 = 0.8  # a line explains at least this fraction of the variance of |dE|: a steady trend
LARGE_CHANGE = 0.01  # a steady change of 1 % of E0 - V_min or more is damping / injection, not drift
ROUND_OFF = 1e-12  # relative to E0 - V_min: below it the energy error is rounding (see classify_energy)
SERIES_POINTS = 500
DT_RANGE = (1e-5, 1e-1)  # s, the bisection's bracket
BISECTION_RATIO = 1.1  # stop when the smallest unstable dt is within 10 % of the largest stable one
SAMPLES_PER_RUN = 100  # state checks (finite, warnings) per stability run
MAX_FACTOR = 1e9  # the largest parameter value overrides.parse accepts
MJ_MINVAL = 1e-15  # MuJoCo's mjMINVAL, the smallest mass or principal inertia it compiles
TARGETED_STATES = 16
TARGET_DISTANCES = (-1.0, -8.0)  # log10 rad: the targeted states' distances from the worst configuration
FIT_FROM_COND = 1e3  # the slope of disagreement vs cond is fitted where cond(M) >= this (above round-off)
PROPOSAL_MARGIN = 10.0  # the proposed solve tier is this times the largest measured disagreement / (cond eps)
MUJOCO_INTEGRATORS = ("Euler", "RK4", "implicit", "implicitfast")
MIRROR_INTEGRATORS = ("Euler", "RK4")
NO_EULERDAMP = "Euler (no eulerdamp)"


@dataclass(frozen=True)
class Settings:
    """What a stress run measures; QUICK and FULL are the two the command offers."""

    drift_horizons: tuple[float, ...] = (100.0, 1000.0)  # s
    drift_sample: float = 0.1  # s between energy samples
    speeds: tuple[float, ...] = (1.0, 10.0, 50.0)  # rad/s, every coordinate
    stability_t_end: float = 10.0  # s
    growth_factors: tuple[float, ...] = (GROWTH, math.inf)  # the energy criterion, and divergence alone
    ratios: tuple[float, ...] = tuple(10.0**k for k in range(13))
    cond_states: int = 1000
    seed: int = 0
    damping_factors: tuple[float, ...] = (1.0, 10.0, 100.0, 1000.0)
    stiff_timesteps: tuple[float, ...] = (1e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2, 5e-2, 1e-1)  # s
    stiff_t_end: float = 2.0  # s: at 1000x the notes' damping the motion dies within ~10 ms
    stiff_sample: float = 0.1  # s, a multiple of every stiff timestep
    sections: tuple[str, ...] = ("drift", "stability", "conditioning", "stiff_friction")


FULL = Settings()
QUICK = Settings(
    drift_horizons=(100.0,),
    speeds=(50.0,),
    ratios=tuple(10.0**k for k in range(0, 13, 3)),
    cond_states=200,
    stiff_timesteps=(1e-3, 5e-3, 2e-2, 1e-1),
)


# ----------------------------------------------------------------------------------------------
# Runs with early exit


@dataclass
class Run:
    """Samples of one run; a failed run stops at the first sample that shows the failure."""

    t: np.ndarray  # (K,) s
    q: np.ndarray  # (K, n) rad
    v: np.ndarray  # (K, n) rad/s
    failure: str | None = None  # why it stopped: a MuJoCo warning, a non-finite state, an overflow
    t_fail: float | None = None  # s, the sample time at which the failure was seen


def quiet_mujoco_warnings() -> Any:
    """MuJoCo's warnings collected instead of printed (engines/mujoco.py `collected_warnings`)."""
    from ..engines import mujoco as engine

    return engine.collected_warnings()


def simulate(
    system: Any,
    sources: dict[str, Any],
    engine: str,
    integrator: str,
    q0: Any,
    v0: Any,
    tau: Any,
    *,
    timestep: float,
    t_end: float,
    sample_steps: int,
    eulerdamp: bool = True,
) -> Run:
    """A free run sampled every `sample_steps` steps, stopped at the first sign of instability.

    Args:
        engine: "mujoco" (mj_step) or "mirror" (MuJoCo's scheme on the hand equations, validate/mirror.py).
        q0, v0, tau: (n,) initial state and constant input.
        timestep: s; the run takes ceil(t_end / timestep) steps (a whole number of samples).
        eulerdamp: False disables MuJoCo's implicit treatment of joint damping in Euler (mujoco only).
    """
    from ..errors import unknown_name

    if integrator not in MUJOCO_INTEGRATORS or (engine == "mirror" and integrator not in MIRROR_INTEGRATORS):
        raise unknown_name(
            f"{engine} integrator", integrator, MUJOCO_INTEGRATORS if engine == "mujoco" else MIRROR_INTEGRATORS
        )
    n = system.nv
    q0, v0, tau = (np.asarray(x, dtype=float).copy() for x in (q0, v0, tau))
    steps = max(1, math.ceil(t_end / timestep - 1e-9))
    chunks = max(1, math.ceil(steps / sample_steps))
    qs, vs, ts = [q0], [v0], [0.0]
    failure, t_fail = None, None
    if engine == "mujoco":
        from ..engines import mujoco as mj

        done_q, done_v, failure, k_fail = mj.sampled_run(
            sources["mujoco"],
            q0,
            v0,
            tau,
            chunks,
            sample_steps,
            integrator=integrator,
            timestep=timestep,
            eulerdamp=eulerdamp,
        )
        qs += done_q
        vs += done_v
        ts += [k * sample_steps * timestep for k in range(1, len(done_q) + 1)]
        t_fail = None if k_fail is None else k_fail * sample_steps * timestep
    elif engine == "mirror":
        from ..dynamics.mirror import mirror_trajectory

        grid = np.array([0.0, sample_steps * timestep])
        q, v = q0, v0
        with np.errstate(all="ignore"):
            for k in range(1, chunks + 1):
                try:
                    tr = mirror_trajectory(
                        system, sources["hand"], q, v, tau, grid, integrator=integrator, timestep=timestep
                    )
                    q, v = tr.q[-1], tr.v[-1]
                except (OverflowError, ValueError, ZeroDivisionError, FloatingPointError) as exc:
                    failure = f"overflow ({type(exc).__name__})"
                else:
                    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
                        failure = "non-finite state"
                if failure:
                    t_fail = k * sample_steps * timestep
                    break
                qs.append(q)
                vs.append(v)
                ts.append(k * sample_steps * timestep)
    else:
        raise HarnessError(f"engine must be 'mujoco' or 'mirror'; got '{engine}'.")
    return Run(np.array(ts), np.array(qs).reshape(-1, n), np.array(vs).reshape(-1, n), failure, t_fail)


def minimum_potential(system: Any, hand: Any) -> float:
    """V_min (J): the smallest potential energy on a grid of 65 points per coordinate over [-pi, pi]."""
    n = system.nv
    points = 65 if n <= 3 else 9
    g = np.linspace(-np.pi, np.pi, points)
    q = np.stack(np.meshgrid(*[g] * n, indexing="ij"), axis=-1).reshape(-1, n)
    return float(hand.energies(q, np.zeros_like(q))[1].min())


def run_energy(hand: Any, run: Run) -> np.ndarray:
    """E = T + V at every sample of a run (J), by the hand equations."""
    with np.errstate(all="ignore"):
        kin, pot = hand.energies(run.q, run.v)
    return kin + pot


# ----------------------------------------------------------------------------------------------
# Energy classification


def downsample(t: np.ndarray, y: np.ndarray, points: int = SERIES_POINTS) -> dict[str, list[float]]:
    """At most `points` samples for a plot: the first sample, then in each of `points` - 1 buckets the
    sample of largest |y| (so the envelope survives)."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    if len(t) <= points:
        return {"t": t.tolist(), "y": y.tolist()}
    edges = np.linspace(1, len(t), points, dtype=int)  # points - 1 buckets after the first sample
    idx = [0]
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        if b > a:
            seg = np.abs(y[a:b])
            idx.append(a + int(np.nanargmax(seg)) if np.any(np.isfinite(seg)) else a)
    return {"t": t[idx].tolist(), "y": y[idx].tolist()}


def classify_energy(
    t: Any, E: Any, *, V_min: float, failure: str | None = None, t_fail: float | None = None, growth: float = GROWTH
) -> dict[str, Any]:
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
    E0 = float(E[0])
    available = max(E0 - V_min, np.finfo(float).tiny)
    out: dict[str, Any] = {
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
    dE = E - E0
    good = dE[finite]
    out.update(
        max_abs=float(np.abs(good).max()) if good.size else float("inf"),
        final=float(dE[-1]) if finite[-1] else float("nan"),
    )
    out["relative_max"] = out["max_abs"] / available
    out["relative_final"] = out["final"] / available
    gain = float(good.max()) if good.size else float("inf")
    if failure or not finite.all():
        return {**out, "class": "unstable", "reason": failure or "non-finite energy"}
    if gain > growth * available:
        t_grow = float(t[np.argmax(dE > growth * available)])
        return {
            **out,
            "class": "unstable",
            "t_fail": t_grow,
            "reason": f"energy gain {gain:.3g} J > {growth:g} x (E0 - V_min) = {growth * available:.3g} J",
        }
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
    out.update(early_envelope=early_env, late_envelope=late_env, rate=float(slope), r2=r2, direction=direction)
    if out["relative_max"] <= ROUND_OFF:
        return {
            **out,
            "class": "round-off",
            "direction": None,
            "reason": f"max |dE| = {out['relative_max']:.2g} of E0 - V_min <= {ROUND_OFF:g}",
        }
    if late_env <= ENVELOPE_GROWTH * early_env:
        return {
            **out,
            "class": "bounded oscillation",
            "direction": None,
            "reason": f"late |dE| envelope {late_env:.2g} J <= {ENVELOPE_GROWTH:g} x early {early_env:.2g} J",
        }
    if r2 < STEADY_R2:
        return {
            **out,
            "class": "irregular",
            "reason": f"|dE| envelope grows ({early_env:.2g} -> {late_env:.2g} J) but no line fits (R^2 {r2:.2f})",
        }
    large = abs(late_mean) >= LARGE_CHANGE * available
    cls = ("numerical damping" if direction == "loss" else "energy injection") if large else "secular drift"
    return {
        **out,
        "class": cls,
        "reason": f"|dE| grows at {slope:.2g} J/s (R^2 {r2:.2f}); {direction} of {abs(late_mean) / available:.2g} "
        f"of E0 - V_min by the end",
    }


# ----------------------------------------------------------------------------------------------
# Long horizons


def conservative(system: Any) -> bool:
    return not ({"damping", "actuation"} & set(system.uses))


def drift_rows(system: Any, sources: dict[str, Any], settings: Settings, *, V_min: float) -> list[dict[str, Any]]:
    """Energy over every horizon, for every MuJoCo integrator and mirror, at the MJCF timestep."""
    from ..dynamics.integrate import initial_state

    q0, v0 = initial_state(system)
    tau = np.zeros(system.nv)
    dt = float(system.mujoco_model().opt.timestep)
    sample_steps = max(1, round(settings.drift_sample / dt))
    horizon = max(settings.drift_horizons)
    rows = []
    runs = [("mujoco", i) for i in MUJOCO_INTEGRATORS] + [("mirror", i) for i in MIRROR_INTEGRATORS]
    for engine, integrator in runs:
        run = simulate(
            system, sources, engine, integrator, q0, v0, tau, timestep=dt, t_end=horizon, sample_steps=sample_steps
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


# ----------------------------------------------------------------------------------------------
# High energy: the largest stable timestep


def stability_trial(
    system: Any,
    sources: dict[str, Any],
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


def stability_rows(system: Any, sources: dict[str, Any], settings: Settings, *, V_min: float) -> list[dict[str, Any]]:
    """Per speed, engine, integrator and criterion (settings.growth_factors): the bisection's result."""
    from ..dynamics.integrate import initial_state

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


# ----------------------------------------------------------------------------------------------
# Ill-conditioning


def equilibrated_cond(M: np.ndarray) -> np.ndarray:
    """cond of D^-1/2 M D^-1/2, D = diag(M): what is left of cond(M) after the best diagonal scaling
    (van der Sluis: within a factor n of it). (N, n, n) -> (N,)."""
    d = 1.0 / np.sqrt(np.einsum("...ii->...i", M))
    return np.linalg.cond(M * d[..., :, None] * d[..., None, :])


def worst_configuration(system: Any, hand: Any) -> np.ndarray:
    """The q (rad) with the largest cond(M): the best point of a grid, refined by Nelder-Mead on log cond."""
    from scipy.optimize import minimize

    n = system.nv
    g = np.linspace(-np.pi, np.pi, 65 if n <= 3 else 9)
    grid = np.stack(np.meshgrid(*[g] * n, indexing="ij"), axis=-1).reshape(-1, n)
    with np.errstate(all="ignore"):
        cond = np.linalg.cond(hand.mass_matrix(grid))
    start = grid[int(np.nanargmax(np.where(np.isfinite(cond), cond, -np.inf)))]

    def neg_log_cond(q: np.ndarray) -> float:
        c = float(np.linalg.cond(hand.mass_matrix(q[None]))[0])
        return -math.log(c) if np.isfinite(c) else -800.0

    res = minimize(neg_log_cond, start, method="Nelder-Mead", options={"xatol": 1e-13, "fatol": 1e-13, "maxiter": 4000})
    return res.x if res.fun <= neg_log_cond(start) else start


def conditioning_states(system: Any, hand: Any, *, n: int, seed: int) -> tuple[Any, np.ndarray]:
    """compare.random_states plus TARGETED_STATES approaching the worst configuration, and that q."""
    from ..checks import pointwise as compare

    states = compare.random_states(system, n=n, seed=seed)
    q_worst = worst_configuration(system, hand)
    rng = np.random.default_rng(seed + 1)
    dist = np.logspace(*TARGET_DISTANCES, TARGETED_STATES)
    u = rng.normal(size=(TARGETED_STATES, system.nv))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    q = q_worst + dist[:, None] * u
    v = rng.uniform(-compare.V_RANGE, compare.V_RANGE, q.shape)
    tau = (
        rng.uniform(-compare.TAU_RANGE, compare.TAU_RANGE, q.shape) if "actuation" in system.uses else np.zeros_like(q)
    )
    return compare.States(np.vstack([states.q, q]), np.vstack([states.v, v]), np.vstack([states.tau, tau])), q_worst


@dataclass(frozen=True)
class Sweep:
    name: str  # e.g. "mass link2/link1"
    kind: str  # "mass" or "inertia"
    heavy: str  # body made heavier
    light: str  # body made lighter beyond MAX_FACTOR


def sweep_overrides(system: Any, sweep: Sweep, ratio: float) -> tuple[tuple[str, float], ...]:
    """Overrides (added to the system's own) that make the heavy body `ratio` times the light one's
    mass (or inertia), relative to the system as loaded."""
    heavy_f = min(ratio, MAX_FACTOR)
    light_f = ratio / heavy_f
    out: list[tuple[str, float]] = []
    if sweep.kind == "mass":
        out.append((f"body/{sweep.heavy}/mass", float(system.view[f"body/{sweep.heavy}/mass"]) * heavy_f))
        if light_f > 1.0:
            # keep the light body's inertia tensor: its smallest principal inertia must stay above mjMINVAL
            out.append((f"body/{sweep.light}/inertia", light_f))
            out.append((f"body/{sweep.light}/mass", float(system.view[f"body/{sweep.light}/mass"]) / light_f))
    else:
        out.append((f"body/{sweep.heavy}/inertia", heavy_f))
        if light_f > 1.0:
            out.append((f"body/{sweep.light}/inertia", 1.0 / light_f))
    return tuple(out)


def conditioning_sweeps(system: Any, hand: Any) -> list[Sweep]:
    """Ratio sweeps between the first and the last body, both ways: of masses where M depends on them,
    of inertias where it does not (the mass-balanced gimbal). None for one coordinate (cond(M) = 1)."""
    from ..systems import load

    if system.nv < 2 or len(system.bodies) < 2:
        return []
    from ..engines.hand import HandSource

    first, last = system.bodies[0], system.bodies[-1]
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (8, system.nv))
    # twice the mass, the same inertia tensor (body/<b>/mass scales the inertia alike)
    heavier = load(
        system.name,
        overrides=(
            *system.overrides,
            (f"body/{last}/inertia", 0.5),
            (f"body/{last}/mass", 2.0 * float(system.view[f"body/{last}/mass"])),
        ),
    )
    same = np.allclose(HandSource(heavier).mass_matrix(q), hand.mass_matrix(q), rtol=1e-12, atol=0.0)
    kind = "inertia" if same else "mass"
    return [Sweep(f"{kind} {last}/{first}", kind, last, first), Sweep(f"{kind} {first}/{last}", kind, first, last)]


def conditioning_point(system: Any, *, n_states: int, seed: int) -> dict[str, Any]:
    """cond(M) and the sources' disagreement in q'' and tau_inverse at one parameter set.

    Besides compare.compare's rows (their `scaled` error, `tolerance` and verdict), each row gets the
    verdict of the tier's base rtol alone (`passed_base`: what an unscaled tier would say) and the
    constant C that a per-state tier max(rtol, C kappa eps) needs to pass every state: the largest
    per-state error / (kappa eps) over the states whose error exceeds rtol (`c_state` for kappa =
    cond(M), `c_state_eq` for the equilibrated cond; 0 if none does), and over all states (`c_state_all`)."""
    from ..checks import pointwise as compare
    from ..checks.tolerances import TOLERANCES
    from ..engines import make_sources

    sources = make_sources(system)
    states, q_worst = conditioning_states(system, sources["hand"], n=n_states, seed=seed)
    values = compare.evaluate(sources, states)
    M = values["mujoco" if "mujoco" in values else "hand"]["M"]  # compare.compare's reference
    cond, cond_eq = np.linalg.cond(M), equilibrated_cond(M)
    rows = []
    for r in compare.compare(values, states):
        if r["quantity"] not in ("qacc", "tau_inverse"):
            continue
        a, b = r["pair"].split("~")
        per_state = np.abs(values[a][r["quantity"]] - values[b][r["quantity"]]).reshape(len(states), -1).max(axis=1)
        rel = per_state / r["scale"]
        base = getattr(TOLERANCES, r["tier"]).rtol
        # only states beyond the base rtol constrain C: below it the tier passes whatever C is
        over = rel > base
        rows.append(
            {
                **r,
                "passed_base": bool(np.all(np.isfinite(rel)) and r["scaled"] <= base),
                "base_tolerance": base,
                "c_state": float(np.max(rel[over] / (cond[over] * EPS), initial=0.0)),
                "c_state_eq": float(np.max(rel[over] / (cond_eq[over] * EPS), initial=0.0)),
                "c_state_all": float(np.max(rel / (cond * EPS))),
                "c_state_eq_all": float(np.max(rel / (cond_eq * EPS))),
                "worst_state_cond": float(cond[int(np.argmax(per_state))]),
            }
        )
    return {
        "cond_median": float(np.median(cond)),
        "cond_max": float(cond.max()),
        "cond_random_max": float(cond[:n_states].max()),
        "cond_eq_median": float(np.median(cond_eq)),
        "cond_eq_max": float(cond_eq.max()),
        "q_worst": q_worst,
        "n_states": n_states,
        "n_targeted": TARGETED_STATES,
        "rows": rows,
    }


def conditioning_rows(system: Any, sources: dict[str, Any], settings: Settings) -> list[dict[str, Any]]:
    from ..systems import load

    out = []
    for sweep in conditioning_sweeps(system, sources["hand"]):
        for ratio in settings.ratios:
            extra = sweep_overrides(system, sweep, ratio)
            base = {
                "system": system.name,
                "sweep": sweep.name,
                "kind": sweep.kind,
                "ratio": float(ratio),
                "overrides": [list(o) for o in extra],
            }
            try:
                point = conditioning_point(
                    load(system.name, overrides=(*system.overrides, *extra)),
                    n_states=settings.cond_states,
                    seed=settings.seed,
                )
            except HarnessError as exc:
                out.append({**base, "quantity": None, "pair": None, "refused": str(exc)})
                continue
            info = {k: v for k, v in point.items() if k != "rows"}
            for r in point["rows"]:
                out.append(
                    {
                        **base,
                        **info,
                        **{
                            k: r[k]
                            for k in (
                                "quantity",
                                "pair",
                                "scaled",
                                "max_abs",
                                "scale",
                                "tier",
                                "tolerance",
                                "passed",
                                "base_tolerance",
                                "passed_base",
                                "c_state",
                                "c_state_eq",
                                "c_state_all",
                                "c_state_eq_all",
                                "worst_state_cond",
                            )
                        },
                        "per_cond_eps": r["scaled"] / (info["cond_max"] * EPS),
                    }
                )
    return out


def conditioning_summary(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per (system, sweep, quantity): at each point the worst pair's disagreement against cond(M) over
    the sample; the log-log slope where cond >= FIT_FROM_COND; the largest per-state error / (cond eps)
    (C) and / (cond_eq eps) (C_eq); the smallest cond at which the base tier and the current tier fail."""
    groups: dict[tuple[str, str, str], dict[float, dict[str, Any]]] = {}
    for r in rows:
        if r.get("quantity") is None:
            continue
        p = groups.setdefault((r["system"], r["sweep"], r["quantity"]), {}).setdefault(
            r["ratio"],
            {
                "cond_max": r["cond_max"],
                "cond_eq_max": r["cond_eq_max"],
                "scaled": 0.0,
                "tolerance": 0.0,
                "passed": True,
                "passed_base": True,
                "c_state": 0.0,
                "c_state_eq": 0.0,
                "c_state_all": 0.0,
                "c_state_eq_all": 0.0,
                "base": r["base_tolerance"],
            },
        )
        p["scaled"] = max(p["scaled"], r["scaled"])
        p["tolerance"] = max(p["tolerance"], r["tolerance"])
        p["c_state"] = max(p["c_state"], r["c_state"])
        p["c_state_eq"] = max(p["c_state_eq"], r["c_state_eq"])
        p["c_state_all"] = max(p["c_state_all"], r["c_state_all"])
        p["c_state_eq_all"] = max(p["c_state_eq_all"], r["c_state_eq_all"])
        p["passed"] = p["passed"] and r["passed"]
        p["passed_base"] = p["passed_base"] and r["passed_base"]
    out = []
    for (system, sweep, quantity), points in sorted(groups.items()):
        pts = [points[k] for k in sorted(points)]
        cond = np.array([p["cond_max"] for p in pts])
        err = np.array([p["scaled"] for p in pts])
        fit = (cond >= FIT_FROM_COND) & (err > 0) & np.isfinite(err)
        slope = None
        if fit.sum() >= 2 and np.ptp(np.log10(cond[fit])) >= 1:
            slope = float(np.polyfit(np.log10(cond[fit]), np.log10(err[fit]), 1)[0])
        out.append(
            {
                "system": system,
                "sweep": sweep,
                "quantity": quantity,
                "points": len(pts),
                "cond_range": [float(cond.min()), float(cond.max())],
                "disagreement_range": [float(err.min()), float(err.max())],
                "slope": slope,
                "c_state": max(p["c_state"] for p in pts),
                "c_state_eq": max(p["c_state_eq"] for p in pts),
                "c_state_all": max(p["c_state_all"] for p in pts),
                "c_state_eq_all": max(p["c_state_eq_all"] for p in pts),
                "base_tolerance": pts[0]["base"],
                "base_tier_fails_from_cond": min((p["cond_max"] for p in pts if not p["passed_base"]), default=None),
                "tier_fails_from_cond": min((p["cond_max"] for p in pts if not p["passed"]), default=None),
                "series": {
                    "ratio": sorted(points),
                    "cond_max": cond.tolist(),
                    "cond_eq_max": [p["cond_eq_max"] for p in pts],
                    "scaled": err.tolist(),
                    "tolerance": [p["tolerance"] for p in pts],
                },
            }
        )
    return out


def proposed_solve_tier(summary: list[dict[str, Any]]) -> dict[str, Any]:
    """The per-state solve tier max(rtol, C eps kappa) the measurements support: C = PROPOSAL_MARGIN x the
    largest C any state beyond rtol needed (`c_state`), rounded up to one significant digit; for kappa =
    cond(M), and for comparison the equilibrated cond_eq (which does not bound the error: near the
    folded point pendulum with a light elbow M is nearly diagonal yet its entries lose digits to
    cancellation in 2 + 2 cos(phi), so its error follows cond(M), not cond_eq)."""
    from ..checks.tolerances import TOLERANCES

    if not summary:
        return {}

    def up(x: float) -> float:
        if x <= 0:
            return 0.0
        e = math.floor(math.log10(x))
        return float(math.ceil(round(x / 10**e, 9)) * 10**e)

    c = max(s["c_state"] for s in summary)
    c_eq = max(s["c_state_eq"] for s in summary)
    C, C_eq = up(PROPOSAL_MARGIN * c), up(PROPOSAL_MARGIN * c_eq)
    rtol = TOLERANCES.solve.rtol
    return {
        "formula": "per state: max(rtol, C eps kappa)",
        "rtol": rtol,
        "eps": EPS,
        "margin": PROPOSAL_MARGIN,
        "current_cond_factor": getattr(TOLERANCES.solve, "cond_factor", None),
        "measured_C_cond": c,
        "measured_C_cond_all_states": max(s["c_state_all"] for s in summary),
        "C_cond": C,
        "kappa_from_cond": rtol / (C * EPS) if C else None,
        "measured_C_cond_eq": c_eq,
        "measured_C_cond_eq_all_states": max(s["c_state_eq_all"] for s in summary),
        "C_cond_eq": C_eq,
        "kappa_from_cond_eq": rtol / (C_eq * EPS) if C_eq else None,
    }


# ----------------------------------------------------------------------------------------------
# Stiff friction


def stiff_rows(system: Any, settings: Settings) -> list[dict[str, Any]]:
    """Every integrator at every timestep on the system with its joint damping times each factor."""
    from ..dynamics.integrate import initial_state, scipy_trajectory, time_grid
    from ..dynamics.mirror import eulerdamp_active
    from ..engines import make_sources
    from ..systems import load

    q0, v0 = initial_state(system)
    tau = np.zeros(system.nv)
    t = time_grid(settings.stiff_t_end, settings.stiff_sample)
    rows = []
    for factor in settings.damping_factors:
        extra = tuple((f"joint/{j}/damping", float(system.view[f"joint/{j}/damping"]) * factor) for j in system.joints)
        damped = load(system.name, overrides=(*system.overrides, *extra))
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


# ----------------------------------------------------------------------------------------------
# The whole stress run


def _sort_key(row: dict[str, Any]) -> tuple[Any, ...]:
    keys = (
        "system",
        "sweep",
        "engine",
        "integrator",
        "quantity",
        "pair",
        "horizon",
        "speed",
        "criterion",
        "damping_factor",
        "ratio",
        "timestep",
    )
    return tuple((0, "") if row.get(k) is None else (1, row[k]) for k in keys)


def run_stress(
    names: list[str] | None,
    *,
    overrides: tuple[tuple[str, float], ...] = (),
    quick: bool = False,
    settings: Settings | None = None,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """The four stress experiments on the systems named (all when none), with `overrides` on each.

    Every system is loaded and compiled with the overrides first, so an unknown system, an unknown key
    or a model MuJoCo refuses is a one-line HarnessError before any long run starts.
    """
    from ..engines import make_sources
    from ..results import provenance
    from ..systems import load, system_names

    settings = settings or (QUICK if quick else FULL)
    say = progress or (lambda msg: None)
    systems_ = [load(n, overrides=tuple(overrides)) for n in (names or system_names())]
    for s in systems_:
        try:
            s.mujoco_model()
        except HarnessError as exc:
            if "mjMINVAL" not in str(exc):
                raise
            raise HarnessError(
                f"{exc} ({s.name}: MuJoCo refuses masses and principal inertias below {MJ_MINVAL:g}; "
                f"the point bobs carry 1e-14 kg m^2, so scale body/<name>/inertia up with a smaller "
                f"mass)."
            ) from None
        s.params  # noqa: B018 - the equations read the overridden model: a bad value fails here
    results: dict[str, Any] = {
        "provenance": provenance(settings.seed),
        "quick": quick,
        "settings": asdict(settings),
        "overrides": [list(o) for o in overrides],
        "systems": [s.name for s in systems_],
        "criteria": _criteria(),
        "drift": [],
        "stability": [],
        "conditioning": [],
        "stiff_friction": [],
        "skipped": [],
        "timing": {},
    }
    start = time.perf_counter()
    with quiet_mujoco_warnings():
        for s in systems_:
            sources = make_sources(s)
            V_min = minimum_potential(s, sources["hand"])
            for section in settings.sections:
                t0 = time.perf_counter()
                if section == "drift":
                    if conservative(s):
                        results["drift"] += drift_rows(s, sources, settings, V_min=V_min)
                    else:
                        results["skipped"].append(
                            {
                                "system": s.name,
                                "section": section,
                                "why": f"not conservative (uses {', '.join(sorted(s.uses))})",
                            }
                        )
                elif section == "stability":
                    results["stability"] += stability_rows(s, sources, settings, V_min=V_min)
                elif section == "conditioning":
                    rows = conditioning_rows(s, sources, settings)
                    if not rows:
                        results["skipped"].append(
                            {"system": s.name, "section": section, "why": "one coordinate: M is a scalar, cond(M) = 1"}
                        )
                    results["conditioning"] += rows
                elif section == "stiff_friction":
                    if "damping" in s.uses:
                        results["stiff_friction"] += stiff_rows(s, settings)
                    else:
                        results["skipped"].append({"system": s.name, "section": section, "why": "no joint damping"})
                else:
                    raise HarnessError(f"unknown stress section '{section}'.")
                elapsed = time.perf_counter() - t0
                results["timing"][f"{s.name}/{section}"] = elapsed
                say(f"[{time.perf_counter() - start:6.1f} s] {s.name}: {section} ({elapsed:.1f} s)")
    for key in ("drift", "stability", "conditioning", "stiff_friction", "skipped"):
        results[key] = sorted(results[key], key=_sort_key)
    summary = conditioning_summary(results["conditioning"])
    results["conditioning_summary"] = summary
    results["solve_tier_proposal"] = proposed_solve_tier(summary)
    results["timing"]["total"] = time.perf_counter() - start
    return results


def _criteria() -> dict[str, str]:
    return {
        "instability": (
            f"a non-finite state, any MuJoCo warning (d.warning[i].number > 0), an overflow in a mirror, "
            f"or (criterion 'energy x{1 + GROWTH:g}') max(E - E0) > {GROWTH:g} x (E0 - V_min); criterion "
            f"'divergence': the first three only"
        ),
        "classes": (
            f"round-off: max |dE| <= {ROUND_OFF:g} x (E0 - V_min); bounded oscillation: late |dE| envelope "
            f"<= {ENVELOPE_GROWTH:g} x early (last vs first tenth); "
            f"secular drift: grows, a line fits |dE| vs t (R^2 >= {STEADY_R2:g}), < {LARGE_CHANGE:.0%} of "
            f"E0 - V_min; numerical damping / energy injection: the same with a loss / gain >= "
            f"{LARGE_CHANGE:.0%}; irregular: grows, no line fits"
        ),
        "bisection": (
            f"log(dt) in [{DT_RANGE[0]:g}, {DT_RANGE[1]:g}] s until the bracket ratio <= "
            f"{BISECTION_RATIO:g}; the top is tried first, the bottom only if the bisection ends there"
        ),
        "conditioning": (
            "cond(M): 2-norm condition number of the hand M; disagreement: compare.compare's 'scaled' "
            "(max |a - b| / the quantity's range over the sample), tolerance and verdict from its rows"
        ),
        "series": f"downsampled to <= {SERIES_POINTS} points: in each bucket the sample of largest |y|",
    }


def write_stress(results: dict[str, Any], out: Path) -> Path:
    """Writes out/stress.json atomically (rendered in memory first: a failure leaves the old file)."""
    from ..results import atomic_write, dumps

    path = Path(out) / "stress.json"
    text = dumps(results)
    atomic_write(path, text)
    return path


# ----------------------------------------------------------------------------------------------
# Summary and command


def _fmt(x: Any, spec: str = ".1e") -> str:
    return "-" if x is None else format(x, spec)


def print_summary(results: dict[str, Any], console: Any = None) -> None:
    """Readable tables of the results (rich)."""
    from rich.console import Console
    from rich.table import Table

    console = console or Console()
    if results["drift"]:
        table = Table(title="Energy over long horizons (MJCF timestep; dE = E - E0, E by the hand equations)")
        for col in (
            "system",
            "engine",
            "integrator",
            "horizon s",
            "class",
            "direction",
            "max |dE| / (E0-Vmin)",
            "|dE| rate J/s",
        ):
            table.add_column(col)
        for r in results["drift"]:
            table.add_row(
                r["system"],
                r["engine"],
                r["integrator"],
                f"{r['horizon']:g}",
                r["class"],
                r["direction"] or "-",
                _fmt(r["relative_max"], ".2e"),
                _fmt(r["rate"], ".1e"),
            )
        console.print(table)
    if results["stability"]:
        speeds = sorted({r["speed"] for r in results["stability"]})
        criteria = sorted({r["criterion"] for r in results["stability"]}, key=lambda c: c == "divergence")
        table = Table(
            title=f"Largest stable timestep (s) over {results['stability'][0]['t_end']:g} s, bisection on "
            f"log dt in [{DT_RANGE[0]:g}, {DT_RANGE[1]:g}]; v0 = speed on every coordinate; "
            f"criteria: {' / '.join(criteria)}"
        )
        for col in ("system", "engine", "integrator", *[f"{s:g} rad/s" for s in speeds]):
            table.add_column(col)
        cells: dict[tuple[str, str, str], dict[float, dict[str, str]]] = {}
        for r in results["stability"]:
            text = (
                f">={r['max_stable']:.2g}"
                if r["min_unstable"] is None
                else f"<{r['min_unstable']:.2g}"
                if r["max_stable"] is None
                else f"{r['max_stable']:.3g}"
            )
            cells.setdefault((r["system"], r["engine"], r["integrator"]), {}).setdefault(r["speed"], {})[
                r["criterion"]
            ] = text
        for (system, engine, integrator), by_speed in cells.items():
            table.add_row(
                system,
                engine,
                integrator,
                *[" / ".join(by_speed.get(s, {}).get(c, "-") for c in criteria) for s in speeds],
            )
        console.print(table)
    if results["conditioning_summary"]:
        table = Table(
            title="Ill-conditioning: the worst pair's disagreement (compare's scaled error) vs cond(M) over "
            "the sample; C = max per-state error / (cond eps)"
        )
        for col in (
            "system",
            "sweep",
            "quantity",
            "cond(M) max",
            "disagreement",
            "slope",
            "C",
            "C (cond_eq)",
            "base tier fails from cond",
            "current tier fails from cond",
        ):
            table.add_column(col)
        for s in results["conditioning_summary"]:
            table.add_row(
                s["system"],
                s["sweep"],
                s["quantity"],
                f"{s['cond_range'][0]:.1e} .. {s['cond_range'][1]:.1e}",
                f"{s['disagreement_range'][0]:.1e} .. {s['disagreement_range'][1]:.1e}",
                _fmt(s["slope"], ".2f"),
                f"{s['c_state']:.2g}",
                f"{s['c_state_eq']:.2g}",
                _fmt(s["base_tier_fails_from_cond"]),
                _fmt(s["tier_fails_from_cond"]),
            )
        console.print(table)
        p = results.get("solve_tier_proposal") or {}
        if p:
            console.print(
                f"Solve tier per state max({p['rtol']:g}, C eps kappa): the states beyond {p['rtol']:g} needed "
                f"C = {p['measured_C_cond']:.2g} with kappa = cond(M) ({p['measured_C_cond_eq']:.2g} with the "
                f"equilibrated cond, whose ratio reaches {p['measured_C_cond_eq_all_states']:.2g} at states below "
                f"{p['rtol']:g}: it does not bound the error); {p['margin']:g}x margin gives C = "
                f"{p['C_cond']:g} on cond(M), binding from cond {_fmt(p['kappa_from_cond'])}; "
                f"current cond_factor: {p['current_cond_factor']}.",
                highlight=False,
            )
    if results["stiff_friction"]:
        dts = sorted({r["timestep"] for r in results["stiff_friction"]})
        table = Table(
            title="Stiff friction: stable? and max |q - q_ref| (rad) vs DOP853 rtol 1e-12 on the hand "
            "equations, per timestep (s)"
        )
        for col in ("system", "damping x", "engine", "integrator", *[f"{d:g}" for d in dts]):
            table.add_column(col)
        cells2: dict[tuple[Any, ...], dict[float, str]] = {}
        for r in results["stiff_friction"]:
            cells2.setdefault((r["system"], f"{r['damping_factor']:g}", r["engine"], r["integrator"]), {})[
                r["timestep"]
            ] = f"{r['max_error']:.0e}" if r["stable"] else "UNSTABLE"
        for key, by_dt in cells2.items():
            table.add_row(*key, *[by_dt.get(d, "-") for d in dts])
        console.print(table)
    for s in results["skipped"]:
        console.print(f"skipped {s['section']} on {s['system']}: {s['why']}")


def stress_command(args: Any) -> int:
    """`lagrange-xval stress [SYSTEM ...] [--set KEY=VALUE ...] [--quick] [--out DIR]`."""
    from rich.console import Console

    from ..systems.overrides import parse

    raw = list(getattr(args, "set", None) or [])
    overrides = parse(raw) if all(isinstance(x, str) for x in raw) else tuple((str(k), float(v)) for k, v in raw)
    err = Console(stderr=True)
    names = list(getattr(args, "systems", None) or []) or None
    results = run_stress(
        names,
        overrides=overrides,
        quick=bool(getattr(args, "quick", False)),
        progress=lambda msg: err.print(msg, highlight=False),
    )
    path = write_stress(results, Path(getattr(args, "out", None) or "reports"))
    print_summary(results, Console(width=None if sys.stdout.isatty() else 160))
    print(
        f"wrote {path} ({'quick' if results['quick'] else 'full'} stress, {results['timing']['total']:.0f} s)",
        file=sys.stdout,
    )
    return 0


__all__ = [
    "FULL",
    "QUICK",
    "Run",
    "Settings",
    "classify_energy",
    "max_stable_timestep",
    "run_stress",
    "simulate",
    "stress_command",
    "write_stress",
]

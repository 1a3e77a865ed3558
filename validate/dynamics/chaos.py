"""Chaos-aware trajectory judgement: how errors grow, how far ahead a run can be trusted.

On a chaotic system (the double pendulum of notes section 1 from theta = 0, phi = 3) two correct
integrations of the same equations drift apart: every error, down to the rounding of the initial
state, is amplified roughly like exp(lambda t). A fixed threshold on the trajectory difference then
says more about the horizon than about the equations. This module measures the growth and turns it
into an expectation:

  amplification   A(t) = ||P_q Phi(t)||_2, Phi(t) = dx(t)/dx(0) from the variational equations
                  (heyoka, on the symbolic hand equations of validate/dynamics/reference.py), P_q the q rows:
                  the largest q error (rad) per unit initial state error.
  Lyapunov        largest exponent lambda, by Benettin's method: tangent vectors renormalised by QR
                  every `interval` (variational), and, as a simple independent path, two nearby
                  trajectories renormalised to d0 (`method="two trajectories"`).
  envelope        e(t_k) = e0 A(t_k) + sum_{j<k} ||P_q Phi(t_k) Phi(t_{j+1})^-1||_2 ||delta_j||_2:
                  the first-order bound on the propagated error of a run whose per-window error
                  (one output interval, restarted from the reference) is delta_j (Lady Windermere's
                  fan with norms). Window errors are measured by restarting the run from the
                  reference at every sample, so chaos cannot amplify them.
  horizon         the first time the envelope reaches a tolerance.
  judge           a free-running error passes if it stays below SAFETY x envelope up to the horizon.

SAFETY = 10: the envelope is already an upper bound to first order (triangle inequality over the
windows, operator norms, the 2-norm of the q error bounding its largest component). The factor
covers what the bound neglects: second-order growth (relative size e / 1 rad, < 1e-6 within the
horizon at 1e-6 rad), Phi's own error (heyoka in double, ~1e-12 relative), and that a free run
rounds differently from the restarted windows that measured delta (same distribution, different
realisation; the sum over ~1000 windows averages that out to well within 10x).

The envelope is built from the run's own window errors, so the judge alone cannot catch a wrong
equation: it says whether the free-run error is explained by the window errors and how far ahead
that holds. Whether the window errors are what they should be is the other half: for a mirror and
mj_step (the same scheme on two sources) they must be round-off (`window_ulps` <= ROUND_OFF_ULPS;
a wrong term makes them ~h |da|, millions of ulps); against the reference they are the scheme's
truncation error, whose order `convergence_order` measures. A free run whose horizon is the first
sample (Euler at 1 ms: window errors 2e-2 rad) passes trivially: nothing beyond 10 ms can be trusted
to the tolerance, which is the finding.

All public functions return JSON-able dicts (floats, lists, None) unless documented as arrays.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from typing import Any, TypedDict

import numpy as np

from ..core.errors import unknown_name
from ..handwritten.forms import accelerations_only
from ..model.start import Scheme, Start
from ..results.schema import Convergence, FreeRunCheck, MirrorCheck, MirrorVerdict, RoundOff
from ..sources.base import Source, stepped
from ..systems import System
from .flow import DEFAULT_TOLERANCE as DEFAULT_TOLERANCE
from .flow import SAFETY as SAFETY
from .flow import Flow as Flow
from .flow import amplification as amplification
from .flow import error_envelope as error_envelope
from .flow import flow as flow
from .flow import horizon_from_rounding as horizon_from_rounding
from .flow import judge_free_run as judge_free_run
from .flow import predictability_horizon as predictability_horizon
from .flow import predicted_error, sample_at, transfer_norms
from .integrate import (
    DEFAULT_DT_OUT,
    DEFAULT_T_END,
    Trajectory,
    energy,
    initial_state,
    mujoco_trajectory,
    time_grid,
    wall_time_stop,
)
from .lyapunov import chaos_summary as chaos_summary
from .lyapunov import lyapunov_exponent as lyapunov_exponent
from .mirror import INTEGRATORS, lockstep, mirror_steps, mirror_trajectory, mujoco_steps
from .reference import CHECK, DEFAULT_CACHE_DIR, reference_trajectory

ROUND_OFF_ULPS = 16  # window differences of two sources under one scheme (measured <= 3 ulps of max |x|)
# ... on the notes' models, 10 steps per window. The limit grows with what rounding does (`round_off_limit`):
#   limit = ROUND_OFF_ULPS (steps / ROUND_OFF_STEPS) (1 + cond(M) h max|a| / max|x|)
# steps per window (each rounds the state), and the solve's rounding of a (~cond(M) eps |a|) carried into
# the state in units of its spacing (x h / max|x|). Measured against it (windows of 10 steps at 1 ms):
# notes' double pendulum 2 ulps of 19; m1 = m2/50 105 of 4,270; bars at 1:20 lengths 55 of 775;
# point at l2 = l1/20 3 of 4,300: never above 0.17 of the limit; a wrong term makes millions of ulps.
ROUND_OFF_STEPS = 10
CONVERGENCE_T_END = 1.0  # s: short enough that chaos does not bend the error curves (RK4 at 2 s does)
CONVERGENCE_TIMESTEPS = {
    "RK4": (0.02, 0.01, 0.005, 0.0025),
    "Euler": (0.002, 0.001, 0.0005, 0.00025),
    "implicit": (0.002, 0.001, 0.0005, 0.00025),
    "implicitfast": (0.002, 0.001, 0.0005, 0.00025),
}
EXPECTED_ORDER = {"RK4": 4, "Euler": 1, "implicit": 1, "implicitfast": 1}
# The sweep starts at the largest of CONVERGENCE_TIMESTEPS[0] / 2^k within STABLE_FRACTION of the
# model's own stable step, h_stable = STABILITY_LIMIT / max |lambda| (the largest eigenvalue of the
# equations' Jacobian along the reference over the sweep's interval): the boundary of the scheme's
# stability region, |h lambda| = 2.78 for RK4 (2.83 on the imaginary axis) and 2 for MuJoCo's
# semi-implicit Euler on an oscillator. At a 1:50 mass ratio (double_pendulum_point, m1 = m2/50)
# max |lambda| = 440 /s: RK4 at 0.02 s diverges (h_stable 6.3 ms), so the sweep starts at 2.5 ms;
# on the notes' models (max |lambda| ~ 9 /s) the sweep is the constant one.
STABILITY_LIMIT = {"RK4": 2.78, "Euler": 2.0, "implicit": 2.0, "implicitfast": 2.0}
STABLE_FRACTION = 0.5  # well inside the region, where the error is in its asymptotic regime
JACOBIAN_STEP = 1e-6  # central differences of the accelerations, relative to max(|x|, 1)


class PairCheck(MirrorVerdict):
    """`pair_check`: two free runs of one scheme ("a~b"), their largest difference (rad) and its verdict."""

    pair: str
    integrator: str
    timestep: float
    max_difference: float
    difference_at: dict[str, float]


class EnergyDrift(TypedDict):
    """`energy_drift`: a run's energy minus the reference's (J; "rate" J/s, "relative" to max |E_ref|)."""

    engine: str
    integrator: str
    timestep: float
    max_abs: float
    final: float
    rate: float
    relative: float
    reference_energy_range: float


# ----------------------------------------------------------------------------------------------
# Runs, window errors, judging


def _run(
    system: System, sources: Mapping[str, Source], engine: str, start: Start, t: np.ndarray, scheme: Scheme
) -> Trajectory:
    """A free run: MuJoCo stepping (engine "mujoco") or the mirror of its scheme on another source."""
    integrator, timestep = scheme.integrator, scheme.timestep
    if engine == "mujoco":
        return mujoco_trajectory(system, stepped(sources["mujoco"]), start, t, integrator=integrator, timestep=timestep)
    return mirror_trajectory(system, sources[engine], start, t, integrator=integrator, timestep=timestep)


def window_errors(
    system: System,
    sources: Mapping[str, Source],
    engine: str,
    ref: Trajectory,
    tau: np.ndarray,
    scheme: Scheme,
) -> np.ndarray:
    """(K-1, 2n): the run restarted from the reference at each sample, minus the reference one sample later."""
    dt_out = float(ref.t[1] - ref.t[0])
    steps = round(dt_out / scheme.timestep)
    q, v = ref.q[:-1], ref.v[:-1]
    if engine == "mujoco":
        q1, v1 = mujoco_steps(stepped(sources["mujoco"]), q, v, tau, scheme, steps=steps)
    else:
        q1, v1 = mirror_steps(system, sources[engine], q, v, tau, scheme, steps=steps)
    return np.concatenate([q1 - ref.q[1:], v1 - ref.v[1:]], axis=1)


def free_run_check(
    system: System,
    sources: Mapping[str, Source],
    start: Start,
    t: np.ndarray,
    *,
    engine: str = "mujoco",
    integrator: str = "RK4",
    timestep: float | None = None,
    tolerance: float = DEFAULT_TOLERANCE,
    ref: Trajectory | None = None,
    cache_dir: str | os.PathLike[str] | None = DEFAULT_CACHE_DIR,
) -> FreeRunCheck:
    """A free run against the reference, judged against its propagated window errors.

    Returns {"engine", "integrator", "timestep" (s), "max_error", "error_at" {"1 s": .., "10 s": ..},
    "max_window_error", "envelope_at" (the bound), "predicted_at" (the first-order prediction),
    "predicted_horizon" (s or None), "prediction_mismatch" (max |error - predicted| / max error),
    "judge": judge_free_run(...)}; errors in rad (max over q), window errors as state 2-norms.
    """
    tau = start.tau
    dt = float(timestep or system.mujoco_model().opt.timestep)
    if ref is None:
        ref, _ = reference_trajectory(system, start, t, cache_dir=cache_dir)
    run = _run(system, sources, engine, start, t, Scheme(integrator, dt))
    err = np.abs(run.q - ref.q).max(axis=1)
    w = window_errors(system, sources, engine, ref, tau, Scheme(integrator, dt))
    fl = flow(system, start, t)
    env = error_envelope(fl, window_errors=w, floor=rounding_floor(ref))
    return _free_run_entry(engine, integrator, dt, t, err, w, env, predicted_error(fl, w), tolerance)


def _free_run_entry(
    engine: str,
    integrator: str,
    dt: float,
    t: np.ndarray,
    err: np.ndarray,
    w: np.ndarray,
    env: np.ndarray,
    pred: np.ndarray,
    tolerance: float,
) -> FreeRunCheck:
    return {
        "engine": engine,
        "integrator": integrator,
        "timestep": dt,
        "max_error": float(err.max()),
        "error_at": sample_at(t, err),
        "max_window_error": float(np.linalg.norm(w, axis=1).max()),
        "envelope_at": sample_at(t, env),
        "predicted_at": sample_at(t, pred),
        "predicted_horizon": predictability_horizon(t, pred, tolerance),
        "prediction_mismatch": float(np.abs(err - pred).max() / max(float(err.max()), np.finfo(float).tiny)),
        "judge": judge_free_run(t, err, env, tolerance=tolerance),
    }


def pair_check(
    system: System,
    sources: Mapping[str, Source],
    a: str,
    b: str,
    start: Start,
    t: np.ndarray,
    *,
    integrator: str = "RK4",
    timestep: float | None = None,
    ref: Trajectory | None = None,
    tolerance: float = DEFAULT_TOLERANCE,
    cache_dir: str | os.PathLike[str] | None = DEFAULT_CACHE_DIR,
) -> PairCheck:
    """Two free runs of the same scheme (e.g. MuJoCo and the hand mirror) judged against the envelope of
    their window-by-window difference (both restarted from the reference at every sample).

    Returns {"pair", "integrator", "timestep", "max_difference", "difference_at", "max_window_difference",
    "window_ulps" (in units of the spacing of doubles at max |x|), "round_off" (<= ROUND_OFF_ULPS),
    "envelope_at", "judge", "passed" (round-off windows and judge passed)}.
    """
    tau = start.tau
    dt = float(timestep or system.mujoco_model().opt.timestep)
    if ref is None:
        ref, _ = reference_trajectory(system, start, t, cache_dir=cache_dir)
    run_a = _run(system, sources, a, start, t, Scheme(integrator, dt))
    run_b = _run(system, sources, b, start, t, Scheme(integrator, dt))
    err = np.abs(run_a.q - run_b.q).max(axis=1)
    w = window_errors(system, sources, a, ref, tau, Scheme(integrator, dt)) - window_errors(
        system, sources, b, ref, tau, Scheme(integrator, dt)
    )
    env = error_envelope(flow(system, start, t), window_errors=w, floor=rounding_floor(ref))
    return {
        "pair": f"{a}~{b}",
        "integrator": integrator,
        "timestep": dt,
        "max_difference": float(err.max()),
        "difference_at": sample_at(t, err),
        **_mirror_verdict(
            t, err, w, env, ref, tolerance, round_off_limit(sources["hand"], ref, tau, timestep=dt)["limit"]
        ),
    }


def round_off_limit(hand: Source, ref: Trajectory, tau: np.ndarray, *, timestep: float) -> RoundOff:
    """The window ulps two sources under one scheme may differ by on this model and run (see ROUND_OFF_ULPS)."""
    cond = float(np.linalg.cond(hand.mass_matrix(ref.q)).max())
    a = float(np.abs(hand.forward(ref.q, ref.v, np.broadcast_to(tau, ref.q.shape))).max())
    x = float(np.abs(np.concatenate([ref.q, ref.v], axis=1)).max())
    steps = round(float(ref.t[1] - ref.t[0]) / timestep)
    limit = ROUND_OFF_ULPS * (steps / ROUND_OFF_STEPS) * (1.0 + cond * timestep * a / max(x, 1.0))
    return {
        "limit": limit,
        "formula": f"{ROUND_OFF_ULPS} (steps / {ROUND_OFF_STEPS}) (1 + cond(M) h max|a| / max|x|)",
        "cond_max": cond,
        "max_acceleration": a,
        "max_state": x,
        "steps": steps,
        "timestep": timestep,
    }


def _mirror_verdict(
    t: np.ndarray,
    diff: np.ndarray,
    w: np.ndarray,
    env: np.ndarray,
    ref: Trajectory,
    tolerance: float,
    limit: float,
    until: float | None = None,
) -> MirrorVerdict:
    """Round-off windows (within `limit` ulps, `round_off_limit`) and a free-run difference inside the
    envelope (judged no later than `until`: the scheme's own horizon): the two halves of a mirror's verdict."""
    ulp = float(np.spacing(np.abs(np.concatenate([ref.q, ref.v], axis=1)).max()))
    window_ulps = float(np.linalg.norm(w, axis=1).max() / ulp)
    judge = judge_free_run(t, diff, env, tolerance=tolerance, until=until)
    return {
        "max_window_difference": float(np.linalg.norm(w, axis=1).max()),
        "window_ulps": window_ulps,
        "window_ulps_limit": limit,
        "round_off": window_ulps <= limit,
        "envelope_at": sample_at(t, env),
        "judge": judge,
        "passed": window_ulps <= limit and judge["passed"],
    }


def _slope(t: np.ndarray, y: np.ndarray) -> float:
    """Least-squares slope of y(t); NaN where y is not finite (a run that diverged or stopped)."""
    return float(np.polyfit(t, y, 1)[0]) if np.isfinite(y).all() else float("nan")


def rounding_floor(ref: Trajectory) -> np.ndarray:
    """(K-1,) one rounding of the state at the end of each window: eps ||x(t_{j+1})||."""
    return np.finfo(float).eps * np.linalg.norm(np.concatenate([ref.q[1:], ref.v[1:]], axis=1), axis=1)


# ----------------------------------------------------------------------------------------------
# Convergence order and energy drift


def largest_rate(source: Source, ref: Trajectory, tau: np.ndarray) -> float:
    """max |lambda| (1/s) of the Jacobian of (v, a(q, v, tau)) at the reference's samples, by central
    differences of the source's batched forward dynamics."""
    q, v = ref.q, ref.v
    k, n = q.shape
    taus = np.broadcast_to(tau, q.shape)
    jac = np.zeros((k, 2 * n, 2 * n))
    jac[:, :n, n:] = np.eye(n)
    for j in range(2 * n):
        x = q if j < n else v
        h = JACOBIAN_STEP * max(float(np.abs(x[:, j % n]).max()), 1.0)
        d = np.zeros_like(q)
        d[:, j % n] = h
        up = source.forward(q + d, v, taus) if j < n else source.forward(q, v + d, taus)
        down = source.forward(q - d, v, taus) if j < n else source.forward(q, v - d, taus)
        jac[:, n:, j] = (up - down) / (2 * h)
    return float(np.abs(np.linalg.eigvals(jac)).max())


def sweep_timesteps(integrator: str, rate: float) -> tuple[tuple[float, ...], float]:
    """The convergence sweep's timesteps inside the model's stable step, and that step (s)."""
    stable = STABILITY_LIMIT[integrator] / max(rate, np.finfo(float).tiny)
    base = CONVERGENCE_TIMESTEPS[integrator]
    k = max(0, math.ceil(math.log2(base[0] / (STABLE_FRACTION * stable)) - 1e-12))
    return tuple(dt / 2**k for dt in base), stable


def convergence_order(
    system: System,
    sources: Mapping[str, Source],
    start: Start,
    *,
    integrator: str,
    timesteps: tuple[float, ...] | None = None,
    t_end: float = CONVERGENCE_T_END,
    engine: str = "mujoco",
    cache_dir: str | os.PathLike[str] | None = DEFAULT_CACHE_DIR,
    check: str | None = CHECK,
) -> Convergence:
    """The observed order of `integrator` from a timestep sweep against the reference.

    error(dt) = max over the grid (output step: the largest timestep) of max |q - q_ref|; the order is
    the least-squares slope of log error against log dt.
    """
    if integrator not in INTEGRATORS:
        raise unknown_name("MuJoCo integrator", integrator, INTEGRATORS)
    tau = start.tau
    stable = None
    if timesteps is None:
        coarse = time_grid(t_end, DEFAULT_DT_OUT)  # samples 10 ms apart: a 0.02 s grid missed the fastest
        around, _ = reference_trajectory(system, start, coarse, cache_dir=cache_dir, check=check)
        timesteps, stable = sweep_timesteps(integrator, largest_rate(sources["hand"], around, tau))
    dts = tuple(timesteps)
    t = time_grid(t_end, max(dts))
    ref, _ = reference_trajectory(system, start, t, cache_dir=cache_dir, check=check)
    errors = []
    for dt in dts:
        run = _run(system, sources, engine, start, t, Scheme(integrator, dt))
        errors.append(float(np.abs(run.q - ref.q).max()))
    usable = [(dt, e) for dt, e in zip(dts, errors, strict=True) if e > 0 and np.isfinite(e)]  # a diverged run: NaN
    order = (
        float(np.polyfit(np.log([d for d, _ in usable]), np.log([e for _, e in usable]), 1)[0])
        if len(usable) >= 2
        else None
    )
    local = [float(x) for x in np.diff(np.log(errors)) / np.diff(np.log(dts))] if all(e > 0 for e in errors) else None
    return {
        "engine": engine,
        "integrator": integrator,
        "t_end": t_end,
        "timesteps": list(dts),
        "stable_timestep": stable,
        "timesteps_from": "given"
        if stable is None
        else f"the largest of {CONVERGENCE_TIMESTEPS[integrator][0]:g} s / 2^k within {STABLE_FRACTION:g} x the "
        f"model's stable step {stable:.3g} s ({STABILITY_LIMIT[integrator]:g} / max |lambda| along the reference)",
        "errors": errors,
        "order": order,
        "pairwise_orders": local,
        "expected": EXPECTED_ORDER[integrator],
    }


def energy_drift(
    system: System,
    sources: Mapping[str, Source],
    start: Start,
    t: np.ndarray,
    *,
    integrator: str,
    timestep: float | None = None,
    engine: str = "mujoco",
    ref: Trajectory | None = None,
    cache_dir: str | os.PathLike[str] | None = DEFAULT_CACHE_DIR,
) -> EnergyDrift:
    """Energy of a run minus the reference's energy at the same times (J), by the hand equations.

    For a conservative system (no damping, no input) the reference energy is constant to ~1e-15
    and this is the usual drift; with damping or inputs it is the run's energy error.
    """
    dt = float(timestep or system.mujoco_model().opt.timestep)
    if ref is None:
        ref, _ = reference_trajectory(system, start, t, cache_dir=cache_dir)
    run = _run(system, sources, engine, start, t, Scheme(integrator, dt))
    e_run, e_ref = energy(system, sources["hand"], run), energy(system, sources["hand"], ref)
    diff = e_run - e_ref
    scale = float(np.max(np.abs(e_ref)) or 1.0)
    slope = _slope(t, diff)
    return {
        "engine": engine,
        "integrator": integrator,
        "timestep": dt,
        "max_abs": float(np.abs(diff).max()),
        "final": float(diff[-1]),
        "rate": slope,
        "relative": float(np.abs(diff).max() / scale),
        "reference_energy_range": float(np.ptp(e_ref)),
    }


# ----------------------------------------------------------------------------------------------
# Everything for one system, as the pipeline's results


def crossvalidate(
    system: System,
    sources: Mapping[str, Source],
    *,
    start: Start | None = None,
    t_end: float = DEFAULT_T_END,
    dt_out: float = DEFAULT_DT_OUT,
    tolerance: float = DEFAULT_TOLERANCE,
    integrators: tuple[str, ...] = INTEGRATORS,
    mirror_engines: tuple[str, ...] = ("hand", "pinocchio"),
    cache_dir: str | os.PathLike[str] | None = DEFAULT_CACHE_DIR,
    lockstep_every: int = 10,
) -> dict[str, Any]:
    """Trajectory cross-validation of one system, JSON-able: reference, chaos measures, and per MuJoCo
    integrator (at the MJCF's timestep) the free run against the reference, the mirrors against
    mj_step (free run judged by the round-off envelope, and lockstep), convergence order and energy.

    The start is the module's INITIAL_STATE (or the harness's generic one) with zero input unless given.
    """

    start = Start.at_rest(*initial_state(system)) if start is None else start
    tau = start.tau
    t = time_grid(t_end, dt_out)
    dt = float(system.mujoco_model().opt.timestep)
    ref, ref_info = reference_trajectory(system, start, t, cache_dir=cache_dir)
    fl = flow(system, start, t)
    g = transfer_norms(fl)
    floor = rounding_floor(ref)
    out: dict[str, Any] = {
        "q0": start.q0.tolist(),
        "v0": start.v0.tolist(),
        "tau": tau.tolist(),
        "t_end": t_end,
        "dt_out": dt_out,
        "timestep": dt,
        "tolerance": tolerance,
        "safety": SAFETY,
        "reference": ref_info,
        "chaos": chaos_summary(system, start, t=t, tolerance=tolerance, cache_dir=cache_dir),
        "amplification": amplification(fl),  # (K,) on the grid t: how much the dynamics amplify an error
        "round_off": round_off_limit(sources["hand"], ref, tau, timestep=dt),
        "integrators": {},
    }
    lock_states = (ref.q[::lockstep_every], ref.v[::lockstep_every])
    for integrator in integrators:
        out["integrators"][integrator] = _integrator_entry(
            system,
            sources,
            integrator,
            start=start,
            t=t,
            dt=dt,
            ref=ref,
            fl=fl,
            transfer=g,
            floor=floor,
            tolerance=tolerance,
            limit=out["round_off"]["limit"],
            mirror_engines=mirror_engines,
            lock_states=lock_states,
            cache_dir=cache_dir,
        )
    # The mirrors decide (round-off windows, difference inside the envelope); the free runs against the
    # reference are findings about the integrators (horizon, prediction), judged but not decisive.
    _unmirrorable(system, out["integrators"])
    out["passed"] = all(
        m["passed"] or m.get("judged") is False for e in out["integrators"].values() for m in e["mirrors"].values()
    )
    return out


def _integrator_entry(
    system: System,
    sources: Mapping[str, Source],
    integrator: str,
    *,
    start: Start,
    t: np.ndarray,
    dt: float,
    ref: Trajectory,
    fl: Flow,
    transfer: np.ndarray,
    floor: np.ndarray,
    tolerance: float,
    limit: float,
    mirror_engines: tuple[str, ...],
    lock_states: tuple[np.ndarray, np.ndarray],
    cache_dir: str | os.PathLike[str] | None,
) -> dict[str, Any]:
    """One MuJoCo integrator's entry of `crossvalidate`: its free run against the reference, the mirrors
    against mj_step (judged within `limit` round-off ulps), lockstep, convergence order and energy."""
    tau = start.tau
    runs, windows = {}, {}
    for engine in ("mujoco", *mirror_engines):
        runs[engine] = _run(system, sources, engine, start, t, Scheme(integrator, dt))
        windows[engine] = window_errors(system, sources, engine, ref, tau, Scheme(integrator, dt))
    err = np.abs(runs["mujoco"].q - ref.q).max(axis=1)
    env = error_envelope(fl, window_errors=windows["mujoco"], floor=floor, transfer=transfer)
    entry: dict[str, Any] = {
        "free_run": _free_run_entry(
            "mujoco",
            integrator,
            dt,
            t,
            err,
            windows["mujoco"],
            env,
            predicted_error(fl, windows["mujoco"]),
            tolerance,
        ),
        "mirrors": {},
    }
    horizon = entry["free_run"]["judge"]["horizon"]
    for engine in mirror_engines:
        w = windows["mujoco"] - windows[engine]
        env_m = error_envelope(fl, window_errors=w, floor=floor, transfer=transfer)
        entry["mirrors"][f"mujoco~{engine}"] = _mirror_entry(
            t, runs["mujoco"], runs[engine], w, env_m, ref, tolerance, limit, horizon
        )
    entry["lockstep"] = lockstep(
        system,
        {k: sources[k] for k in ("mujoco", *mirror_engines)},
        lock_states,
        integrator=integrator,
        timestep=dt,
        tau=tau,
    )["pairs"]
    entry["convergence"] = convergence_order(system, sources, start, integrator=integrator, cache_dir=cache_dir)
    e_run = energy(system, sources["hand"], runs["mujoco"])
    e_ref = energy(system, sources["hand"], ref)
    entry["energy"] = {
        "max_abs": float(np.abs(e_run - e_ref).max()),
        "relative": float(np.abs(e_run - e_ref).max() / (np.abs(e_ref).max() or 1.0)),
        "rate": _slope(t, e_run - e_ref),
    }
    return entry


def _mirror_entry(
    t: np.ndarray,
    stepped: Trajectory,
    mirror: Trajectory,
    w: np.ndarray,
    env: np.ndarray,
    ref: Trajectory,
    tolerance: float,
    limit: float,
    horizon: float | None,
) -> MirrorCheck:
    """MuJoCo's run against its mirror's: judged while the scheme's own error leaves the tolerance unreached
    (`horizon`, its free run's), and no later than where the wall-time budget stopped the mirror (no
    evidence about the derivation: `integrate.wall_time_stop`); a mirror that diverged or failed fails."""
    diff = np.abs(stepped.q - mirror.q).max(axis=1)
    stop = wall_time_stop(mirror.stats)
    until = horizon if stop is None else stop if horizon is None else min(horizon, stop)
    out: MirrorCheck = {
        "max_difference": float(diff.max() if stop is None else np.nanmax(diff)),
        "difference_at": sample_at(t, diff),
        **_mirror_verdict(t, diff, w, env, ref, tolerance, limit, until),
    }
    status, reason = str(mirror.stats.get("status", "ok")), str(mirror.stats.get("reason", ""))
    if stop is not None:
        out.update({"status": status, "judged_short": reason})
    elif status != "ok":
        out.update({"passed": False, "status": status, "reason": reason})
    return out


NO_DAMPED_MIRROR = (
    "not judged: explicit accelerations with inputs u give no mass matrix, so MuJoCo's Euler with implicit "
    "joint damping, a = (M + h D)^-1 f, cannot be mirrored on them (Pinocchio's mirror of it stands)"
)


def _unmirrorable(system: System, integrators: dict[str, Any]) -> None:
    """Marks the hand equations' mirror of MuJoCo's damped Euler as not judged where it cannot be built."""
    if not (accelerations_only(system.equations) and "damping" in system.uses):
        return
    mirror = integrators.get("Euler", {}).get("mirrors", {}).get("mujoco~hand")
    if mirror is not None:
        mirror.update(judged=False, why_not_judged=NO_DAMPED_MIRROR)

"""The free runs `run` judges, as results: each run against the reference with its own error estimate and
threshold (estimate.py), the interval they are judged over (the amplification the chaos stage measured),
and for a derivation that disagrees or a model alone, the bounded runs shown as information; where there
is no symbolic source, which engine departs from the reference and whether that is expected (trust.py)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..core.arrays import Floats
from ..core.cachedir import Cache
from ..model.start import Start
from ..results.schema import TrustSummary
from ..results.stages import Clock, lap
from ..sources.base import OneStateSource, Source, one_state
from ..systems import System
from . import estimate, experiments, fast, integrate, trust
from .integrate import Trajectory, wall_time_stop
from .reference import reference_trajectory
from .stagecache import cached_stage, states_digest

# Drake's free run is error-controlled (runge_kutta3 at a target accuracy), whose error does not scale with
# the accuracy asked: its rerun at a tenth of it can underestimate the error tenfold (cart_pole: 1.2e-6 rad
# against a 1e-6 threshold), so judging it against its own estimate could fail a right derivation.
DRAKE_NOT_JUDGED = (
    "information only: Drake's error-controlled integrator, whose own error estimate (the same at a tenth of "
    "its accuracy) is not a bound; its distance to the reference is shown"
)


def reference_dir(cache: Cache | None) -> Path | None:
    """The `cache_dir` of the reference and chaos functions for `cache` (None: no cache)."""
    return None if cache is None else cache.folder("reference")


TRAJECTORY_THRESHOLD = estimate.FLOOR  # rad: the floor under each run's own threshold (dynamics/estimate.py)
# The integrators `run` cross-validates (mirrors, convergence order, energy, free runs judged inside
# the predictability horizon); implicit and implicitfast are in `chaos.INTEGRATORS` for the benchmark.
RUN_INTEGRATORS = ("RK4", "Euler")


# Runs are judged against the reference up to the time the chaos could lift the harness's own
# integration error (about 1e-9 rad, scipy at rtol 1e-11 and MuJoCo RK4 at 1 ms, over the first
# second) to the threshold: where the amplification ||dq(t)/dx(0)|| reaches JUDGE_AMPLIFICATION.
JUDGE_AMPLIFICATION = 1e3
# Where the chaos stage fails, the amplification is unknown: the runs are judged over the first
# UNMEASURED_HORIZON only (on the notes' chaotic start the amplification is 20 at 1 s and reaches 1e3
# at 5.1 s, measured), and the report says why.
UNMEASURED_HORIZON = 1.0  # s
# A run is judged only while its own threshold (dynamics/estimate.py) stays below this: beyond it the
# run's own truncation error is as large as what wrong equations do within a second (1e-3 to 1e-1 rad),
# so the run can no longer tell equations apart, and the report says from when.
MAX_THRESHOLD = 1e-3  # rad


def trajectory_results(
    system: System,
    sources: Mapping[str, Source],
    *,
    t_end: float,
    dt_out: float,
    cache: Cache | None = None,
    clock: Clock | None = None,
    drake_run: bool = False,
) -> dict[str, Any]:
    """The three sources' free runs against the reference solution of the hand equations (heyoka's
    Taylor method in long double, kept in `cache`), plus the notes' perturbed start for the divergence.
    `clock`: the reference's, each run's, the perturbed start's and the error estimates' wall seconds.
    `drake_run`: Drake's own free run too (information only, not judged: DRAKE_NOT_JUDGED; with its
    estimate it cost ~5 s of a double pendulum's ~25, so it runs on request, `run --drake-run`)."""

    start = Start.at_rest(*integrate.initial_state(system))
    t = integrate.time_grid(t_end, dt_out)
    ref, ref_info = reference_trajectory(system, start, t, cache_dir=reference_dir(cache))
    lap(clock, "trajectories: reference")
    trajs = fast.run_trajectories(system, sources, t_end=t_end, dt_out=dt_out, clock=clock, drake=drake_run)
    q0b = start.q0.copy()
    q0b[-1] += experiments.PERTURBATION
    perturbed = fast.accurate_trajectory(system, sources["hand"], Start(q0b, start.v0, start.tau), t)
    perturbed.stats["label"] = f"{system.coordinates[-1]}0 + {experiments.PERTURBATION:g}"
    lap(clock, "trajectories: perturbed start")
    estimates = run_estimates(system, sources, trajs, start, cache)
    lap(clock, "estimates")
    runs = [_run_entry(system, sources, tr, ref, est) for tr, est in zip(trajs, estimates, strict=True)]
    for run in runs:
        if run["source"] == "drake":  # shown and measured, not judged: see DRAKE_NOT_JUDGED
            run["counts"], run["why_not_counted"] = False, DRAKE_NOT_JUDGED
    runs.append(_run_entry(system, sources, perturbed, ref))
    runs[-1]["counts"] = False
    runs[-1]["why_not_counted"] = (
        f"information only: a different start ({runs[-1]['label']}), compared with the reference from the "
        "unperturbed start to show how far the start alone moves the motion"
    )
    reference = (
        f"hand equations, {ref_info.get('method', 'Taylor')} ({ref_info.get('precision', '')}); "
        f"agrees with a second method to {ref_info.get('agreement_q', float('nan')):.1e} rad"
    )
    info = {k: v for k, v in ref_info.items() if np.isscalar(v) or isinstance(v, str)}
    return {
        **_start_and_reference(start, (t_end, dt_out, t), reference, info),
        "threshold_rule": estimate.rule(),
        "safety": estimate.SAFETY,
        "runs": runs,
    }


def run_estimates(
    system: System, sources: Mapping[str, Source], trajs: list[Trajectory], start: Start, cache: Cache | None
) -> list[tuple[np.ndarray, str]]:
    """Each run's own error estimate (dynamics/estimate.py), kept in `cache` by content: the system's,
    the start's and each run's own samples (its q digest), so an estimate is read back only for the
    very run it estimates."""
    runs = [[tr.source, tr.method, states_digest(_Samples(tr.q, tr.v))] for tr in trajs]
    stored = cached_stage(
        cache,
        system,
        sources,
        "estimates",
        [runs, [np.asarray(x, dtype=float).tolist() for x in (start.q0, start.v0, start.tau)]],
        lambda: {"estimates": [estimate.run_estimate(system, sources, tr, start) for tr in trajs]},
    )
    return [(np.asarray(est, dtype=float), str(how)) for est, how in stored["estimates"]]


class _Samples:
    """A run's samples as `states_digest` reads them (q, v; no input)."""

    def __init__(self, q: np.ndarray, v: np.ndarray) -> None:
        self.q, self.v, self.tau = q, v, np.zeros(0)


def _start_and_reference(
    start: Start, grid: tuple[float, float, np.ndarray], reference: str, info: Mapping[str, object]
) -> dict[str, Any]:
    """What every free-run record starts with: the start (q0, v0, tau), the grid (t_end, dt_out, t),
    the reference and the threshold."""
    t_end, dt_out, t = grid
    return {
        "q0": start.q0,
        "v0": start.v0,
        "tau": start.tau,
        "t_end": t_end,
        "dt_out": dt_out,
        "t": t,
        "reference": reference,
        "reference_info": info,
        "threshold": TRAJECTORY_THRESHOLD,
    }


def _run_entry(
    system: System,
    sources: Mapping[str, Source],
    tr: Trajectory,
    ref: Trajectory,
    est: tuple[np.ndarray, str] | None = None,
) -> dict[str, Any]:
    """One run against `ref`; `est`: its own error estimate (K,) and how it was made, which sets its
    threshold (dynamics/estimate.py); without one (runs not judged), the floor."""
    err = integrate.error_against(tr, ref)
    thr = estimate.threshold(est[0] if est is not None else np.zeros(len(tr.t)))
    meter = sources.get("hand") or sources.get("symbolic") or sources["mujoco"]
    e = integrate.energy(system, meter, tr)
    missing = integrate.energy_missing(meter)
    run = {
        "source": tr.source,
        "method": tr.method,
        "stats": tr.stats,
        "q": tr.q,
        "v": tr.v,
        "energy": e,
        "error_vs_hand": err,
        "max_error_vs_hand": float(np.nanmax(err)) if np.isfinite(err).any() else float("inf"),
        "threshold": thr,
        "first_exceeds_threshold": integrate.first_exceeding(tr.t, np.nan_to_num(err, nan=np.inf), thr),
        "energy_drift": None
        if missing
        else float(np.nanmax(np.abs(e - e[0])))
        if np.isfinite(e).any()
        else float("inf"),
        "counts": True,
    }
    if missing:
        run["energy_missing"] = missing
    if est is not None:
        run["error_estimate"], run["estimate_how"] = est[0], est[1]
    if "label" in tr.stats:
        run["label"] = tr.stats["label"]
    return run


def judged_interval(t: np.ndarray, amplification: Floats | None, chaos_failed: str | None = None) -> tuple[float, str]:
    """Until when the runs are judged, and why: where the amplification reaches JUDGE_AMPLIFICATION,
    or UNMEASURED_HORIZON where the chaos stage that measures it failed (`chaos_failed`: its outcome)."""
    if amplification is None:
        until = float(t[t <= UNMEASURED_HORIZON + 1e-12][-1])
        why = chaos_failed or "the amplification was not measured"
        return until, (
            f"the amplification of errors is unknown ({why}), so the runs are judged only over the first "
            f"{until:g} s, a conservative horizon, and not beyond"
        )
    amp = np.asarray(amplification, dtype=float)
    beyond = np.nonzero(amp > JUDGE_AMPLIFICATION)[0]
    if not len(beyond):
        return float(t[-1]), f"the amplification of errors stays below {JUDGE_AMPLIFICATION:g} over the whole run"
    until = float(t[beyond[0] - 1]) if beyond[0] > 0 else float(t[0])
    return until, (
        f"the amplification of errors by the dynamics reaches {JUDGE_AMPLIFICATION:g} at {until:g} s: beyond it the "
        "harness's own integration error alone could pass the threshold"
    )


def judge_trajectories(traj: dict[str, Any], amplification: Floats | None, chaos_failed: str | None = None) -> None:
    """Marks each counted run passed or not: its error against the reference stays within its own
    threshold up to the judged interval's end (`judged_interval`), or earlier where that threshold
    passes MAX_THRESHOLD (the run's own error too large to tell equations apart; said per run)."""
    t = np.asarray(traj["t"], dtype=float)
    until, because = judged_interval(t, amplification, chaos_failed)
    traj["judged_until"], traj["judged_because"] = until, because
    for run in traj["runs"]:
        if not run.get("counts", True):
            continue
        thr = np.broadcast_to(np.asarray(run.get("threshold", traj["threshold"]), dtype=float), t.shape)
        end = until
        coarse = np.nonzero((thr > MAX_THRESHOLD) & (t <= until + 1e-12))[0]
        if len(coarse):
            end = float(t[coarse[0] - 1]) if coarse[0] > 0 else float(t[0])
            run["judged_because"] = (
                f"its own error estimate makes its threshold {thr[coarse[0]]:.2g} rad at {t[coarse[0]]:g} s, above "
                f"{MAX_THRESHOLD:g} rad: beyond {end:g} s this run cannot tell equations apart"
            )
        end = _wall_time_stop(run, end)
        inside = t <= end + 1e-12
        err = np.asarray(run["error_vs_hand"], dtype=float)[inside]
        run["judged_until"] = end
        run["threshold_at_judged_end"] = float(thr[inside][-1])
        run["passed"] = bool(np.all(np.isfinite(err)) and np.all(err <= thr[inside]))


def _wall_time_stop(run: dict[str, Any], end: float) -> float:
    """Where the harness's wall-time budget stopped the run, when before `end`: it is judged until then
    (said on the run; `integrate.wall_time_stop`)."""
    stats = run.get("stats") or {}
    stop = wall_time_stop(stats)
    if stop is None:
        return end
    if stop < end:
        spent = str(stats["reason"]).removeprefix("stopped: budget: ")
        run["judged_because"] = f"the harness's wall-time budget ran out then ({spent})"
    return min(end, stop)


def divergence_results(
    system: System, sources: Mapping[str, Source], *, t_end: float, dt_out: float, why: str, aba_reference: bool = False
) -> dict[str, Any]:
    """For a derivation that already disagrees: the three sources' free runs, bounded, against
    MuJoCo's, as information (where the wrong equations part from the engines), never a verdict.
    `aba_reference` (a chain with no symbolic source): against Pinocchio's ABA integrated by DOP853 at
    rtol 1e-12 and checked at half the tolerance (dynamics/estimate.py `aba_reference`) instead."""
    start = Start.at_rest(*integrate.initial_state(system))
    t = integrate.time_grid(t_end, dt_out)
    trajs = fast.run_trajectories(system, sources, t_end=t_end, dt_out=dt_out)
    ref = next(tr for tr in trajs if tr.source == "mujoco")
    reference = f"{ref.label} (the hand derivation disagrees with the engines, so it is not the reference)"
    info: Mapping[str, object] = {"method": ref.method}
    trusted: TrustSummary | None = None
    if aba_reference:
        ref, check, info = estimate.aba_reference(system, sources["pinocchio"], start, t)
        reference = f"{info['method']}; agrees with {info['check']} to {info['agreement_q']:.1e} rad"
        runs = [_run_entry(system, sources, tr, ref, estimate.run_estimate(system, sources, tr, start)) for tr in trajs]
        trusted = trust_of(one_state(sources["pinocchio"]), runs, ref, check, start)
    else:
        runs = [_run_entry(system, sources, tr, ref) for tr in trajs]
    for run in runs:
        run["counts"] = False
        run["why_not_counted"] = why
    return {
        **({"trust": trusted} if trusted is not None else {}),
        **_start_and_reference(start, (t_end, dt_out, t), reference, info),
        "information_only": why,
        "runs": runs,
    }


def trust_of(
    pinocchio: OneStateSource, runs: list[dict[str, Any]], ref: Trajectory, check: Trajectory, start: Start
) -> TrustSummary:
    """Which engine departs from the reference, from when, and whether it is expected
    (dynamics/trust.py): the reference's own horizon, the Lyapunov exponent and predictability horizon,
    and each run's trusted interval with one sentence."""
    t = np.asarray(ref.t)
    limit = trust.reference_until(ref, check)
    rate = trust.lyapunov(pinocchio, start, float(t[-1]))
    for run in runs:
        run["trust"] = trust.run_trust(run, t, limit)
        run["trust_statement"] = trust.statement(run.get("label") or run["method"], run["trust"], float(t[-1]))
    return {
        "reference_until": limit,
        "lyapunov_exponent": rate,
        "predictability_horizon": trust.horizon(rate),
        "trust_rule": f"until the first of: the run's distance to the reference passing its own threshold, its "
        f"own error estimate passing {trust.TRUST:g} rad, the reference's own horizon",
        "horizon_rule": f"t_p = ln({trust.TRUST:g} / {trust.ROUNDING:g}) / lambda, lambda by Benettin's method on "
        f"Pinocchio's ABA (DOP853 rtol {trust.RTOL:g}, renormalised every {trust.INTERVAL:g} s)",
    }

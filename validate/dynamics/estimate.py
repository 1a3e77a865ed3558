"""Each free run's own predicted error, and the threshold it is judged against.

A fixed threshold on a run's distance to the reference judges the integrator's truncation error as
much as the equations: MuJoCo's RK4 at 1 ms is accurate to 1e-8 rad on the notes' pendulums and to
1e-5 on a held-out model whose frequencies are twice theirs. So each run is judged against its own
error estimate at its own step and tolerance, from the same scheme run once more:

  MuJoCo (fixed step h, order p)   the same integrator at h/2 (step doubling); Richardson:
                                   e(t) ~ |q_h(t) - q_h/2(t)| 2^p / (2^p - 1).
  scipy (rtol, atol)               DOP853 at rtol/10, atol/10 on the same source: e(t) ~ |q - q_fine|
                                   10 / 9. Not the same method: LSODA's (odeint's) error stops scaling
                                   with its tolerance near rtol 1e-12 (its run at rtol 1e-12 was as far
                                   from the reference, 5e-6 rad, as the one at 1e-11 on a 50 kg bob on a
                                   0.1 m rod under a 2 m rod, so the estimate was 70 times too small),
                                   where DOP853's keeps scaling (8e-9 rad there).
  Drake's RK3 (target accuracy)    the same at accuracy/10, e(t) ~ |q - q_fine| 10 / 9, as scipy's.
  heyoka's Taylor (tol 1e-15)      none: ~1e-14 rad after 10 s (bench), far below the floor.

threshold(t) = max(FLOOR, SAFETY e(t)). SAFETY = 10 covers what the estimate neglects: the next order
of the truncation error (relative size h/T for RK4, T a period of the model; below 0.1 for the
repository's models at any scale in [0.5, 2]), and that a chaotic run amplifies the two runs' errors
alike only to first order. FLOOR (the trajectory tier, 1e-6 rad) is the smallest disagreement the
stage resolves: wrong equations or a wrong engine setting part from the reference at 1e-3 to 1e-1 rad
within a second, and a well-resolved run's estimate can be ~0 (the Taylor runs, an error passing
through zero). "Beyond the threshold" then means that the run does not solve the reference's
equations, never that its step is too coarse for the model: the estimate says that, and is reported.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TypedDict

import numpy as np

from ..core.tolerances import TOLERANCES
from ..model.start import Start
from ..sources.base import Source, SteppedSource, stepped
from ..systems import System
from .drakerun import DRAKE_DEFAULT, drake_trajectory
from .flow import SAFETY as FLOW_SAFETY
from .integrate import SCIPY_DEFAULT, ScipyOptions, Trajectory, mujoco_trajectory, scipy_trajectory

SAFETY = FLOW_SAFETY  # 10: see the module docstring
FLOOR = TOLERANCES.trajectory.rtol  # rad
ORDER = {"RK4": 4, "Euler": 1, "implicit": 1, "implicitfast": 1}
FINER = 10.0  # scipy's check run: rtol and atol divided by this
CHECK_METHOD = "DOP853"  # scipy's check run: a method whose error keeps scaling with its tolerance


def rule() -> str:
    """The threshold rule, as the report states it."""
    return (
        f"each run's own threshold, max({FLOOR:g} rad, {SAFETY:g} x its own error estimate) at every sample ("
        "MuJoCo's fixed-step run against the same integrator at half the step (Richardson, "
        f"|q_h - q_h/2| 2^p / (2^p - 1)), scipy's against {CHECK_METHOD} at rtol/{FINER:g} "
        f"(|q - q_fine| {FINER:g} / {FINER - 1:g}), Drake's the same at accuracy/{FINER:g}, "
        f"the Taylor runs none: ~1e-14 rad, below {FLOOR:g})"
    )


def mujoco_estimate(
    system: System, source: SteppedSource, tr: Trajectory, start: Start, *, integrator: str = "RK4"
) -> tuple[np.ndarray, str]:
    """(K,) rad: the Richardson estimate of a MuJoCo run's error at its model timestep, and how."""
    dt = float(source.m.opt.timestep)
    half = mujoco_trajectory(system, source, start, tr.t, integrator=integrator, timestep=dt / 2)
    p = ORDER[integrator]
    factor = 2.0**p / (2.0**p - 1.0)
    est = np.abs(tr.q - half.q).max(axis=1) * factor
    return est, f"MuJoCo {integrator} at dt {dt:g} against dt {dt / 2:g}, x {factor:.4g} (order {p})"


def scipy_estimate(
    system: System, source: Source, tr: Trajectory, start: Start, *, opts: ScipyOptions | None = None
) -> tuple[np.ndarray, str]:
    """(K,) rad: a scipy run's error estimated from CHECK_METHOD at a tenth of its tolerances (module
    docstring). A check run that stops early (budget, blow-up) gives NaN samples: no estimate there (the floor)."""
    o = opts or SCIPY_DEFAULT
    fine = scipy_trajectory(
        system, source, start, tr.t, method=CHECK_METHOD, rtol=o["rtol"] / FINER, atol=o["atol"] / FINER
    )
    diff = np.nan_to_num(np.abs(tr.q - fine.q).max(axis=1), nan=0.0)
    est = diff * FINER / (FINER - 1.0)
    return (
        est,
        f"scipy {o['method']} at rtol {o['rtol']:g} against {CHECK_METHOD} at rtol {o['rtol'] / FINER:g}, "
        f"x {FINER / (FINER - 1):.4g}",
    )


def drake_estimate(system: System, source: Source, tr: Trajectory, start: Start) -> tuple[np.ndarray, str]:
    """(K,) rad: a Drake error-controlled run's error estimated from the same scheme at a tenth of its
    target accuracy (DRAKE_DEFAULT's), as scipy's; a check run that stops gives no estimate there."""
    o = DRAKE_DEFAULT
    fine = drake_trajectory(
        system, source, start, tr.t, scheme=o["scheme"], accuracy=o["accuracy"] / FINER, max_step=o["max_step"]
    )
    est = np.nan_to_num(np.abs(tr.q - fine.q).max(axis=1), nan=0.0) * FINER / (FINER - 1.0)
    fine_acc, factor = o["accuracy"] / FINER, FINER / (FINER - 1)
    how = f"Drake {o['scheme']} at accuracy {o['accuracy']:g} against {fine_acc:g}, x {factor:.4g}"
    return est, how


def run_estimate(system: System, sources: Mapping[str, Source], tr: Trajectory, start: Start) -> tuple[np.ndarray, str]:
    """The error estimate of one of `fast.run_trajectories`' runs, by how it was made."""
    if tr.source == "mujoco":
        return mujoco_estimate(system, stepped(sources["mujoco"]), tr, start, integrator=tr.method.split()[1])
    if tr.source == "drake":
        return drake_estimate(system, sources["drake"], tr, start)
    if tr.method.startswith("scipy"):
        return scipy_estimate(system, sources[tr.source], tr, start)
    return np.zeros(len(tr.t)), f"none: {tr.method} is accurate to ~1e-14 rad over 10 s (bench), below the floor"


def threshold(estimate: np.ndarray) -> np.ndarray:
    """(K,) rad: max(FLOOR, SAFETY x estimate) at every sample."""
    return np.maximum(FLOOR, SAFETY * np.asarray(estimate, dtype=float))


ABA_METHOD, ABA_RTOL = "DOP853", 1e-12  # the reference of a chain with no symbolic source (atol = rtol)


class AbaReference(TypedDict):
    """`aba_reference`'s account of itself: how the reference and its check were made, their largest
    difference in q (rad) and the reference run's status."""

    method: str
    check: str
    agreement_q: float
    status: str


def aba_reference(
    system: System, source: Source, start: Start, t: np.ndarray
) -> tuple[Trajectory, Trajectory, AbaReference]:
    """The reference of a chain with no symbolic source (no equations the Taylor method can trace):
    Pinocchio's ABA by scipy's ABA_METHOD at ABA_RTOL, and its check, the same at half the tolerances;
    info["agreement_q"] (rad) is the two runs' largest difference, the reference's stated accuracy."""
    ref = scipy_trajectory(system, source, start, t, method=ABA_METHOD, rtol=ABA_RTOL, atol=ABA_RTOL)
    half = ABA_RTOL / 2
    check = scipy_trajectory(system, source, start, t, method=ABA_METHOD, rtol=half, atol=half)
    agreement = float(np.nanmax(np.abs(ref.q - check.q))) if np.isfinite(check.q).any() else float("nan")
    info: AbaReference = {
        "method": f"Pinocchio ABA, scipy {ABA_METHOD} rtol {ABA_RTOL:g}",
        "check": f"the same at rtol {half:g}",
        "agreement_q": agreement,
        "status": ref.stats.get("status", "ok"),
    }
    return ref, check, info

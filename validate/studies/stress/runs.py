"""Long runs: MuJoCo (through sources/mujoco.py) or the mirror on the hand equations, sampled, stopping
at the first warning or non-finite state; their energy, downsampled for the results.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from contextlib import AbstractContextManager

import numpy as np

from ...core.errors import HarnessError, unknown_name
from ...dynamics.mirror import mirror_trajectory
from ...model.start import Scheme, Start
from ...sources.base import Source, stepped
from ...systems import System
from .settings import MIRROR_INTEGRATORS, MUJOCO_INTEGRATORS, SERIES_POINTS, Run
from .shapes import Series


def quiet_mujoco_warnings() -> AbstractContextManager[list[str]]:
    """MuJoCo's warnings collected instead of printed (sources/mujoco.py `collected_warnings`)."""
    from ...sources import mujoco as engine  # imports MuJoCo: loaded when first used

    return engine.collected_warnings()


def simulate(
    system: System,
    sources: Mapping[str, Source],
    engine: str,
    start: Start,
    stepping: Scheme,
    *,
    t_end: float,
    sample_steps: int,
    eulerdamp: bool = True,
) -> Run:
    """A free run sampled every `sample_steps` steps, stopped at the first sign of instability.

    Args:
        engine: "mujoco" (mj_step) or "mirror" (MuJoCo's scheme on the hand equations, validate/dynamics/mirror.py).
        start: the (n,) initial state and constant input.
        stepping: the integrator and timestep (s); the run takes ceil(t_end / timestep) steps (a whole
            number of samples).
        eulerdamp: False disables MuJoCo's implicit treatment of joint damping in Euler (mujoco only).
    """
    integrator, timestep = stepping.integrator, stepping.timestep
    if integrator not in MUJOCO_INTEGRATORS or (engine == "mirror" and integrator not in MIRROR_INTEGRATORS):
        raise unknown_name(
            f"{engine} integrator", integrator, MUJOCO_INTEGRATORS if engine == "mujoco" else MIRROR_INTEGRATORS
        )
    n = system.nv
    q0, v0 = start.q0.copy(), start.v0.copy()
    steps = max(1, math.ceil(t_end / timestep - 1e-9))
    chunks = max(1, math.ceil(steps / sample_steps))
    qs, vs, ts = [q0], [v0], [0.0]
    failure, t_fail = None, None
    if engine == "mujoco":
        from ...sources import mujoco as mj  # imports MuJoCo

        done_q, done_v, failure, k_fail = mj.sampled_run(
            stepped(sources["mujoco"]),
            start,
            chunks,
            sample_steps,
            stepping,
            eulerdamp=eulerdamp,
        )
        qs += done_q
        vs += done_v
        ts += [k * sample_steps * timestep for k in range(1, len(done_q) + 1)]
        t_fail = None if k_fail is None else k_fail * sample_steps * timestep
    elif engine == "mirror":  # one run over the whole grid: compiled RK4 where the equations trace
        grid = np.arange(chunks + 1) * (sample_steps * timestep)
        tr = mirror_trajectory(system, sources["hand"], start, grid, integrator=integrator, timestep=timestep)
        good = ~np.isnan(tr.q).any(axis=1) & ~np.isnan(tr.v).any(axis=1)
        k = int(np.argmin(good)) if not good.all() else len(grid)
        qs, vs, ts = list(tr.q[:k]), list(tr.v[:k]), list(grid[:k])
        if k < len(grid) or tr.stats.get("status") != "ok":
            failure = _mirror_failure(tr.stats)
            t_fail = float(grid[min(k, len(grid) - 1)])
    else:
        raise HarnessError(f"engine must be 'mujoco' or 'mirror'; got '{engine}'.")
    return Run(np.array(ts), np.array(qs).reshape(-1, n), np.array(vs).reshape(-1, n), failure, t_fail)


def _mirror_failure(stats: Mapping[str, object]) -> str:
    """Why a mirror run stopped, in the words `simulate` uses for MuJoCo's runs."""
    reason = str(stats.get("reason") or "")
    if "non-finite" in reason:
        return "non-finite state"
    if "Overflow" in reason or stats.get("status") == "diverged":
        return f"overflow ({reason})" if reason else "non-finite state"
    return reason or str(stats.get("status"))


def minimum_potential(system: System, hand: Source) -> float:
    """V_min (J): the smallest potential energy on a grid of 65 points per coordinate over [-pi, pi]."""
    n = system.nv
    points = 65 if n <= 3 else 9
    g = np.linspace(-np.pi, np.pi, points)
    q = np.stack(np.meshgrid(*[g] * n, indexing="ij"), axis=-1).reshape(-1, n)
    potential = getattr(hand, "potential", None)  # V alone where the source has it: T over the grid costs 50x
    if callable(potential):
        return float(np.min(potential(q)))
    return float(hand.energies(q, np.zeros_like(q))[1].min())


def run_energy(hand: Source, run: Run) -> np.ndarray:
    """E = T + V at every sample of a run (J), by the hand equations."""
    with np.errstate(all="ignore"):
        kin, pot = hand.energies(run.q, run.v)
    return kin + pot


def downsample(t: np.ndarray, y: np.ndarray, points: int = SERIES_POINTS) -> Series:
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

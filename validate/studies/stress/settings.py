"""The stress tests' settings (full and --quick), thresholds and the record of one run."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...model.set_values import MJ_MINVAL as MJ_MINVAL  # mjMINVAL: the smallest mass or inertia MuJoCo compiles
from ...sources.base import MUJOCO_INTEGRATORS as MUJOCO_INTEGRATORS  # defined once, there

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


TARGETED_STATES = 16


TARGET_DISTANCES = (-1.0, -8.0)  # log10 rad: the targeted states' distances from the worst configuration


FIT_FROM_COND = 1e3  # the slope of disagreement vs cond is fitted where cond(M) >= this (above round-off)


PROPOSAL_MARGIN = 10.0  # the proposed solve tier is this times the largest measured disagreement / (cond eps)


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
    # the most steps one stability run may take (the search's bottom is raised to stability_t_end / this):
    mujoco_trial_steps: int = 1_000_000  # MuJoCo's C loop: ~1-10 us a step on 1-3 joints
    mirror_trial_steps: int = 100_000  # a mirror: compiled RK4 ~1 us a step; Python Euler ~20-50 us
    # a mirror steps the person's numpy equations: its cost per step (measured on 10 steps before the
    # search) times the steps may not pass this; an explicit-accelerations module rebuilt into M and
    # bias costs ~7 ms a step, so a 2 s run at 1 ms would take 14 s
    mirror_trial_seconds: float = 10.0
    # the worst-conditioned configuration: a grid of this many points per coordinate (up to 3 joints;
    # 9 beyond), then at most this many Nelder-Mead iterations (65^3 states of a 3-joint arm's numpy
    # M take ~3 s a sweep point)
    worst_grid: int = 65
    worst_iterations: int = 4000


FULL = Settings()


QUICK = Settings(
    drift_horizons=(100.0,),
    speeds=(50.0,),
    ratios=tuple(10.0**k for k in range(0, 13, 3)),
    cond_states=200,
    stiff_timesteps=(1e-3, 5e-3, 2e-2, 1e-1),
    stability_t_end=2.0,
    mujoco_trial_steps=100_000,
    mirror_trial_steps=10_000,
    mirror_trial_seconds=1.0,
    worst_grid=17,
    worst_iterations=300,
)


@dataclass
class Run:
    """Samples of one run; a failed run stops at the first sample that shows the failure."""

    t: np.ndarray  # (K,) s
    q: np.ndarray  # (K, n) rad
    v: np.ndarray  # (K, n) rad/s
    failure: str | None = None  # why it stopped: a MuJoCo warning, a non-finite state, an overflow
    t_fail: float | None = None  # s, the sample time at which the failure was seen

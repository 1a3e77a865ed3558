"""Stress tests of numerical stability: long horizons, high energy, ill-conditioning, stiff friction.

Four experiments, written as sorted long-format rows to `reports/stress.json` (series are downsampled
to at most SERIES_POINTS points, so the report can plot them without the raw runs):

  drift           Energy E = T + V (by the hand equations) along free runs of `drift_horizons` from the
                  notes' initial state, on the conservative systems (USES without "damping" and
                  "actuation"): MuJoCo's Euler (semi-implicit), RK4, implicit and implicitfast at the
                  MJCF timestep, and the mirrors (validate/dynamics/mirror.py) of RK4 and Euler on the hand
                  equations. One run of the longest horizon gives every shorter one (its first part).
  stability       The largest timestep at which each MuJoCo integrator and each fixed-step mirror stays
                  stable for `stability_t_end` from the notes' q0 with every speed (in the notes'
                  coordinates) set to s rad/s: bisection on log(dt) in DT_RANGE until the bracket's
                  ratio is below BISECTION_RATIO, under each criterion below (each run made once and
                  judged under both). The bottom of the range is raised where a run would take more
                  than the settings' steps (MuJoCo) or steps and seconds at its measured cost (a mirror
                  on the person's numpy equations): "<dt" then means unstable there, not searched below.
                  A module without T or V gets no drift and no energy criterion (divergence alone),
                  each said under "skipped".
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

Modules: settings (full and --quick, thresholds, the run record), runs (long runs and their energy),
energy (the classification), stability (largest stable timesteps, stiff friction), conditioning
(ill-conditioning sweeps and targeted states), output (run_stress, stress.json, summary, command).
"""

from .conditioning import conditioning_point, conditioning_sweeps, sweep_overrides
from .energy import classify_energy
from .output import run_stress, stress_command, write_stress
from .runs import downsample, minimum_potential, quiet_mujoco_warnings, run_energy, simulate
from .settings import (
    BISECTION_RATIO,
    DT_RANGE,
    FULL,
    MIRROR_INTEGRATORS,
    MUJOCO_INTEGRATORS,
    QUICK,
    SERIES_POINTS,
    Run,
    Settings,
)
from .stability import max_stable_timestep, stability_trial

__all__ = [
    "BISECTION_RATIO",
    "DT_RANGE",
    "FULL",
    "MIRROR_INTEGRATORS",
    "MUJOCO_INTEGRATORS",
    "QUICK",
    "SERIES_POINTS",
    "Run",
    "Settings",
    "classify_energy",
    "conditioning_point",
    "conditioning_sweeps",
    "downsample",
    "max_stable_timestep",
    "minimum_potential",
    "quiet_mujoco_warnings",
    "run_energy",
    "run_stress",
    "simulate",
    "stability_trial",
    "stress_command",
    "sweep_overrides",
    "write_stress",
]

"""Run time against error: a work-precision sweep of every integrator the harness can use, and the
"fast harness" ratios, measured in one run and written to `bench.json` (data only; the report
module draws the plots from it).

What is swept, per system, from its `initial_state` with tau = 0, on the grid t = 0, 0.01, ..., 10 s:

  scipy on the hand equations (the generated scalar fast path) and on Pinocchio's ABA
  (`PinocchioSource.rhs`): `solve_ivp` RK45, DOP853, Radau, LSODA; the compiled drivers
  `scipy.integrate.ode("dop853")` and `odeint` (LSODA); rtol 1e-3 ... 1e-12, atol = rtol * 1e-3
  (the states are O(1) rad and rad/s, so the relative test is the one that binds; the small atol
  only matters where a component crosses zero). `ode` has no dense output: on a 10 ms grid it must
  stop at every sample, which caps its step at 10 ms and sets its error, whatever rtol; it is
  therefore also run with two outputs only ("(2 outputs)": t = 2 s and 10 s), where rtol governs.
  MuJoCo's Euler, implicit, implicitfast, RK4 at timesteps 1e-2 ... 1e-5 s (the model's own
  `opt.integrator`/`opt.timestep` are set and restored), and the mirror RK4 on Pinocchio's ABA.
  The harness's default (`integrate.scipy_trajectory` with `integrate.SCIPY_DEFAULT`) as one more run.
  The frontier contenders (dynamics/compiled.py): heyoka's adaptive Taylor integrator in double
  precision on the hand equations at tol 1e-6 ... 1e-16; the hand equations as a compiled function
  (heyoka `cfunc`, engine "hand-cfunc") under `solve_ivp` DOP853 and `odeint`; RK4 with its steps
  compiled ("compiled RK4", up to 10 steps per call); MuJoCo's `rollout` at 1e-2 ... 1e-4 s, for one
  trajectory and for a batch of `Plan.rollout_batch` copies of the start (its row's time is the batch's
  divided by the batch). Compilation is never timed.

What is measured per run: the error against the reference (heyoka Taylor in long double, accurate
to ~1e-17, cached) as max over coordinates of |q - q_ref| at t = 2 s and 10 s, and its maximum over
the predictability horizon (the chaos summary's horizon at 1e-6 rad; it is 73 s for the double
pendulums and none for the regular systems, so on this 10 s grid the window is the whole run, as
`horizon_window_s` says); the first time the error exceeds 1e-6 rad (the run's own horizon);
CPU time (`time.process_time`) and wall time (`time.perf_counter`) of the integration alone (no
setup, no compilation, no error computation; for MuJoCo the loop of `mj_step(m, d, nstep=k)` with a
copy of qpos/qvel per sample, ~0.3 us each); right-hand-side evaluations (steps for MuJoCo).
A run shorter than `Plan.min_timed` is executed back to back until the total reaches it and the mean is
taken, the first (cold) execution dropped (timeit's autorange); the row's time is the median over
repeats. Runs that diverge (non-finite values, MuJoCo's bad-qpos/qvel/qacc warnings), fail (the
solver gives up) or exceed the per-run budget are recorded with that status, not dropped; a timeout
is enforced from inside the right-hand side (checked every 128 calls: it raises, or for `ode`, whose
compiled driver crashes on a Python exception, returns NaN so the driver stops), and for MuJoCo
between samples. A setting tighter than one that timed out is not run (status "skipped").

Parallelism. Timing runs execute in the workers of a `concurrent.futures.Executor` (a process pool
with one worker per core by default; any executor will do, a distributed one included) and each run
is timed inside its worker. Both cores time at once: measured on this 2-core machine, DOP853 on the
double pendulum costs 0.052 s of CPU alone and 0.052-0.053 s with a second timing process on the
other core (wall time alone 0.052 s, but 0.10 s whenever another engineer's process shared the
machine). CPU time is therefore the cost the tables rank by; wall time is recorded beside it and is
only as fair as the machine is quiet. CPU time is less sensitive to load, not immune (a virtual CPU
the host preempts still accrues it; single --quick measurements have varied by 1.7x under other
engineers' load), hence medians over interleaved repeats in the full bench (the median spread of a
row's repeats was 2%). To keep whatever noise there is even, each repeat submits the runs
round-robin over all methods (one setting of every method, then the next setting; later repeats
rotate the method order) so both workers stay busy until the queue drains and noise hits all
methods alike. The ratio measurements interleave their sides inside one task, so they are fair
whatever runs beside them. Only `lagrange-xval run`, which uses both cores itself, is timed with
nothing else of ours running (after the pool is shut down).

Modules: plan (the Plan value: what is swept, budgets, targets; FULL and QUICK), runners (one timed
run in a worker), analysis
(errors, rows, Pareto fronts, the sweep), baselines (what the ratios are measured against: the
hand-written right-hand side and the minimal pointwise calls; MuJoCo's and Pinocchio's raw loops
live in sources/baselines.py), ratios (the fast-harness ratios and the default path against the
fastest method at equal error, `frontier_ratios`), output (run_bench, bench.json, the command),
tables (the console summary).
"""

from .analysis import errors_against, pareto_front, sort_key, sweep, time_to_epsilon
from .baselines import hand_math_rhs, numpy_solve_rhs, raw_hand, raw_pointwise
from .output import bench_command, run_bench, run_time_command, write_bench
from .plan import FULL, QUICK, Plan, Sweep, method_name, scipy_spec, step_spec, taylor_spec
from .ratios import default_ratio, frontier_ratios, rhs_ratio, run_wall_times
from .runners import (
    case_for,
    execute,
    prepare,
    resources,
    run_compiled_rk4,
    run_mirror,
    run_mujoco,
    run_rollout,
    run_scipy,
    run_taylor,
)
from .tables import summary

__all__ = [
    "FULL",
    "QUICK",
    "Plan",
    "Sweep",
    "bench_command",
    "case_for",
    "default_ratio",
    "errors_against",
    "execute",
    "frontier_ratios",
    "hand_math_rhs",
    "method_name",
    "numpy_solve_rhs",
    "pareto_front",
    "prepare",
    "raw_hand",
    "raw_pointwise",
    "resources",
    "rhs_ratio",
    "run_bench",
    "run_compiled_rk4",
    "run_mirror",
    "run_mujoco",
    "run_rollout",
    "run_scipy",
    "run_taylor",
    "run_time_command",
    "run_wall_times",
    "scipy_spec",
    "sort_key",
    "step_spec",
    "summary",
    "taylor_spec",
    "sweep",
    "time_to_epsilon",
    "write_bench",
]

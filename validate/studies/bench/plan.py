"""The benchmark's plan as a value: what is swept (drivers, schemes, tolerances, timesteps), its
budgets and the targets of the fast-harness ratios. FULL and QUICK are the two the command offers;
`dataclasses.replace` makes any other (the tests' small budgets, `--repeats`).

What stays a module constant is not a setting but a fact about the code: which drivers give the
whole grid, which are contenders, a row's statuses, the sample times the error columns are named after.
"""

from __future__ import annotations

from dataclasses import dataclass

from ...dynamics.integrate import SCIPY_DEFAULT
from ...results.schema import Spec
from ...sources import drake as drake_engine  # imports no pydrake: `unavailable` looks it up
from ...sources.base import MUJOCO_INTEGRATORS  # every one is swept

ERROR_TIMES = (2.0, 10.0)  # s: the samples of the rows' "error_2s" and "error_10s"


CHECK_EVERY = 128  # right-hand-side calls between deadline / finiteness checks (a power of two)


SCIPY_DRIVERS = ("solve_ivp", "ode", "ode_endpoints", "odeint")


# The drivers that give the whole 10 ms grid (as the harness's own trajectories must): all but
# "ode_endpoints", which samples t = 2 s and 10 s only.
GRID_DRIVERS = (
    "solve_ivp",
    "ode",
    "odeint",
    "mujoco",
    "mirror",
    "default",
    "taylor",
    "compiled_rk4",
    "rollout",
    "drake",
)


# Contenders: the methods a person who cares about run time against error would pick, beside scipy.
CONTENDER_DRIVERS = ("taylor", "compiled_rk4", "rollout", "rollout_batch", "drake")


STATUSES = ("ok", "diverged", "failed", "timeout", "skipped")  # a row's "status"


@dataclass(frozen=True)
class Sweep:
    """One method at each of its settings: (engine, driver, scheme) at every value of `setting`."""

    engine: str
    driver: str
    scheme: str
    setting: str  # "rtol" (atol = rtol * Plan.atol_factor), "tol", "timestep" (s) or "accuracy"
    values: tuple[float, ...]


@dataclass(frozen=True)
class Plan:
    """What one bench measures, its budgets and the ratios' targets; FULL and QUICK are the two the command offers."""

    sweeps: tuple[Sweep, ...]  # in submission order; the harness's default path is added by `specs`
    systems: tuple[str, ...] = ()  # () = every repository system
    quick: bool = False  # the small plan: so labelled in bench.json and the summary
    t_end: float = 10.0  # s: the grid of `run` (the reference cache is keyed by it)
    dt_out: float = 0.01  # s
    horizon_tolerance: float = 1e-6  # rad: the trajectory tier, and the chaos summary's horizon tolerance
    epsilons: tuple[float, ...] = (1e-3, 1e-6, 1e-9, 1e-12)  # rad, for "time to reach error eps" at t = 2 s
    frontier_epsilons: tuple[float, ...] = (1e-6, 1e-9, 1e-12)  # rad at 2 s: the default path against the fastest
    atol_factor: float = 1e-3  # atol = rtol * atol_factor
    rollout_batch: int = 8  # copies of the start in one batched rollout (its row's time is per trajectory)
    taylor_max_steps: int = 1_000_000  # a budget without a per-step callback: the references take ~46 steps/s
    budget: float = 20.0  # s of wall time per run
    min_timed: float = 0.05  # s: shorter runs are repeated back to back (autorange)
    max_executions: int = 200
    repeats: int = 3
    target_s: float | None = None  # s: what the whole bench should take (the quick plan's)
    rhs_system: str = "double_pendulum_point"
    rhs_target: float = 1.5  # fast path time / hand-written math time
    rhs_reps: int = 15
    pointwise_sizes: tuple[int, ...] = (1_000, 100_000)  # states per batch: the pointwise ratio at each
    pointwise_target: float = 1.5  # harness time / raw engine calls time
    pointwise_reps: int = 5
    flag_integrators: tuple[str, ...] = ("RK4", "Euler")
    flag_steps: int = 20_000  # mj_step calls per timing of the disable flags
    ratio_reps: int = 7  # interleaved repeats of the flags' and the checks' timings
    checks_target: float = 1.5  # a harness trajectory check's time / the fastest run computing the same at its error
    default_epsilon: float = 1e-9  # rad at t = 2 s
    default_target: float = 1.5  # default scipy time / fastest scipy driver reaching default_epsilon
    time_run: bool = True  # time `lagrange-xval run` (5 full runs take over a minute)
    run_repeats: int = 5
    # s wall for `lagrange-xval run` of the notes' systems with a warm cache, on 2 cores (issue 36); the
    # fresh-machine and cold-cache runs are reported beside it, not judged
    run_warm_target_s: float = 5.0

    def specs(self) -> list[Spec]:
        """Every run of one system, loosest setting first within each method; Drake's where pydrake is
        importable; the harness's default path last."""
        specs = [
            spec_of(s, value, self)
            for s in self.sweeps
            if s.driver != "drake" or not drake_engine.unavailable()
            for value in s.values
        ]
        specs.append(default_spec())
        for s in specs:
            s["method"] = method_name(s)
        return specs


def spec_of(sweep: Sweep, value: float, plan: Plan) -> Spec:
    """One run of a sweep: its engine, driver, scheme, setting, value and atol (rtol settings only)."""
    if sweep.setting == "rtol":
        return scipy_spec(sweep.engine, sweep.driver, sweep.scheme, value, atol_factor=plan.atol_factor)
    batch = plan.rollout_batch if sweep.driver == "rollout_batch" else None
    spec: Spec = {
        "engine": sweep.engine,
        "driver": sweep.driver,
        "scheme": sweep.scheme,
        "setting": sweep.setting,
        "value": value,
        "atol": None,
    }
    if batch:
        spec["batch"] = batch
    return spec


def default_spec() -> Spec:
    """The harness's default path (`integrate.scipy_trajectory` with `integrate.SCIPY_DEFAULT`), one run."""
    return {
        "engine": "hand",
        "driver": "default",
        "scheme": SCIPY_DEFAULT["method"],
        "setting": "rtol",
        "value": SCIPY_DEFAULT["rtol"],
        "atol": SCIPY_DEFAULT["atol"],
    }


def method_name(spec: Spec) -> str:
    """The row's method label, e.g. "hand solve_ivp DOP853", "mujoco RK4", "pinocchio mirror RK4"."""
    engine, driver, scheme = spec["engine"], spec["driver"], spec.get("scheme")
    label = {
        "solve_ivp": f"solve_ivp {scheme}",
        "ode": "ode dop853",
        "ode_endpoints": "ode dop853 (2 outputs)",
        "odeint": "odeint",
        "mujoco": str(scheme),
        "mirror": f"mirror {scheme}",
        "default": "default scipy_trajectory",
        "taylor": "heyoka Taylor (double)",
        "compiled_rk4": "compiled RK4 (heyoka cfunc)",
        "rollout": f"rollout {scheme}",
        "rollout_batch": f"rollout {scheme} (batch of {spec.get('batch')}, per trajectory)",
        "drake": str(scheme),
    }[driver]
    return f"{engine} {label}"


def scipy_spec(engine: str, driver: str, scheme: str, rtol: float, *, atol_factor: float) -> Spec:
    """A scipy run at `rtol`, atol = rtol * atol_factor."""
    return {
        "engine": engine,
        "driver": driver,
        "scheme": scheme,
        "setting": "rtol",
        "value": rtol,
        "atol": rtol * atol_factor,
    }


def taylor_spec(tol: float, engine: str = "hand") -> Spec:
    """heyoka's Taylor integrator in double precision on the hand equations or the "symbolic" source."""
    return {"engine": engine, "driver": "taylor", "scheme": "double", "setting": "tol", "value": tol, "atol": None}


def step_spec(engine: str, driver: str, scheme: str, timestep: float, *, batch: int | None = None) -> Spec:
    """A fixed-step run at `timestep` (s); `batch`: the copies of a "rollout_batch" run."""
    spec: Spec = {
        "engine": engine,
        "driver": driver,
        "scheme": scheme,
        "setting": "timestep",
        "value": timestep,
        "atol": None,
    }
    if batch is not None:
        spec["batch"] = batch
    return spec


def _drake_sweeps(accuracies: tuple[float, ...], timesteps: tuple[float, ...]) -> list[Sweep]:
    """Drake's integrators on its continuous plant (sources/drake.py `free_run`): its error-controlled RK3
    at target accuracies, and fixed-step RK2 and explicit Euler."""
    fixed = [Sweep("drake", "drake", scheme, "timestep", timesteps) for scheme in ("runge_kutta2", "explicit_euler")]
    return [Sweep("drake", "drake", "runge_kutta3", "accuracy", accuracies), *fixed]


def full_sweeps() -> tuple[Sweep, ...]:
    """Every method: scipy's four drivers on the hand equations and Pinocchio's ABA, MuJoCo's integrators,
    the mirror, the compiled contenders, heyoka's Taylor, MuJoCo's rollout and Drake's integrators."""
    rtols = tuple(10.0**-k for k in range(3, 13))
    timesteps = (1e-2, 1e-3, 1e-4, 1e-5)  # s
    rollout = (1e-2, 1e-3, 1e-4)  # s: rollout records every step, 1e-5 s would hold 1e6 states per copy
    taylor = tuple(10.0**-k for k in range(6, 17))  # heyoka's Taylor in double: 1e-6 .. 1e-16
    out: list[Sweep] = []
    for engine in ("hand", "pinocchio"):
        out += [Sweep(engine, "solve_ivp", m, "rtol", rtols) for m in ("RK45", "DOP853", "Radau", "LSODA")]
        out += [Sweep(engine, driver, "dop853", "rtol", rtols) for driver in ("ode", "ode_endpoints")]
        out.append(Sweep(engine, "odeint", "LSODA", "rtol", rtols))
    out += [Sweep("mujoco", "mujoco", integ, "timestep", timesteps) for integ in MUJOCO_INTEGRATORS]
    out.append(Sweep("pinocchio", "mirror", "RK4", "timestep", timesteps))
    out += [
        Sweep("hand-cfunc", "solve_ivp", "DOP853", "rtol", rtols),
        Sweep("hand-cfunc", "odeint", "LSODA", "rtol", rtols),
    ]
    out += [Sweep(engine, "taylor", "double", "tol", taylor) for engine in ("hand", "symbolic")]
    out.append(Sweep("hand", "compiled_rk4", "RK4", "timestep", timesteps))
    out += [Sweep("mujoco", driver, "RK4", "timestep", rollout) for driver in ("rollout", "rollout_batch")]
    return (*out, *_drake_sweeps(tuple(10.0**-k for k in range(4, 13)), (1e-2, 1e-3, 1e-4)))


def quick_sweeps() -> tuple[Sweep, ...]:
    """A few settings of each kind of method, and every driver a harness check uses."""
    rtols = (1e-3, 1e-6, 1e-9, 1e-12)
    timesteps = (1e-2, 1e-3, 1e-4)  # s
    rollout = (1e-2, 1e-3)  # s
    taylor = (1e-6, 1e-9, 1e-12, 1e-15)
    out = [Sweep("hand", "solve_ivp", m, "rtol", rtols) for m in ("DOP853", "RK45", "LSODA")]
    out += [Sweep("mujoco", "mujoco", integ, "timestep", timesteps) for integ in ("RK4", "Euler")]
    out.append(Sweep("hand", "odeint", "LSODA", "rtol", rtols))  # the default's driver
    out.append(Sweep("hand-cfunc", "odeint", "LSODA", "rtol", rtols))
    out.append(Sweep("pinocchio", "odeint", "LSODA", "rtol", rtols))  # Pinocchio's check's driver
    out += [Sweep(engine, "taylor", "double", "tol", taylor) for engine in ("hand", "symbolic")]
    out.append(Sweep("hand", "compiled_rk4", "RK4", "timestep", timesteps))
    out.append(Sweep("mujoco", "rollout", "RK4", "timestep", rollout))
    out.append(Sweep("pinocchio", "mirror", "RK4", "timestep", rollout))  # its check's
    out.append(Sweep("mujoco", "rollout_batch", "RK4", "timestep", rollout))
    return (*out, *_drake_sweeps((1e-4, 1e-6, 1e-8, 1e-10), (1e-2, 1e-3)))


FULL = Plan(sweeps=full_sweeps())


QUICK = Plan(
    sweeps=quick_sweeps(),
    systems=("double_pendulum_point", "gimbal"),
    quick=True,
    budget=5.0,
    repeats=1,
    target_s=60.0,
    rhs_reps=7,
    pointwise_reps=3,
    flag_steps=5_000,
    ratio_reps=3,
    time_run=False,
)

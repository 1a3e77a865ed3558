"""The benchmark's plan: what is swept (drivers, schemes, tolerances, timesteps), its budgets and
the targets of the fast-harness ratios.
"""

from __future__ import annotations

from typing import Any

from ...dynamics.integrate import SCIPY_DEFAULT
from ...engines import drake as drake_engine  # imports no pydrake: `unavailable` looks it up
from ...engines.base import MUJOCO_INTEGRATORS  # every one is swept

T_END = 10.0  # s: the grid of `run` (the reference cache is keyed by it)


DT_OUT = 0.01  # s


ERROR_TIMES = (2.0, 10.0)  # s


HORIZON_TOLERANCE = 1e-6  # rad: the trajectory tier, and the chaos summary's horizon tolerance


EPSILONS = (1e-3, 1e-6, 1e-9, 1e-12)  # rad, for "time to reach error eps" at t = 2 s


FRONTIER_EPSILONS = (1e-6, 1e-9, 1e-12)  # rad at t = 2 s: the default path against the fastest contender


ATOL_FACTOR = 1e-3  # atol = rtol * ATOL_FACTOR


RTOLS = tuple(10.0**-k for k in range(3, 13))


QUICK_RTOLS = (1e-3, 1e-6, 1e-9, 1e-12)


IVP_METHODS = ("RK45", "DOP853", "Radau", "LSODA")


QUICK_IVP_METHODS = ("DOP853", "RK45", "LSODA")


QUICK_MUJOCO_INTEGRATORS = ("RK4", "Euler")


TIMESTEPS = (1e-2, 1e-3, 1e-4, 1e-5)  # s


QUICK_TIMESTEPS = (1e-2, 1e-3, 1e-4)


TAYLOR_TOLERANCES = tuple(10.0**-k for k in range(6, 17))  # heyoka's Taylor in double: 1e-6 .. 1e-16


QUICK_TAYLOR_TOLERANCES = (1e-6, 1e-9, 1e-12, 1e-15)


TAYLOR_MAX_STEPS = 1_000_000  # a budget without a per-step callback: the references take ~46 steps/s


ROLLOUT_TIMESTEPS = (1e-2, 1e-3, 1e-4)  # rollout records every step: 1e-5 s would hold 1e6 states per copy


QUICK_ROLLOUT_TIMESTEPS = (1e-2, 1e-3)


ROLLOUT_BATCH = 8  # copies of the start in one batched rollout (its row's time is per trajectory)


# Drake's own integrators on its continuous plant (engines/drake.py `free_run`), where pydrake is installed:
# its error-controlled RK3 at target accuracies, and fixed-step RK2 and explicit Euler.
DRAKE_ACCURACIES = tuple(10.0**-k for k in range(4, 13))


QUICK_DRAKE_ACCURACIES = (1e-4, 1e-6, 1e-8, 1e-10)


DRAKE_FIXED = ("runge_kutta2", "explicit_euler")


DRAKE_TIMESTEPS = (1e-2, 1e-3, 1e-4)  # s


QUICK_DRAKE_TIMESTEPS = (1e-2, 1e-3)


QUICK_SYSTEMS = ("double_pendulum_point", "gimbal")


BUDGET = 20.0  # s of wall time per run


QUICK_BUDGET = 5.0


MIN_TIMED = 0.05  # s: shorter runs are repeated back to back (autorange)


MAX_EXECUTIONS = 200


DEFAULT_REPEATS = 3


QUICK_REPEATS = 1


QUICK_TARGET_S = 60.0


CHECK_EVERY = 128  # right-hand-side calls between deadline / finiteness checks (a power of two)


RHS_SYSTEM = "double_pendulum_point"


RHS_TARGET = 1.5  # fast path time / hand-written math time


POINTWISE_SIZES = (1_000, 100_000)  # states per batch: the pointwise ratio at each


POINTWISE_TARGET = 1.5  # harness time / raw engine calls time


CHECKS_TARGET = 1.5  # a harness trajectory check's time / the fastest run computing the same at its error


DEFAULT_EPSILON = 1e-9  # rad at t = 2 s


DEFAULT_TARGET = 1.5  # default scipy time / fastest scipy driver reaching DEFAULT_EPSILON


RUN_REPEATS = 5


RUN_TARGET_S = 20.0  # s wall for `lagrange-xval run` on all systems, warm or cold cache (issue 10)


RUN_WARM_TARGET_S = 15.0  # s wall with a warm cache (issue 6)


FLAG_INTEGRATORS = ("RK4", "Euler")


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


def method_name(spec: dict[str, Any]) -> str:
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
        "rollout_batch": f"rollout {scheme} (batch of {ROLLOUT_BATCH}, per trajectory)",
        "drake": str(scheme),
    }[driver]
    return f"{engine} {label}"


def scipy_spec(engine: str, driver: str, scheme: str | None, rtol: float) -> dict[str, Any]:
    return {
        "engine": engine,
        "driver": driver,
        "scheme": scheme,
        "setting": "rtol",
        "value": rtol,
        "atol": rtol * ATOL_FACTOR,
    }


def taylor_spec(tol: float, engine: str = "hand") -> dict[str, Any]:
    """heyoka's Taylor integrator in double precision on the hand equations or the "symbolic" source."""
    return {"engine": engine, "driver": "taylor", "scheme": "double", "setting": "tol", "value": tol, "atol": None}


def step_spec(engine: str, driver: str, scheme: str, timestep: float) -> dict[str, Any]:
    return {
        "engine": engine,
        "driver": driver,
        "scheme": scheme,
        "setting": "timestep",
        "value": timestep,
        "atol": None,
    }


def drake_specs(*, quick: bool) -> list[dict[str, Any]]:
    """Drake's integrators as contenders: RK3 at each target accuracy, RK2 and explicit Euler at fixed
    steps; none where pydrake is not importable."""
    if drake_engine.unavailable():
        return []
    accuracies = QUICK_DRAKE_ACCURACIES if quick else DRAKE_ACCURACIES
    specs = [
        {
            "engine": "drake",
            "driver": "drake",
            "scheme": "runge_kutta3",
            "setting": "accuracy",
            "value": a,
            "atol": None,
        }
        for a in accuracies
    ]
    for scheme in DRAKE_FIXED:
        specs += [
            step_spec("drake", "drake", scheme, dt) for dt in (QUICK_DRAKE_TIMESTEPS if quick else DRAKE_TIMESTEPS)
        ]
    return specs


def plan(*, quick: bool) -> list[dict[str, Any]]:
    """Every run of one system, loosest setting first within each method."""
    specs: list[dict[str, Any]] = []
    if quick:
        for m in QUICK_IVP_METHODS:
            specs += [scipy_spec("hand", "solve_ivp", m, r) for r in QUICK_RTOLS]
        for integ in QUICK_MUJOCO_INTEGRATORS:
            specs += [step_spec("mujoco", "mujoco", integ, dt) for dt in QUICK_TIMESTEPS]
        specs += [scipy_spec("hand", "odeint", "LSODA", r) for r in QUICK_RTOLS]  # the default's driver
        specs += [scipy_spec("hand-cfunc", "odeint", "LSODA", r) for r in QUICK_RTOLS]
        specs += [scipy_spec("pinocchio", "odeint", "LSODA", r) for r in QUICK_RTOLS]  # Pinocchio's check's driver
        specs += [taylor_spec(tol) for tol in QUICK_TAYLOR_TOLERANCES]
        specs += [taylor_spec(tol, "symbolic") for tol in QUICK_TAYLOR_TOLERANCES]
        specs += [step_spec("hand", "compiled_rk4", "RK4", dt) for dt in QUICK_TIMESTEPS]
        specs += [step_spec("mujoco", "rollout", "RK4", dt) for dt in QUICK_ROLLOUT_TIMESTEPS]
        specs += [step_spec("pinocchio", "mirror", "RK4", dt) for dt in QUICK_ROLLOUT_TIMESTEPS]  # its check's
        specs += [step_spec("mujoco", "rollout_batch", "RK4", dt) for dt in QUICK_ROLLOUT_TIMESTEPS]
    else:
        for engine in ("hand", "pinocchio"):
            for m in IVP_METHODS:
                specs += [scipy_spec(engine, "solve_ivp", m, r) for r in RTOLS]
            for driver in ("ode", "ode_endpoints"):
                specs += [scipy_spec(engine, driver, "dop853", r) for r in RTOLS]
            specs += [scipy_spec(engine, "odeint", "LSODA", r) for r in RTOLS]
        for integ in MUJOCO_INTEGRATORS:
            specs += [step_spec("mujoco", "mujoco", integ, dt) for dt in TIMESTEPS]
        specs += [step_spec("pinocchio", "mirror", "RK4", dt) for dt in TIMESTEPS]
        specs += [scipy_spec("hand-cfunc", "solve_ivp", "DOP853", r) for r in RTOLS]
        specs += [scipy_spec("hand-cfunc", "odeint", "LSODA", r) for r in RTOLS]
        specs += [taylor_spec(tol) for tol in TAYLOR_TOLERANCES]
        specs += [taylor_spec(tol, "symbolic") for tol in TAYLOR_TOLERANCES]
        specs += [step_spec("hand", "compiled_rk4", "RK4", dt) for dt in TIMESTEPS]
        for driver in ("rollout", "rollout_batch"):
            specs += [step_spec("mujoco", driver, "RK4", dt) for dt in ROLLOUT_TIMESTEPS]
    specs += drake_specs(quick=quick)
    specs.append(
        {
            "engine": "hand",
            "driver": "default",
            "scheme": SCIPY_DEFAULT["method"],
            "setting": "rtol",
            "value": SCIPY_DEFAULT["rtol"],
            "atol": SCIPY_DEFAULT["atol"],
        }
    )
    for s in specs:
        s["method"] = method_name(s)
    return specs

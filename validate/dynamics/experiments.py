"""The notes' own simulation experiments, reproduced for the hand derivation and every printed form.

The notes integrate the double pendulum with ode45 from theta = 0, phi = 3 and from phi = 3.01
(Matlab's default RelTol 1e-3, then 1e-6) and say the two responses stop resembling each other
after about 7 s. Here every dynamic form (the hand derivation, each printed implicit, explicit and
Matlab form) runs both initial conditions with scipy's RK45 (the same Dormand-Prince 5(4) pair as
ode45) at both tolerances, and two times are reported:

    separation   when the two initial conditions differ by more than RESEMBLANCE (rad);
    departure    when the phi = 3 run departs by more than RESEMBLANCE from the accurate solution
                 of the hand equations (heyoka Taylor in double, dynamics/fast.py): how long the loose
                 solver is right.

Some printed forms are wrong, so every integration is bounded (validate/dynamics/integrate.py `Budget`): a
form that blows up or spends its budget is recorded with the reason ("diverged at t = ...",
"stopped: budget: ...") as its status, and its run is kept up to there (NaN after).
"""

from __future__ import annotations

import numpy as np

from ..forms import Explicit, Implicit, NotApplicable
from ..model.start import Start
from ..sources.fastpath import ScalarRhs, scalar_rhs
from ..sources.hand import HandSource
from ..systems import System
from .fast import accurate_trajectory
from .integrate import (
    DEFAULT_BUDGET,
    Budget,
    RunStats,
    first_exceeding,
    initial_state,
    integrate_rhs,
    outcome,
    time_grid,
)

PERTURBATION = 0.01  # rad, added to the last coordinate, as the notes perturb phi
RESEMBLANCE = 0.5  # rad: half a radian apart, two pendulum animations no longer look alike
TOLERANCES = (1e-3, 1e-6)  # Matlab's default RelTol, and the notes' odeset('RelTol', 1e-6)
T_END = 10.0  # s, the notes' [0, 10]
DT_OUT = 0.02  # s


def dynamic_forms(system: System) -> list[tuple[str, Implicit | Explicit | None]]:
    """(name, variant) for the hand derivation (variant None) and every printed form with dynamics."""
    return [("hand derivation", None)] + [(v.name, v) for v in system.variants if isinstance(v, (Explicit, Implicit))]


def _integrate(
    rhs: ScalarRhs,
    q0: np.ndarray,
    v0: np.ndarray,
    tau: np.ndarray,
    t: np.ndarray,
    *,
    method: str,
    rtol: float,
    atol: float,
    budget: Budget = DEFAULT_BUDGET,
) -> tuple[np.ndarray, RunStats]:
    """q (K, n) of the compiled right-hand side `rhs` (NaN after a stop) and {"status", "stopped_at",
    "reason", "nfev"} (validate/dynamics/integrate.py `outcome`); never raises for what `rhs` computes."""
    n = len(q0)
    run = integrate_rhs(
        rhs,
        np.concatenate([q0, v0]),
        t,
        method=method,
        rtol=rtol,
        atol=atol,
        budget=budget,
        args=([float(x) for x in tau],),
    )
    info: RunStats = {**outcome(run, t, budget=budget, equations="printed form", solver=f"scipy {method}", n=n)}
    info["nfev"] = run.nfev
    return run.y[:, :n].copy(), info


def _status(info: RunStats) -> str:
    """The run's status for the report: ok, or the one-line reason ("diverged at t = ...", ...)."""
    return "ok" if info["status"] == "ok" else str(info["reason"])


def run_experiments(system: System) -> dict[str, object]:
    """Both initial conditions, both tolerances, every dynamic form; plain data for the report."""
    q0, v0 = initial_state(system)
    tau = np.zeros(system.nv)
    t = time_grid(T_END, DT_OUT)
    q0b = q0.copy()
    q0b[-1] += PERTURBATION
    forms = dynamic_forms(system)

    fast = accurate_trajectory(system, HandSource(system), Start(q0, v0, tau), t)
    accurate, accurate_info = fast.q, fast.stats
    runs: list[dict[str, object]] = []
    for name, variant in forms:
        try:
            rhs = scalar_rhs(system, variant)
        except NotApplicable as exc:  # a printed form that does not apply to these parameters
            runs.extend({"form": name, "rtol": rtol, "status": f"not applicable: {exc}"} for rtol in TOLERANCES)
            continue
        for rtol in TOLERANCES:
            qa, info_a = _integrate(rhs, q0, v0, tau, t, method="RK45", rtol=rtol, atol=1e-6)
            qb, info_b = _integrate(rhs, q0b, v0, tau, t, method="RK45", rtol=rtol, atol=1e-6)
            sep = np.abs(qa - qb).max(axis=1)
            dep = np.abs(qa - accurate).max(axis=1)
            runs.append(
                {
                    "form": name,
                    "rtol": rtol,
                    "status": _status(info_a) if info_a["status"] != "ok" else _status(info_b),
                    "stopped_at": min(info_a["stopped_at"], info_b["stopped_at"]),
                    "q": qa,
                    "q_perturbed": qb,
                    "separation_time": first_exceeding(t, np.nan_to_num(sep, nan=np.inf), RESEMBLANCE),
                    "departure_time": first_exceeding(t, np.nan_to_num(dep, nan=np.inf), RESEMBLANCE),
                }
            )
    return {
        "method": "scipy RK45 (Dormand-Prince 5(4), as Matlab's ode45), atol 1e-6",
        "accurate": f"hand equations, {fast.method}",
        "q0": q0,
        "v0": v0,
        "perturbed_coordinate": system.coordinates[-1],
        "perturbation": PERTURBATION,
        "resemblance": RESEMBLANCE,
        "t": t,
        "q_accurate": accurate,
        "accurate_status": _status(accurate_info),
        "runs": runs,
        # What the notes say of this experiment (equations module; None where the notes have none).
        "notes_experiment": getattr(system.equations, "NOTES_EXPERIMENT", None),
        "notes_separation": getattr(system.equations, "NOTES_SEPARATION", None),
    }

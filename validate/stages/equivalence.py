"""Two formulations of one physical system must map onto each other.

A module may declare `SAME_SYSTEM_AS = "<other system>"`: both MJCFs then describe the same chain
(the same joints), and each module's JOINT_MAP (identity if absent) maps joint angles to its own
coordinates, so q_this = B q_other with B = A_this A_other^-1. The hand equations of both must
satisfy, at random states and along a trajectory, with the same physical parameters (both read
from this system's model, and from each of its probe models):

    M_other = B^T M_this B,  bias_other = B^T bias_this,  T, V and body positions equal,
    q_this(t) = B q_other(t) when both start from mapped initial states.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..core.tolerances import TOLERANCES, UP_TO_A_CONSTANT
from ..dynamics.fast import accurate_trajectory
from ..dynamics.integrate import (
    DEFAULT_DT_OUT,
    DEFAULT_T_END,
    initial_state,
    time_grid,
)
from ..model.start import Start
from ..results.schema import Equivalence, EquivalenceRow
from ..sources.hand import HandSource
from ..systems import System, load
from ..verdict.pointwise import midrange, random_states


def _map(system: System) -> np.ndarray:
    A = system.joint_map
    return np.eye(system.nv) if A is None else A


def _rows_at(
    this_sys: System, other_sys: System, B: np.ndarray, *, n: int, seed: int, label: str
) -> list[EquivalenceRow]:
    states = random_states(other_sys, n=n, seed=seed)
    q_o, v_o = states.q, states.v
    q_t, v_t = q_o @ B.T, v_o @ B.T
    this, that = HandSource(this_sys), HandSource(other_sys)
    pairs: dict[str, Callable[[], tuple[np.ndarray, np.ndarray]]] = {
        "M": lambda: (B.T @ this.mass_matrix(q_t) @ B, that.mass_matrix(q_o)),
        "bias": lambda: (this.bias(q_t, v_t) @ B, that.bias(q_o, v_o)),
        "T": lambda: (this.energies(q_t, v_t)[0], that.energies(q_o, v_o)[0]),
        "V": lambda: (this.energies(q_t, v_t)[1], that.energies(q_o, v_o)[1]),
        "body_positions": lambda: (this.body_positions(q_t), that.body_positions(q_o)),
    }
    rows: list[EquivalenceRow] = []
    for quantity, compute in pairs.items():
        tolerance = TOLERANCES.algebraic.rtol
        try:
            a, b = compute()
            if quantity in UP_TO_A_CONSTANT:  # V's zero is each derivation's own (results.schema.SCALED_DEFINITION)
                a = a - midrange(a - b)
            err = float(np.abs(a - b).max())
            scale = float(np.abs(b).max()) or 1.0
            passed = bool(err / scale <= TOLERANCES.algebraic.rtol)
            row: EquivalenceRow = {
                "quantity": quantity,
                "parameters": label,
                "tolerance": tolerance,
                "max_abs": err,
                "scaled": err / scale,
                "passed": passed,
            }
        except Exception as exc:  # noqa: BLE001 - a derivation's own failure is a failing row
            row = {
                "quantity": quantity,
                "parameters": label,
                "tolerance": tolerance,
                "max_abs": float("inf"),
                "scaled": float("inf"),
                "passed": False,
                "error": f"{type(exc).__name__}: {exc}",
            }
        rows.append(row)
    return rows


def check_equivalence(
    system: System,
    probe_systems: list[System] | None = None,
    *,
    n: int = 200,
    seed: int = 0,
    t_end: float = DEFAULT_T_END,
) -> Equivalence | None:
    """Rows of the mapped comparison, or None if the module names no other formulation.

    Both derivations are evaluated with the same physical parameters: the other module reads its
    parameters from THIS system's model (and from each of `probe_systems`, this system's probe
    models), so editing one model never fails the other."""
    other_name = getattr(system.equations, "SAME_SYSTEM_AS", None)
    if other_name is None:
        return None

    other_module = load(other_name).equations
    rows: list[EquivalenceRow] = []
    B = _map(system) @ np.linalg.inv(_map(system.derive(equations=other_module)))
    for i, this_sys in enumerate([system, *(probe_systems or [])]):
        other_sys = this_sys.derive(equations=other_module)
        label = "model" if i == 0 else f"probe {i}"
        try:
            other_sys.params  # noqa: B018 - reads the other module's parameters from this model
        except Exception as exc:  # noqa: BLE001
            rows.append(
                {
                    "quantity": "parameters",
                    "parameters": label,
                    "max_abs": float("inf"),
                    "scaled": float("inf"),
                    "tolerance": 0.0,
                    "passed": False,
                    "error": f"{other_name}'s parameters() cannot read {system.mjcf.name}: {type(exc).__name__}: {exc}",
                }
            )
            continue
        rows += _rows_at(this_sys, other_sys, B, n=n, seed=seed + i, label=label)
    # Trajectories from the other system's initial state, mapped, at this model's parameters.

    other_sys = system.derive(equations=other_module)
    this, that = HandSource(system), HandSource(other_sys)
    q0, v0 = initial_state(other_sys)
    t = time_grid(t_end, DEFAULT_DT_OUT)
    tau = np.zeros(system.nv)
    tr_o = accurate_trajectory(other_sys, that, Start.of(q0, v0, tau), t)
    tr_t = accurate_trajectory(system, this, Start.of(B @ q0, B @ v0, tau), t)
    err = np.abs(tr_t.q - tr_o.q @ B.T).max(axis=1)
    worst = float(np.nanmax(err)) if np.isfinite(err).any() else float("inf")
    rows.append(
        {
            "quantity": f"trajectory q over {t_end:g} s",
            "parameters": "model",
            "max_abs": worst,
            "scaled": worst,
            "tolerance": TOLERANCES.trajectory.rtol,
            "passed": bool(np.all(np.isfinite(err)) and worst <= TOLERANCES.trajectory.rtol),
        }
    )
    return {
        "other": other_name,
        "map": B,
        "n_states": n,
        "probes": len(probe_systems or []),
        "rows": rows,
        "passed": all(r["passed"] for r in rows),
    }

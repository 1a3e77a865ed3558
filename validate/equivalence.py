"""Two formulations of one physical system must map onto each other.

A module may declare `SAME_SYSTEM_AS = "<other system>"`: both MJCFs then describe the same chain
(the same joints), and each module's JOINT_MAP (identity if absent) maps joint angles to its own
coordinates, so q_this = B q_other with B = A_this A_other^-1. The hand equations of both must
satisfy, at random states and along a trajectory:

    M_other = B^T M_this B,  bias_other = B^T bias_this,  T, V and body positions equal,
    q_this(t) = B q_other(t) when both start from mapped initial states.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .compare import random_states
from .integrate import SCIPY_DEFAULT, scipy_trajectory, time_grid
from .sources.hand import HandSource
from .tolerances import TOLERANCES


def _map(system: Any) -> np.ndarray:
    A = system.joint_map
    return np.eye(system.nv) if A is None else A


def check_equivalence(system: Any, *, n: int = 200, seed: int = 0, t_end: float = 10.0) -> dict[str, Any] | None:
    """Rows of the mapped comparison, or None if the module names no other formulation."""
    other_name = getattr(system.equations, "SAME_SYSTEM_AS", None)
    if other_name is None:
        return None
    from .systems import load

    other = load(other_name)
    B = _map(system) @ np.linalg.inv(_map(other))
    states = random_states(other, n=n, seed=seed)
    q_o, v_o = states.q, states.v
    q_t, v_t = q_o @ B.T, v_o @ B.T
    this, that = HandSource(system), HandSource(other)
    pairs = {
        "M": (B.T @ this.mass_matrix(q_t) @ B, that.mass_matrix(q_o)),
        "bias": (this.bias(q_t, v_t) @ B, that.bias(q_o, v_o)),
        "T": (this.energies(q_t, v_t)[0], that.energies(q_o, v_o)[0]),
        "V": (this.energies(q_t, v_t)[1], that.energies(q_o, v_o)[1]),
        "body_positions": (this.body_positions(q_t), that.body_positions(q_o)),
    }
    rows = []
    for quantity, (a, b) in pairs.items():
        err = float(np.abs(a - b).max())
        scale = float(np.abs(b).max()) or 1.0
        rows.append(
            {
                "quantity": quantity,
                "max_abs": err,
                "scaled": err / scale,
                "tolerance": TOLERANCES.algebraic.rtol,
                "passed": err / scale <= TOLERANCES.algebraic.rtol,
            }
        )
    # Trajectories from the other system's initial state, mapped.
    from .integrate import initial_state

    q0, v0 = initial_state(other)
    t = time_grid(t_end, 0.01)
    tau = np.zeros(system.nv)
    tr_o = scipy_trajectory(other, that, q0, v0, tau, t, **SCIPY_DEFAULT)
    tr_t = scipy_trajectory(system, this, B @ q0, B @ v0, tau, t, **SCIPY_DEFAULT)
    err = np.abs(tr_t.q - tr_o.q @ B.T).max(axis=1)
    rows.append(
        {
            "quantity": f"trajectory q over {t_end:g} s",
            "max_abs": float(err.max()),
            "scaled": float(err.max()),
            "tolerance": TOLERANCES.trajectory.rtol,
            "passed": float(err.max()) <= TOLERANCES.trajectory.rtol,
        }
    )
    return {"other": other_name, "map": B, "n_states": n, "rows": rows, "passed": all(r["passed"] for r in rows)}

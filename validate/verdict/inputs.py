"""The inputs of a derivation: explicit accelerations or a residual taking the actuators' controls `u`
(tau = B u, validate/systems/__init__.py `input_matrix`), and explicit accelerations taking `tau`
that ignore a coordinate's.

Explicit accelerations with `u` give M^-1 B, not M: they are judged as a printed explicit form is
(judge.py `judge_variant`: M^-1 times each force against the engines'). A residual with `u` gives
B u, judged against tau. An input a function ignores (a zero response) is named.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..core.tolerances import TOLERANCES, Tolerances
from ..forms import Explicit
from ..handwritten.forms import written_form, written_function
from ..results.schema import TermRow
from ..systems import System
from .judge import judge_variant
from .pointwise import States
from .terms import EngineTerms, term_rows

ErrorRow = Callable[[str, str, str], TermRow]  # (term, engine, why) -> a failing row


def ignored_torques(system: System, states: States) -> str:
    """For explicit accelerations taking tau: the coordinates whose tau the person's qacc ignores (a
    published form with inputs on the actuated coordinates only, transcribed with tau), said plainly."""
    if written_form(system.equations) != "c" or system.inputs != "tau":
        return ""
    qacc, q = written_function(system.derivation, "qacc"), states.q[:16]
    zero = np.zeros_like(q)
    try:
        with np.errstate(all="ignore"):
            a0 = np.asarray(qacc(system.params, q, zero, zero), dtype=float)
            cols = [
                np.asarray(qacc(system.params, q, zero, np.broadcast_to(e, q.shape)), dtype=float) - a0
                for e in np.eye(system.nv)
            ]
    except Exception:  # noqa: BLE001 - the call's own failure is reported by hand_terms
        return ""
    lost = [j for j, c in enumerate(cols) if np.all(np.isfinite(c)) and not np.any(c)]
    if not lost:
        return ""
    which = ", ".join(f"tau[{j}] ({system.coordinates[j]})" for j in lost)
    return (
        f"your qacc does not depend on {which}: qacc(p, q, v, tau) takes a generalized force on every coordinate; "
        "for inputs on the actuated coordinates only, name its last parameter u (the actuators' controls)"
    )


def _controls(system: System, tau: np.ndarray) -> np.ndarray:
    """u with B u = tau (the states' tau is drawn in the inputs' range)."""
    return np.asarray(tau) @ np.linalg.pinv(system.input_matrix).T


def _unit_controls(system: System, q: np.ndarray) -> list[np.ndarray]:
    nu = system.input_matrix.shape[1]
    return [np.broadcast_to(np.eye(nu)[k], (len(q), nu)) for k in range(nu)]


def _ignored_inputs(system: System, response: list[np.ndarray], fname: str, error_row: ErrorRow) -> list[TermRow]:
    """A failing actuation row for each input the person's function ignores (its response is zero)."""
    out: list[TermRow] = []
    for k, col in enumerate(response):
        if np.all(np.isfinite(col)) and not np.any(col):
            why = f"your {fname} does not depend on u[{k}] (actuator {system.actuators[k]})"
            out += [error_row("actuation", engine, why) for engine in ("mujoco", "pinocchio")]
    return out


def acceleration_rows(
    system: System, states: States, terms: EngineTerms, *, error_row: ErrorRow, tolerances: Tolerances = TOLERANCES
) -> list[TermRow]:
    """Explicit accelerations with inputs u, judged as a printed explicit form is (judge.py): each
    force's acceleration M^-1 (G, C v, friction, B u) against the engines', and the accelerations."""
    qacc = written_function(system.derivation, "qacc")
    variant = Explicit(
        name="your derivation",
        notes_equations=(),
        acceleration=lambda p, q, v, tau: qacc(p, q, v, _controls(system, tau)),
    )
    try:
        with np.errstate(all="ignore"):
            rows: list[TermRow] = list(
                judge_variant(system, variant, terms, states, tolerances=tolerances, printed_parameters=False)["terms"]
            )
            zero = np.zeros_like(states.q)
            a0 = np.asarray(qacc(system.params, states.q, zero, _controls(system, zero)), dtype=float)
            response = [
                np.asarray(qacc(system.params, states.q, zero, u), dtype=float) - a0
                for u in _unit_controls(system, states.q)
            ]
    except Exception as exc:  # noqa: BLE001 - the user's code: its failure is the finding
        why = f"qacc() raised {type(exc).__name__}: {exc}".strip()
        return [error_row("acceleration", engine, why) for engine in terms.engines]
    for row in rows:
        row["pair"] = f"hand~{row['engine']}"
    return rows + _ignored_inputs(system, response, "qacc", error_row)


def actuation_rows(
    system: System, states: States, terms: EngineTerms, *, error_row: ErrorRow, tolerances: Tolerances = TOLERANCES
) -> list[TermRow]:
    """An implicit residual with inputs u: -(r(q, 0, 0, u) - r(q, 0, 0, 0)) is the person's B u, against tau."""
    r, p, q = written_function(system.derivation, "residual"), system.params, states.q
    zero = np.zeros_like(q)
    try:
        with np.errstate(all="ignore"):
            r0 = np.asarray(r(p, q, zero, zero, _controls(system, zero)), dtype=float)
            mine = r0 - np.asarray(r(p, q, zero, zero, _controls(system, states.tau)), dtype=float)
            response = [r0 - np.asarray(r(p, q, zero, zero, u), dtype=float) for u in _unit_controls(system, q)]
    except Exception as exc:  # noqa: BLE001 - the user's code: its failure is the finding
        why = f"residual() raised {type(exc).__name__}: {exc}".strip()
        return [error_row("actuation", engine, why) for engine in terms.engines]
    refs = {k: terms.by_engine[k]["tau"] for k in terms.engines}
    rows = term_rows("actuation", mine, refs, states, tier="algebraic", tolerances=tolerances, who="hand")
    return rows + _ignored_inputs(system, response, "residual", error_row)

"""Explicit accelerations with inputs, `qacc(p, q, v, u)`, explained in forces as form (a) is.

Such a module gives M^-1 times each force, not the forces (handwritten/forms.py `_accelerations_facade`:
M = I, bias and passive in accelerations). To name a slip in the person's symbols, each of their
terms is mapped back to a force with the model's own mass matrix M (the engines' at the same
parameters), and the forces are then explained entry by entry as form (a)'s are (verdict/explain.py):

    gravity   G = -M qacc(q, 0, 0)           velocity  C v = -M (even part of qacc(q, v, 0) - qacc(q, 0, 0))
    friction  passive = M (odd part in v)    mass      M_yours = B (d qacc / d u)^-1, where every
                                                       coordinate is actuated (B square and invertible)

A slip in one force keeps its entries a simple difference from the expected ones ("G[shoulder]: yours
has l1 where expected has lc1"). A slip in the mass matrix of an under-actuated module (M cannot be
read back from M^-1 B) changes every force mapped back, and is said to be no single slip.

Actuation is explained numerically, column by column: the person's B = M (d qacc / d u) (of an
implicit residual r(p, q, v, a, u): -(d r / d u)) against the model's (each actuator's gear on its
joint): "B[theta2, elbow_motor]: yours is 1/2 of the model's: the gear 2 (actuator/elbow_motor/gear) is
left out (u enters as tau = u)".
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..handwritten.forms import written_form, written_function
from ..results.schema import Explanation
from ..sources import make_source
from ..systems import System
from .pointwise import random_states

User = Callable[[System, np.ndarray, np.ndarray], np.ndarray]
GEAR_RTOL = 1e-6  # a column of yours is a multiple of the model's when it fits to this, relative


def _engine_mass(system: System, q: np.ndarray) -> np.ndarray:
    """The model's own M at `system`'s parameters (MuJoCo's; u forms have no JOINT_MAP), (N, n, n)."""
    return np.asarray(make_source(system, "mujoco").mass_matrix(q), dtype=float)


def _response(system: System, q: np.ndarray) -> np.ndarray:
    """d qacc / d u at rest (N, n, nu): the person's M^-1 B, column by column."""
    qacc, p = written_function(system.derivation, "qacc"), system.params
    zero = np.zeros_like(q)
    nu = system.input_matrix.shape[1]
    u0 = np.zeros((len(q), nu))
    a0 = np.asarray(qacc(p, q, zero, u0), dtype=float)
    cols = [np.asarray(qacc(p, q, zero, u0 + np.eye(nu)[k]), dtype=float) - a0 for k in range(nu)]
    return np.stack(cols, axis=-1)


def force_part(part: str, index: tuple[int, ...]) -> User:
    """user(system, q, v) of one entry of a force of a u-form module, mapped back with the model's M."""

    def user(system: System, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        eq, p = system.derivation, system.params
        M = _engine_mass(system, q)
        zero = np.zeros_like(q)
        if part == "M":
            B = system.input_matrix
            x = np.einsum("ij,njk->nik", B, np.linalg.inv(_response(system, q)))
        elif part == "G":
            x = np.einsum("nij,nj->ni", M, np.asarray(eq.bias(p, q, zero), dtype=float))
        elif part == "Cv":
            accel = np.asarray(eq.bias(p, q, v), dtype=float) - np.asarray(eq.bias(p, q, zero), dtype=float)
            x = np.einsum("nij,nj->ni", M, accel)
        else:  # passive
            x = np.einsum("nij,nj->ni", M, np.asarray(eq.passive(p, q, v), dtype=float))
        return np.asarray(x[(slice(None), *index)])

    return user


def mass_identifiable(system: System) -> bool:
    """M can be read back from M^-1 B: every coordinate actuated, B square and invertible."""
    B = system.input_matrix
    return bool(B.shape[0] == B.shape[1] and np.linalg.matrix_rank(B) == B.shape[0])


def actuation_explanations(system: System, probe_systems: list[System], *, seed: int = 0) -> list[Explanation]:
    """Each actuator whose column of the person's B = M (d qacc / d u) differs from the model's: by what
    factor where it is a multiple of it (a gear left out or doubled), else on which coordinates."""
    out: list[Explanation] = []
    B = system.input_matrix
    for s in [system, *probe_systems]:
        q = random_states(s, n=8, seed=seed).q
        with np.errstate(all="ignore"):
            mine = _input_columns(s, q)
        for k, actuator in enumerate(s.actuators):
            if any(e["entry"].endswith(f", {actuator}]") for e in out):
                continue
            found = _column(s, B if s is system else s.input_matrix, mine[..., k], k, actuator)
            if found is not None:
                out.append({**found, "at_model": s is system})
    return out


def _input_columns(system: System, q: np.ndarray) -> np.ndarray:
    """The person's B (N, n, nu): M (d qacc / d u) for explicit accelerations, -(d residual / d u) for
    an implicit residual."""
    if written_form(system.equations) == "c":
        return np.asarray(np.einsum("nij,njk->nik", _engine_mass(system, q), _response(system, q)))
    r, p = written_function(system.derivation, "residual"), system.params
    zero = np.zeros_like(q)
    nu = system.input_matrix.shape[1]
    u0 = np.zeros((len(q), nu))
    r0 = np.asarray(r(p, q, zero, zero, u0), dtype=float)
    cols = [r0 - np.asarray(r(p, q, zero, zero, u0 + np.eye(nu)[k]), dtype=float) for k in range(nu)]
    return np.stack(cols, axis=-1)


def _column(system: System, B: np.ndarray, mine: np.ndarray, k: int, actuator: str) -> Explanation | None:
    """One actuator's column, explained (None where it agrees)."""
    expected = B[:, k]
    scale = max(float(np.abs(expected).max()), float(np.abs(mine).max()), 1e-300)
    if not np.all(np.isfinite(mine)) or float(np.abs(mine - expected).max()) <= 1e-9 * scale:
        return None
    j = int(np.argmax(np.abs(expected)))
    joint = system.coordinates[j]
    key = f"actuator/{actuator}/gear"
    gear = float(system.view[key][0] if np.ndim(system.view[key]) else system.view[key])
    factor = float(np.median(mine[:, j] / expected[j]))
    fits = float(np.abs(mine - factor * expected).max()) <= GEAR_RTOL * scale
    entry = f"B[{joint}, {actuator}]"
    if fits and np.isclose(factor * gear, 1.0, rtol=GEAR_RTOL):
        said = f"yours is 1/{gear:g} of the model's: the gear {gear:g} ({key}) is left out (u enters as tau = u)"
    elif fits:
        said = f"yours is {factor:.6g} times the model's (gear {gear:g}, {key})"
    else:
        where = ", ".join(f"{c}: {float(np.median(mine[:, i])):.4g}" for i, c in enumerate(system.coordinates))
        said = f"yours puts u[{k}] on ({where}) where the model puts its gear {gear:g} on {joint} alone"
    return {"term": "actuation", "entry": entry, "expected": f"{gear:g}", "explained": fits, "statement": said}

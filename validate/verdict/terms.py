"""What the engines say each term of a derivation is, and the rows that compare a derivation's term
with it (verdict/judge.py judges the printed forms with these, verdict/verdict.py a derivation).

`EngineTerms` separates the engines' dynamics into the terms a printed form is split into (mass
matrix, gravity, velocity, friction, actuation; verdict/judge.py's docstring says how a form is
split); `term_rows` compares one term of a derivation with every engine's, as `TermRow`s.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import TypeAlias

import numpy as np

from ..core.tolerances import UP_TO_A_CONSTANT, Tolerances
from ..model.modelview import ModelView
from ..results.schema import ComparisonRow, TermRow
from ..sources.base import Kinematics, Source, posed
from ..systems import System
from .pointwise import States, error_row

# engine -> quantity ("M", "bias", "passive", "qacc", "T", "V", ...) -> its values at the states (Source.evaluate)
EngineValues: TypeAlias = dict[str, dict[str, np.ndarray]]

ENGINES = ("mujoco", "pinocchio", "symbolic", "drake")  # the references a derivation is judged against


def engines_of(sources: Mapping[str, Source]) -> tuple[str, ...]:
    """The references among `sources` (the symbolic one is left out of chains too long to derive)."""
    return tuple(n for n in ENGINES if n in sources)


TERM_ORDER = (
    "printed parameters",
    "mass matrix",
    "gravity",
    "velocity",
    "friction",
    "actuation",
    "residual",
    "acceleration",
    "value",
)


def frictionless_params(system: System) -> object:
    """The equations' parameters read from the same model with every joint's damping set to zero."""
    values = {k: (0.0 if k.endswith("/damping") else system.view[k]) for k in system.view}
    return system.derivation.parameters(ModelView(values, system.view.source + " (no friction)"))


def _solve(M: np.ndarray, x: np.ndarray) -> np.ndarray:
    """M^-1 x at every state: M (N, n, n), x (N, n)."""
    return np.asarray(np.linalg.solve(M, x[..., None])[..., 0])


class EngineTerms:
    """The engines' primitives at the sample states, computed once per system."""

    def __init__(
        self,
        system: System,
        sources: Mapping[str, Source],
        states: States,
        values: EngineValues | None = None,
    ) -> None:
        """`values`: what `compare.evaluate` already computed at these states, reused rather than recomputed."""
        q, v, tau = states.q, states.v, states.tau
        zero = np.zeros_like(q)
        self.engines = engines_of(sources)
        self.by_engine: EngineValues = {}
        for name in self.engines:
            src = sources[name]
            known = (values or {}).get(name)
            M = known["M"] if known else src.mass_matrix(q)
            G = src.bias(q, zero)
            bias = known["bias"] if known else src.bias(q, v)
            passive = known["passive"] if known else src.passive(q, v)
            solve = functools.partial(_solve, M)
            self.by_engine[name] = {
                "M": M,
                "G": G,
                "Cv": bias - G,
                "passive": passive,
                "tau": tau,
                "a": known["qacc"] if known else src.forward(q, v, tau),
                "a_gravity": solve(-G),
                "a_velocity": solve(-(bias - G)),
                "a_friction": solve(passive),
                "a_actuation": solve(tau),
            }
        self._sources, self._states = sources, states
        self.energies = {
            name: (values[name]["T"], values[name]["V"]) if values and name in values else sources[name].energies(q, v)
            for name in self.engines
        }

    @functools.cached_property
    def kinematics(self) -> dict[str, Kinematics]:
        """Per-body kinematics of each engine, computed on first use (derivation steps need them)."""
        q, v = self._states.q, self._states.v
        return {name: posed(self._sources[name]).kinematics(q, v) for name in self.engines}


def term_rows(
    term: str,
    printed: np.ndarray,
    engines: dict[str, np.ndarray],
    states: States,
    *,
    tier: str,
    tolerances: Tolerances,
    min_scale: dict[str, float] | None = None,
    who: str = "printed",
    cond: np.ndarray | None = None,
    up_to_constant: bool | None = None,
) -> list[TermRow]:
    """`printed` against each engine's value: one row per engine (pointwise.error_row's, as a term);
    the potential energy up to a constant (`up_to_constant` None: as core.tolerances.UP_TO_A_CONSTANT
    says of `term`)."""
    constant = term in UP_TO_A_CONSTANT if up_to_constant is None else up_to_constant
    return [
        as_term_row(
            error_row(
                term,
                f"{who}~{name}",
                printed,
                ref,
                states,
                tier=tier,
                tolerances=tolerances,
                min_scale=(min_scale or {}).get(name, 0.0),
                cond=cond,
                up_to_constant=constant,
            ),
            engine=name,
        )
        for name, ref in engines.items()
    ]


def as_term_row(row: ComparisonRow, *, engine: str) -> TermRow:
    """A comparison row as a derivation's term row: its `quantity` is the `term`, judged against `engine`."""
    out: TermRow = {
        "term": row["quantity"],
        "engine": engine,
        "pair": row["pair"],
        "max_abs": row["max_abs"],
        "max_rel": row["max_rel"],
        "scale": row["scale"],
        "scaled": row["scaled"],
        "tolerance": row["tolerance"],
        "tier": row["tier"],
        "passed": row["passed"],
        "worst_state": row["worst_state"],
    }
    if "cond_max" in row:
        out["cond_max"] = row["cond_max"]
    if "constant" in row:
        out["constant"] = row["constant"]
    return out


def _axis_rotation(axis: np.ndarray, angle: np.ndarray, engine: str) -> np.ndarray:
    """The engine's own rotation by `angle` about the unit `axis`, (N, 3, 3)."""
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    if engine == "mujoco":
        from ..sources import mujoco as engine_module
    elif engine == "drake":
        from ..sources import drake as engine_module  # type: ignore[no-redef]
    else:
        from ..sources import pinocchio as engine_module  # type: ignore[no-redef]
    return engine_module.axis_rotation(axis, np.asarray(angle, dtype=float))


def engine_quantity(
    system: System, terms: EngineTerms, quantity: tuple[object, ...], engine: str, states: States, angle_index: int
) -> np.ndarray:
    """What `engine` computes for a derivation step's quantity."""
    kind, which = quantity[0], quantity[1] if len(quantity) > 1 else None
    if kind == "axis_rotation":
        return _axis_rotation(np.asarray(which), states.q[:, angle_index], engine)
    kin = terms.kinematics[engine]
    if which is None:
        if kind == "kinetic_energy":
            return terms.energies[engine][0]
        if kind == "potential_energy":
            return terms.energies[engine][1]
        if kind == "lagrangian":
            return np.asarray(terms.energies[engine][0] - terms.energies[engine][1])
        raise ValueError(f"quantity {quantity} needs a body")
    k = system.bodies.index(which)
    simple = {
        "com_position": kin.com_position,
        "com_velocity": kin.com_velocity,
        "origin_position": kin.origin_position,
        "origin_velocity": kin.origin_velocity,
        "rotation": kin.rotation,
        "angular_velocity": kin.angular_velocity,
        "kinetic_energy": kin.kinetic_energy,
        "potential_energy": kin.potential_energy,
    }
    if kind in simple:
        return np.asarray(simple[kind][:, k])
    if kind in ("translational_kinetic_energy", "rotational_kinetic_energy"):
        trans = np.asarray(
            0.5
            * system.view[f"body/{which}/mass"]
            * np.einsum("ni,ni->n", kin.com_velocity[:, k], kin.com_velocity[:, k])
        )
        return trans if kind.startswith("translational") else kin.kinetic_energy[:, k] - trans
    if kind == "com_speed_squared":
        return np.asarray(np.einsum("ni,ni->n", kin.com_velocity[:, k], kin.com_velocity[:, k]))
    if kind == "angular_velocity_body":
        return np.asarray(np.einsum("nji,nj->ni", kin.rotation[:, k], kin.angular_velocity[:, k]))
    raise ValueError(f"unknown derivation-step quantity {quantity}")

"""Probe parameter sets: the same chain with every parameter of a derivation moved independently.

A derivation checked only at the model's own numbers can hide its mistakes there: with m1 = m2 = 1
and l1 = l2 = 1, writing l1 l2 for l2^2, m2 for m1 or forgetting a factor l changes nothing. So
every derivation is also judged at K probe models. A probe moves each field of the derivation's
`Params` by its own random factor in [0.5, 0.8] or [1.25, 2] (moderate, never near 1), builds the
model the derivation says it describes at those values (`assumptions(p)`, written into the MJCF
text at full precision), and compiles it, so that MuJoCo, Pinocchio and the equations read the same
numbers. The probe is kept only if the equations read back exactly the values it was built with and
the compiled model is what the derivation assumes (a mismatch there is itself a finding: the
derivation's `parameters()` reads a number from the wrong element).

What a derivation takes as given is its stated assumption, and the probes keep it: a field that is
zero in the model stays zero, a model number the derivation does not have as a parameter (its
`assumptions` fix it) stays as it is. The notes' printed forms also assume equal parameters (one m,
one l, l = 2c); a module declares such ties once as `PRINTED_FORMS_ASSUME` (see
equations/__init__.py), and the printed forms' probes keep them while moving everything else.

A derivation whose `assumptions()` do not state the whole model (none at all, or only the relations
its formulas bake in: a uniform rod's inertia m l^2 / 12) reads the rest from the model. Its probes
move the model's own numbers that `parameters()` reads (validate/handwritten/reads.py), each by its own
factor, write the relations `assumptions()` states at the parameters read from the moved numbers, and
take as the probe's parameters what `parameters()` reads from the compiled probe model: such a probe
never blames `parameters()` for reading what the model holds.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from ..core.errors import HarnessError
from ..handwritten.reads import Knob, Overlay, dataclass_instance, knobs, numeric_fields
from ..model.modelview import ModelView
from ..model.set_values import set_values
from ..results.schema import ProbeEntry
from ..systems import System
from . import modelsync

DEFAULT_PROBES = 4
FACTOR_RANGES = ((0.5, 0.8), (1.25, 2.0))  # moderate perturbations, never near 1
ATTEMPTS = 64  # draws per probe before giving up (a full inertia that breaks the triangle inequality: up
# to 40% of independent draws for a pendulum with six inertia parameters, so 64 leave ~1e-25 to chance)
READBACK_RTOL = 1e-12  # the equations must read back the numbers a probe was built with


@dataclass(frozen=True)
class Probe:
    """One parameter set: index 0 is the model's own; `system` is compiled from the edited MJCF."""

    index: int
    label: str
    system: System
    changed: dict[str, tuple[float, float]]  # Params field -> (model's value, probe's value)

    def describe(self) -> str:
        if not self.changed:
            return "the model's own parameters"
        return ", ".join(f"{k} {a:.6g} -> {b:.6g}" for k, (a, b) in self.changed.items())

    def as_dict(self) -> ProbeEntry:
        return {
            "index": self.index,
            "label": self.label,
            "changed": {k: [a, b] for k, (a, b) in self.changed.items()},
        }


class ProbeError(HarnessError):
    """A probe model could not be built or does not read back as built."""


class ParametersMisread(ProbeError):
    """The equations read back other numbers than the probe was built with: a finding about parameters()."""

    def __init__(self, message: str, wrong: dict[str, tuple[float, float]]) -> None:
        super().__init__(message)
        self.wrong = wrong


def param_fields(params: object) -> dict[str, float]:
    """The numeric fields of a Params dataclass, by name."""
    return numeric_fields(params)


def describe_ties(ties: tuple[Mapping[str, float], ...]) -> str:
    """The equalities as a person writes them: "m1 = m2; l1 = 2 c1 = 2 c2"."""

    def term(name: str, k: float) -> str:
        return name if k == 1 else f"{k:g} {name}"

    return "; ".join(" = ".join(term(n, k) for n, k in tie.items()) for tie in ties)


def _factor(rng: np.random.Generator) -> float:
    lo, hi = FACTOR_RANGES[int(rng.integers(len(FACTOR_RANGES)))]
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _tie(values: dict[str, float], nominal: dict[str, float], ties: tuple[Mapping[str, float], ...]) -> None:
    """Keeps coef * field equal across each tie: every field follows the first one's new value."""
    for tie in ties:
        names = [n for n in tie if n in values]
        if len(names) < 2:
            continue
        lead = names[0]
        for n in names[1:]:
            values[n] = values[lead] * tie[lead] / tie[n]


def draw(
    nominal: dict[str, float],
    rng: np.random.Generator,
    *,
    ties: tuple[Mapping[str, float], ...] = (),
    only: tuple[str, ...] | None = None,
) -> dict[str, float]:
    """New values for the fields: each non-zero one times its own factor (`only`: just those)."""
    values = dict(nominal)
    for name, x in nominal.items():
        if x != 0.0 and (only is None or name in only):
            values[name] = x * _factor(rng)
    _tie(values, nominal, ties)
    return values


def _assumed_values(assumed: Mapping[str, object]) -> dict[str, object]:
    """The numeric assumptions a probe writes into the MJCF (structure keys stay as they are)."""
    return {k: v for k, v in assumed.items() if not isinstance(v, str)}


def build(system: System, values: dict[str, float], *, index: int, label: str) -> Probe:
    """The probe model for `values` (Params fields): written, compiled and read back."""

    eq = system.derivation
    base = dataclass_instance(system.params)
    params = dataclasses.replace(base, **values)
    try:
        assumed = eq.assumptions(params)
    except Exception as exc:  # noqa: BLE001 - the user's module: its failure is a finding
        raise ProbeError(f"assumptions() fails at the probe parameters: {type(exc).__name__}: {exc}") from None
    text = set_values(system.mjcf_xml(), _assumed_values(assumed), model_view=system.view)
    probe_system = system.derive(text=text, overrides=())
    probe_system.mujoco_model()  # a model MuJoCo refuses is a ProbeError for the caller to redraw
    readback = param_fields(probe_system.params)
    wrong = {
        k: (values[k], readback.get(k, float("nan")))
        for k in values
        if not abs(readback.get(k, np.nan) - values[k]) <= READBACK_RTOL * max(abs(values[k]), 1e-300)
    }
    if wrong:
        detail = ", ".join(f"{k} = {b:.6g} (built with {a:.6g})" for k, (a, b) in wrong.items())
        raise ParametersMisread(
            f"parameters() reads {detail} from a model built from the derivation's own assumptions", wrong
        )
    mismatches = [r for r in modelsync.equations_vs_model(probe_system) if not r["passed"]]
    if mismatches:
        keys = ", ".join(r["key"] for r in mismatches[:4])
        raise ProbeError(f"the probe model differs from what assumptions() says at {keys}")
    nominal = param_fields(base)
    changed = {k: (nominal[k], values[k]) for k in values if values[k] != nominal[k]}
    return Probe(index, label, probe_system, changed)


def reads_model(system: System) -> bool:
    """Whether the derivation reads numbers from the model that its assumptions() do not state (the
    probes then move the model's numbers, not the Params fields)."""
    return not modelsync.states_every_key(system)


def _merge(values: dict[str, float | np.ndarray], key: str, given: object) -> None:
    """values[key] with `given`'s non-NaN entries written over it (NaN entries: leave as is)."""
    new = np.asarray(given, dtype=float)
    if key not in values or new.ndim == 0:
        values[key] = new if new.ndim else float(new)
        return
    old = np.asarray(values[key], dtype=float)
    values[key] = np.where(np.isnan(new), old, new)


def _full(view: ModelView, key: str, given: float | np.ndarray) -> float | np.ndarray:
    """The key's value in `view` with `given`'s non-NaN entries written over it."""
    partial = np.asarray(given, dtype=float)
    if partial.ndim == 0:
        return float(partial)
    return np.where(np.isnan(partial), np.asarray(view[key], dtype=float), partial)


def build_moved(system: System, moved: dict[Knob, float], *, index: int, label: str) -> Probe:
    """The probe model with the model numbers `moved` (Knob -> new value) and the relations the
    derivation's assumptions() state at the parameters read from them: written, compiled, read."""
    view, eq = system.view, system.derivation
    values: dict[str, float | np.ndarray] = {}
    for knob, value in moved.items():
        _merge(values, knob.key, knob.moved(value))
    read = eq.parameters(Overlay(view, {k: _full(view, k, v) for k, v in values.items()}))
    try:
        assumed = _assumed_values(eq.assumptions(read))
    except Exception as exc:  # noqa: BLE001 - the user's module: its failure is a finding
        raise ProbeError(f"assumptions() fails at the probe parameters: {type(exc).__name__}: {exc}") from None
    for key, given in assumed.items():
        _merge(values, key, given)
    text = set_values(system.mjcf_xml(), values, model_view=view)
    probe_system = system.derive(text=text, overrides=())
    probe_system.mujoco_model()  # a model MuJoCo refuses is a ProbeError for the caller to redraw
    mismatches = [r for r in modelsync.equations_vs_model(probe_system) if not r["passed"]]
    if mismatches:
        keys = ", ".join(r["key"] for r in mismatches[:4])
        raise ProbeError(f"the probe model differs from what assumptions() says at {keys}")
    nominal, now = param_fields(system.params), param_fields(probe_system.params)
    changed = {k: (nominal[k], now[k]) for k in nominal if k in now and now[k] != nominal[k]}
    return Probe(index, label, probe_system, changed)


def _draw_moved(knob_list: list[Knob], rng: np.random.Generator, only: Knob | None = None) -> dict[Knob, float]:
    return {k: k.value * _factor(rng) for k in knob_list if only is None or k == only}


def _moved_probes(system: System, k: int, seed: int, family: str) -> tuple[list[Probe], list[str]]:
    """Probes of a derivation that reads the model: its numbers moved, each independently."""
    knob_list = knobs(system.derivation.parameters, system.view)
    rng = np.random.default_rng([seed, k, len(family)])
    return _drawn(system, k, lambda i: build_moved(system, _draw_moved(knob_list, rng), index=i, label=f"probe {i}"))


def _drawn(system: System, k: int, attempt: Callable[[int], Probe]) -> tuple[list[Probe], list[str]]:
    """The model's own parameters (index 0) and probes 1..k, each the first of ATTEMPTS attempts that
    builds (ParametersMisread propagates); the second item lists why any probe could not be built."""
    out = [Probe(0, "model", system, {})]
    problems: list[str] = []
    for i in range(1, k + 1):
        last = ""
        for _ in range(ATTEMPTS):
            try:
                out.append(attempt(i))
                break
            except ParametersMisread:
                raise
            except HarnessError as exc:
                last = str(exc)
        else:
            problems.append(f"probe {i}: no valid model in {ATTEMPTS} draws ({last})")
    return out, problems


def probes(
    system: System,
    *,
    k: int = DEFAULT_PROBES,
    seed: int = 0,
    ties: tuple[Mapping[str, float], ...] = (),
    family: str = "independent",
) -> tuple[list[Probe], list[str]]:
    """The model's own parameters (index 0) and up to `k` probes; the second item lists why any
    probe could not be built (each after ATTEMPTS draws). ParametersMisread propagates: it is a
    finding about the derivation, not a failed draw."""
    if reads_model(system) and not ties:
        return _moved_probes(system, k, seed, family)
    nominal = param_fields(system.params)
    rng = np.random.default_rng([seed, k, len(family)])
    return _drawn(system, k, lambda i: build(system, draw(nominal, rng, ties=ties), index=i, label=f"probe {i}"))


def single_field_probes(system: System, *, seed: int = 0) -> list[Probe]:
    """One probe per non-zero field, that field alone moved: which parameter exposes a mistake (for a
    derivation that reads the model: one per model number it reads)."""
    if reads_model(system):
        return _single_moved(system, seed)
    nominal = param_fields(system.params)
    rng = np.random.default_rng([seed, 7])
    out = []
    for i, name in enumerate(n for n, x in nominal.items() if x != 0.0):
        for _ in range(ATTEMPTS):
            try:
                out.append(build(system, draw(nominal, rng, only=(name,)), index=100 + i, label=f"{name} alone"))
                break
            except HarnessError:
                continue
    return out


def _single_moved(system: System, seed: int) -> list[Probe]:
    knob_list = knobs(system.derivation.parameters, system.view)
    rng = np.random.default_rng([seed, 7])
    out = []
    for i, knob in enumerate(knob_list):
        for _ in range(ATTEMPTS):
            try:
                moved = _draw_moved(knob_list, rng, only=knob)
                out.append(build_moved(system, moved, index=100 + i, label=f"{'/'.join(knob.fields)} alone"))
                break
            except HarnessError:
                continue
    return out

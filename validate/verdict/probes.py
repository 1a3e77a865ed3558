"""Probe parameter sets: the same chain with every parameter of a derivation moved independently.

A derivation checked only at the model's own numbers can hide its mistakes there: with m1 = m2 = 1
and l1 = l2 = 1, writing l1 l2 for l2^2, m2 for m1 or forgetting a factor l changes nothing. So
every derivation is also judged at K probe models. A probe moves each field of the derivation's
`Params` by its own random factor in [0.5, 0.8] or [1.25, 2] (moderate, never near 1), builds the
model the derivation says it describes at those values (`assumptions(p)`, written into the MJCF
text at full precision), and compiles it, so that MuJoCo, Pinocchio and the equations read the same
numbers. The probe is kept only if the equations read back the values it was built with (to the
precision the compiled model keeps each number: an entry of an inertia relative to the inertia's
largest entry, see `field_scales`) and the compiled model is what the derivation assumes (a mismatch
there is itself a finding: the derivation's `parameters()` reads a number from the wrong element).

A body's mass, centre of mass and inertia are not moved field by field: independent factors on the
six entries of a real link's inertia break the triangle inequality at most draws (a 7-joint arm's
probes could not be built at all at some seeds). They are drawn together, as one rigid body through
the log-Cholesky factor of the body's pseudo-inertia matrix (validate/model/pseudo_inertia.py), so
that every draw is a valid body; the fields that read them (found by `knobs`) follow the drawn
numbers. What is zero stays zero there too.

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
from ..handwritten.reads import Knob, Overlay, dataclass_instance, field_scales, knobs, numeric_fields
from ..model.modelview import ModelView, key_parts
from ..model.pseudo_inertia import perturbed_body
from ..model.set_values import set_values
from ..results.schema import ProbeEntry
from ..systems import System
from . import modelsync

DEFAULT_PROBES = 4
FACTOR_RANGES = ((0.5, 0.8), (1.25, 2.0))  # moderate perturbations, never near 1
ATTEMPTS = 64  # draws per probe before giving up: a body drawn as one rigid body is always valid, but a tie,
# an inertia assumptions() computes from other fields, or a field moved alone (single_field_probes) may not be
READBACK_RTOL = 1e-12  # the equations read back the numbers a probe was built with, relative to each field's
# scale (`field_scales`: an inertia's entry relative to the inertia's largest entry, what the compiled model keeps)
BODY_FIELDS = ("mass", "com", "inertia")  # drawn together, as one rigid body
BODY_DRAWS = 32  # rigid bodies drawn per body and probe, for one whose every number moves by a moderate factor


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


def _body_of(knob: Knob) -> str:
    """The body whose mass, centre or inertia `knob` is, or ""."""
    parts = key_parts(knob.key)
    return parts[1] if parts is not None and parts[0] == "body" and parts[2] in BODY_FIELDS else ""


def _in_range(old: float, new: float) -> bool:
    """Whether new / old is a factor of FACTOR_RANGES (moderate, never near 1)."""
    ratio = new / old
    return any(lo <= ratio <= hi for lo, hi in FACTOR_RANGES)


def _draw_body(view: ModelView, body: str, knob_list: list[Knob], rng: np.random.Generator) -> dict[Knob, float]:
    """One body's knobs at a rigid body drawn near the model's (pseudo_inertia.perturbed_body): valid at
    every draw. An inertia entry is a sum of the factor's moved entries, so its ratio may fall near 1;
    of BODY_DRAWS draws the first whose every ratio is a factor of FACTOR_RANGES is kept, else the one
    with the most such (each of them a valid body all the same)."""
    mass0 = float(view[f"body/{body}/mass"])
    com0 = np.asarray(view[f"body/{body}/com"], dtype=float)
    inertia0 = np.asarray(view[f"body/{body}/inertia"], dtype=float)
    mine = [k for k in knob_list if _body_of(k) == body]
    best: dict[Knob, float] = {}
    best_count = -1
    for _ in range(BODY_DRAWS):
        mass, com, inertia = perturbed_body(mass0, com0, inertia0, lambda: _factor(rng))
        drawn = {"mass": np.asarray(mass), "com": com, "inertia": inertia}
        values = {k: float(drawn[k.key.rsplit("/", 1)[1]][k.index]) for k in mine}
        count = sum(_in_range(k.value, v) for k, v in values.items())
        if count > best_count:
            best, best_count = values, count
        if count == len(mine):
            break
    return best


def draw_bodies(view: ModelView, knob_list: list[Knob], rng: np.random.Generator) -> dict[Knob, float]:
    """New values of the knobs that are a body's mass, centre or inertia: each body drawn as one rigid body
    near the model's (`_draw_body`), so that every draw is one MuJoCo compiles."""
    out: dict[Knob, float] = {}
    for body in dict.fromkeys(b for k in knob_list if (b := _body_of(k))):
        out |= _draw_body(view, body, knob_list, rng)
    return out


def one_to_one(knob_list: list[Knob]) -> list[Knob]:
    """The knobs one field alone follows, each field following that knob alone: the fields a body's draw
    may set. A number two fields read (m1 and m2 both from link1's mass, a misread) or a field two
    numbers make are left to their own factors, so that a probe still tells them apart."""
    count: dict[str, int] = {}
    for k in knob_list:
        for name in k.fields:
            count[name] = count.get(name, 0) + 1
    return [k for k in knob_list if len(k.fields) == 1 and count[k.fields[0]] == 1]


def draw(
    nominal: dict[str, float],
    rng: np.random.Generator,
    *,
    ties: tuple[Mapping[str, float], ...] = (),
    only: tuple[str, ...] | None = None,
    bodies: Mapping[Knob, float] | None = None,
) -> dict[str, float]:
    """New values for the fields: each non-zero one times its own factor (`only`: just those); the
    fields that read a body's mass, centre or inertia (the knobs of `bodies`, with their drawn values,
    each followed by one field alone: `one_to_one`) follow those values instead, d field / d number
    times the change."""
    values = dict(nominal)
    moved = dict(bodies or {})
    following = {f for k in moved for f in k.fields}
    for name, x in nominal.items():
        if x != 0.0 and (only is None or name in only) and name not in following:
            values[name] = x * _factor(rng)
    for knob, new in moved.items():
        for name, gain in zip(knob.fields, knob.gains, strict=True):
            exact = len(knob.fields) == 1 and nominal.get(name) == gain * knob.value
            values[name] = gain * new if exact else values[name] + gain * (new - knob.value)
    _tie(values, nominal, ties)
    return values


def _assumed_values(assumed: Mapping[str, object]) -> dict[str, object]:
    """The numeric assumptions a probe writes into the MJCF (structure keys stay as they are)."""
    return {k: v for k, v in assumed.items() if not isinstance(v, str)}


def readback_scales(system: System) -> dict[str, float]:
    """{field: the size of the model numbers `parameters()` reads it from} (reads.field_scales), the
    scale a field's read-back is compared at."""
    return field_scales(system.derivation.parameters, system.view)


def _misread(
    values: dict[str, float], readback: dict[str, float], scales: Mapping[str, float]
) -> dict[str, tuple[float, float]]:
    """The fields read back otherwise than built, beyond READBACK_RTOL of the larger of the value and
    the field's scale (a product of inertia of 4e-8 beside moments of 1e-3 is kept to ~1e-19, not 4e-20)."""
    out = {}
    for k, want in values.items():
        got = readback.get(k, float("nan"))
        if not abs(got - want) <= READBACK_RTOL * max(abs(want), scales.get(k, 0.0), 1e-300):
            out[k] = (want, got)
    return out


def build(
    system: System, values: dict[str, float], *, index: int, label: str, scales: Mapping[str, float] | None = None
) -> Probe:
    """The probe model for `values` (Params fields): written, compiled and read back (`scales`: each
    field's, `readback_scales(system)` if not given)."""

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
    wrong = _misread(values, param_fields(probe_system.params), readback_scales(system) if scales is None else scales)
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


def _draw_moved(
    knob_list: list[Knob], rng: np.random.Generator, only: Knob | None = None, view: ModelView | None = None
) -> dict[Knob, float]:
    """New values of the knobs: a body's mass, centre and inertia drawn together as one rigid body (given
    the model's `view`), every other number times its own factor (`only`: that knob alone, by a factor)."""
    if only is not None:
        return {only: only.value * _factor(rng)}
    bodies = draw_bodies(view, knob_list, rng) if view is not None else {}
    return {k: bodies[k] if k in bodies else k.value * _factor(rng) for k in knob_list}


def _moved_probes(system: System, k: int, seed: int, family: str) -> tuple[list[Probe], list[str]]:
    """Probes of a derivation that reads the model: its numbers moved, each body as one rigid body."""
    knob_list = knobs(system.derivation.parameters, system.view)
    rng = np.random.default_rng([seed, k, len(family)])

    def attempt(i: int) -> Probe:
        return build_moved(system, _draw_moved(knob_list, rng, view=system.view), index=i, label=f"probe {i}")

    return _drawn(system, k, attempt)


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
    knob_list = one_to_one(knobs(system.derivation.parameters, system.view)) if k else []
    scales = readback_scales(system) if k else {}

    def attempt(i: int) -> Probe:
        values = draw(nominal, rng, ties=ties, bodies=draw_bodies(system.view, knob_list, rng))
        return build(system, values, index=i, label=f"probe {i}", scales=scales)

    return _drawn(system, k, attempt)


def single_field_probes(system: System, *, seed: int = 0) -> list[Probe]:
    """One probe per non-zero field, that field alone moved: which parameter exposes a mistake (for a
    derivation that reads the model: one per model number it reads)."""
    if reads_model(system):
        return _single_moved(system, seed)
    nominal = param_fields(system.params)
    rng = np.random.default_rng([seed, 7])
    scales = readback_scales(system)
    out = []
    for i, name in enumerate(n for n, x in nominal.items() if x != 0.0):
        for _ in range(ATTEMPTS):
            try:
                values = draw(nominal, rng, only=(name,))
                out.append(build(system, values, index=100 + i, label=f"{name} alone", scales=scales))
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

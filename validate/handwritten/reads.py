"""Which model numbers a derivation's `parameters(model)` reads, and which of its fields each one moves.

A person's module reads its parameters from the compiled model by key (`model["body/pole/mass"]`,
`2 * model["body/pole/com"][2]`). Recording the keys it asks for, and then moving each number of
each key on its own to see which fields follow, tells the harness two things without any
declaration: the model numbers a probe may move (each independently, at full precision, so that
`parameters()` reads them back), and the person's name for a model number (`l` for
`body/pole/com[2]`, with the factor 2), so that a diagnosis can speak the person's words.

    knobs(parameters, view) -> [Knob(key, index, value, fields, gains)]
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable, Collection, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeAlias

import numpy as np
import numpy.typing as npt

from ..core.errors import HarnessError
from ..model.modelview import key_parts

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

# The keys whose numbers a probe may move (a body's orientation, a joint's axis and the structure keys
# are the chain's shape, not its parameters: moving one entry of a quaternion or an axis is no model).
MOVABLE = ("mass", "com", "inertia", "pos", "damping", "armature", "stiffness", "springref", "gear")
NUDGE = 1e-3  # the relative move that finds which fields follow a number
ModelValue: TypeAlias = float | str | np.ndarray  # what a model view holds: a number, a name, an array


def movable(key: str) -> bool:
    """Whether a probe may move the numbers of `key` (gravity and the MOVABLE fields of bodies, joints
    and actuators)."""
    parts = key_parts(key)
    return key == "gravity" or (parts is not None and parts[2] in MOVABLE)


def dataclass_instance(params: object) -> DataclassInstance:
    """What `parameters()` returned, which must be a dataclass instance (a HarnessError otherwise)."""
    if not dataclasses.is_dataclass(params) or isinstance(params, type):
        raise HarnessError(f"parameters() must return a dataclass instance; got {type(params).__name__}.")
    return params


def hashable(params: DataclassInstance) -> DataclassInstance:
    """`params` itself where it can be hashed (a frozen dataclass); a plain `@dataclass` cannot, and the
    caches key on parameter sets (the traced dynamics, the energies), so it becomes a copy of a subclass
    hashed and compared by identity: the same fields, values and methods, shared by no other System."""
    cls = type(params)
    if cls.__hash__ is not None:
        return params
    kept = copy.copy(params)  # a slotted dataclass too
    kept.__class__ = _by_identity(cls)
    return kept


def _by_identity(cls: type) -> type:
    """A subclass of `cls` hashed and compared as `object` is (named as `cls`, for messages)."""
    namespace = {"__hash__": object.__hash__, "__eq__": object.__eq__, "__module__": cls.__module__, "__slots__": ()}
    return type(cls.__name__, (cls,), {**namespace, "__qualname__": cls.__qualname__})


def numeric_fields(params: object) -> dict[str, float]:
    """The numeric fields of what `parameters()` returned (a dataclass), by name."""
    out = {}
    for f in dataclasses.fields(dataclass_instance(params)):
        value = getattr(params, f.name)
        if isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool):
            out[f.name] = float(value)
    return out


class Recorder(Mapping[str, ModelValue]):
    """A model view that remembers which keys were read, in order."""

    def __init__(self, view: Mapping[str, ModelValue]) -> None:
        self.view = view
        self.read: list[str] = []

    def __getitem__(self, key: str) -> ModelValue:
        value = self.view[key]
        if key not in self.read:
            self.read.append(key)
        return value

    def __iter__(self) -> Iterator[str]:
        return iter(self.view)

    def __len__(self) -> int:
        return len(self.view)


class Overlay(Mapping[str, ModelValue]):
    """A model view with some keys replaced (what `parameters()` would read from an edited model)."""

    def __init__(self, view: Mapping[str, ModelValue], replaced: Mapping[str, ModelValue]) -> None:
        self.view, self.replaced = view, replaced

    def __getitem__(self, key: str) -> ModelValue:
        return self.replaced[key] if key in self.replaced else self.view[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.view)

    def __len__(self) -> int:
        return len(self.view)


@dataclass(frozen=True)
class Knob:
    """One model number that `parameters()` reads: `key[index]` (an inertia's (i, j) stands for its
    symmetric pair too), its value, the fields that follow it and d field / d number for each."""

    key: str
    index: tuple[int, ...]
    value: float
    fields: tuple[str, ...]
    gains: tuple[float, ...]

    @property
    def label(self) -> str:
        """`body/pole/com[2]`, as a person indexes it."""
        return self.key + "".join(f"[{i}]" for i in self.index)

    def moved(self, value: float) -> np.ndarray | float:
        """The key's value with this number set to `value` (entries of other numbers NaN: left as they are)."""
        if not self.index:
            return value
        shape = (3, 3) if self.key.endswith("/inertia") else (4,) if self.key.endswith("/quat") else (3,)
        out = np.full(shape, np.nan)
        out[self.index] = value
        if len(self.index) == 2:
            out[self.index[::-1]] = value
        return out


def edited(view: Mapping[str, ModelValue], knob: Knob, value: float) -> dict[str, ModelValue]:
    """{key: the key's full value with knob's number set to `value`}."""
    current = view[knob.key]
    if not knob.index:
        return {knob.key: value}
    arr = np.array(current, dtype=float)
    arr[knob.index] = value
    if len(knob.index) == 2:
        arr[knob.index[::-1]] = value
    return {knob.key: arr}


def _indices(key: str, value: npt.ArrayLike) -> list[tuple[int, ...]]:
    arr = np.asarray(value, dtype=float)
    if key.endswith("/inertia"):
        return [(i, j) for i in range(3) for j in range(i, 3)]
    return [tuple(int(i) for i in idx) for idx in np.ndindex(arr.shape)]


def _read_keys(
    parameters: Callable[[Mapping[str, ModelValue]], object], view: Mapping[str, ModelValue]
) -> tuple[list[str], dict[str, float]]:
    recorder = Recorder(view)
    base = numeric_fields(parameters(recorder))
    return recorder.read, base


def knobs(
    parameters: Callable[[Mapping[str, ModelValue]], object],
    view: Mapping[str, ModelValue],
    only: Collection[str] | None = None,
) -> list[Knob]:
    """Every non-zero movable number that `parameters()` reads and that some numeric field follows (of
    the keys in `only`, where given: each number costs a call of `parameters()`)."""
    keys, base = _read_keys(parameters, view)
    out = []
    for key in keys:
        if not movable(key) or isinstance(view[key], str) or (only is not None and key not in only):
            continue
        arr = np.asarray(view[key], dtype=float)
        for index in _indices(key, arr):
            value = float(arr[index]) if index else float(arr)
            if value == 0.0 or not np.isfinite(value):
                continue
            probe = Knob(key, index, value, (), ())
            nudged = value * (1.0 + NUDGE)
            moved = numeric_fields(parameters(Overlay(view, edited(view, probe, nudged))))
            follow = [k for k in base if moved.get(k) != base[k]]
            if follow:
                gains = tuple((moved[k] - base[k]) / (nudged - value) for k in follow)
                out.append(Knob(key, index, value, tuple(follow), gains))
    return out


def field_scales(
    parameters: Callable[[Mapping[str, ModelValue]], object], view: Mapping[str, ModelValue]
) -> dict[str, float]:
    """{field: the size of the model numbers it is read from}: each key `parameters()` reads, nudged as a
    whole by NUDGE of its largest entry, and for each field that follows, |d field / d entry| times that
    entry. A field read from one entry of an inertia is then measured against the inertia's largest
    entry, which is the precision the compiled model keeps it at (MuJoCo stores principal moments and a
    quaternion, so an off-diagonal entry of 4e-8 beside moments of 1e-3 is known to about 1e-19), and a
    field that is zero in the model has a scale too. Fields no key moves are left out."""
    keys, base = _read_keys(parameters, view)
    out: dict[str, float] = {}
    for key in keys:
        if isinstance(view[key], str):
            continue
        arr = np.asarray(view[key], dtype=float)
        size = float(np.abs(arr).max(initial=0.0))
        if not (size > 0 and np.isfinite(size)):
            continue
        delta = NUDGE * size
        moved = numeric_fields(parameters(Overlay(view, {key: arr + delta})))
        for name, x in moved.items():
            if name in base and x != base[name] and np.isfinite(x):
                out[name] = max(out.get(name, 0.0), abs(x - base[name]) / delta * size)
    return out


def names_of(knob_list: list[Knob]) -> dict[str, str]:
    """{model number label: the person's field name}, where one field alone follows the number: the
    person's word for `body/link2/mass` (`m2`), with the factor where it is not 1 (`l/2` for
    `body/pole/com[2]` where the person reads `l = 2 * com[2]`; `-g` for `gravity[2]`)."""
    out = {}
    for k in knob_list:
        if len(k.fields) == 1:
            gain = k.gains[0]
            sign, size = ("-" if gain < 0 else ""), abs(gain)
            out[k.label] = sign + k.fields[0] + ("" if abs(size - 1.0) < 1e-9 else f"/{size:.6g}")
    return out

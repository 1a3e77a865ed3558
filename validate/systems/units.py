"""What each parameter of a derivation is: the model keys it sets (through the module's own
`assumptions`) and their unit, so that a table of parameters can say `l1 (m)` beside `I1 (kg m^2)`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # the package imports this module
    from ..handwritten.reads import ModelValue
    from . import System


KEY_UNITS = {  # the last part of a model key -> its unit (modelview.py's key list)
    "mass": "kg",
    "com": "m",
    "pos": "m",
    "inertia": "kg m^2",
    "armature": "kg m^2",
    "frictionloss": "N m",
    "stiffness": "N m/rad",
    "gear": "1",
}


def key_unit(key: str, view: Mapping[str, ModelValue] | None = None) -> str:
    if key == "gravity":
        return "m/s^2"
    kind = key.rsplit("/", 1)[-1]
    if kind == "damping":
        slide = False
        if view is not None:
            try:
                slide = view[key.rsplit("/", 1)[0] + "/type"] == "slide"
            except Exception:  # noqa: BLE001 - a view without the joint's type: a hinge
                slide = False
        return "N s/m" if slide else "N m s/rad"
    return KEY_UNITS.get(kind, "")


def _numeric(x: object) -> np.ndarray | None:
    try:
        return np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        return None


def parameter_keys(system: System) -> dict[str, dict[str, list[str] | str]]:
    """{Params field: {"keys": model keys it sets, "unit": their unit}}: each field doubled alone, the
    keys of `assumptions` that change with it. A field no key follows gets an empty unit (unknown)."""
    from ..handwritten.reads import dataclass_instance

    eq, params = system.derivation, dataclass_instance(system.params)
    try:
        base = eq.assumptions(params)
    except Exception:  # noqa: BLE001 - the derivation's own failure is reported elsewhere
        return {}
    if not set(system.view) <= set(base):  # the derivation reads the model: the keys it reads say it
        return _read_keys(system)
    out: dict[str, dict[str, list[str] | str]] = {}
    for f in dataclasses.fields(params):
        value = getattr(params, f.name)
        try:
            x = float(value)
        except (TypeError, ValueError):
            continue
        try:
            moved = eq.assumptions(dataclasses.replace(params, **{f.name: 2 * x if x else 1.0}))
        except Exception:  # noqa: BLE001 - a field the assumptions cannot take doubled: unit unknown
            moved = base
        keys, linear = [], []
        for k, a in base.items():
            a0, a1 = _numeric(a), _numeric(moved.get(k))
            if a0 is None or a1 is None or a0.shape != a1.shape:
                continue
            changed = np.isfinite(a0) & np.isfinite(a1) & (a0 != a1)
            if np.any(changed):
                keys.append(k)
                if x and np.allclose(a1[changed], 2 * a0[changed], rtol=1e-9, atol=0):
                    linear.append(k)  # the field is this key's value (or a share of it), not a factor of it
        ranked = sorted(linear or keys, key=lambda k: PRIORITY.index(_kind(k)) if _kind(k) in PRIORITY else 99)
        out[f.name] = {"keys": keys, "unit": key_unit(ranked[0], system.view) if ranked else ""}
    return out


PRIORITY = ("mass", "com", "pos", "gravity", "damping", "armature", "stiffness", "frictionloss", "inertia", "gear")


def _kind(key: str) -> str:
    return "gravity" if key == "gravity" else key.rsplit("/", 1)[-1]


def _read_keys(system: System) -> dict[str, dict[str, list[str] | str]]:
    """{Params field: {"keys": the model numbers parameters() reads for it, "unit": theirs}} (a field
    that one number alone moves in proportion has that number's unit; else unknown)."""
    from ..handwritten.reads import knobs

    try:
        found = knobs(system.derivation.parameters, system.view)
    except Exception:  # noqa: BLE001 - the derivation's own failure is reported elsewhere
        return {}
    keys: dict[str, list[str]] = {}
    for knob in found:
        for field in knob.fields:
            keys.setdefault(field, []).append(knob.label)
    out: dict[str, dict[str, list[str] | str]] = {}
    for field, labels in keys.items():
        alone = [k for k in found if k.fields == (field,)]
        out[field] = {"keys": labels, "unit": key_unit(alone[0].key, system.view) if len(alone) == 1 else ""}
    return out

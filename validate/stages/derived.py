"""The model's derived equations as text and as results data, kept in the cache (kind `derive`).

Simplifying a 3-joint arm's equations takes about 10 s (symbolic/readable.py); the text depends only
on the model's structure (symbolic/derivation.structure_key), the coordinates' names, the format and
the harness's code, which together key the cache entry, so a second `derive` or `run` reads it back.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from typing import TypeVar, cast

import numpy as np

from ..core import cache
from ..core.cachedir import Cache
from ..model.modelview import ModelView
from ..results.schema import DerivedEquations
from ..sources.symbolic import derivation_of
from ..symbolic.derivation import derive, structure_key
from ..symbolic.readable import as_data, as_text, equations
from ..systems import System

T = TypeVar("T")


def _cached(what: str, compute: Callable[[], T], store: Cache | None) -> T:
    """`compute()` (JSON-able), or what `store` (None: no cache) holds for `what`."""
    key = hashlib.sha256((cache.harness_hash() + what).encode()).hexdigest()
    where = None if store is None else store.folder("derive")
    path = None if where is None else where / f"{key[:32]}.npz"
    found = None if path is None else cache.load(path, key)
    if found is not None and "value" in found[1]:
        return cast(T, found[1]["value"])  # what `compute` returned, read back from JSON
    value = compute()
    if path is not None:
        cache.store(path, key, {}, {"value": value})
    return value


SIMPLIFY_MAX_DOF = 3  # a 3-joint arm's entries simplify in about 20 s; a 6-joint arm's take far longer


def _what(
    view: ModelView, joints: tuple[str, ...], coordinates: tuple[str, ...], joint_map: np.ndarray | None, fmt: str
) -> str:
    mapping = None if joint_map is None else [[float(x) for x in row] for row in joint_map]
    return repr((structure_key(view, joints), tuple(coordinates), json.dumps(mapping), fmt))


def derived_text(
    view: ModelView,
    joints: tuple[str, ...],
    coordinates: tuple[str, ...],
    joint_map: np.ndarray | None,
    fmt: str,
    *,
    cache: Cache | None = None,
    simplify: bool = True,
) -> str:
    """The equations of motion of the model `view` as text, LaTeX or Python (symbolic/readable.as_text),
    simplified unless `simplify` is False (exact, with common subexpressions), kept in `cache` (None: not kept)."""
    return str(
        _cached(
            _what(view, joints, coordinates, joint_map, fmt) + ("" if simplify else " exact"),
            lambda: as_text(
                equations(derive(view, joints, readable=True), tuple(coordinates), joint_map, simplify=simplify), fmt
            ),
            cache,
        )
    )


def derived_data(system: System, *, cache: Cache | None = None) -> DerivedEquations:
    """The system's derived equations for the results: each term as text and LaTeX (readable.as_data),
    kept in `cache` (None: not kept)."""
    view, joints = system.view, system.joints
    return DerivedEquations(
        **_cached(
            _what(view, joints, system.coordinates, system.joint_map, "data"),
            lambda: cast(  # symbolic/readable.as_data's shape
                DerivedEquations,
                as_data(equations(derivation_of(system), tuple(system.coordinates), system.joint_map)),
            ),
            cache,
        )
    )

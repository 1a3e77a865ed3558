"""A stage's results kept by content: a second `run` on unchanged files reads them back, never recomputes.

The chaos stage (mirrors, lockstep, convergence orders, energy; dynamics/chaos.py `crossvalidate`)
and the notes' experiments are deterministic functions of what they are given: the compiled
scene MuJoCo steps (its binary MJB: every number, option and disabled flag), the model as the
other readers see it (the model view), the equations module's source and its traced right-hand
side, the parameters and overrides, the harness's own source, the engines' versions and the stage's
arguments. `content_key` hashes all of them, so a change to any one is a new entry and the stage
runs again; the entry is verified on every read like every other entry (core/cache.py).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..core import cache
from ..core.cachedir import Cache
from ..core.package import installed_version
from ..sources.base import Source, stepped
from ..sources.baselines import StateBatch
from ..systems import System
from .reference import param_key, source_hash, symbolic_dynamics

ENGINES = ("mujoco", "pinocchio", "numpy", "scipy", "heyoka")  # whose versions every stage entry is keyed by


def _versions() -> dict[str, str]:
    return {name: installed_version(name) or "" for name in ENGINES}


def _mjb(source: Source) -> str:
    """SHA-256 of the compiled MuJoCo scene the runs step (MJB bytes)."""
    from ..sources.mujoco import model_digest

    return model_digest(stepped(source).m)


def states_digest(states: StateBatch) -> str:
    """SHA-256 of sample states' q, v and tau (a stage judged at them is keyed by them)."""
    h = hashlib.sha256()
    for x in (states.q, states.v, states.tau):
        h.update(np.ascontiguousarray(x, dtype=float).tobytes())
    return h.hexdigest()


def content_key(system: System, sources: Mapping[str, Source], stage: str, arguments: object) -> str:
    """Hash of everything `stage` of `system` depends on (see the module docstring)."""
    module_file = getattr(system.equations, "__file__", None)
    blob = {
        "stage": stage,
        "arguments": arguments,
        "system": system.name,
        "sources": sorted(sources),
        "scene": _mjb(sources["mujoco"]),
        "view": hashlib.sha256(repr(sorted(system.view.items())).encode()).hexdigest(),
        "model_file": source_hash(str(system.mjcf)),
        "module": source_hash(module_file),
        "equations": hashlib.sha256(str(symbolic_dynamics(system).rhs).encode()).hexdigest(),
        "params": param_key(system),
        "overrides": [[k, float(v).hex()] for k, v in system.overrides],
        "locked": list(system.locked),
        "harness": cache.harness_hash(),
        "versions": _versions(),
    }
    return hashlib.sha256(json.dumps(blob, sort_keys=True, default=repr).encode()).hexdigest()[:32]


def _plain(x: object) -> object:
    """numpy's arrays and scalars as the lists and numbers JSON holds (NaN kept: the json module reads it back)."""
    return x.tolist() if hasattr(x, "tolist") else repr(x)


def as_stored(value: Mapping[str, object]) -> dict[str, Any]:
    """`value` as an entry holds it: what a hit returns, so that a computed and a read stage are alike."""
    return json.loads(json.dumps(value, default=_plain))  # type: ignore[no-any-return]


def cached_stage(
    store: Cache | None,
    system: System,
    sources: Mapping[str, Source],
    stage: str,
    arguments: object,
    compute: Callable[[], Mapping[str, object]],
) -> dict[str, Any]:
    """`compute()` (a dict of lists, numbers and arrays) as stored, with "cache": "hit" (read back),
    "miss" (computed and written) or "off" (no cache, or a key that cannot be made: equations that
    cannot be traced)."""
    where = None if store is None else store.folder("chaos")
    try:
        key = None if where is None else content_key(system, sources, stage, arguments)
    except Exception:  # noqa: BLE001 - no key, no entry: the stage runs as without a cache
        key = None
    if where is None or key is None:
        return {**as_stored(compute()), "cache": "off"}
    path = Path(where) / f"{system.name}-{stage}-{key}.npz"
    found = cache.load_bytes(path, key)
    if found is not None:
        return {**json.loads(found), "cache": "hit"}
    value = as_stored(compute())
    cache.store_bytes(path, key, json.dumps(value).encode())  # experiments take over the header's 1 MiB
    return {**value, "cache": "miss"}

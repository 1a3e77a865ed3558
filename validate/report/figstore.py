"""Figures kept by content: a figure function called with the same data draws the same PNG, so a
store the caller hands in (`kept_in`; the command line's is the run's cache, cli/outputs.py) answers
a second call without drawing (drawing was 70% of rendering a system's section, 0.24 s a figure).
Without a store every figure is drawn, as before."""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
from collections.abc import Callable, Iterator, Mapping
from contextvars import ContextVar
from typing import ParamSpec, Protocol

from ..core.package import installed_version

P = ParamSpec("P")


class FigureStore(Protocol):
    """Where figures are kept: the PNG for a key, or None; `put` keeps one."""

    def get(self, key: str) -> bytes | None: ...

    def put(self, key: str, png: bytes) -> None: ...


_STORE: ContextVar[FigureStore | None] = ContextVar("figure_store", default=None)


@contextlib.contextmanager
def kept_in(store: FigureStore | None) -> Iterator[None]:
    """Figures drawn inside this block are kept in (and read back from) `store` (None: none)."""
    token = _STORE.set(store)
    try:
        yield
    finally:
        _STORE.reset(token)


def _plain(x: object) -> object:
    return x.tolist() if hasattr(x, "tolist") else repr(x)


# What the results say of where a value came from (the cache hit or missed, and its file), never drawn: a
# figure of the same data is the same figure whether its data was computed or read back.
PROVENANCE_KEYS = frozenset({"cache", "cache_file"})


def _data(x: object) -> object:
    """`x` without its provenance entries (PROVENANCE_KEYS), at any depth of dicts and lists."""
    if isinstance(x, dict):
        return {k: _data(v) for k, v in x.items() if k not in PROVENANCE_KEYS}
    if isinstance(x, list | tuple):
        return [_data(v) for v in x]
    return x


def figure_key(fn: Callable[..., bytes], args: tuple[object, ...], kwargs: Mapping[str, object]) -> str:
    """SHA-256 of the figure function, its source and the data it is given (not where the data came from)."""
    import inspect

    # matplotlib's version from its metadata: a figure found in the store never imports matplotlib (0.3 s)
    h = hashlib.sha256(f"{fn.__module__}.{fn.__qualname__} {installed_version('matplotlib')}".encode())
    h.update(inspect.getsource(fn).encode())
    h.update(json.dumps(_data([args, kwargs]), default=_plain, sort_keys=True).encode())
    return h.hexdigest()


def kept(fn: Callable[P, bytes]) -> Callable[P, bytes]:
    """`fn` (data -> PNG bytes), answered from the store `kept_in` set, if any."""

    @functools.wraps(fn)
    def figure(*args: P.args, **kwargs: P.kwargs) -> bytes:
        store = _STORE.get()
        if store is None:
            return fn(*args, **kwargs)
        key = figure_key(fn, args, kwargs)
        found = store.get(key)
        if found is not None:
            return found
        png = fn(*args, **kwargs)
        store.put(key, png)
        return png

    return figure

"""Figures kept by content (validate/report/figstore.py): drawn once per content, then read back."""

from __future__ import annotations

import numpy as np
from lagrange_xval.cli.outputs import CachedFigures
from lagrange_xval.core.cachedir import Cache
from lagrange_xval.report.figstore import kept, kept_in

DRAWN: list[int] = []


@kept
def _figure(name: str, t: np.ndarray) -> bytes:
    DRAWN.append(1)
    return f"{name}:{t.sum()}".encode()


def test_a_figure_is_drawn_once_per_content_and_read_back_from_the_cache(tmp_path):
    """Same data: read back, the same bytes; other data: drawn; no store: drawn every time."""
    DRAWN.clear()
    store = CachedFigures(Cache.at(tmp_path))
    t = np.arange(3.0)
    with kept_in(store):
        first = _figure("a", t)
        assert _figure("a", t) == first and len(DRAWN) == 1
        assert _figure("a", t + 1) != first and len(DRAWN) == 2
    assert len(list((tmp_path / "figures").iterdir())) == 2
    _figure("a", t)
    assert len(DRAWN) == 3


@kept
def _runs_figure(runs: list[dict]) -> bytes:
    DRAWN.append(1)
    return repr([r["q"] for r in runs]).encode()


def test_where_the_data_came_from_is_not_part_of_the_figure(tmp_path):
    """The same runs read back from the cache (`"cache": "hit"`) or computed (`"miss"`) are one figure;
    other data is another."""
    DRAWN.clear()
    with kept_in(CachedFigures(Cache.at(tmp_path))):
        _runs_figure([{"q": [1.0], "info": {"cache": "miss", "cache_file": "a.npz"}}])
        _runs_figure([{"q": [1.0], "info": {"cache": "hit", "cache_file": "b.npz"}}])
        assert len(DRAWN) == 1
        _runs_figure([{"q": [2.0], "info": {"cache": "hit"}}])
        assert len(DRAWN) == 2

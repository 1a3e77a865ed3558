"""Shared fixtures: systems are discovered, never listed by hand."""

from __future__ import annotations

import pytest
from lagrange_xval.validate import systems
from lagrange_xval.validate.checks import pointwise as compare
from lagrange_xval.validate.engines import make_sources

SYSTEMS = systems.system_names()
N_STATES = 1000
SEED = 0


@pytest.fixture(scope="session", params=SYSTEMS)
def system(request):
    return systems.load(request.param)


_cache: dict[str, object] = {}


def evaluated(system):
    """Every source's quantities at the seeded states, computed once per system per session."""
    if system.name not in _cache:
        states = compare.random_states(system, n=N_STATES, seed=SEED)
        sources = make_sources(system)
        _cache[system.name] = (states, sources, compare.evaluate(sources, states))
    return _cache[system.name]

"""Shared fixtures: systems are discovered, never listed by hand; every cache is a temporary one."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from lagrange_xval import systems
from lagrange_xval.core.cache import CACHE_ENV
from lagrange_xval.core.cachedir import Cache
from lagrange_xval.sources import make_sources
from lagrange_xval.verdict import pointwise as compare

SYSTEMS = systems.system_names()
N_STATES = 1000
SEED = 0


@pytest.fixture(scope="session", autouse=True)
def session_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cache]:
    """One temporary cache for the session: what a test passes on (the `cache` fixture), and the
    configured cache of code that reads `$LAGRANGE_XVAL_CACHE` (the benchmark's workers, `derive`),
    so that no test writes into the checkout or the user's cache folder."""
    folder = tmp_path_factory.mktemp("cache")
    before = os.environ.get(CACHE_ENV)
    os.environ[CACHE_ENV] = str(folder)  # inherited by the subprocesses and pool workers tests start
    try:
        yield Cache.at(folder)
    finally:
        if before is None:
            os.environ.pop(CACHE_ENV, None)
        else:
            os.environ[CACHE_ENV] = before


@pytest.fixture
def cache(session_cache: Cache) -> Cache:
    """The session's temporary cache, for a test that passes one down (lx.check(..., cache=cache))."""
    return session_cache


@pytest.fixture
def own_cache(tmp_path: Path) -> Cache:
    """A cache of the test's own, empty at its start."""
    return Cache.at(tmp_path / "cache")


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


@pytest.fixture(scope="session")
def cli_run(tmp_path_factory: pytest.TempPathFactory):
    """`lagrange-xval run ARGS --out DIR` in a fresh folder, once per session for the same ARGS (an
    end-to-end run that several tests read: the robots' runs take 5 to 30 s each): the finished
    process and its output folder. A test must not change what it reads. The test files run on
    pytest-xdist workers, a file on one worker (`--dist loadfile`): tests that share a run sit in one file."""
    done: dict[tuple[str, ...], tuple[subprocess.CompletedProcess[str], Path]] = {}

    def run(*args: str) -> tuple[subprocess.CompletedProcess[str], Path]:
        if args not in done:
            folder = tmp_path_factory.mktemp("run")
            proc = subprocess.run(
                [sys.executable, "-m", "lagrange_xval.cli", "run", *args, "--out", "out"],
                cwd=folder,
                capture_output=True,
                text=True,
                timeout=900,
            )
            done[args] = (proc, folder / "out")
        return done[args]

    return run

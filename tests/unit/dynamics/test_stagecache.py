"""A stage kept by content (validate/dynamics/stagecache.py): read back only for the same content."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from lagrange_xval.core.cachedir import Cache
from lagrange_xval.dynamics.stagecache import cached_stage, content_key
from lagrange_xval.sources import make_source
from lagrange_xval.systems import MODELS_DIR, System, load


@pytest.fixture(scope="module")
def pendulum() -> System:
    return load("simple_pendulum")


def _sources(system: System) -> dict:
    return {"mujoco": make_source(system, "mujoco")}


def test_the_key_changes_with_parameters_arguments_and_the_module(pendulum, tmp_path):
    """Another parameter value, another argument, another module text (same equations): another key."""
    sources = _sources(pendulum)
    key = content_key(pendulum, sources, "chaos", [1.0])
    assert key == content_key(pendulum, sources, "chaos", [1.0])
    heavier = pendulum.with_overrides(**_a_mass(pendulum))
    assert content_key(heavier, _sources(heavier), "chaos", [1.0]) != key
    assert content_key(pendulum, sources, "chaos", [2.0]) != key
    assert content_key(pendulum, sources, "experiments", [1.0]) != key
    module = tmp_path / "simple_pendulum.py"
    module.write_text(open(pendulum.equations.__file__).read() + "\n# an edit\n")
    model = tmp_path / "simple_pendulum.xml"
    shutil.copy(MODELS_DIR / "simple_pendulum.xml", model)
    edited = System.from_files(model, module)
    assert content_key(edited, _sources(edited), "chaos", [1.0]) != key


def _a_mass(system: System) -> dict[str, float]:
    body = system.bodies[0]
    return {f"body__{body}__mass": float(system.view[f"body/{body}/mass"]) * 1.5}


def test_a_hit_returns_what_was_computed_and_an_edited_entry_is_recomputed(pendulum, tmp_path, capsys):
    """The second call reads the first's value (NaN and arrays as stored); an entry edited on disk is
    refused and the stage computed again."""
    calls = []

    def compute() -> dict:
        calls.append(1)
        return {"x": np.arange(3.0), "nan": float("nan"), "n": np.int64(2)}

    store = Cache.at(tmp_path)
    sources = _sources(pendulum)
    first = cached_stage(store, pendulum, sources, "chaos", [], compute)
    second = cached_stage(store, pendulum, sources, "chaos", [], compute)
    assert (first["cache"], second["cache"], len(calls)) == ("miss", "hit", 1)
    assert second["x"] == [0.0, 1.0, 2.0] and second["n"] == 2 and np.isnan(second["nan"])
    assert {k: v for k, v in first.items() if k not in ("cache", "nan")} == {
        k: v for k, v in second.items() if k not in ("cache", "nan")
    }
    (entry,) = (tmp_path / "chaos").iterdir()
    data = bytearray(entry.read_bytes())
    data[-200] ^= 0xFF
    entry.write_bytes(bytes(data))
    assert cached_stage(store, pendulum, sources, "chaos", [], compute)["cache"] == "miss"
    assert len(calls) == 2
    assert cached_stage(None, pendulum, sources, "chaos", [], compute)["cache"] == "off"
    capsys.readouterr()

"""Explanations of wrong expressions are kept in the cache they are given (kind "explain"), keyed by
what they are computed from: the user's numbers included, so a changed module never reads another's
explanation; without a cache nothing is written."""

from __future__ import annotations

import pathlib
import shutil

import pytest
from lagrange_xval.core.cachedir import Cache
from lagrange_xval.systems import System
from lagrange_xval.verdict import explain as explaining
from lagrange_xval.verdict.verdict import derivation_probes

ROOT = pathlib.Path(__file__).resolve().parents[3]
RIGHT = "m22 = p.m2 * p.c2**2 + p.I2"


def _system(folder: pathlib.Path, new: str) -> System:
    """The rigid-bar double pendulum with M[phi, phi] written as `new`, from `folder` (always the same path)."""
    text = (ROOT / "equations" / "double_pendulum_bars.py").read_text()
    text = text.replace("from ..._", "from lagrange_xval.equations._")
    assert text.count(RIGHT) == 1
    folder.mkdir(exist_ok=True)
    (folder / "bars.py").write_text(text.replace(RIGHT, new))
    shutil.copy(ROOT / "models" / "double_pendulum_bars.xml", folder / "bars.xml")
    return System.from_files(folder / "bars.xml", folder / "bars.py")


def _explain(system: System, cache: Cache | None) -> list[dict]:
    probes = derivation_probes(system, n_probes=2)
    return explaining.explain(system, [p.system for p in probes.probes], ["mass matrix"], cache=cache)


def test_a_second_explanation_is_read_back_and_a_changed_module_is_not(tmp_path, monkeypatch):
    kept = Cache.at(tmp_path / "cache")
    first = _explain(_system(tmp_path / "user", "m22 = p.m2 * p.c2**2"), kept)
    assert any("lacks the term I_link2_zz" in e["statement"] for e in first), first
    assert len(list((tmp_path / "cache" / "explain").glob("*.npz"))) >= 1

    def never(*args, **kwargs):
        raise AssertionError("computed again although the cache holds it")

    with monkeypatch.context() as m:
        m.setattr(explaining, "_explain_entry", never)
        assert _explain(_system(tmp_path / "user", "m22 = p.m2 * p.c2**2"), kept) == first
    # the same file, another mistake: other numbers, another key, its own explanation
    second = _explain(_system(tmp_path / "user", "m22 = p.m2 * p.c2**2 + 2 * p.I2"), kept)
    assert second != first and any("twice" in e["statement"] for e in second), second


def test_no_cache_writes_nothing_and_explains_the_same(tmp_path):
    found = _explain(_system(tmp_path / "user", "m22 = p.m2 * p.c2**2"), None)
    assert any("lacks the term I_link2_zz" in e["statement"] for e in found), found
    assert not list(tmp_path.rglob("*.npz"))


@pytest.mark.parametrize("changed", ["q", "mine"])
def test_the_key_follows_the_states_and_the_users_numbers(changed):
    import numpy as np
    import sympy as sp

    class Samples:
        q, v, p, args = np.zeros((4, 2)), np.zeros((4, 2)), np.ones((4, 3)), [sp.Symbol("x")]

    class D:
        parameters = {sp.Symbol("m"): "a mass"}

    mine = np.arange(4.0)
    base = explaining._entry_key(D, Samples, "mass matrix", "M[0, 0]", sp.Symbol("x") ** 2, mine)
    if changed == "q":
        Samples.q = Samples.q + 1e-12
    else:
        mine = mine + 1e-12
    assert explaining._entry_key(D, Samples, "mass matrix", "M[0, 0]", sp.Symbol("x") ** 2, mine) != base

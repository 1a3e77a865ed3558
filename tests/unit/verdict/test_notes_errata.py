"""The verdicts the harness found on the notes' printed forms, pinned.

Nothing in the harness knows these; they were found by `judge` and are pinned here so that a
change in the judge, the engines or a transcription that flips one is noticed.
"""

from __future__ import annotations

import pytest
from lagrange_xval import systems
from lagrange_xval.sources import make_sources
from lagrange_xval.verdict import judge
from lagrange_xval.verdict import pointwise as compare

# (system, printed form) -> (verdict, first disagreeing term); every other form agrees.
DISAGREE = {
    ("double_pendulum_bars", "kinetic energy (74)"): ("disagrees", "value"),
    ("double_pendulum_point", "bob 2 position (9)-(10)"): ("disagrees", "value"),
    ("double_pendulum_point", "bob 2 velocity (13)-(14)"): ("disagrees", "value"),
    ("double_pendulum_point", "explicit (35)-(36)"): ("disagrees", "velocity"),
    ("double_pendulum_point", "matlab double_bob_pendulum"): ("disagrees", "gravity"),
    ("gimbal", "R_2^0 (80)"): ("disagrees", "value"),
    ("gimbal", "explicit (87)-(88)"): ("disagrees", "friction"),
    ("gimbal", "matlab double_gimbal_state_space_model"): ("disagrees", "velocity"),
}


@pytest.fixture(scope="module")
def verdicts():
    out = {}
    for name in systems.system_names():
        s = systems.load(name)
        for v in judge.judge_system(s, compare.random_states(s, n=200, seed=0), make_sources(s)):
            out[(name, v["name"])] = v
    return out


def test_every_printed_form_has_a_verdict(verdicts):
    assert verdicts, "no printed forms found"
    assert all(v["verdict"] in ("agrees", "disagrees") for v in verdicts.values()), {
        k: v.get("reason") for k, v in verdicts.items() if v["verdict"] not in ("agrees", "disagrees")
    }


def test_verdicts_are_the_ones_found(verdicts):
    found = {
        k: (v["verdict"], v.get("first_disagreeing_term")) for k, v in verdicts.items() if v["verdict"] != "agrees"
    }
    assert found == DISAGREE


def test_eq_9_missing_l_shows_only_at_the_probe_parameters(verdicts):
    """x2 = sin(theta) + sin(theta + phi) l is right where l = 1: only the rescaled probe exposes it."""
    v = verdicts[("double_pendulum_point", "bob 2 position (9)-(10)")]
    assert v["disagrees_at"].startswith("probe")


def test_disagreements_are_large_not_rounding(verdicts):
    """A wrong print is off by a sizeable fraction of the quantity's range, never by rounding."""
    for key in DISAGREE:
        assert verdicts[key]["worst_term"]["scaled"] > 1e-3, key

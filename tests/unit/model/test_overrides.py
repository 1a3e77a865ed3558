"""Parameter overrides reach all three sources with the same numbers."""

from __future__ import annotations

import pytest
from lagrange_xval import systems
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.model import overrides
from lagrange_xval.sources import make_sources
from lagrange_xval.verdict import modelsync
from lagrange_xval.verdict import pointwise as compare

CASES = {
    "double_pendulum_point": (("body/link2/mass", 3.0), ("scale/length", 1.3)),
    "double_pendulum_bars": (("scale/mass", 1.7), ("scale/gravity", 0.8)),
    "gimbal": (("joint/psi/damping", 0.5), ("body/inner/inertia", 2.0)),
}


def test_an_override_the_equations_do_not_describe_is_named():
    """The gimbal's equations state gear-1 motors: a gear of 2 is another model, and the sync check says which key."""
    s = systems.load("gimbal", overrides=(("actuator/motor_theta/gear", 2.0),))
    bad = modelsync.check(s, make_sources(s)["pinocchio"])["mismatches"]
    assert [r["key"] for r in bad] == ["actuator/motor_theta/gear"]


@pytest.mark.parametrize("name", sorted(CASES))
def test_overridden_model_is_the_same_in_every_source(name):
    s = systems.load(name, overrides=CASES[name])
    sources = make_sources(s)
    assert modelsync.check(s, sources["pinocchio"])["passed"]
    result = compare.pointwise(s, n=100, seed=3, sources=sources)
    bad = [r for r in result["rows"] if not r["passed"]]
    assert not bad, [(r["quantity"], r["pair"], r["scaled"]) for r in bad]


def test_overrides_change_the_compiled_numbers_at_full_precision():
    s = systems.load("double_pendulum_bars", overrides=(("scale/length", 1.3),))
    izz = s.view["body/link1/inertia"][2, 2]
    assert izz == pytest.approx(1.3**2 / 12, rel=1e-15)
    assert "1e-14" not in s.mjcf_xml()  # the bar's tiny axial inertia was scaled, not rounded away


@pytest.mark.parametrize(
    "item, message",
    [
        ("scale/mass=-1", "out of range"),
        ("body/link1/mass=-2", "must be positive"),
        ("body/link9/mass=2", "Unknown body 'link9'"),
        ("joint/theta/damping=nan", "must be finite"),
        ("foo=1", "Valid keys"),
        ("scale/mass", "KEY=VALUE"),
    ],
)
def test_bad_overrides_are_one_line_errors(item, message):
    with pytest.raises(HarnessError, match=message):
        systems.load("double_pendulum_point", overrides=overrides.parse([item])).mujoco_model()

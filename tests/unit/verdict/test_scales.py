"""What a pointwise `scaled` is divided by (results.schema.SCALED_DEFINITION), on small models.

- V is compared up to a constant: a body welded to the world (a pedestal) is counted in V by MuJoCo and
  Drake and merged into Pinocchio's universe, which V does not count; the constant changes no equation
  of motion, so it never FAILs, and it is reported. A V that differs by more than a constant FAILs.
- Every scale has an absolute floor from the model's own physical scales: a quantity zero for every
  source (qacc of a rotor on a vertical axis, V of a body gravity does not move) is judged against the
  model's m g L, g / L, ..., not against its own rounding noise (scaled 1.0, a FAIL).
"""

from __future__ import annotations

from pathlib import Path

import lagrange_xval as lx
import numpy as np
import pytest
from lagrange_xval.core.tolerances import NO_SCALES, PhysicalScales
from lagrange_xval.sources import make_sources
from lagrange_xval.systems import System
from lagrange_xval.verdict import pointwise as compare

# A 2-link arm on a pedestal welded to the world, its 3 kg centre of mass 0.4 m up (V: 11.77 J more by
# MuJoCo and Drake than by Pinocchio, every state).
PEDESTAL = """<mujoco model="pedestal_arm">
  <worldbody>
    <body name="pedestal" pos="0 0 0">
      <inertial pos="0 0 0.4" mass="3" diaginertia="0.05 0.05 0.02"/>
      <body name="upper" pos="0 0 0">
        <joint name="shoulder" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 -0.3" mass="1.2" diaginertia="0.03 0.03 0.002"/>
        <body name="fore" pos="0 0 -0.6">
          <joint name="elbow" type="hinge" axis="0 1 0"/>
          <inertial pos="0.05 0 -0.25" mass="0.7" diaginertia="0.02 0.02 0.001"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

# A disc on a vertical hinge, its centre of mass off the axis: gravity does no work (V constant, G
# zero), one coordinate, constant M, no actuator: qacc is zero for every source, up to rounding.
ROTOR = """<mujoco model="rotor">
  <worldbody>
    <body name="disc" pos="0 0 0.3">
      <joint name="spin" type="hinge" axis="0 0 1"/>
      <inertial pos="0.13 0.07 0.02" mass="1.7" diaginertia="0.011 0.013 0.02"/>
    </body>
  </worldbody>
</mujoco>
"""


def _system(tmp_path: Path, text: str, name: str) -> System:
    path = tmp_path / f"{name}.xml"
    path.write_text(text)
    return System.model_only(path)


def _states(n: int = 12) -> compare.States:
    q = np.linspace(-3, 3, n)[:, None]
    return compare.States(q, np.ones_like(q), np.zeros_like(q))


def test_v_apart_by_a_constant_passes_and_the_constant_is_reported():
    states = _states()
    V = 9.81 * np.cos(states.q[:, 0])
    row = compare.error_row("V", "a~b", V + 93.7, V, states, tier="algebraic", up_to_constant=True)
    assert row["passed"] and row["max_abs"] < 1e-13, row
    assert row["constant"] == pytest.approx(93.7, abs=1e-12)


def test_v_apart_by_more_than_a_constant_fails():
    """The same constant and 1e-6 of the swing more: not a constant, judged (and FAILs)."""
    states = _states()
    V = 9.81 * np.cos(states.q[:, 0])
    row = compare.error_row("V", "a~b", 1.000001 * V + 93.7, V, states, tier="algebraic", up_to_constant=True)
    assert not row["passed"] and row["scaled"] > 1e-8, row


def test_a_pedestal_welded_to_the_world_passes_on_v_and_says_the_constant(tmp_path):
    """MuJoCo and Drake count the pedestal's m g z (11.77 J), Pinocchio does not: V passes up to it."""
    system = _system(tmp_path, PEDESTAL, "pedestal_arm")
    result = compare.pointwise(system, n=20, seed=0)
    v_rows = {r["pair"]: r for r in result["rows"] if r["quantity"] == "V"}
    assert result["passed"], [r for r in result["rows"] if not r["passed"]]
    assert v_rows["mujoco~pinocchio"]["constant"] == pytest.approx(3 * 9.81 * 0.4, rel=1e-12)
    assert abs(v_rows["drake~mujoco"]["constant"]) < 1e-12  # both count every body with mass
    assert lx.check(system, n_states=20, probes=0).passed


def test_a_wrong_v_on_the_pedestal_still_fails(tmp_path):
    """One source's V scaled by 1 + 1e-6 (more than a constant): the V rows with it FAIL."""
    system = _system(tmp_path, PEDESTAL, "pedestal_arm")
    states = compare.random_states(system, n=20, seed=0)
    values = compare.evaluate(make_sources(system), states)
    values["pinocchio"]["V"] = values["pinocchio"]["V"] * (1 + 1e-6)
    rows = compare.compare(values, states, scales=compare.physical_scales(system, states))
    failed = {r["pair"] for r in rows if r["quantity"] == "V" and not r["passed"]}
    assert failed == {"drake~pinocchio", "mujoco~pinocchio", "pinocchio~symbolic"}, failed


def test_a_quantity_zero_for_every_source_is_judged_against_the_models_own_scale(tmp_path):
    """The rotor's qacc is rounding noise (~1e-15) for every source: against the model's floor it
    passes; against its own magnitude (no floor, as before) it is scaled 1.0 and FAILs."""
    system = _system(tmp_path, ROTOR, "rotor")
    states = compare.random_states(system, n=20, seed=0)
    values = compare.evaluate(make_sources(system), states)
    floored = compare.compare(values, states, scales=compare.physical_scales(system, states))
    bare = compare.compare(values, states, scales=NO_SCALES)
    assert all(r["passed"] for r in floored), [r for r in floored if not r["passed"]]
    assert any(r["quantity"] == "qacc" and not r["passed"] and r["scaled"] >= 0.5 for r in bare)
    assert lx.check(system, n_states=20, probes=0).passed


def test_the_physical_scales_are_the_models_masses_lengths_and_gravity(tmp_path):
    """Pedestal arm: the moving mass 1.9 kg (the pedestal is welded), the reach 0.6 m + |(0.05, 0, -0.25)|
    to the forearm's centre of mass, a = g + L max|v|^2; floors m a L, a / L, m L^2."""
    system = _system(tmp_path, PEDESTAL, "pedestal_arm")
    states = compare.random_states(system, n=20, seed=0)
    s = compare.physical_scales(system, states)
    L = 0.6 + float(np.hypot(0.05, 0.25))
    a = 9.81 + L * float(np.abs(states.v).max()) ** 2
    assert (s.mass, s.length, s.accel) == pytest.approx((1.9, L, a), rel=1e-12)
    energy = 1.9 * (9.81 * L + L * L * float(np.abs(states.v).max()) ** 2)
    assert s.floor("V") == pytest.approx(energy) and s.floor("qacc") == pytest.approx(a / L)
    assert s.floor("M") == pytest.approx(1.9 * L * L) and s.floor("body_rotations") == 1.0
    slide = PhysicalScales(2.0, 0.5, 10.0, hinges=False, slides=True)  # at rest: a = g
    assert (slide.floor("bias"), slide.floor("qacc"), slide.floor("M")) == (20.0, 10.0, 2.0)
    # A free root's travel (3 m) is in positions and energies only, never in its hinges' inertia.
    root = PhysicalScales(2.0, 0.5, 10.0, speed=1.0, hinges=True, slides=True, travel=3.0)
    assert (root.floor("M"), root.floor("V"), root.floor("body_positions")) == (2.0, 2.0 * (35.0 + 1.0), 3.5)


def test_inverse_dynamics_is_scaled_by_its_inertial_terms():
    """gymnasium-robotics' fetch/reach.xml (the test extra): at MuJoCo's qacc of ~1e10 (a nearly singular
    M, light links) |M||a| is ~1e12 per row, and MuJoCo's and Pinocchio's tau_inverse differ by ~eps of it
    while M, bias and qacc agree to 1e-15: rounding, judged against the size of M a's terms."""
    robotics = pytest.importorskip("gymnasium_robotics")
    system = System.model_only(Path(robotics.__file__).parent / "envs" / "assets" / "fetch" / "reach.xml")
    states = compare.random_states(system, n=4, seed=0)
    values = compare.evaluate(make_sources(system), states)
    a = values["mujoco"]["qacc"]
    inertial = compare.inertial_scale(values["mujoco"]["M"], a)
    assert np.abs(a).max() > 1e8 and inertial > 1e6 * np.abs(values["mujoco"]["bias"]).max()
    rows = {(r["quantity"], r["pair"]): r for r in compare.compare(values, states)}
    row = rows["tau_inverse", "mujoco~pinocchio"]
    assert row["passed"] and row["scale"] >= inertial  # the rounding of M a is what the two differ by
    # a difference beyond that rounding still fails
    wrong = {**values["pinocchio"], "tau_inverse": values["pinocchio"]["tau_inverse"] + 1e-6 * inertial}
    rows = {(r["quantity"], r["pair"]): r for r in compare.compare({**values, "pinocchio": wrong}, states)}
    assert not rows["tau_inverse", "mujoco~pinocchio"]["passed"]


def test_the_inertial_scale_is_the_largest_row_of_abs_m_times_abs_a():
    M = np.array([[[2.0, -1.0], [-1.0, 3.0]]])
    assert compare.inertial_scale(M, np.array([[1.0, -2.0]])) == 7.0  # rows: 2 + 2 = 4, 1 + 6 = 7
    assert compare.inertial_scale(M, None) == 0.0 and compare.inertial_scale(M, np.zeros((1, 3))) == 0.0

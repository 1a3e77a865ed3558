"""Issue 42: the derived equations read a joint's `ref` as MuJoCo does. MuJoCo's qpos0 is the joints'
`ref`, the file writes each body where it is at q = ref, and a joint turns (or slides) its body by
q - ref; `springref` is where its spring is relaxed, in q. dm_control's finger.xml (`ref="-90"` on its
proximal hinge) had every derived body pose 90 degrees off MuJoCo's and Drake's."""

from __future__ import annotations

import numpy as np
import pytest
from lagrange_xval.sources import make_source
from lagrange_xval.sources.symbolic import derivation_of
from lagrange_xval.systems import System
from lagrange_xval.verdict import pointwise

DEGREE = """<mujoco model="ref_degree">
  <compiler angle="degree"/>
  <worldbody>
    <body name="upper" pos="0 0 1" euler="0 0 15">
      <joint name="shoulder" type="hinge" axis="0 1 0" pos="0 0 0.05" ref="-90" springref="20" stiffness="2"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0.1" size="0.05" mass="1"/>
      <body name="slider" pos="0.5 0 0">
        <joint name="rail" type="slide" axis="1 0 0.5" ref="0.1" springref="0.3" stiffness="5" damping="0.2"/>
        <geom type="box" size="0.1 0.05 0.05" mass="0.5" pos="0.1 0 0.02"/>
        <body name="lower" pos="0.2 0 0">
          <joint name="elbow" type="hinge" axis="0 0 1" ref="35"/>
          <geom type="capsule" fromto="0 0 0 0.3 0.1 0" size="0.04" mass="0.7"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

RADIAN = """<mujoco model="ref_radian">
  <compiler angle="radian"/>
  <option gravity="0 -3 -9.81"/>
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="1 0 0" ref="0.7" springref="-0.3" stiffness="4"/>
      <geom type="capsule" fromto="0 0 0 0 0.4 0" size="0.05" mass="1.2"/>
      <body name="slider" pos="0 0.4 0">
        <joint name="rail" type="slide" axis="0 1 0" ref="-0.05" springref="0.2" stiffness="3"/>
        <geom type="sphere" size="0.08" mass="0.4" pos="0 0.05 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.mark.parametrize("text", [DEGREE, RADIAN], ids=["degree", "radian"])
def test_derived_equations_read_ref_and_springref_as_mujoco(tmp_path, text):
    """M, bias, passive, T, V and the bodies' poses of the derived equations agree with MuJoCo's at
    random states, on hinges and slides with a `ref` and a `springref`, in degrees and in radians."""
    path = tmp_path / "model.xml"
    path.write_text(text)
    system = System.model_only(path)
    refs = [system.view[f"joint/{j}/ref"] for j in system.joints if f"joint/{j}/ref" in system.view]
    assert len(refs) >= 2, "the model must have refs to test"
    states = pointwise.random_states(system, n=50, seed=4)
    sources = {n: make_source(system, n) for n in ("mujoco", "symbolic")}
    rows = pointwise.compare(pointwise.evaluate(sources, states), states)
    compared = {r["quantity"] for r in rows}
    assert compared >= {"M", "bias", "passive", "T", "V", "body_positions", "body_rotations"}, compared
    bad = [f"{r['quantity']} {r['scaled']:.2e}" for r in rows if not r["passed"]]
    assert not bad, bad


def test_at_q_equal_ref_the_bodies_are_where_the_file_writes_them(tmp_path):
    """At qpos0 (the refs) the derived body frames are MuJoCo's as compiled, not turned by the refs."""
    import mujoco

    path = tmp_path / "model.xml"
    path.write_text(DEGREE)
    system = System.model_only(path)
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    q0 = np.array([system.view.get(f"joint/{j}/ref", 0.0) for j in system.joints])[None]
    symbolic = make_source(system, "symbolic")
    rotations = symbolic.body_rotations(q0)[0]
    for k, body in enumerate(system.bodies):
        np.testing.assert_allclose(rotations[k], data.xmat[model.body(body).id].reshape(3, 3), atol=1e-12)


def test_a_hinge_ref_in_whole_degrees_is_written_as_a_fraction_of_pi(tmp_path):
    """`ref="-90"` is -pi/2 in the derivation (exact: its sines and cosines are exact), and the refs
    key the structure, so two models that differ only there are derived apart."""
    import sympy as sp
    from lagrange_xval.symbolic.derivation import structure_key

    path = tmp_path / "model.xml"
    path.write_text(DEGREE)
    system = System.model_only(path)
    rotation = derivation_of(system).rotation["upper"]
    arguments = {f.args[0] for f in rotation.atoms(sp.sin, sp.cos)}
    assert arguments == {sp.Symbol("shoulder", real=True)}, rotation  # sin(q - (-pi/2)) is cos(q), exactly
    other = tmp_path / "other.xml"
    other.write_text(DEGREE.replace('ref="-90"', 'ref="-80"'))
    assert structure_key(system.view, system.joints) != structure_key(System.model_only(other).view, system.joints)

"""A joint's armature (rotor inertia) counted once in T by every source, composite joints too.

Pinocchio 4.1's `computeKineticEnergy` adds the armature of a hinge on the x, y or z axis (RX, RY, RZ)
and not that of a hinge on another axis (RevoluteUnaligned); the Pinocchio source once added
1/2 armature v^2 on top of it, so every geared arm FAILed on T (the armature of aligned hinges counted
twice). T is now 1/2 v^T M v on CRBA's M. These tests fail on that code: T against 1/2 v^T M v on an
aligned and an unaligned hinge, `check --model` on a 2-link arm with armature, a planar root (one
composite joint in Pinocchio) with armature, and a right hand derivation of a geared arm.
"""

from __future__ import annotations

from pathlib import Path

import lagrange_xval as lx
import numpy as np
from lagrange_xval.sources import make_source
from lagrange_xval.systems import System
from lagrange_xval.verdict import pointwise as compare

# A 2-link arm in the x-z plane hanging along -z, hinges about +y, geared motors (armature 0.3, 0.1),
# on a base welded to the world whose centre of mass is 0.3 m above the shoulder: MuJoCo counts the
# base's potential energy (a constant), Pinocchio merges it into the universe and does not.
GEARED_ARM = """<mujoco model="geared_arm">
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="base" pos="0 0 0">
      <inertial pos="0 0 0.3" mass="2" diaginertia="0.01 0.01 0.01"/>
      <body name="link1" pos="0 0 0">
        <joint name="shoulder" type="hinge" axis="0 1 0" armature="0.3"/>
        <inertial pos="0 0 -0.25" mass="1" diaginertia="0.02 0.02 0.001"/>
        <body name="link2" pos="0 0 -0.5">
          <joint name="elbow" type="hinge" axis="0 1 0" armature="0.1"/>
          <inertial pos="0 0 -0.2" mass="0.5" diaginertia="0.01 0.01 0.001"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator><motor name="m1" joint="shoulder"/><motor name="m2" joint="elbow"/></actuator>
</mujoco>
"""

# Three joints in one body (a planar root): Pinocchio's MJCF parser makes them one composite joint.
PLANAR = """<mujoco model="planar_geared">
  <worldbody>
    <body name="torso" pos="0 0 0">
      <joint name="rx" type="slide" axis="1 0 0" armature="0.2"/>
      <joint name="rz" type="slide" axis="0 0 1"/>
      <joint name="ry" type="hinge" axis="0 1 0" armature="0.05"/>
      <inertial pos="0.1 0 0.05" mass="3" diaginertia="0.1 0.2 0.3"/>
      <body name="leg" pos="0.2 0 -0.1">
        <joint name="knee" type="hinge" axis="0 1 0" armature="0.1"/>
        <inertial pos="0 0 -0.2" mass="1" diaginertia="0.02 0.03 0.01"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

# The hand derivation of GEARED_ARM: the acrobot's M (examples/acrobot.py) plus each rotor's inertia
# on the diagonal, T = 1/2 v^T M v, V with its own zero at the shoulder (the base not counted).
DERIVATION = '''"""A geared 2-link arm: the rotor inertia J1, J2 of each joint's motor on M's diagonal."""

from dataclasses import dataclass
from typing import Any

import numpy as np
from lagrange_xval.forms import body, hinge, stack_matrix, stack_vector

COORDINATES = ("th1", "th2")
JOINTS = ("shoulder", "elbow")
BODIES = ("link1", "link2")


@dataclass(frozen=True)
class Params:
    m1: float
    m2: float
    l1: float
    c1: float
    c2: float
    I1: float
    I2: float
    J1: float
    J2: float
    g: float


def parameters(model: Any) -> Params:
    return Params(
        m1=float(model["body/link1/mass"]),
        m2=float(model["body/link2/mass"]),
        l1=float(-model["body/link2/pos"][2]),
        c1=float(-model["body/link1/com"][2]),
        c2=float(-model["body/link2/com"][2]),
        I1=float(model["body/link1/inertia"][1, 1]),
        I2=float(model["body/link2/inertia"][1, 1]),
        J1=float(model["joint/shoulder/armature"]),
        J2=float(model["joint/elbow/armature"]),
        g=float(-model["gravity"][2]),
    )


def assumptions(p: Params) -> dict[str, Any]:
    nan = float("nan")
    about_y = lambda i: np.array([[nan, 0.0, nan], [0.0, i, 0.0], [nan, 0.0, nan]])  # noqa: E731
    out = {
        "gravity": np.array([0.0, 0.0, -p.g]),
        **body("link1", parent="base", mass=p.m1, com=(0, 0, -p.c1), inertia=about_y(p.I1)),
        **body("link2", parent="link1", mass=p.m2, com=(0, 0, -p.c2), inertia=about_y(p.I2), pos=(0, 0, -p.l1)),
        **hinge("shoulder", body="link1", axis=(0, 1, 0)),
        **hinge("elbow", body="link2", axis=(0, 1, 0)),
    }
    out["joint/shoulder/armature"], out["joint/elbow/armature"] = p.J1, p.J2
    return out


def mass_matrix(p: Params, q: np.ndarray) -> np.ndarray:
    A = p.I1 + p.m1 * p.c1**2 + p.m2 * p.l1**2
    B = p.I2 + p.m2 * p.c2**2
    K = p.m2 * p.l1 * p.c2 * np.cos(q[..., 1])
    return stack_matrix([[A + B + 2 * K + p.J1, B + K], [B + K, B + p.J2 + 0 * K]])


def bias(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    H = p.m2 * p.l1 * p.c2 * np.sin(q[..., 1])
    s12 = np.sin(q[..., 0] + q[..., 1])
    G1 = (p.m1 * p.c1 + p.m2 * p.l1) * p.g * np.sin(q[..., 0]) + p.m2 * p.c2 * p.g * s12
    G2 = p.m2 * p.c2 * p.g * s12
    w1, w2 = v[..., 0], v[..., 1]
    return stack_vector([-H * (2 * w1 * w2 + w2**2) + G1, H * w1**2 + G2])


def passive(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.zeros(np.broadcast_shapes(np.shape(q), np.shape(v)))


def kinetic_energy(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    return 0.5 * np.einsum("...i,...ij,...j->...", v, mass_matrix(p, q), v)


def potential_energy(p: Params, q: np.ndarray) -> np.ndarray:
    th1, th12 = q[..., 0], q[..., 0] + q[..., 1]
    return -(p.m1 * p.c1 + p.m2 * p.l1) * p.g * np.cos(th1) - p.m2 * p.c2 * p.g * np.cos(th12)


def body_positions(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    th1, th12 = q[..., 0], q[..., 0] + q[..., 1]
    zero = np.zeros_like(th1)
    u1 = stack_vector([-np.sin(th1), zero, -np.cos(th1)])
    u2 = stack_vector([-np.sin(th12), zero, -np.cos(th12)])
    return {"link1": p.c1 * u1, "link2": p.l1 * u1 + p.c2 * u2}


VARIANTS = ()
'''


def _model(tmp_path: Path, text: str, name: str) -> Path:
    path = tmp_path / f"{name}.xml"
    path.write_text(text)
    return path


def test_pinocchio_kinetic_energy_is_half_vMv_with_the_armature_once(tmp_path):
    """Pinocchio's T equals 1/2 v^T M v from MuJoCo's M (armature on its diagonal) and MuJoCo's T."""
    system = System.model_only(_model(tmp_path, GEARED_ARM, "geared_arm"))
    states = compare.random_states(system, n=10, seed=1)
    pin, mj = make_source(system, "pinocchio"), make_source(system, "mujoco")
    T_pin, _ = pin.energies(states.q, states.v)
    T_mj, _ = mj.energies(states.q, states.v)
    M = mj.mass_matrix(states.q)
    half_vMv = 0.5 * np.einsum("ni,nij,nj->n", states.v, M, states.v)
    assert np.allclose(T_pin, half_vMv, rtol=1e-12, atol=0.0), (T_pin - half_vMv).max()
    assert np.allclose(T_pin, T_mj, rtol=1e-12, atol=0.0)


def test_a_hinge_off_the_axes_counts_its_armature_once(tmp_path):
    """The shoulder about (0.6, 0.8, 0): Pinocchio's RevoluteUnaligned, whose armature
    computeKineticEnergy leaves out; T still equals MuJoCo's 1/2 v^T M v."""
    text = GEARED_ARM.replace('axis="0 1 0" armature="0.3"', 'axis="0.6 0.8 0" armature="0.3"')
    system = System.model_only(_model(tmp_path, text, "unaligned_arm"))
    states = compare.random_states(system, n=10, seed=3)
    pin, mj = make_source(system, "pinocchio"), make_source(system, "mujoco")
    T_mj = mj.energies(states.q, states.v)[0]
    assert np.allclose(pin.energies(states.q, states.v)[0], T_mj, rtol=1e-12, atol=0.0)
    assert np.allclose(pin.evaluate(states.q, states.v, states.tau)["T"], T_mj, rtol=1e-12, atol=0.0)


def test_composite_joint_with_armature_counts_it_once(tmp_path):
    """Several joints in one body (Pinocchio's composite joint) with armature: T from Pinocchio's
    computeKineticEnergy, as `evaluate` and `energies` give it, equals MuJoCo's."""
    system = System.model_only(_model(tmp_path, PLANAR, "planar_geared"))
    states = compare.random_states(system, n=10, seed=2)
    pin, mj = make_source(system, "pinocchio"), make_source(system, "mujoco")
    T_mj, _ = mj.energies(states.q, states.v)
    assert np.allclose(pin.energies(states.q, states.v)[0], T_mj, rtol=1e-12, atol=0.0)
    evaluated = pin.evaluate(states.q, states.v, states.tau)["T"]
    assert np.allclose(evaluated, T_mj, rtol=1e-12, atol=0.0)


def test_check_model_on_a_two_link_arm_with_armature_passes(tmp_path):
    """`check --model` on the geared arm: every reader agrees, T included (it FAILed at 1.6e1 J)."""
    result = lx.check(System.model_only(_model(tmp_path, GEARED_ARM, "geared_arm")), n_states=20, probes=0)
    assert result.passed, result.statement
    # every source counts the rotors once: MuJoCo, Pinocchio, Drake (a motor's reflected inertia) and the
    # symbolic derivation (J v^2 / 2 in T, J on M's diagonal), each pair of them on T
    pairs = {r.pair for r in result.rows if r.quantity == "T"}
    assert {"mujoco~pinocchio", "drake~mujoco", "mujoco~symbolic", "drake~pinocchio"} <= pairs, pairs


def test_a_right_derivation_of_a_geared_arm_passes(tmp_path):
    """A hand derivation with the rotor inertias on M's diagonal (and its own zero of V) passes."""
    model = _model(tmp_path, GEARED_ARM, "geared_arm")
    module = tmp_path / "geared_arm.py"
    module.write_text(DERIVATION)
    result = lx.check(System.from_files(model, module), n_states=20, probes=0)
    assert result.passed, result.statement


def test_a_derivation_that_forgets_the_rotors_fails(tmp_path):
    """The same derivation without J1 in M: judged wrong (the test above can fail)."""
    model = _model(tmp_path, GEARED_ARM, "geared_arm")
    module = tmp_path / "geared_arm_wrong.py"
    module.write_text(DERIVATION.replace("A + B + 2 * K + p.J1", "A + B + 2 * K"))
    result = lx.check(System.from_files(model, module), n_states=20, probes=0)
    assert not result.passed, result.statement

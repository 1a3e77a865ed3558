"""set_values writes ModelView keys into the MJCF text: MuJoCo and Pinocchio read back what was written."""

from __future__ import annotations

import os
import tempfile

import mujoco
import numpy as np
import pinocchio as pin
import pytest
from lagrange_xval import systems
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.forms import planar_inertia
from lagrange_xval.model import modelview, set_values

SYSTEMS = systems.system_names()
RTOL = 1e-13  # the contract: what is written compiles back to 1e-13 of the array's largest entry
PIN_RTOL = 1e-12  # Pinocchio against the values written (it reads fullinertia as is, MuJoCo diagonalises it)
STRUCTURE = ("parent", "type", "body", "joint")


def compiled(text: str) -> modelview.ModelView:
    """The reference path, independent of set_values' own verification."""
    return modelview.from_mujoco(mujoco.MjModel.from_xml_string(text), "test")


def close(expected, actual, rtol: float = RTOL) -> bool:
    if isinstance(expected, str) or isinstance(actual, str):
        return expected == actual
    e, a = np.asarray(expected, dtype=float), np.asarray(actual, dtype=float)
    scale = max(np.abs(e).max(initial=0.0), np.abs(a).max(initial=0.0))
    return e.shape == a.shape and bool(np.all(np.abs(e - a) <= rtol * scale))


def differing(expected, view, rtol: float = RTOL) -> list[str]:
    return [f"{k}: wrote {expected[k]!r}, read {view[k]!r}" for k in expected if not close(expected[k], view[k], rtol)]


def rotation(rng: np.random.Generator) -> np.ndarray:
    w, x, y, z = unit(rng.normal(size=4))
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def perturbed(view: modelview.ModelView, rng: np.random.Generator) -> dict:
    """A random valid value for every settable key of the model."""
    out: dict = {}
    g = view["gravity"]
    out["gravity"] = (
        rng.uniform(0.5, 2) * 9.81 * unit(unit(g if np.any(g) else rng.normal(size=3)) + rng.normal(size=3))
    )
    for key in view:
        kind, _, field = key.rpartition("/")
        kind = kind.split("/")[0]
        x = view[key]
        if field == "mass":
            out[key] = x * rng.uniform(0.5, 2)
        elif field == "inertia":
            R = rotation(rng)
            out[key] = R @ (x * rng.uniform(0.5, 2) * rng.uniform(0.5, 2) ** 2) @ R.T  # off-diagonal entries appear
        elif field == "com":
            out[key] = x * rng.uniform(0.5, 2) + rng.uniform(-0.2, 0.2, 3)  # off the axis
        elif field == "pos":
            out[key] = x * rng.uniform(0.5, 2) + rng.uniform(-0.1, 0.1, 3)
        elif field in ("quat", "axis"):
            out[key] = unit(rng.normal(size=4 if field == "quat" else 3))
        elif field in ("damping", "armature", "frictionloss", "stiffness"):
            out[key] = rng.uniform(0.01, 2.0)
        elif field == "gear":
            out[key] = rng.choice([-1, 1]) * rng.uniform(0.5, 3.0)
    return out


@pytest.mark.parametrize("name", SYSTEMS)
def test_own_values_give_back_the_same_model(name):
    """Every key set to its own value compiles to the same view."""
    s = systems.load(name)
    view = compiled(set_values.set_values(s.mjcf_xml(), dict(s.view), verify=False))
    assert sorted(view) == sorted(s.view)
    assert not differing(dict(s.view), view)


@pytest.mark.parametrize("name", SYSTEMS)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_values_read_back_as_set(name, seed):
    """Random valid values of every settable key are what MuJoCo compiles, and the structure is unchanged."""
    s = systems.load(name)
    values = perturbed(s.view, np.random.default_rng([seed, len(name)]))
    view = compiled(set_values.set_values(s.mjcf_xml(), values, verify=False))
    assert not differing(values, view)
    structure = {k: v for k, v in s.view.items() if k.rpartition("/")[2] in STRUCTURE}
    assert not differing(structure, view)
    anisotropic = [k for k in values if k.endswith("/inertia") and np.ptp(np.linalg.eigvalsh(s.view[k])) > 1e-16]
    assert all(abs(view[k][0, 1]) > 1e-6 * np.abs(view[k]).max() for k in anisotropic)  # the rotation made products


def pinocchio_model(text: str):
    fd, path = tempfile.mkstemp(suffix=".xml")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        return pin.buildModelFromMJCF(path)
    finally:
        os.unlink(path)


@pytest.mark.parametrize("name", SYSTEMS)
def test_pinocchio_reads_the_edited_text_alike(name):
    """Pinocchio's mass, centre of mass and inertia of each body (in the body frame) are the values written."""
    s = systems.load(name)
    values = perturbed(s.view, np.random.default_rng([5, len(name)]))
    model = pinocchio_model(set_values.set_values(s.mjcf_xml(), values))
    bad = []
    for body in (k.split("/")[1] for k in s.view if k.startswith("body/") and k.endswith("/mass")):
        frame = model.frames[model.getBodyId(body)]
        # Pinocchio's inertias live in the joint frame (at the joint's pos); the body frame is the frame's.
        inertia = frame.placement.actInv(model.inertias[frame.parentJoint])
        for what, got in (("mass", inertia.mass), ("com", inertia.lever), ("inertia", inertia.inertia)):
            key = f"body/{body}/{what}"
            if not close(values[key], got, PIN_RTOL):
                bad.append(f"{key}: wrote {values[key]!r}, Pinocchio has {got!r}")
    assert not bad


@pytest.mark.parametrize(
    "moments",
    [(1.0, 2.0, 3.0), (0.5, 0.5, 1.0), (1 / 12, 1 / 12, 2e-15), (1 / 12, 1 / 12, 1e-14), (3e-15, 3e-15, 3e-15)],
    ids=["lamina", "disc", "rod-2e-15", "rod-1e-14", "point"],
)
def test_rotated_bodies_on_mujocos_edges_read_back(moments):
    """Rotated laminas (A + B = C) and rods or points with moments near MuJoCo's minimum compile and read back."""
    s = systems.load("gimbal")
    rng = np.random.default_rng(int(1e3 * sum(moments)))
    bad = []
    for scale in (1e-3, 1.0, 1e3):
        R = rotation(rng)
        inertia = R @ np.diag(np.array(moments) * (scale if moments[2] > 1e-13 else 1.0)) @ R.T
        text = set_values.set_values(s.mjcf_xml(), {"body/inner/inertia": inertia}, verify=False)
        if not close(inertia, compiled(text)["body/inner/inertia"]):
            bad.append(scale)
    assert not bad


@pytest.mark.parametrize("name", SYSTEMS)
def test_nan_inertia_entries_are_chosen_to_keep_the_body_valid(name):
    """planar_inertia(izz) with izz far above the old moments compiles and keeps izz and the zero products exactly."""
    s = systems.load(name)
    bodies = [k for k in s.view if k.endswith("/inertia")]
    values = {k: planar_inertia(50.0 * np.abs(s.view[k]).max()) for k in bodies}
    text = set_values.set_values(s.mjcf_xml(), values)
    view = compiled(text)
    for k in bodies:
        inertia, p = view[k], np.linalg.eigvalsh(view[k])
        assert inertia[2, 2] == values[k][2, 2], k
        assert inertia[0, 2] == inertia[1, 2] == 0.0, k
        assert p[0] + p[1] >= 1.04 * p[2], (k, p)  # chosen with a margin, not on MuJoCo's edge


@pytest.mark.parametrize("name", SYSTEMS)
def test_nan_entries_keep_the_current_values_where_valid(name):
    """NaN entries keep the model's numbers: a planar inertia at the old izz, NaN masses and vector components."""
    s = systems.load(name)
    values = {}
    for k in s.view:
        if k.endswith("/inertia"):
            values[k] = planar_inertia(s.view[k][2, 2])
        elif k.endswith("/mass"):
            values[k] = float("nan")
        elif k.endswith("/com"):
            values[k] = np.array([np.nan, s.view[k][1] + 0.25, np.nan])
    view = compiled(set_values.set_values(s.mjcf_xml(), values))
    expected = {k: s.view[k] for k in s.view if k.endswith(("/inertia", "/mass"))}
    expected |= {k: s.view[k] + [0.0, 0.25, 0.0] for k in s.view if k.endswith("/com")}
    assert not differing(expected, view)


@pytest.mark.parametrize("name", SYSTEMS)
def test_nan_entries_keep_every_current_component(name):
    """On a perturbed model (no zero components), NaN scalars and NaN components of every key change nothing."""
    s = systems.load(name)
    rng = np.random.default_rng([11, len(name)])
    text = set_values.set_values(s.mjcf_xml(), perturbed(s.view, rng))
    before = compiled(text)
    values = {}
    for key, x in before.items():
        if key.rpartition("/")[2] not in STRUCTURE:
            x = np.array(x, dtype=float)
            values[key] = np.where(rng.random(x.shape) < 0.5, np.nan, x) if x.ndim else np.nan
    assert not differing(dict(before), compiled(set_values.set_values(text, values)))


@pytest.mark.parametrize("name", SYSTEMS)
def test_one_key_changes_that_key_alone(name):
    """Setting one key leaves every other key as it was (dampers or gravity enabled by the edit included)."""
    s = systems.load(name)
    values = perturbed(s.view, np.random.default_rng([9, len(name)]))
    bad = []
    for key, value in values.items():
        view = compiled(set_values.set_values(s.mjcf_xml(), {key: value}, verify=False))
        expected = dict(s.view) | {key: value}
        bad += [f"setting {key}: {d}" for d in differing(expected, view)]
    assert not bad


SYNTHETIC = """<!-- header -->
<mujoco model="synthetic">
  <compiler angle="degree"/>
  <default>
    <joint damping="0.7" armature="0.1"/>
    <general gear="2 0 0 3 0 0"/>
  </default>
  <worldbody>
    <body name="a" euler="10 20 30" pos="0.1 0 0">
      <joint name="ja" axis="0 1 0"/>
      <geom type="box" size="0.1 0.2 0.3" mass="2"/>
      <body name="b" pos="0 0 -1" axisangle="1 0 0 30">
        <joint name="jb" type="slide" axis="0 0 1"/>
        <inertial pos="0 0 -0.5" mass="1" diaginertia="1 2 2.5" euler="0 0 45"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <general name="act" joint="ja"/>
  </actuator>
</mujoco>"""


def test_bodies_without_inertial_defaults_and_degrees():
    """A geom-derived inertia, default-class joint values, degree angles and a missing <option> are all handled."""
    before = compiled(SYNTHETIC)
    rng = np.random.default_rng(3)
    values = perturbed(before, rng)
    for subset in (values, {"body/a/mass": 3.0}, {"gravity": [1.0, np.nan, 2.0]}, {"joint/ja/axis": [np.nan, 1.0, 0]}):
        text = set_values.set_values(SYNTHETIC, subset)
        assert text.startswith("<!-- header -->")
        view = compiled(text)
        expected = dict(before) | {k: np.where(np.isnan(v), before[k], v) for k, v in subset.items()}
        assert not differing(expected, view)


BAD = [
    ("double_pendulum_bars", "body/link1/mass", 0.0, "must be positive"),
    ("double_pendulum_bars", "body/link1/mass", -1.0, "must be positive"),
    ("double_pendulum_bars", "body/link1/mass", np.inf, "not finite"),
    ("double_pendulum_bars", "gravity", [0.0, -np.inf, 0.0], "not finite"),
    ("double_pendulum_bars", "body/link1/com", [0.0, 1.0], "shape"),
    ("double_pendulum_bars", "body/link1/inertia", np.diag([1.0, 1.0, 3.0]), "triangle inequality"),
    ("double_pendulum_bars", "body/link1/inertia", np.diag([1.0, -1.0, 1.0]), "not positive definite"),
    ("double_pendulum_bars", "body/link1/inertia", [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]], "not symmetric"),
    (
        "double_pendulum_bars",
        "body/link1/inertia",
        [[1, np.nan, np.nan], [np.nan, 1, np.nan], [np.nan, np.nan, 3]],
        "no values of the NaN entries",
    ),
    ("double_pendulum_bars", "body/link1/quat", [1.0, 1.0, 0.0, 0.0], "unit"),
    ("double_pendulum_bars", "joint/theta/axis", [0.0, 0.0, 2.0], "unit"),
    ("double_pendulum_bars", "joint/theta/damping", -0.1, "non-negative"),
    ("double_pendulum_bars", "joint/theta/armature", -0.1, "non-negative"),
    ("double_pendulum_bars", "joint/theta/frictionloss", -0.1, "non-negative"),
    ("double_pendulum_bars", "joint/theta/stiffness", -0.1, "non-negative"),
    ("double_pendulum_bars", "joint/theta/stiffness", "stiff", "not a number"),
    ("double_pendulum_bars", "body/link2/parent", "world", "structure"),
    ("double_pendulum_bars", "joint/theta/type", "slide", "structure"),
    ("double_pendulum_bars", "joint/phi/body", "link1", "structure"),
    ("gimbal", "actuator/motor_psi/joint", "theta", "structure"),
    ("gimbal", "actuator/motor_psi/gear", "two", "not a number"),
    ("gimbal", "actuator/motor_psi/gear", -np.inf, "not finite"),
]


@pytest.mark.parametrize("name, key, value, message", BAD, ids=[f"{k}={v!r}" for _, k, v, _ in BAD])
def test_bad_values_are_one_line_errors_naming_the_key(name, key, value, message):
    """Unphysical, non-finite, misshapen values and structure changes are refused, naming the key."""
    with pytest.raises(HarnessError, match=message) as err:
        set_values.set_values(systems.load(name).mjcf_xml(), {key: value})
    assert key in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    "key, shown",
    [
        ("body/link9/mass", "Unknown body 'link9'."),
        ("joint/thetta/damping", "Unknown joint 'thetta'. Did you mean 'theta'?"),
        ("actuator/motor/gear", "Unknown actuator 'motor'"),
        ("body/link1/colour", "Unknown body key 'body/link1/colour'"),
        ("gravitation", "Unknown model key 'gravitation'. Did you mean 'gravity'?"),
    ],
)
def test_unknown_keys_and_names_list_the_valid_ones(key, shown):
    """An unknown key or name is a one-line error that lists the valid ones."""
    with pytest.raises(HarnessError) as err:
        set_values.set_values(systems.load("double_pendulum_bars").mjcf_xml(), {key: 1.0})
    assert shown in str(err.value) and "Valid: " in str(err.value) and "\n" not in str(err.value)

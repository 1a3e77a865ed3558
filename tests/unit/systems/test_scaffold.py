"""`lagrange-xval new`: a starting equations module for a model in a person's own folder, reported as
"not provided" until its dynamics are written, and passing every check once they are right."""

from __future__ import annotations

import re
import runpy
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.cli import main

from tests.e2e.test_robots import ROBOTS, needs_robots

# `new` writes the minimal equations contract of issue 24 (no USES, no DESCRIPTION: the physics is read
# from the model, the docstring describes the system).
EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
ARM = EXAMPLES / "urdf" / "spatial_arm.urdf"

# The simple pendulum's dynamics in the fields `new` writes for it (those its dynamics read): the bob's
# mass, its centre's offset along y from the hinge (the hinge at the body's origin, axis z), its inertia
# about z and g, gravity along -y.
FILLED_IN = """

def kinetic_energy(p, q, v):
    return 0.5 * (p.m_link * p.cy_link**2 + p.Izz_link) * v[..., 0] ** 2


def potential_energy(p, q):
    return -p.m_link * p.g * float(GRAVITY_DIRECTION[1]) * body_positions(p, q)["link"][..., 1]


def body_positions(p, q):
    s, c = np.sin(q[..., 0]), np.cos(q[..., 0])
    return {"link": np.stack([-s * p.cy_link, c * p.cy_link, 0.0 * s], axis=-1)}


def body_rotations(p, q):
    s, c = np.sin(q[..., 0]), np.cos(q[..., 0])
    zero, one = 0.0 * s, 1.0 + 0.0 * s
    rows = [np.stack([c, -s, zero], -1), np.stack([s, c, zero], -1), np.stack([zero, zero, one], -1)]
    return {"link": np.stack(rows, axis=-2)}
"""


@pytest.fixture
def folder(tmp_path):
    shutil.copy(systems.MODELS_DIR / "simple_pendulum.xml", tmp_path / "pendulum.xml")
    return tmp_path


def test_new_writes_a_module_reported_not_provided(folder, capsys):
    assert main(["new", "mine", "--model", str(folder / "pendulum.xml")]) == 0
    module = folder / "mine.py"
    assert module.is_file() and str(module) in capsys.readouterr().out
    code = main(["check", "--model", str(folder / "pendulum.xml"), "--equations", str(module)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "not provided" in err[0]
    assert main(["new", "mine", "--model", str(folder / "pendulum.xml")]) == 2, "overwrote a module"
    assert "exists already" in capsys.readouterr().err


def test_the_module_once_filled_in_passes_every_check(folder, capsys):
    """The generated parameters() and assumptions() are right: with correct dynamics the derivation
    agrees at the model's parameters and at every probe, which moves each generated field."""
    assert main(["new", "mine", "--model", str(folder / "pendulum.xml"), "--dir", str(folder)]) == 0
    module = folder / "mine.py"
    module.write_text(module.read_text() + FILLED_IN)
    system = systems.System.from_files(folder / "pendulum.xml", module)
    assert system.params.m_link == 1.0 and system.params.g == pytest.approx(9.81)
    code = main(["check", "--model", str(folder / "pendulum.xml"), "--equations", str(module), "--json"])
    out = capsys.readouterr().out
    assert code == 0, out[-2000:]
    import lagrange_xval as lx

    lx.check(system, n_states=200).assert_ok()  # every term, at the model's parameters and at 4 probes
    reports = folder / "reports"
    code = main(["run", "--model", str(folder / "pendulum.xml"), "--equations", str(module), "--out", str(reports)])
    assert code == 0, capsys.readouterr().out[-2000:]  # the whole job: trajectories, chaos, report, replay
    assert (reports / "mine.rrd").is_file() and (reports / "report.html").is_file()


def test_a_wrong_filling_is_caught(folder):
    """The converse: the potential energy without the mass (hidden by m = 1 in the model) disagrees
    at the probes, which move the generated m_link, and the term is named."""
    import lagrange_xval as lx

    assert main(["new", "mine", "--model", str(folder / "pendulum.xml")]) == 0
    module = folder / "mine.py"
    module.write_text(module.read_text() + FILLED_IN.replace("return -p.m_link * p.g", "return -p.g"))
    result = lx.check(systems.System.from_files(folder / "pendulum.xml", module), n_states=100)
    assert not result.passed
    assert result.failures[0].quantity in {"gravity", "potential energy"}, result.failures[0]


def _derive_python(model: Path, *lock: str) -> str:
    done = subprocess.run(
        [sys.executable, "-m", "lagrange_xval.cli", "derive", "--model", str(model), "--python", *lock],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_new_writes_the_minimal_contract(folder):
    """No USES (the physics is read from the model) and no DESCRIPTION (the docstring's first paragraph
    is one); the coordinates, joints and bodies written out; the helpers from lagrange_xval.forms."""
    assert main(["new", "mine", "--model", str(folder / "pendulum.xml")]) == 0
    text = (folder / "mine.py").read_text()
    assert "USES" not in text and "DESCRIPTION" not in text
    assert "from lagrange_xval.forms import not_provided" in text and "_forms" not in text
    module = runpy.run_path(str(folder / "mine.py"))
    assert module["__doc__"].startswith("mine: the equations of motion of pendulum.xml")
    assert module["COORDINATES"] == module["JOINTS"] == ("theta",) and module["BODIES"] == ("link",)
    p = module["parameters"](systems.System.model_only(folder / "pendulum.xml").view)
    assert p.m_link == 1.0 and "gravity" in module["assumptions"](p)


def test_new_lock_writes_the_module_of_the_locked_urdf(tmp_path, capsys):
    """`new --lock yaw`: the locked joint is no coordinate and has no parameter; the check command it
    prints carries the same --lock."""
    assert main(["new", "mine", "--model", str(ARM), "--dir", str(tmp_path), "--lock", "yaw"]) == 0
    assert capsys.readouterr().out.rstrip().endswith("--lock yaw`")
    module = runpy.run_path(str(tmp_path / "mine.py"))
    assert module["COORDINATES"] == module["JOINTS"] == ("shoulder", "elbow")
    assert not [f for f in module["Params"].__dataclass_fields__ if f.endswith("_yaw")]
    module["parameters"](systems.System.model_only(ARM, locked=("yaw",)).view)  # every field is in the model
    assert main(["new", "other", "--model", str(ARM), "--dir", str(tmp_path), "--lock", "nope"]) == 2
    assert "no joint 'nope' to lock" in capsys.readouterr().err and not (tmp_path / "other.py").exists()


@needs_robots
def test_new_on_the_panda_with_or_without_its_fingers_locked(tmp_path, capsys):
    """The Panda's second finger mimics the first: a constraint, left out like every other, so `new`
    without --lock writes all nine joints; with both fingers locked it writes the seven arm joints."""
    assert ROBOTS is not None
    panda = ROBOTS / "panda_description/urdf/panda.urdf"
    assert main(["new", "whole", "--model", str(panda), "--dir", str(tmp_path)]) == 0
    whole = runpy.run_path(str(tmp_path / "whole.py"))
    assert len(whole["COORDINATES"]) == 9 and "panda_finger_joint2" in whole["COORDINATES"]
    fingers = "panda_finger_joint1,panda_finger_joint2"
    assert main(["new", "mine", "--model", str(panda), "--dir", str(tmp_path), "--lock", fingers]) == 0
    module = runpy.run_path(str(tmp_path / "mine.py"))
    assert module["COORDINATES"] == tuple(f"panda_joint{i}" for i in range(1, 8))
    module["parameters"](systems.System.model_only(panda, locked=tuple(fingers.split(","))).view)


@needs_robots
def test_the_panda_locked_to_two_joints_filled_in_from_derive_passes(tmp_path):
    """A gripper robot end to end: the Panda with its fingers and five arm joints locked (seven joints
    derive too slowly), new's module with derive's dynamics written in passes check, probes included."""
    import lagrange_xval as lx

    assert ROBOTS is not None
    panda = ROBOTS / "panda_description/urdf/panda.urdf"
    locked = (*(f"panda_joint{i}" for i in range(3, 8)), "panda_finger_joint1", "panda_finger_joint2")
    lock = ["--lock", ",".join(locked)]
    assert main(["new", "mine", "--model", str(panda), "--dir", str(tmp_path), *lock]) == 0
    module = tmp_path / "mine.py"
    module.write_text(module.read_text() + "\n\n" + _derive_python(panda, *lock))
    system = lx.System.from_files(panda, module, locked=locked)
    assert system.coordinates == ("panda_joint1", "panda_joint2")
    lx.check(system, n_states=50, probes=1).assert_ok()


# Issue 44, item 5: a student's triple pendulum of rigid bars (capsules, hinges along y, damped), the
# motion in the x-z plane. Its equations of motion read 16 numbers: per bar the mass, the centre's
# offset along the bar (z; its x is 0, its y off the plane), the inertia about y and the bar's place in
# its parent (z: the pivot's height for bar 1, the length of the bar above for bars 2 and 3), per joint
# the damping, and g. Before, `new` wrote 58 fields here (every inertia entry, every offset).
TRIPLE = """<mujoco model="triple">
  <worldbody>
    <body name="bar1" pos="0 0 2">
      <joint name="theta1" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.02" mass="1"/>
      <body name="bar2" pos="0 0 -0.5">
        <joint name="theta2" type="hinge" axis="0 1 0" damping="0.04"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.02" mass="0.8"/>
        <body name="bar3" pos="0 0 -0.4">
          <joint name="theta3" type="hinge" axis="0 1 0" damping="0.03"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.02" mass="0.6"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
TRIPLE_FIELDS = {
    *(f"{f}_bar{i}" for f in ("m", "cz", "Iyy", "pz") for i in (1, 2, 3)),
    *(f"d_theta{i}" for i in (1, 2, 3)),
    "g",
}


@pytest.fixture
def triple(tmp_path):
    """(model, module text, module namespace) of `new triple` on the 3-bar pendulum."""
    model = tmp_path / "triple.xml"
    model.write_text(TRIPLE)
    assert main(["new", "triple", "--model", str(model)]) == 0
    text = (tmp_path / "triple.py").read_text()
    return model, text, runpy.run_path(str(tmp_path / "triple.py"))


def test_new_on_a_planar_three_bar_pendulum_writes_the_fields_its_dynamics_read(triple):
    """16 fields, not 58: only the inertia about the hinge axis, the offsets in the plane of motion; every
    other number of the model stated (NaN where the dynamics do not depend on it, 0.0 for a zero they
    rely on), so that the module keeps the strict contract."""
    model, text, module = triple
    fields = module["Params"].__dataclass_fields__
    assert len(fields) == 16 and set(fields) == TRIPLE_FIELDS
    view = systems.System.model_only(model).view
    p = module["parameters"](view)
    assert p.cz_bar2 == pytest.approx(-0.2) and p.pz_bar1 == 2.0 and p.Iyy_bar3 == view["body/bar3/inertia"][1][1]
    assumed = module["assumptions"](p)
    assert set(view) <= set(assumed), "a key of the model is not stated"
    inertia = assumed["body/bar2/inertia"]
    assert inertia[1, 1] == p.Iyy_bar2 and np.isnan(np.delete(inertia.ravel(), 4)).all()
    assert assumed["body/bar2/com"][0] == 0.0 and np.isnan(assumed["body/bar2/com"][1])  # in the plane, off it
    assert np.isnan(assumed["body/bar1/pos"][0])  # the pivot's place along x: no dynamics depends on it
    assert "float(float(" not in text and 'g=float(np.linalg.norm(model["gravity"])),' in text


def test_new_writes_form_a_stubs_and_lists_the_five_forms(triple):
    """The stubs of the form the README recommends (M and bias), counted as not provided; no passive stub
    (it would be taken as written); the docstring lists the five forms the harness reads, each by the
    functions that make it."""
    from lagrange_xval.handwritten.forms import FORMS

    _, text, module = triple
    for fn in ("mass_matrix", "bias", "kinetic_energy", "potential_energy", "body_positions", "body_rotations"):
        assert module[fn].not_provided, fn
    with pytest.raises(NotImplementedError, match="mass_matrix"):
        module["mass_matrix"](None, np.zeros(3))
    assert "passive" not in module and text.index("def mass_matrix") < text.index("def kinetic_energy")
    doc = module["__doc__"]
    assert "ONE of the five forms" in doc and "four" not in doc and len(FORMS) == 5
    listed = [line.strip() for line in doc.splitlines() if re.match(r"\s+\([a-e]\) ", line)]
    assert [line[1] for line in listed] == list(FORMS)
    for line, names in zip(listed, FORMS.values(), strict=True):
        assert all(f"{n}(" in line for n in names), line
    assert "damps or springs theta1, theta2, theta3" in " ".join(doc.split())
    readme = (Path(__file__).resolve().parents[3] / "README.md").read_text()
    assert "any of the five forms" in readme


@pytest.mark.parametrize("model", ["triple", "spatial_arm"])
def test_the_fields_are_the_parameters_of_the_symbolic_derivation(model, tmp_path):
    """`new`'s fields (found from the chain's energies, numerically) are the derivation's parameters (the
    free symbols of its T, V and passive forces, named as `derive --python` binds them), and the gears:
    on the spatial arm a body turning about z alone has Izz alone, the others every non-zero product."""
    from lagrange_xval.symbolic.derivation import derive
    from lagrange_xval.systems.scaffold import field_of

    path = ARM if model == "spatial_arm" else tmp_path / "triple.xml"
    if model == "triple":
        path.write_text(TRIPLE)
    system = systems.System.model_only(path)
    d = derive(system.view, system.joints)
    symbols = set().union(d.T.free_symbols, d.V.free_symbols, *(x.free_symbols for x in d.passive))
    expected = {field_of(*d.source[s]) for s in symbols if s in d.source}
    assert main(["new", "mine", "--model", str(path), "--dir", str(tmp_path)]) == 0
    fields = set(runpy.run_path(str(tmp_path / "mine.py"))["Params"].__dataclass_fields__)
    assert {f for f in fields if not f.startswith("gear_")} == expected
    if model == "spatial_arm":
        assert [f for f in fields if f.endswith("_link1") and f.startswith("I")] == ["Izz_link1"]


def test_the_three_bar_module_filled_in_from_derive_passes_check(triple):
    """A module `new` wrote, its stubs replaced by `derive --python`'s M, bias, passive and energies (in
    the same Params fields), passes `check`, its probes built from the module's own assumptions."""
    import json

    model, text, _ = triple
    derived = _derive_python(model)
    module = model.with_name("triple.py")
    stubs = text.index("@not_provided\ndef mass_matrix")
    module.write_text(text[:stubs] + derived[derived.index("import numpy as np") :])
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "lagrange_xval.cli",
            "check",
            "--model",
            str(model),
            "--equations",
            str(module),
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    verdict = json.loads(done.stdout)["verdict"]
    assert done.returncode == 0 and verdict["passed"], verdict["statement"]
    assert verdict["probes"]["built"] >= 3, verdict["statement"]

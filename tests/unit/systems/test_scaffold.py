"""`lagrange-xval new`: a starting equations module for a model in a person's own folder, reported as
"not provided" until its dynamics are written, and passing every check once they are right."""

from __future__ import annotations

import runpy
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from lagrange_xval import systems
from lagrange_xval.cli import main

from tests.e2e.test_robots import ROBOTS, needs_robots

# `new` writes the minimal equations contract of issue 24 (no USES, no DESCRIPTION: the physics is read
# from the model, the docstring describes the system).
EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
ARM = EXAMPLES / "urdf" / "spatial_arm.urdf"

# The simple pendulum's dynamics in the generated fields, for any position, centre of mass,
# inertia and anchor: a body turning about z (the model's hinge axis) with gravity along -y.
FILLED_IN = """

def _arm(p):
    return p.cx_link - p.jx_theta, p.cy_link - p.jy_theta  # centre of mass from the hinge, body frame


def kinetic_energy(p, q, v):
    dx, dy = _arm(p)
    return 0.5 * (p.m_link * (dx**2 + dy**2) + p.Izz_link + p.arm_theta) * v[..., 0] ** 2


def potential_energy(p, q):
    return -p.m_link * p.g * float(GRAVITY_DIRECTION[1]) * body_positions(p, q)["link"][..., 1]


def body_positions(p, q):
    dx, dy = _arm(p)
    s, c = np.sin(q[..., 0]), np.cos(q[..., 0])
    x = p.px_link + p.jx_theta + c * dx - s * dy
    y = p.py_link + p.jy_theta + s * dx + c * dy
    z = p.pz_link + p.cz_link + 0.0 * s
    return {"link": np.stack([x, y, z], axis=-1)}


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

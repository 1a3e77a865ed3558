"""`lagrange-xval new`: a starting equations module for a model in a person's own folder, reported as
"not provided" until its dynamics are written, and passing every check once they are right."""

from __future__ import annotations

import shutil

import pytest
from lagrange_xval.validate import systems
from lagrange_xval.validate.cli import main

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

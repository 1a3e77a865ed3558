"""Forms (e) and (f): a Hamiltonian H(q, pm) (validate/handwritten/hamiltonian.py) and the energies as
text in a TOML file (validate/handwritten/textform.py), each checked through the public API from a
folder of the user's own; a mistake in either is found in the term it is in, and a Hamiltonian or
an expression of the wrong shape is a one-line error.
"""

from __future__ import annotations

import shutil
import textwrap
from pathlib import Path

import lagrange_xval as lx
import numpy as np
import pytest
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.handwritten import hamiltonian, textform
from lagrange_xval.handwritten.forms import written_form

ROOT = Path(__file__).resolve().parents[3]

# The double pendulum of equations/double_pendulum_point.py, as its Hamiltonian.
HAMILTONIAN = '''"""Double pendulum, point bobs, relative angles: H = pm^T M^-1 pm / 2 + V."""
from dataclasses import dataclass

import numpy as np
from lagrange_xval.forms import body, hinge, planar_inertia

DESCRIPTION = "Double pendulum as its Hamiltonian."
COORDINATES = ("theta", "phi")
JOINTS = ("theta", "phi")
BODIES = ("link1", "link2")


@dataclass(frozen=True)
class Params:
    m1: float
    m2: float
    l1: float
    l2: float
    g: float
    I1: float
    I2: float


def parameters(model):
    return Params(
        m1=model["body/link1/mass"],
        m2=model["body/link2/mass"],
        l1=-model["body/link2/pos"][1],
        l2=-model["body/link2/com"][1],
        g=-model["gravity"][1],
        I1=model["body/link1/inertia"][2, 2],
        I2=model["body/link2/inertia"][2, 2],
    )


def assumptions(p):
    return {
        "gravity": np.array([0.0, -p.g, 0.0]),
        **body("link1", parent="world", mass=p.m1, com=(0, -p.l1, 0), inertia=planar_inertia(p.I1)),
        **body("link2", parent="link1", mass=p.m2, com=(0, -p.l2, 0), inertia=planar_inertia(p.I2), pos=(0, -p.l1, 0)),
        **hinge("theta", body="link1", axis=(0, 0, 1)),
        **hinge("phi", body="link2", axis=(0, 0, 1)),
    }


def hamiltonian(p, q, pm):
    th, ph = q[..., 0], q[..., 1]
    c = np.cos(ph)
    m11 = p.m1 * p.l1**2 + p.m2 * (p.l1**2 + p.l2**2 + 2 * p.l1 * p.l2 * c) + p.I1 + p.I2
    m12 = p.m2 * (p.l2**2 + p.l1 * p.l2 * c) + p.I2
    m22 = p.m2 * p.l2**2 + p.I2
    det = m11 * m22 - m12**2
    p1, p2 = pm[..., 0], pm[..., 1]
    T = (m22 * p1**2 - 2 * m12 * p1 * p2 + m11 * p2**2) / (2 * det)
    V = -(p.m1 + p.m2) * p.g * p.l1 * np.cos(th) - p.m2 * p.g * p.l2 * np.cos(th + ph)
    return T + V
'''


def _docstring_example() -> str:
    """The TOML example of validate/handwritten/textform.py's docstring, as a person would copy it: the
    cart-pole of examples/cart_pole.py (theta from the upright, the rod's centre of mass at l/2), its
    energies on paper; V counts from the world origin's height, as the engines do."""
    lines = (textform.__doc__ or "").splitlines()
    first = next(i for i, line in enumerate(lines) if line.strip().startswith("# cart_pole.toml"))
    last = next(i for i in range(first, len(lines)) if not lines[i].strip())
    return textwrap.dedent("\n".join(lines[first:last])) + "\n"


TEXT = _docstring_example()


def _write(folder: Path, model: str, name: str, text: str, mistake: tuple[str, str] | None = None) -> lx.System:
    """The system of `model` (a repository file) and `text` written as `name` in `folder`, with
    `mistake` (old, new) planted in the text."""
    shutil.copy(ROOT / model, folder / "model.xml")
    if mistake is not None:
        assert text.count(mistake[0]) == 1, mistake[0]
        text = text.replace(*mistake)
    (folder / name).write_text(text)
    return lx.System.from_files(folder / "model.xml", folder / name)


def _hamiltonian_system(folder: Path, mistake: tuple[str, str] | None = None) -> lx.System:
    return _write(folder, "models/double_pendulum_point.xml", "dp.py", HAMILTONIAN, mistake)


def _text_system(folder: Path, mistake: tuple[str, str] | None = None) -> lx.System:
    return _write(folder, "examples/cart_pole.xml", "cp.toml", TEXT, mistake)


def test_a_hamiltonian_passes_every_check(tmp_path):
    """Model checks, pointwise agreement and every term (energies included) at 2 probes."""
    system = _hamiltonian_system(tmp_path)
    assert written_form(system.equations) == "e"
    result = lx.check(system, n_states=100, probes=2)
    result.assert_ok()
    checked = {r.quantity for r in result.rows if r.check == "derivation"}
    assert {"mass matrix", "gravity", "velocity", "kinetic energy", "potential energy"} <= checked


@pytest.mark.parametrize(
    ("mistake", "term"),
    [
        (("T = (m22 * p1**2", "T = (2 * m22 * p1**2"), "mass matrix"),  # a factor 2 in one entry of M^-1
        (("- p.m2 * p.g * p.l2 * np.cos(th + ph)", "- p.m1 * p.g * p.l2 * np.cos(th + ph)"), "gravity"),
    ],
    ids=["inverse-mass-entry", "potential"],
)
def test_a_wrong_hamiltonian_is_named(tmp_path, mistake, term):
    result = lx.check(_hamiltonian_system(tmp_path, mistake), n_states=50, probes=1)
    assert not result.passed
    assert result.failures[0].quantity == term, result.statement


def _mujoco(system: lx.System, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's M(q) and free acceleration at (q, v)."""
    import mujoco

    model = system.mujoco_model()
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = q, v
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return M, data.qacc.copy()


def test_hamiltons_equations_agree_with_mujoco(tmp_path):
    """At pm = M v (MuJoCo's M): qdot = dH/dpm is v, and pdot = -dH/dq is d(M v)/dt = M a + (dM/dt) v
    (the derivative of M along v by central differences); a factor 2 in one entry of M^-1 breaks qdot."""
    system = _hamiltonian_system(tmp_path)
    rng = np.random.default_rng(0)
    h = 1e-6
    for _ in range(10):
        q, v = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-3, 3, 2)
        M, a = _mujoco(system, q, v)
        qdot, pdot = hamiltonian.hamilton_equations(system.equations, system.params, q, M @ v)
        dM = (_mujoco(system, q + h * v, v)[0] - _mujoco(system, q - h * v, v)[0]) / (2 * h)
        np.testing.assert_allclose(qdot, v, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(pdot, M @ a + dM @ v, rtol=1e-6, atol=1e-6)
    wrong = _hamiltonian_system(tmp_path, ("T = (m22 * p1**2", "T = (2 * m22 * p1**2"))
    qdot, _ = hamiltonian.hamilton_equations(wrong.equations, wrong.params, q, M @ v)
    assert not np.allclose(qdot, v, rtol=1e-6, atol=0)


@pytest.mark.parametrize(
    ("extra", "why"),
    [("p1**4", "not quadratic in the momenta pm"), ("p.m1 * p1", "has a term linear in the momenta")],
    ids=["quartic", "linear"],
)
def test_a_hamiltonian_of_another_shape_is_one_line(tmp_path, extra, why):
    with pytest.raises(HarnessError, match=why) as caught:
        _hamiltonian_system(tmp_path, ("return T + V", f"return T + V + {extra}"))
    assert "\n" not in str(caught.value)


def test_energies_as_text_pass_every_check(tmp_path):
    """A TOML file of T, V and friction: every term, the energies and the friction at 2 probes."""
    system = _text_system(tmp_path)
    assert written_form(system.equations) == "d"
    assert system.coordinates == ("x", "theta") and system.uses == {"gravity", "damping", "actuation"}
    result = lx.check(system, n_states=100, probes=2)
    result.assert_ok()
    assert {r.probe for r in result.rows if r.check == "derivation"} >= {0, 1, 2}


@pytest.mark.parametrize(
    ("mistake", "term"),
    [
        (("(mp*lc^2 + I)/2*dtheta^2", "(mp*lc^2 + 2*I)/2*dtheta^2"), "mass matrix"),
        (("mp*g*(h + pz + lc*cos(theta))", "mp*g*(h + pz + 2*lc*cos(theta))"), "gravity"),
        (('friction = ["-kx*dx", "0"]', 'friction = ["-kx*dx", "-kx*dtheta"]'), "friction"),
    ],
    ids=["inertia", "potential", "friction"],
)
def test_a_wrong_text_file_is_named(tmp_path, mistake, term):
    result = lx.check(_text_system(tmp_path, mistake), n_states=50, probes=1)
    assert not result.passed
    assert result.failures[0].quantity == term, result.statement


@pytest.mark.parametrize(
    ("mistake", "message"),
    [
        (('V = "mc*g', "V = \"__import__('os') + mc*g"), r"__import__\('os'\). is not allowed"),
        (
            ('V = "mc*g', "V = \"__import__('os').system('true') + mc*g"),
            r"__import__\('os'\)\.system\('true'\). is not",
        ),
        (('V = "mc*g', 'V = "mq*g'), "'mq' is not a declared symbol"),
        (('V = "mc*g', 'V = "mc.real*g'), "'mc.real' is not allowed"),
        (('V = "mc*g', 'V = "max(mc, 1)*g'), "'max\\(mc, 1\\)' is not allowed"),
        (('V = "mc*g', 'V = "(lambda: 1)()*mc*g'), "is not allowed"),
        (('V = "mc*g', 'V = "dx*mc*g'), "'dx' is not a declared symbol"),  # V has no velocities
        (('g = "-gravity[2]"', 'g = "-gravity[5]"'), "no entry"),
        (('mc = "body/cart/mass"', 'mc = "body/kart/mass"'), "Did you mean 'body/cart/mass'"),
        (('joints = ["x", "theta"]', 'joints = ["x", "th"]'), "'th' is not a joint of the model"),
    ],
    ids=[
        "import",
        "import-system",
        "undeclared",
        "attribute",
        "other-call",
        "lambda",
        "velocity-in-V",
        "index",
        "key",
        "joint",
    ],
)
def test_a_bad_text_file_is_one_line(tmp_path, mistake, message):
    """Nothing in the file is evaluated: what is not a number, a declared name, an operator or a listed
    function is refused in one line naming the expression, the part and what is valid."""
    with pytest.raises(HarnessError, match=message) as caught:
        _text_system(tmp_path, mistake)
    assert "\n" not in str(caught.value)


def test_equations_as_text_run_end_to_end(tmp_path):
    """`run --model cp.xml --equations cp.toml` writes the reports and exits 0."""
    from lagrange_xval.cli import main

    _text_system(tmp_path)
    out = tmp_path / "reports"
    code = main(
        ["run", "--model", str(tmp_path / "model.xml"), "--equations", str(tmp_path / "cp.toml"), "--out", str(out)]
        + ["--no-replay"]
    )
    assert code == 0
    assert (out / "results.json").is_file() and "cp.toml" in (out / "report.md").read_text()


@pytest.mark.parametrize("form", ["hamiltonian", "text"])
def test_the_new_forms_trace_for_the_fast_path(tmp_path, form):
    """The derived M, bias and friction trace symbolically (fast path and Taylor reference) to round-off."""
    from lagrange_xval.dynamics.reference import rhs_check

    system = _hamiltonian_system(tmp_path) if form == "hamiltonian" else _text_system(tmp_path)
    assert rhs_check(system) < 1e-12

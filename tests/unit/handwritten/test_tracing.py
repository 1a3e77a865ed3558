"""A person's numpy code as they write it: branches traced, and returns held to real numbers.

The module is the simple pendulum with viscous damping written `-k |v| sign(v)` and gravity passed
through np.where, np.minimum and np.maximum that never bind; its variants return a complex, a
wrongly shaped, a ragged or a string mass matrix. Each is written into a temporary folder.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import lagrange_xval as lx
import numpy as np
import pytest
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.dynamics import reference
from lagrange_xval.handwritten.values import real_array
from lagrange_xval.sources import fastpath

ROOT = Path(__file__).resolve().parents[3]
MASS = "    return stack_matrix([[p.m * p.l**2 + p.I + np.zeros(np.shape(q)[:-1])]])"
PASSIVE = "    return np.zeros(np.broadcast_shapes(np.shape(q), np.shape(v)))"
GRAVITY = "    g = p.m * p.g * p.l * np.sin(q[..., 0])"
BRANCHY_GRAVITY = """    s = np.sin(q[..., 0])
    g = p.m * p.g * p.l * np.where(np.abs(s) >= 0.0, s, 0.0 * s)  # always the first branch
    g = np.minimum(g, 1e9) + np.maximum(g, -1e9) - g  # neither bound binds"""
BRANCHY_PASSIVE = "    return -p.k * np.abs(v) * np.sign(v) + 0.0 * q"


def _write(folder: Path, *, mass: str = MASS, passive: str = BRANCHY_PASSIVE) -> lx.System:
    """The damped pendulum (models/simple_pendulum.xml with joint damping) and its module in `folder`."""
    folder.mkdir(parents=True, exist_ok=True)
    xml = (ROOT / "models" / "simple_pendulum.xml").read_text()
    xml = xml.replace('damper="disable"', 'damper="enable"')
    xml = xml.replace('<joint name="theta" type="hinge"', '<joint name="theta" type="hinge" damping="0.3"')
    (folder / "branchy.xml").write_text(xml)
    edits = {
        "    I: float  # kg m^2  # noqa: E741 - the notes' symbol\n": (
            "    I: float  # kg m^2  # noqa: E741 - the notes' symbol\n    k: float  # N m s/rad\n"
        ),
        '        I=model["body/link/inertia"][2, 2],\n': (
            '        I=model["body/link/inertia"][2, 2],\n        k=float(model["joint/theta/damping"]),\n'
        ),
        'hinge("theta", body="link", axis=(0, 0, 1))': 'hinge("theta", body="link", axis=(0, 0, 1), damping=p.k)',
        GRAVITY: BRANCHY_GRAVITY,
        PASSIVE: passive,
        MASS: mass,
    }
    text = (ROOT / "equations" / "simple_pendulum.py").read_text()
    for old, new in edits.items():
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    (folder / "branchy.py").write_text(text)
    return lx.System.from_files(folder / "branchy.xml", folder / "branchy.py")


def test_abs_sign_where_minimum_maximum_pass_every_check(tmp_path, recwarn):
    """A correct module written with np.abs, np.sign, np.where, np.minimum and np.maximum agrees everywhere."""
    result = lx.check(_write(tmp_path), n_states=100, probes=1)
    result.assert_ok()
    assert not [str(w.message) for w in recwarn], "no warning from the harness"


def test_branches_trace_to_the_numpy_values(tmp_path):
    """heyoka's select and sympy's Piecewise reproduce the numpy module at random states."""
    system = _write(tmp_path)
    assert reference.rhs_check(system, n_states=32) < 1e-12
    rhs = fastpath.scalar_rhs(system)
    y, tau = np.array([0.7, -1.3]), [0.2]
    from lagrange_xval.sources.hand import HandSource

    numpy_a = HandSource(system).forward(y[None, :1], y[None, 1:], np.array([tau]))[0]
    assert np.allclose(rhs(0.0, y, tau)[1:], numpy_a, rtol=1e-13, atol=0.0)


def test_simulate_from_the_hand_source(tmp_path):
    """`lagrange-xval simulate --source hand` runs the module (the generated code traces its branches)."""
    _write(tmp_path)
    out = tmp_path / "run.csv"
    args = ["--model", str(tmp_path / "branchy.xml"), "--equations", str(tmp_path / "branchy.py")]
    args += ["--source", "hand", "--q0", "1", "--v0", "0.5", "--t-end", "1", "--dt-out", "0.5", "--out", str(out)]
    done = subprocess.run(
        [sys.executable, "-m", "lagrange_xval.cli", "simulate", *args], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr == "", done.stderr
    assert out.read_text().count("\n") > 3


def test_a_branch_numpy_takes_itself_is_refused_by_name_and_line(tmp_path):
    """np.sign on an array the module made plain: one line naming np.sign, passive() and the line."""
    plain = "    v = np.asarray(v)\n" + BRANCHY_PASSIVE
    system = _write(tmp_path, passive=plain)
    line = (tmp_path / "branchy.py").read_text().splitlines().index(BRANCHY_PASSIVE) + 1
    with pytest.raises(HarnessError) as caught:
        reference.symbolic_dynamics(system)
    message = str(caught.value)
    assert f"np.sign in passive() at branchy.py:{line} cannot be traced for the Taylor reference" in message
    assert "Traced" not in message and "\n" not in message


@pytest.mark.parametrize(
    ("mass", "said"),
    [
        (MASS.replace("p.I +", "p.I + 5j +"), "mass_matrix() returned complex values"),
        ("    return np.zeros((3,)) + p.m", "mass_matrix() returned shape (3,)"),
        ("    return [[1.0, 2.0], [3.0]]", "mass_matrix() returned a ragged nested list"),
        ("    return np.full(np.shape(q)[:-1] + (1, 1), 'a')", "mass_matrix() returned strings"),
        (MASS.replace("]])", "]]) * np.inf"), "mass_matrix() is not finite"),
    ],
    ids=["complex", "shape", "ragged", "string", "inf"],
)
def test_a_mass_matrix_that_is_not_real_numbers_is_a_failing_row(tmp_path, recwarn, mass, said):
    """The mass matrix's rows fail with the function and what it returned named; no warning."""
    result = lx.check(_write(tmp_path, mass=mass), n_states=100, probes=1)
    rows = [r for r in result.failures if r.check == "derivation" and r.quantity == "mass matrix"]
    assert rows and all(said in r.detail for r in rows), result.statement
    assert not [str(w.message) for w in recwarn]


def test_real_array_takes_numbers_and_refuses_the_rest():
    """Integers, booleans, NaN and inf become floats; objects and complex are refused by name."""
    assert real_array("f()", [[1, 2]], (3, 1, 2)).shape == (3, 1, 2)
    assert np.isinf(real_array("f()", np.inf)).all()
    with pytest.raises(HarnessError, match=r"f\(\) returned Python objects"):
        real_array("f()", np.array([1.0], dtype=object))
    with pytest.raises(HarnessError, match=r"f\(\) returned complex values"):
        real_array("f()", np.array([1.0 + 0j]))

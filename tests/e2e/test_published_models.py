"""Models as they are published (issue 32): gymnasium's MuJoCo environments, in its wheel (pinned in
requirements.lock), with joint ranges, floors, free joints, several joints in one body, unnamed
actuators and geom-derived inertia. None is refused for a constraint the equations of motion do not
contain; a right hand derivation of one of them passes and a slipped one fails naming the term."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import mujoco
import pytest
from lagrange_xval.cli import main
from lagrange_xval.model import floating, scope
from lagrange_xval.model.start import Start
from lagrange_xval.systems import System

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "gymnasium" / "inverted_double_pendulum.py"


def _assets() -> Path:
    spec = importlib.util.find_spec("gymnasium")
    assert spec is not None and spec.origin, "gymnasium is in requirements.lock (its wheel carries the models)"
    return Path(spec.origin).parent / "envs" / "mujoco" / "assets"


MODELS = sorted(p.name for p in _assets().glob("*.xml"))


def _last(capsys: pytest.CaptureFixture[str]) -> str:
    return capsys.readouterr().out.strip().splitlines()[-1]


def test_constraints_are_listed_and_switched_off_not_refused():
    """A floor, ranges, a control range: each kind named once, and MuJoCo's flags switch them off."""
    model = mujoco.MjModel.from_xml_path(str(_assets() / "hopper.xml"))
    left = scope.unconstrained(model)
    assert any(line.startswith("contacts between 7 pair(s)") for line in left), left
    assert any("the range of joint(s) 'thigh_joint'" in line for line in left), left
    assert model.opt.disableflags & scope.CONSTRAINT_FLAGS == scope.CONSTRAINT_FLAGS
    assert not scope.refusals(model)


def test_free_joints_become_slides_and_hinges_every_reader_shares():
    """ant.xml's free joint: six one-coordinate joints in the same body, listed; unnamed bodies named."""
    converted = floating.convert((_assets() / "ant.xml").read_text())
    model = mujoco.MjModel.from_xml_string(converted.text)
    assert model.nq == model.nv == 14
    assert any("free joint 'root'" in line for line in converted.lines)
    assert any("body#" in line for line in converted.lines)
    assert converted.middle == {"root_ry"}  # the chart's singular angle, kept off +-pi/2 in random states


@pytest.mark.parametrize("name", ["inverted_pendulum.xml", "inverted_double_pendulum.xml", "hopper.xml", "point.xml"])
def test_published_models_pass_alone(name, capsys):
    """Ranges, a floor, several joints in one body, unnamed actuators: a verdict, and every reader agrees."""
    assert main(["check", "--model", str(_assets() / name), "--states", "20"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-1].startswith(f"verdict: {Path(name).stem}: pass") and "left out" not in lines[-1], lines[-1]
    assert lines[-2].startswith("left out, as no equation of motion contains them: "), lines[-2]  # once, above


@pytest.mark.long
@pytest.mark.parametrize("name", MODELS)
def test_every_gymnasium_model_gets_a_verdict(name, capsys):
    """No refusal: exit 0 or 1 with a verdict line, never an error (exit 2)."""
    code = main(["check", "--model", str(_assets() / name), "--states", "10", "--probes", "0"])
    last = _last(capsys)
    assert code in (0, 1) and last.startswith(f"verdict: {Path(name).stem}: "), last


def test_a_hand_derivation_of_the_inverted_double_pendulum_passes_and_a_coriolis_slip_fails(tmp_path, capsys):
    """Written from gymnasium's XML (examples/gymnasium): right, it passes at the model and at the probes
    (the capsules' inertia written into each probe); with the Christoffel symbols' half-term's sign
    flipped, it fails on the velocity terms."""
    model = str(_assets() / "inverted_double_pendulum.xml")
    assert main(["check", "--model", model, "--equations", str(EXAMPLE), "--states", "50"]) == 0
    assert "at 4 probe parameter sets" in _last(capsys)
    text = EXAMPLE.read_text()
    slip = ' - 0.5 * np.einsum("...jki'
    assert slip in text
    wrong = tmp_path / "inverted_double_pendulum.py"
    wrong.write_text(text.replace(slip, ' + 0.5 * np.einsum("...jki'))
    assert main(["check", "--model", model, "--equations", str(wrong), "--states", "50"]) == 1
    last = _last(capsys)
    # the property the slip breaks leads (verdict/structure.py), then the term
    assert last.startswith("verdict: inverted_double_pendulum: FAIL: your velocity terms are not those of your M"), last
    assert "velocity disagrees" in last, last


def test_a_model_with_armature_and_springs_passes_alone(tmp_path, capsys):
    """Slides with stiffness (one off its springref), damping and armature, a hinge with armature: MuJoCo,
    Pinocchio, Drake and the derived equations agree on M, T (armature included), V and the passive
    forces (springs included)."""
    path = tmp_path / "sprung.xml"
    path.write_text(
        """<mujoco model="sprung"><worldbody><body name="cart" pos="0 0 1">
      <joint name="x" type="slide" axis="1 0 0" stiffness="20" springref="0.1" damping="3" armature="0.2"/>
      <joint name="z" type="slide" axis="0 0 1" stiffness="5" damping="1"/>
      <geom type="sphere" size="0.1" mass="1"/>
      <body name="pole" pos="0 0 -0.3"><joint name="th" type="hinge" axis="0 1 0" armature="0.05"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.02" mass="0.5"/></body></body></worldbody></mujoco>"""
    )
    assert main(["check", "--model", str(path), "--states", "30"]) == 0, _last(capsys)
    assert _last(capsys).startswith("verdict: sprung: pass")


def _extreme(tmp_path: Path) -> System:
    """The absolute-angle double pendulum with a 50 kg bob on a 0.1 m rod below a 2 m rod."""
    from lagrange_xval.systems import load

    notes = load("double_pendulum_absolute")
    text = notes.mjcf.read_text()
    text = text.replace('<inertial pos="0 -1 0" mass="1"', '<inertial pos="0 -2 0" mass="1"', 1)
    text = text.replace('<body name="link2" pos="0 -1 0">', '<body name="link2" pos="0 -2 0">', 1)
    i = text.index('<body name="link2"')
    text = text[:i] + text[i:].replace('<inertial pos="0 -1 0" mass="1"', '<inertial pos="0 -0.1 0" mass="50"', 1)
    path = tmp_path / "double_pendulum_absolute.xml"
    path.write_text(text)
    return System(name=notes.name, mjcf=path, equations=notes.equations)


def test_scipys_error_estimate_bounds_its_error_at_an_extreme_ratio(tmp_path):
    """odeint's error against the reference stays within 10 x its own estimate (the threshold) on Pinocchio's
    ABA where the check run is DOP853 (odeint's own check run at rtol/10 was as far off as the run)."""
    import numpy as np
    from lagrange_xval.dynamics.estimate import scipy_estimate, threshold
    from lagrange_xval.dynamics.integrate import SCIPY_DEFAULT, scipy_trajectory
    from lagrange_xval.dynamics.reference import reference_trajectory
    from lagrange_xval.sources import make_source

    system = _extreme(tmp_path)
    t = np.linspace(0.0, 10.0, 1001)
    q0, v0, tau = np.array([0.0, 3.0]), np.zeros(2), np.zeros(2)
    ref, _ = reference_trajectory(system, Start.of(q0, v0, tau), t, cache_dir=None)
    pin = make_source(system, "pinocchio")
    o = SCIPY_DEFAULT
    run = scipy_trajectory(system, pin, Start.of(q0, v0, tau), t, method=o["method"], rtol=o["rtol"], atol=o["atol"])
    estimate, how = scipy_estimate(system, pin, run, Start.of(q0, v0, tau))
    error = np.abs(run.q - ref.q).max(axis=1)
    assert "DOP853" in how
    assert np.all(error <= threshold(estimate)), float((error / threshold(estimate)).max())


@pytest.mark.long
def test_a_right_derivation_passes_at_an_extreme_ratio(tmp_path, capsys):
    """`run` on the 50 kg bob below a 2 m rod: the mirrors judged within their scheme's horizon and the
    scipy runs against their own estimates, so the notes' right derivation passes (it failed both)."""
    system = _extreme(tmp_path)
    eq = tmp_path / "double_pendulum_absolute.py"
    eq.write_text("from lagrange_xval.equations.double_pendulum_absolute import *  # noqa: F403\n")
    out = tmp_path / "out"
    args = ["run", "--model", str(system.mjcf), "--equations", str(eq), "--out", str(out), "--no-replay"]
    assert main(args) == 0, capsys.readouterr().out[-600:]


def test_check_constraints_says_when_and_which_constraint_acts(tmp_path, capsys):
    """`check --constraints`: the model as published (a range on theta, limits on) runs in MuJoCo and
    agrees with the notes' derivation until theta reaches its range, which the verdict names."""
    from lagrange_xval.systems import load

    notes = load("double_pendulum_point")
    text = notes.mjcf.read_text().replace(' constraint="disable" limit="disable"', "", 1)
    text = text.replace('<joint name="theta" type="hinge"', '<joint name="theta" range="-0.2 0.2" type="hinge"', 1)
    model, eq = tmp_path / "ranged.xml", tmp_path / "double_pendulum_point.py"
    model.write_text(text)
    eq.write_text("from lagrange_xval.equations.double_pendulum_point import *  # noqa: F403\n")
    args = ["check", "--model", str(model), "--equations", str(eq), "--states", "20", "--probes", "1"]
    assert main([*args, "--constraints"]) == 0
    last = _last(capsys)
    assert "agrees with the equations until 0.5" in last and "when joint 'theta' reaches its range" in last, last
    assert main(["check", "--model", str(model), "--states", "20", "--constraints"]) == 2
    assert "give --equations" in capsys.readouterr().err


def test_the_output_grid_is_a_whole_number_of_the_models_steps():
    """gymnasium's inverted pendulum steps at 0.02 s: its runs are sampled every step, not every 0.01 s."""
    from lagrange_xval.dynamics.integrate import output_grid

    assert output_grid(10.0, 0.01, 0.002) == (10.0, 0.01)
    assert output_grid(10.0, 0.01, 0.02) == pytest.approx((10.0, 0.02))
    assert output_grid(10.0, 0.01, 0.003) == pytest.approx((0.012 * 833, 0.012))


@pytest.mark.long
def test_run_on_a_published_model_stepping_at_its_own_timestep(tmp_path, capsys):
    """`run --model inverted_pendulum.xml` (timestep 0.02 s, a range, a control range): every stage runs."""
    out = tmp_path / "out"
    args = ["run", "--model", str(_assets() / "inverted_pendulum.xml"), "--out", str(out), "--no-replay"]
    assert main(args) == 0, capsys.readouterr().out[-600:]

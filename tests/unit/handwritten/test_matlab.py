"""A Matlab function as a form of the contract: read as text, run by GNU Octave as written, judged in form (c).

The Octave tests need `octave-cli` (Debian's octave; `.ci/run` installs it): in CI they run and fail
without it; elsewhere they are skipped, and one test checks the one line a machine without it gets.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from lagrange_xval.cli import main
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.handwritten.matlab import read_signature

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = ROOT / "examples" / "matlab"
POINT = ROOT / "models" / "double_pendulum_point.xml"
GIMBAL = ROOT / "models" / "gimbal.xml"
CART_POLE = ROOT / "examples" / "cart_pole.xml"
octave = pytest.mark.skipif(
    shutil.which("octave-cli") is None and os.environ.get("CI") != "true",
    reason="GNU Octave (octave-cli) is not installed; CI installs it and runs these",
)

# The notes' section-1 function with M^-1 written out right (m = l = 1, relative angles).
DOUBLE_BOB_FIXED = """function dydt = double_bob_fixed(t, y)
theta = y(1); phi = y(2); dthetadt = y(3); dphidt = y(4);
g = 9.81; l = 1; m = 1;
c = cos(phi); s = sin(phi);
d = 2 - c^2;
h1 = -s*(2*dthetadt*dphidt + dphidt^2) + g/l*(2*sin(theta) + sin(theta + phi));
h2 = s*dthetadt^2 + g/l*sin(theta + phi);
dydt = zeros(4, 1);
dydt(1) = dthetadt;
dydt(2) = dphidt;
dydt(3) = (-h1 + (1 + c)*h2)/d;
dydt(4) = ((1 + c)*h1 - (3 + 2*c)*h2)/d;
end
"""
# The notes' double gimbal, corrected: friction divided by the inertia, the input torques taken.
GIMBAL_FIXED = """% coordinates: psi, theta
function dydt = gimbal_fixed(t, y, tau)
theta = y(2); dpsidt = y(3); dthetadt = y(4);
I1zz = 1e-3; I2xx = 10e-3; I2yy = 9e-3; I2zz = 5e-3; kpsi = 0.01; ktheta = 0.01;
m11 = I1zz + I2xx*sin(theta)^2 + I2zz*cos(theta)^2;
d = I2xx - I2zz; sc = sin(theta)*cos(theta);
dydt = [dpsidt; dthetadt;
        (tau(1) - kpsi*dpsidt - 2*d*sc*dthetadt*dpsidt)/m11;
        (tau(2) - ktheta*dthetadt + d*sc*dpsidt^2)/I2yy];
end
"""


def _write(folder: Path, name: str, text: str) -> Path:
    path = folder / f"{name}.m"
    path.write_text(text)
    return path


def _verdict(capsys: pytest.CaptureFixture[str], model: Path, equations: Path, *extra: str) -> tuple[int, str]:
    code = main(["check", "--model", str(model), "--equations", str(equations), "--states", "200", *extra])
    lines = [x for x in capsys.readouterr().out.splitlines() if x.startswith("verdict:")]
    assert len(lines) == 1
    return code, lines[0]


# ---- the file read as text (no Octave needed)


@pytest.mark.parametrize(
    ("signature", "mode", "input_name"),
    [
        ("function dydt = f(t, y)", "t,y", "u"),
        ("function dydt = f(t, y, p)", "t,y,p", "u"),
        ("function dydt = f(t, y, tau)", "t,y,tau", "tau"),
        ("function dydt = f(t, y, u)", "t,y,tau", "u"),
        ("function [dydt] = f(t,y,par,tau)", "t,y,p,tau", "tau"),
        ("function dydt = f(~, y)", "t,y", "u"),
    ],
)
def test_the_signature_says_how_the_function_is_called(tmp_path, signature, mode, input_name):
    binding = "% p.m = body/pole/mass\n% par.m = body/pole/mass\n" if "p" in mode.split(",") else ""
    sig = read_signature(_write(tmp_path, "f", f"% comment\n{binding}{signature}\ndydt = y;\nend\n"))
    assert (sig.mode, sig.input_name, sig.name) == (mode, input_name, "f")


def test_comment_lines_give_the_coordinates_joints_and_bindings(tmp_path):
    text = "% coordinates: a, b\n% joints: x theta\n% p.k = 2*joint/x/damping\nfunction d = f(t, y, p)\nd = y;\n"
    sig = read_signature(_write(tmp_path, "f", text))
    assert sig.coordinates == ("a", "b") and sig.joints == ("x", "theta")
    assert [(b.symbol, b.key, b.scale) for b in sig.bindings] == [("k", "joint/x/damping", 2.0)]


@pytest.mark.parametrize(
    ("stem", "text", "said"),
    [
        ("f", "x = 1;\n", "is not a function declaration"),
        ("f", "% only a comment\n", "no code"),
        ("f", "function d = f(t)\nd = 1;\n", "takes 1 inputs"),
        ("f", "function d = f(t, y, p)\nd = y;\n", "bind each field it reads"),
        ("f", "% p.m = body/pole/mass\nfunction d = f(t, y)\nd = y;\n", "binds a struct the function does not take"),
        ("my-pendulum", "function d = f(t, y)\nd = y;\n", "rename the file"),
        ("f", "% p.m = not a key [\nfunction d = f(t, y, p)\nd = y;\n", "is not a model key"),
    ],
)
def test_a_file_that_is_not_such_a_function_is_one_line_naming_what_is_valid(tmp_path, stem, text, said):
    with pytest.raises(HarnessError, match=said) as caught:
        read_signature(_write(tmp_path, stem, text))
    assert "\n" not in str(caught.value)


def test_a_machine_without_octave_says_how_to_install_it(tmp_path):
    """PATH without Octave: the one error line names the file and the install command; nothing written."""
    env = {**os.environ, "PATH": str(Path(sys.executable).parent)}
    done = subprocess.run(
        [sys.executable, "-m", "lagrange_xval.cli", "check", "--model", str(POINT), "--equations"]
        + [str(EXAMPLES / "double_bob_pendulum.m")],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
        timeout=120,
    )
    assert done.returncode != 0 and done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "apt-get install octave" in lines[0] and "double_bob_pendulum.m" in lines[0]
    assert list(tmp_path.iterdir()) == []


# ---- run by Octave


@octave
def test_the_notes_printed_pendulum_function_is_wrong_in_gravity(capsys):
    code, line = _verdict(capsys, POINT, EXAMPLES / "double_bob_pendulum.m")
    assert code == 1 and "FAIL: gravity disagrees at the model's parameters" in line


@octave
def test_the_notes_printed_gimbal_function_is_wrong_in_the_velocity_terms(capsys):
    code, line = _verdict(capsys, GIMBAL, EXAMPLES / "double_gimbal_state_space_model.m")
    assert code == 1 and "FAIL: velocity disagrees" in line and "I_inner_yy where expected has I_inner_zz" in line


@octave
def test_the_corrected_pendulum_passes_and_says_no_probe_could_move_its_numbers(tmp_path, capsys):
    code, line = _verdict(capsys, POINT, _write(tmp_path, "double_bob_fixed", DOUBLE_BOB_FIXED))
    assert code == 0 and "pass: agrees with MuJoCo, Pinocchio and Drake" in line
    assert "its numbers are written inside it" in line and "were not looked for" in line


@octave
def test_the_corrected_gimbal_with_inputs_passes_in_every_term(tmp_path, capsys):
    main(["check", "--model", str(GIMBAL), "--equations", str(_write(tmp_path, "gimbal_fixed", GIMBAL_FIXED))])
    out = capsys.readouterr().out
    assert "verdict: gimbal_fixed: pass" in out
    assert "mass matrix" in out and "actuation" not in out  # tau on every coordinate gives M itself


@octave
def test_a_cart_pole_with_a_struct_of_parameters_passes_at_the_probes(capsys):
    code, line = _verdict(capsys, CART_POLE, EXAMPLES / "cart_pole.m")
    assert code == 0 and "and at 4 probe parameter sets" in line


@octave
def test_a_planted_mistake_in_the_cart_pole_is_named(tmp_path, capsys):
    text = (EXAMPLES / "cart_pole.m").read_text().replace("p.mp*p.g*p.c*sin(th)", "-p.mp*p.g*p.c*sin(th)")
    assert text != (EXAMPLES / "cart_pole.m").read_text()
    code, line = _verdict(capsys, CART_POLE, _write(tmp_path, "cart_pole", text))
    assert code == 1 and "FAIL: gravity disagrees" in line


@octave
@pytest.mark.parametrize(
    ("body", "said"),
    [
        ("dydt = [y(3); y(4); undefined_thing; 0];", "undefined"),
        ("dydt = [y(3); y(4); 0];", "returned 3 values for a state of 4"),
        ("dydt = [0; 0; 0; 0];", "dydt(1:2) is not y(3:4)"),
    ],
)
def test_an_octave_failure_is_named_in_the_verdict(tmp_path, capsys, body, said):
    code, line = _verdict(capsys, POINT, _write(tmp_path, "broken", f"function dydt = broken(t, y)\n{body}\nend\n"))
    assert code == 1 and said in line


@octave
def test_a_function_that_never_returns_is_stopped_and_leaves_no_octave(tmp_path):
    path = _write(tmp_path, "forever", "function dydt = forever(t, y)\nwhile true\nend\n")
    done = subprocess.run(
        [sys.executable, "-m", "lagrange_xval.cli", "check", "--model", str(POINT), "--equations", str(path)]
        + ["--time-limit", "3", "--states", "10"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2 and "qacc did not return within 3 s" in done.stderr
    # Octave's command line names the function's folder (--path): any process left of this command's
    left = subprocess.run(["pgrep", "-f", f"--path {tmp_path}"], capture_output=True, text=True).stdout.split()
    assert [p for p in left if Path(f"/proc/{p}/cmdline").exists()] == []

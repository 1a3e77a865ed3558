"""Every form judged to the same depth (issue 34): one slip, written into the acrobot of examples/ in
each form it can take, is named at the same entry and in the person's symbols: explicit accelerations
taking tau, explicit accelerations taking the actuators' controls u (mapped back to forces with the
model's M), and the energies in Python and in the TOML text form (the slip named in V, with the entry
of G it changes after it). A gear
left out of a u form is named at the actuator's column of B."""

from __future__ import annotations

from pathlib import Path

import lagrange_xval as lx
import pytest

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
SOURCE = (EXAMPLES / "acrobot.py").read_text()
L_FOR_LC = ("(p.m1 * p.lc1 + p.m2 * p.l1)", "(p.m1 * p.lc1 + p.m2 * p.lc1)")  # in G1 and in V alike


def explicit_tau() -> str:
    return SOURCE


def explicit_u() -> str:
    """qacc(p, q, v, u): the elbow motor's control, tau = (0, gear u) written out."""
    out = SOURCE.replace(
        "def qacc(p: Params, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:",
        "def qacc(p: Params, q: np.ndarray, v: np.ndarray, u: np.ndarray) -> np.ndarray:",
    ).replace(
        "    f1 = tau[..., 0] - p.b1 * w1",
        "    tau = stack_vector([0.0 * u[..., 0], p.gear * u[..., 0]])\n    f1 = tau[..., 0] - p.b1 * w1",
    )
    out = out.replace("    g: float  # m/s^2\n", "    g: float  # m/s^2\n    gear: float\n")
    out = out.replace(
        '        g=float(-model["gravity"][2]),\n',
        '        g=float(-model["gravity"][2]),\n        gear=float(model["actuator/elbow_motor/gear"]),\n',
    )
    return out.replace('"actuator/elbow_motor/gear": NAN,', '"actuator/elbow_motor/gear": p.gear,')


def energies() -> str:
    """Form (d): T and V alone, the damping as `passive` (qacc cut out)."""
    start, end = SOURCE.index("def qacc("), SOURCE.index("def kinetic_energy(")
    passive = (
        "def passive(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:\n"
        "    return stack_vector([-p.b1 * v[..., 0], -p.b2 * v[..., 1]])\n\n\n"
    )
    return SOURCE[:start] + passive + SOURCE[end:]


KINETIC = (
    "((Ic1 + m1*lc1^2 + m2*l1^2 + Ic2 + m2*lc2^2 + 2*m2*l1*lc2*cos(theta2))*dtheta1^2"
    " + 2*(Ic2 + m2*lc2^2 + m2*l1*lc2*cos(theta2))*dtheta1*dtheta2 + (Ic2 + m2*lc2^2)*dtheta2^2)/2"
)
TEXT = f"""\
coordinates = ["theta1", "theta2"]
joints = ["shoulder", "elbow"]
T = "{KINETIC}"
V = "-(p.m1 * p.lc1 + p.m2 * p.l1) * p.g * cos(theta1) - p.m2 * p.lc2 * p.g * cos(theta1 + theta2)"
friction = ["-b1*dtheta1", "-b2*dtheta2"]
[symbols]
m1 = "body/link1/mass"
m2 = "body/link2/mass"
l1 = "-body/link2/pos[2]"
lc1 = "-body/link1/com[2]"
lc2 = "-body/link2/com[2]"
Ic1 = "body/link1/inertia[1][1]"
Ic2 = "body/link2/inertia[1][1]"
b1 = "joint/shoulder/damping"
b2 = "joint/elbow/damping"
g = "-gravity[2]"
"""


def text_form() -> str:
    """The energies from paper as the TOML text form (the same V, written with the module's spelling
    of the slip's factors so that one replacement plants it in every form)."""
    return TEXT.replace("p.", "")


FORMS = {"explicit_tau": explicit_tau, "explicit_u": explicit_u, "energies": energies, "text": text_form}


def system_of(folder: Path, name: str, text: str, *, gear: float = 1.0) -> lx.System:
    suffix = "toml" if text.startswith("coordinates = ") else "py"
    (folder / f"{name}.{suffix}").write_text(text)
    xml = (EXAMPLES / "acrobot.xml").read_text()
    assert xml.count('gear="1"') == 1
    (folder / f"{name}.xml").write_text(xml.replace('gear="1"', f'gear="{gear:g}"'))
    return lx.System.from_files(folder / f"{name}.xml", folder / f"{name}.{suffix}")


@pytest.mark.parametrize("form", sorted(FORMS))
def test_each_form_is_right_as_written(form, tmp_path):
    assert lx.check(system_of(tmp_path, form, FORMS[form]()), n_states=60, probes=2).passed


@pytest.mark.parametrize("form", sorted(FORMS))
def test_l_for_lc_is_named_at_the_same_entry_in_every_form(form, tmp_path):
    text = FORMS[form]()
    where = "-" if form in ("energies", "text") else "G1 = "  # into V, or into the G the qacc solves with
    slip = [x.replace("p.", "") for x in L_FOR_LC] if form == "text" else L_FOR_LC
    old = where + slip[0]
    assert text.count(old) == 1, (form, old)
    wrong = text.replace(old, where + slip[1])
    statement = lx.check(system_of(tmp_path, form, wrong), n_states=60, probes=2).statement
    slip = "yours has lc1 where expected has l1"
    if form in ("energies", "text"):  # named where it was made, in V, with the entry of G it changes after it
        assert f"V: {slip}" in statement and "it changes G[theta1]" in statement, statement
    else:
        assert f"G[theta1]: {slip}" in statement, statement


def test_a_gear_left_out_of_a_u_form_is_named_at_its_actuator(tmp_path):
    text = explicit_u().replace("p.gear * u[..., 0]", "u[..., 0]")
    result = lx.check(system_of(tmp_path, "geared", text, gear=2.0), n_states=60, probes=2)
    assert not result.passed
    assert "B[theta2, elbow_motor]: yours is 1/2 of the model's: the gear 2" in result.statement, result.statement


SIGN = {  # the elbow's gravity with its sign flipped: in the G the qacc solves with, or in V
    "explicit_tau": ("G2 = p.m2 * p.lc2 * p.g * s12", "G2 = -p.m2 * p.lc2 * p.g * s12", "G[theta2]: yours"),
    "explicit_u": ("G2 = p.m2 * p.lc2 * p.g * s12", "G2 = -p.m2 * p.lc2 * p.g * s12", "G[theta2]: yours"),
    "energies": ("- p.m2 * p.lc2 * p.g * np.cos(th1 + th2)", "+ p.m2 * p.lc2 * p.g * np.cos(th1 + th2)", "V: yours"),
    "text": ("- m2 * lc2 * g * cos(theta1 + theta2)", "+ m2 * lc2 * g * cos(theta1 + theta2)", "V: yours"),
}


@pytest.mark.parametrize("form", sorted(FORMS))
def test_a_sign_slip_is_named_as_a_sign_in_every_form(form, tmp_path):
    old, new, entry = SIGN[form]
    text = FORMS[form]()
    assert text.count(old) == 1, (form, old)
    statement = lx.check(system_of(tmp_path, form, text.replace(old, new)), n_states=60, probes=2).statement
    assert f"{entry} has the term" in statement and "with the wrong sign" in statement, statement


def test_a_doubled_gear_in_an_implicit_residual_with_u_is_named_at_its_actuator(tmp_path):
    """examples/cart_pole.py's residual taking the cart motor's control u, with u doubled: the actuation
    is named at B[x, motor_x] as an explicit u form's is."""
    source = (EXAMPLES / "cart_pole.py").read_text()
    edits = [
        ("a: np.ndarray, tau: np.ndarray) -> np.ndarray:", "a: np.ndarray, u: np.ndarray) -> np.ndarray:"),
        ("+ p.kx * dx - tau[..., 0]", "+ p.kx * dx - 2 * u[..., 0]"),
        ("- p.mp * p.g * lc * s - tau[..., 1]", "- p.mp * p.g * lc * s"),
    ]
    for old, new in edits:
        assert source.count(old) == 1, old
        source = source.replace(old, new)
    (tmp_path / "cart.py").write_text(source)
    (tmp_path / "cart.xml").write_text((EXAMPLES / "cart_pole.xml").read_text())
    result = lx.check(lx.System.from_files(tmp_path / "cart.xml", tmp_path / "cart.py"), n_states=60, probes=2)
    assert "actuation disagrees" in result.statement
    assert "B[x, motor_x]: yours is 2 times the model's (gear 1, actuator/motor_x/gear)" in result.statement

""" "As if" (issue 44, item 1): a wrong derivation that is the right derivation of another chain is
said as the physical parameter it has instead, with the body, both values and the person's symbols;
a right one, or a mistake no body makes (a Coriolis sign), gets nothing. The mistakes are planted
in the rigid-bar double pendulum of equations/ and the spatial arm of examples/."""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Callable
from pathlib import Path

import lagrange_xval as lx
import numpy as np
import pytest
from lagrange_xval.cli import main
from lagrange_xval.results.schema import AsIf, AsIfReading
from lagrange_xval.sources.pinocchio import PinocchioSource
from lagrange_xval.systems import System
from lagrange_xval.verdict import asif
from lagrange_xval.verdict.pointwise import random_states

from ...mutations import MUTATIONS, load_mutated

ROOT = Path(__file__).resolve().parents[3]
DYNAMICS = "def mass_matrix("  # the bars' dynamics start here: parameters() and assumptions() stay right

# The bars' planted mistakes: (the line as written, the mistake), applied to the dynamics functions.
BARS = {
    "about the joint": [("m22 = p.m2 * p.c2**2 + p.I2", "m22 = p.m2 * p.c2**2 + (p.I2 + p.m2 * p.c2**2)")],
    "mass twice": [("p.m1 * p.c1", "2 * p.m1 * p.c1")],  # T1's m1 c1^2 and V1's m1 c1 alike
    "l for l/2": [("p.c2", "p.l1")],  # bar 2's centre at its full length, everywhere
    "missing half": [("m11 = p.m1 * p.c1**2 + p.I1 +", "m11 = 2 * (p.m1 * p.c1**2 + p.I1) +")],  # T1 without 1/2
    "coriolis sign": [("h * w1**2", "-h * w1**2")],
    "three I2": [("m22 = p.m2 * p.c2**2 + p.I2", "m22 = p.m2 * p.c2**2 + 3 * p.I2")],
    "m c2^2 twice": [("m22 = p.m2 * p.c2**2 + p.I2", "m22 = p.m2 * p.c2**2 + p.I2 + p.m2 * p.c2**2")],
    "right": [],
}


def bars(folder: Path, mistake: str) -> System:
    """The rigid-bar double pendulum with `mistake` planted in its dynamics."""
    head, sep, tail = (ROOT / "equations" / "double_pendulum_bars.py").read_text().partition(DYNAMICS)
    for old, new in BARS[mistake]:
        assert old in tail, f"double_pendulum_bars.py no longer has {old!r}"
        tail = tail.replace(old, new)
    folder.mkdir(exist_ok=True)
    (folder / "bars.py").write_text(head + sep + tail)
    shutil.copy(ROOT / "models" / "double_pendulum_bars.xml", folder / "bars.xml")
    return System.from_files(folder / "bars.xml", folder / "bars.py")


def found(system: System) -> AsIf | None:
    """What the fit says at the verdict's kind of states (seeded), against Pinocchio alone."""
    states = random_states(system, n=64, seed=0)
    return asif.as_if(system, states, {"pinocchio": PinocchioSource(system)})


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("asif")


def test_an_inertia_about_the_joint_is_named_with_the_body_and_both_values(folder):
    said = found(bars(folder / "joint", "about the joint"))
    assert said is not None
    assert (
        "link2's moment of inertia about its joint (0.333 kg m^2) instead of about its centre (0.0833 kg m^2)"
        in (said["statement"])
    ), said["statement"]
    (reading,) = said["readings"]
    assert (reading["bodies"], reading["kind"]) == (["link2"], "about its joint")
    assert reading["yours"] == pytest.approx(1 / 12 + 0.25) and reading["model"] == pytest.approx(1 / 12)
    assert said["names"]["I2"] == "body/link2/inertia[2][2]" and said["residual"] < asif.FIT_RTOL


def test_the_record_follows_its_schema(folder):
    said = found(bars(folder / "joint", "about the joint"))
    assert said is not None
    assert set(said) <= AsIf.__required_keys__ | AsIf.__optional_keys__ and "statement" in said
    for reading in said["readings"]:
        assert set(reading) == AsIfReading.__required_keys__, reading


def test_a_mass_counted_twice_is_named(folder):
    said = found(bars(folder / "mass", "mass twice"))
    assert said is not None
    assert "link1's mass counted twice (2 kg instead of 1 kg)" in said["statement"], said["statement"]
    assert [r["bodies"] for r in said["readings"]] == [["link1"]]
    assert said["names"] == {"m1": "body/link1/mass"}
    # m1 alone is no identifiable parameter of a bar on a fixed hinge: only combinations are said to differ
    assert not any(d.startswith("link1's m:") for d in said["differing"]), said["differing"]


def test_l_where_l_over_2_was_meant_is_named_in_the_persons_symbol_with_its_sign(folder):
    said = found(bars(folder / "centre", "l for l/2"))
    assert said is not None
    assert "link2's centre at 1 m instead of 0.5 m from its joint (l where l/2 was meant)" in said["statement"]
    assert said["names"] == {"c2": "-body/link2/com[1]"}
    assert "[your names: c2 = -body/link2/com[1]]" in said["statement"]


def test_a_missing_half_in_the_kinetic_energy_is_named(folder):
    said = found(bars(folder / "half", "missing half"))
    assert said is not None
    assert (
        "link1's kinetic energy counted twice (moment of inertia about its joint 0.667 instead of 0.333 kg m^2: "
        "a missing 1/2 in its T)" in said["statement"]
    ), said["statement"]
    assert said["readings"][0]["yours"] == pytest.approx(2 / 3)


def test_a_consistent_change_no_kind_names_is_said_as_the_identifiable_combination(folder):
    said = found(bars(folder / "three", "three I2"))
    assert said is not None and not said["readings"]
    assert "the identifiable combination link2's I_zz about its joint: 0.5 instead of 0.3333" in said["statement"]
    assert "(no single parameter can be told apart)" in said["statement"]


def test_a_right_module_is_no_other_chain(folder):
    system = bars(folder / "right", "right")
    assert found(system) is None
    source = PinocchioSource(system)
    Y, tau, theta = asif.person_torques(system, source, random_states(system, n=64, seed=0), 0)
    fit = asif.fit(Y, tau, theta)
    assert fit.residual < asif.FIT_RTOL and not fit.differing()  # None because it is the model's own chain
    assert len(fit.base) == 6  # a planar double pendulum: 6 identifiable combinations of its 20 parameters


def test_a_coriolis_sign_is_no_body_and_gets_no_as_if(folder):
    system = bars(folder / "coriolis", "coriolis sign")
    assert found(system) is None
    source = PinocchioSource(system)
    Y, tau, theta = asif.person_torques(system, source, random_states(system, n=64, seed=0), 0)
    assert asif.fit(Y, tau, theta).residual > 1e3 * asif.FIT_RTOL  # None because no chain fits it


def test_one_joint_a_gravity_sign_is_the_centre_on_the_other_side():
    """A one-joint chain (Pinocchio's regressor is then a vector: read as its one row)."""
    m = next(m for m in MUTATIONS if m.system == "simple_pendulum" and "gravity sign" in m.kinds)
    said = found(lx.systems.load(m.system).derive(equations=load_mutated(m)))
    assert said is not None
    assert "link's centre on the other side of its joint (1 m from it" in said["statement"], said["statement"]
    assert said["names"] == {"l": "-body/link/com[1]"}


def arm(folder: Path, plant: Callable[[str], str]) -> System:
    """The spatial arm of examples/ with a mistake planted in its text."""
    folder.mkdir(exist_ok=True)
    (folder / "arm.py").write_text(plant((ROOT / "examples" / "spatial_arm.py").read_text()))
    shutil.copy(ROOT / "examples" / "spatial_arm.xml", folder / "arm.xml")
    return System.from_files(folder / "arm.xml", folder / "arm.py")


def _m2_twice(text: str) -> str:
    head, sep, tail = text.partition("def _ry(")  # after assumptions(): the dynamics only
    return head + sep + re.sub(r"p\.m2\b", "(2 * p.m2)", tail)


ABOUT_JOINT = '''

def _about_joint(p):
    """link3's inertia about its joint (its origin), where the one about its centre was meant."""
    import dataclasses
    c = np.array([p.c3x, p.c3y, p.c3z])
    s = p.m3 * (c @ c * np.eye(3) - np.outer(c, c))
    names = {"xx": (0, 0), "yy": (1, 1), "zz": (2, 2), "xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
    return dataclasses.replace(p, **{f"I3{k}": getattr(p, f"I3{k}") + s[ij] for k, ij in names.items()})
'''


def _link3_about_joint(text: str) -> str:
    for fn in ("mass_matrix", "bias"):  # the person's I3 is the one about the joint wherever M enters
        head, sep, tail = text.partition(f"def {fn}(")
        signature, colon, body = tail.partition(":\n")
        doc_end = body.index('"""', body.index('"""') + 3) + 3
        text = head + sep + signature + colon + body[:doc_end] + "\n    p = _about_joint(p)" + body[doc_end:]
    return text + ABOUT_JOINT


def test_the_arms_mass_counted_twice_is_named(folder):
    said = found(arm(folder / "arm_m2", _m2_twice))
    assert said is not None
    assert "link2's mass counted twice (3.4 kg instead of 1.7 kg)" in said["statement"], said["statement"]
    assert said["names"] == {"m2": "body/link2/mass"}


def test_the_arms_inertia_about_the_joint_is_named_about_the_hinge_axis(folder):
    system = arm(folder / "arm_i3", _link3_about_joint)
    said = found(system)
    assert said is not None
    (reading,) = said["readings"]
    assert (reading["bodies"], reading["kind"], reading["quantity"]) == (
        ["link3"],
        "about its joint",
        "moment of inertia about the centre, axis y",
    )
    p = system.params
    assert reading["model"] == pytest.approx(p.I3yy)
    assert reading["yours"] == pytest.approx(p.I3yy + p.m3 * (p.c3x**2 + p.c3z**2))
    assert f"instead of about its centre ({p.I3yy:.3g} kg m^2)" in said["statement"]
    assert said["names"]["I3yy"] == "body/link3/inertia[1][1]"


def test_the_fit_costs_milliseconds(folder):
    import time

    system = arm(folder / "arm_m2", _m2_twice)
    states, sources = random_states(system, n=64, seed=0), {"pinocchio": PinocchioSource(system)}
    asif.as_if(system, states, sources)
    start = time.perf_counter()
    asif.as_if(system, states, sources)
    assert time.perf_counter() - start < 0.5  # tens of ms for 3 joints; generous on a loaded machine


def test_check_json_and_the_api_carry_it_after_the_named_slip(folder, capsys):
    system = bars(folder / "joint", "about the joint")
    args = ["--model", str(folder / "joint" / "bars.xml"), "--equations", str(folder / "joint" / "bars.py")]
    assert main(["check", *args, "--states", "40", "--probes", "2", "--json"]) == 1
    verdict = json.loads(capsys.readouterr().out)["verdict"]
    statement = verdict["statement"]
    slip = statement.index("M[theta, theta]: yours has the term c2**2*m2 twice")
    there = statement.index("; your equations are those of this chain with link2's moment of inertia about its joint")
    assert statement.startswith("mass matrix disagrees at the model's parameters") and slip < there, statement
    assert verdict["as_if"]["readings"][0]["kind"] == "about its joint"
    result = lx.check(system, n_states=40, probes=2)
    assert result.statement == statement
    assert result.data["derivation"]["as_if"]["readings"][0]["bodies"] == ["link2"]
    assert np.isfinite(verdict["as_if"]["residual"])


def test_the_slips_names_carry_the_sign_derive_writes(folder):
    """Issue 44 item 4: "[your names: c2 = c_link2 (body/link2/com[1])" dropped the minus sign `derive`
    writes for a symbol read from a negative number ("c_link2 = -body/link2/com[1]")."""
    result = lx.check(bars(folder / "signs", "m c2^2 twice"), n_states=50)
    assert "c2 = c_link2 (-body/link2/com[1])" in result.statement, result.statement
    assert "m2 = m_link2 (body/link2/mass)" in result.statement, result.statement

"""Every disagreement comes with its proof (verdict/reproduce.py): a reproducer written for a real
disagreement of two readers exits 1 alone in a fresh process and prints both numbers; one written
for a planted "disagreement" the libraries do not show exits 0 (so a false FAIL is caught)."""

from __future__ import annotations

import numpy as np
import pytest
from lagrange_xval import System
from lagrange_xval.core.package import EQUATIONS_DIR, MODELS_DIR
from lagrange_xval.sources import make_sources
from lagrange_xval.verdict import pointwise as compare
from lagrange_xval.verdict import reproduce
from lagrange_xval.verdict.decide import decide

# Two links whose masses come from a <default class> geom mass, which Pinocchio's buildModelFromMJCF
# ignores: MuJoCo and Drake read 2 kg per link, Pinocchio another mass.
CLASS_MASS = """<mujoco model="classmass">
  <default><default class="heavy"><geom mass="2" contype="0" conaffinity="0"/></default></default>
  <worldbody>
    <body name="link1">
      <joint name="j1" type="hinge" axis="0 1 0"/>
      <geom class="heavy" type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05"/>
      <body name="link2" pos="0 0 -0.5">
        <joint name="j2" type="hinge" axis="0 1 0" damping="0.3"/>
        <geom class="heavy" type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
# The same arm with its masses on the geoms themselves: every reader agrees.
AGREED = CLASS_MASS.replace('class="heavy" type', 'mass="2" type')

# A URDF every reader agrees on: a continuous joint (Pinocchio: cos, sin), a fixed link, a root link.
URDF = """<?xml version="1.0"?>
<robot name="twolink">
  <link name="base"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>
  </inertial></link>
  <link name="upper"><inertial><origin xyz="0 0 -0.25"/><mass value="1.5"/>
    <inertia ixx="0.03" iyy="0.03" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="package://nowhere/upper.dae"/></geometry></visual></link>
  <link name="lower"><inertial><origin xyz="0 0 -0.2"/><mass value="0.8"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="tool"><inertial><mass value="0.2"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/>
  </inertial></link>
  <joint name="shoulder" type="continuous"><parent link="base"/><child link="upper"/><axis xyz="0 1 0"/>
    <dynamics damping="0.1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/><origin xyz="0 0 -0.5"/>
    <axis xyz="1 0 0"/><limit lower="-2" upper="2" effort="10" velocity="3"/></joint>
  <joint name="flange" type="fixed"><parent link="lower"/><child link="tool"/><origin xyz="0 0 -0.4"/></joint>
</robot>
"""

# A floating body carrying a hinged arm: the free joint is compared as slides and hinges (model/floating.py).
FREE = """<mujoco model="floating">
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint name="root"/>
      <inertial pos="0 0 0" mass="3" diaginertia="0.013 0.04 0.05"/>
      <body name="arm" pos="0.2 0 0">
        <joint name="swing" type="hinge" axis="0 0 1"/>
        <inertial pos="0.15 0 0" mass="0.5" diaginertia="2e-4 4e-3 4e-3"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _model(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def _by_pair(records):
    return {(r["quantity"], r["pair"]): r for r in records}


def test_a_real_misreading_is_reproduced_in_a_fresh_process(tmp_path):
    system = System.model_only(_model(tmp_path, "classmass.xml", CLASS_MASS))
    decision = decide(system, n_states=5, seed=0, probes=0)
    records = reproduce.write(reproduce.reproducers(decision), tmp_path / "proofs")
    found = _by_pair(records)
    # Pinocchio is set aside by the verdict, but its disagreement is what an upstream issue needs
    r = found["M", "mujoco~pinocchio"]
    assert r["file"] == "classmass_M_mujoco_vs_pinocchio.py" and r["path"].endswith(r["file"])
    text = (tmp_path / "proofs" / r["file"]).read_text()
    assert "lagrange_xval" not in text.replace("lagrange-xval", "")  # the libraries' calls only
    assert "buildModelFromMJCF" in text and "from_xml_path" in text and "mj_name2id" in text
    shown = reproduce.run_reproducer(r["path"])
    assert shown.shows and shown.status == 1, shown.output
    a, b = r["numbers"]["mujoco"], r["numbers"]["pinocchio"]
    assert abs(a - b) > 1e-3
    assert repr(a) in shown.output and repr(b) in shown.output  # both numbers printed, as the harness saw them
    assert "mujoco: the number the harness saw" in shown.output
    assert "pinocchio: the number the harness saw" in shown.output
    # Drake reads the class mass as MuJoCo does: Drake~Pinocchio too, and never MuJoCo~Drake
    assert ("M", "drake~pinocchio") in found and ("M", "drake~mujoco") not in found
    assert reproduce.run_reproducer(found["M", "drake~pinocchio"]["path"]).shows


def _planted(system, quantity, pair, *, shift=1.0, n=3):
    """Reproducers of a fake disagreement: the sources' true values, one side's `quantity` shifted."""
    states = compare.random_states(system, n=n, seed=1)
    sources = make_sources(system)
    values = compare.evaluate(sources, states)
    assert compare.pointwise_result(values, states, seed=1)["passed"], "the libraries must agree here"
    a, b = pair.split("~")
    values[b] = {**values[b], quantity: values[b][quantity] + shift}
    return _by_pair(reproduce.cases(system, values, states))


@pytest.mark.parametrize("quantity", ["M", "bias", "qacc", "tau_inverse", "V", "body_positions"])
def test_a_planted_disagreement_the_libraries_do_not_show_exits_0(tmp_path, quantity):
    system = System.model_only(_model(tmp_path, "agreed.xml", AGREED))
    found = _planted(system, quantity, "mujoco~pinocchio")
    records = reproduce.write([found[quantity, "mujoco~pinocchio"]], tmp_path / "proofs")
    shown = reproduce.run_reproducer(records[0]["path"])
    assert shown.status == 0 and not shown.shows, shown.output  # the suite would catch this false FAIL
    assert "NOT the number the harness saw" in shown.output  # Pinocchio's planted number is not its own
    assert reproduce.unshown([records[0]["path"]])[0].path == records[0]["path"]


def test_a_urdf_with_a_continuous_and_a_fixed_joint_reproduces_every_reader(tmp_path):
    system = System.model_only(_model(tmp_path, "twolink.urdf", URDF))
    found = _planted(system, "M", "drake~mujoco") | _planted(system, "bias", "mujoco~pinocchio")
    paths = reproduce.write([found["M", "drake~mujoco"], found["bias", "mujoco~pinocchio"]], tmp_path / "p")
    for record in paths:
        shown = reproduce.run_reproducer(record["path"])
        assert shown.status == 0, shown.output
        assert f"{record['pair'].split('~')[0]}: the number the harness saw" in shown.output


def test_a_locked_urdf_joint_is_locked_in_every_reader_of_the_script(tmp_path):
    system = System.model_only(_model(tmp_path, "twolink.urdf", URDF), locked=("elbow",))
    assert system.joints == ("shoulder",)
    found = _planted(system, "M", "drake~pinocchio") | _planted(system, "V", "mujoco~pinocchio")
    records = reproduce.write([found["M", "drake~pinocchio"], found["V", "mujoco~pinocchio"]], tmp_path / "p")
    for record in records:
        assert "LOCKED = ['elbow']" in (tmp_path / "p" / record["file"]).read_text()
        shown = reproduce.run_reproducer(record["path"])
        assert shown.status == 0, shown.output
        assert f"{record['pair'].split('~')[0]}: the number the harness saw" in shown.output


def test_a_free_joint_is_compared_as_the_harness_converts_it(tmp_path):
    system = System.model_only(_model(tmp_path, "floating.xml", FREE))
    assert "root_tx" in system.joints
    found = _planted(system, "M", "mujoco~pinocchio") | _planted(
        system, "qacc", "mujoco~pinocchio"
    )  # Drake: not a reader of 3 hinges in a body
    records = reproduce.write([found["M", "mujoco~pinocchio"], found["qacc", "mujoco~pinocchio"]], tmp_path / "p")
    for record in records:
        text = (tmp_path / "p" / record["file"]).read_text()
        assert "def slides_and_hinges" in text
        shown = reproduce.run_reproducer(record["path"])
        assert shown.status == 0, shown.output
        assert "mujoco: the number the harness saw" in shown.output
    assert not list(tmp_path.glob(".reproducer_*"))  # the edited copies beside the model are removed


# Two body trees (Pinocchio reads the first only: the harness gathers them), no model name (Drake needs
# one) and an equality constraint (Drake refuses it; every comparison leaves it out).
TWO_TREES = """<mujoco>
  <worldbody>
    <body name="left" pos="-1 0 0">
      <joint name="a" type="hinge" axis="0 1 0"/>
      <inertial pos="0 0 -0.3" mass="1" diaginertia="0.01 0.01 0.001"/>
    </body>
    <body name="right" pos="1 0 0">
      <joint name="b" type="hinge" axis="1 0 0" damping="0.2"/>
      <inertial pos="0 0 -0.4" mass="2" diaginertia="0.02 0.02 0.002"/>
    </body>
  </worldbody>
  <equality><joint joint1="a" joint2="b"/></equality>
</mujoco>
"""


def test_the_harness_edits_for_pinocchio_and_drake_are_made_on_a_copy(tmp_path):
    system = System.model_only(_model(tmp_path, "trees.xml", TWO_TREES))
    found = _planted(system, "bias", "drake~pinocchio") | _planted(system, "T", "drake~mujoco")
    records = reproduce.write([found["bias", "drake~pinocchio"], found["T", "drake~mujoco"]], tmp_path / "p")
    text = (tmp_path / "p" / records[0]["file"]).read_text()
    assert "def one_tree" in text and "def model_name" in text and "def no_equality" in text
    for record in records:
        shown = reproduce.run_reproducer(record["path"])
        assert shown.status == 0, shown.output
        assert "drake: the number the harness saw" in shown.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p", "trees.xml"]


def test_a_wrong_derivation_is_proven_with_the_persons_own_module(tmp_path):
    source = (EQUATIONS_DIR / "simple_pendulum.py").read_text()
    wrong = source.replace("return stack_matrix([[p.m * p.l**2 + p.I", "return stack_matrix([[2 * p.m * p.l**2 + p.I")
    assert wrong != source
    module = _model(tmp_path, "simple_pendulum.py", wrong)
    system = System.from_files(MODELS_DIR / "simple_pendulum.xml", module)
    decision = decide(system, n_states=4, seed=0, probes=0)
    found = _by_pair(reproduce.write(reproduce.reproducers(decision), tmp_path / "proofs"))
    r = found["M", "hand~mujoco"]
    text = (tmp_path / "proofs" / r["file"]).read_text()
    assert "spec_from_file_location" in text and str(module) in text
    shown = reproduce.run_reproducer(r["path"])
    assert shown.shows, shown.output
    assert "hand: the number the harness saw" in shown.output


def test_a_symbolic_side_is_written_as_the_derivations_numbers(tmp_path):
    system = System.model_only(_model(tmp_path, "agreed.xml", AGREED))
    found = _planted(system, "M", "mujoco~symbolic")
    text = found["M", "mujoco~symbolic"]["script"]
    assert "derived symbolically by the harness" in text
    assert ("M", "pinocchio~symbolic") in found


def test_file_names_hold_only_safe_characters():
    assert reproduce.file_name("arm/v2 x", "M", "mujoco", "pinocchio") == "arm_v2_x_M_mujoco_vs_pinocchio.py"
    assert reproduce.file_name("..", "T", "a", "b") == "T_a_vs_b.py"


def test_a_script_that_fails_shows_nothing(tmp_path):
    broken = _model(tmp_path, "broken.py", "raise RuntimeError('no library here')\n")
    shown = reproduce.run_reproducer(broken)
    assert shown.status == 1 and not shown.shows and "no library here" in shown.output  # a traceback's 1 is not proof
    slow = _model(tmp_path, "slow.py", "import time\ntime.sleep(5)\n")
    assert reproduce.run_reproducer(slow, timeout=0.5).status == -1


def test_records_keep_the_state_and_numbers(tmp_path):
    system = System.model_only(_model(tmp_path, "agreed.xml", AGREED))
    found = _planted(system, "T", "mujoco~pinocchio", shift=0.5)
    r = found["T", "mujoco~pinocchio"]
    assert r["entry"] == [] and set(r["numbers"]) == {"mujoco", "pinocchio"}
    assert abs(r["numbers"]["pinocchio"] - r["numbers"]["mujoco"] - 0.5) < 1e-9
    assert set(r["state"]) == {"q", "v", "tau"} and len(r["state"]["q"]) == 2
    assert r["tolerance"] > 0 and 0 <= r["state_index"] < 3
    kept, texts = reproduce.scripts(reproduce.in_folder([r]))
    assert "script" not in kept[0] and texts == {f"reproducers/{r['file']}": r["script"].encode()}
    assert np.isfinite(r["tolerance"])


def test_a_corpus_test_is_two_calls(tmp_path):
    records = reproduce.write_for(_model(tmp_path, "classmass.xml", CLASS_MASS), tmp_path / "p", n_states=3)
    paths = [r["path"] for r in records if "path" in r and r["quantity"] == "V"]
    assert paths and not reproduce.unshown(paths)
    assert reproduce.write_for(_model(tmp_path, "agreed.xml", AGREED), tmp_path / "q", n_states=3) == []


def test_a_failure_to_write_the_proofs_is_said_and_never_the_verdicts(tmp_path, monkeypatch):
    system = System.model_only(_model(tmp_path, "classmass.xml", CLASS_MASS))
    decision = decide(system, n_states=3, seed=0, probes=0)

    def broken(*args):
        raise KeyError("joint/j1/type")

    monkeypatch.setattr(reproduce, "cases", broken)
    (record,) = reproduce.reproducers(decision)
    assert record["skipped"].startswith("the reproducers could not be written: KeyError")

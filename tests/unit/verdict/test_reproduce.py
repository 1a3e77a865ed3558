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
    # V is compared up to a constant: a planted V differs from state to state
    found = _planted(system, quantity, "mujoco~pinocchio", shift=np.arange(1.0, 4.0) if quantity == "V" else 1.0)
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
    found = _planted(system, "M", "drake~pinocchio") | _planted(system, "V", "mujoco~pinocchio", shift=np.arange(3.0))
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


# --- each class of breakage the corpus showed, on a small model (each script run in a fresh process) ---


def _planted_on(system, quantity, pair, side, *, shift=1.0, n=3):
    """`_planted` with the shift on `side` of `pair`: the other side's number must be the library's own."""
    states = compare.random_states(system, n=n, seed=1)
    values = compare.evaluate(make_sources(system), states)
    assert compare.pointwise_result(values, states, seed=1)["passed"], "the libraries must agree here"
    values[side] = {**values[side], quantity: values[side][quantity] + shift}
    return _by_pair(reproduce.cases(system, values, states))


def _read_only(folder):
    for path in [folder, *folder.rglob("*")]:
        path.chmod(0o555 if path.is_dir() else 0o444)


def _writable(folder):
    for path in [folder, *folder.rglob("*")]:
        path.chmod(0o755 if path.is_dir() else 0o644)


# The class-mass arm of CLASS_MASS in an included file under a subfolder: Pinocchio's parser reads no
# include ("No such node (body)" on the raw file); the harness and the script give it the expanded text.
SCENE = """<mujoco model="scene">
  <option gravity="0 0 -9.81"/>
  <include file="parts/arm.xml"/>
</mujoco>
"""


def test_bodies_in_an_include_are_read_expanded_by_every_library_of_the_script(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "arm.xml").write_text(CLASS_MASS.replace('<mujoco model="classmass">', "<mujoco>"))
    system = System.model_only(_model(tmp_path, "scene.xml", SCENE))
    decision = decide(system, n_states=3, seed=0, probes=0)
    found = _by_pair(reproduce.write(reproduce.reproducers(decision), tmp_path / "proofs"))
    r = found["M", "mujoco~pinocchio"]
    assert "def flattened" in (tmp_path / "proofs" / r["file"]).read_text()
    shown = reproduce.run_reproducer(r["path"])
    assert shown.shows and shown.status == 1, shown.output
    assert "mujoco: the number the harness saw" in shown.output
    assert "pinocchio: the number the harness saw" in shown.output


# A body with a mesh geom from <compiler meshdir>: the script's edited text (a free joint converted) is
# written in a temporary folder with the mesh's path absolute, never beside the model.
MESHED = """<mujoco model="meshed">
  <compiler meshdir="assets"/>
  <asset><mesh name="tetra" file="tetra.obj"/></asset>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint name="root"/>
      <inertial pos="0 0 0" mass="2" diaginertia="0.02 0.03 0.04"/>
      <geom type="mesh" mesh="tetra" contype="0" conaffinity="0" mass="0"/>
      <body name="arm" pos="0.2 0 0">
        <joint name="swing" type="hinge" axis="0 0 1"/>
        <inertial pos="0.15 0 0" mass="0.5" diaginertia="2e-4 4e-3 4e-3"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
TETRA = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def test_a_model_with_a_mesh_in_a_read_only_folder_is_edited_in_a_temporary_folder(tmp_path):
    folder = tmp_path / "published"
    (folder / "assets").mkdir(parents=True)
    (folder / "assets" / "tetra.obj").write_text(TETRA)
    system = System.model_only(_model(folder, "meshed.xml", MESHED))
    found = _planted(system, "M", "mujoco~pinocchio") | _planted(system, "qacc", "mujoco~pinocchio")
    _read_only(folder)
    try:
        records = reproduce.write([found["M", "mujoco~pinocchio"], found["qacc", "mujoco~pinocchio"]], tmp_path / "p")
        for record in records:
            text = (tmp_path / "p" / record["file"]).read_text()
            assert "def slides_and_hinges" in text and "def flattened" in text
            shown = reproduce.run_reproducer(record["path"])
            assert shown.status == 0, shown.output  # it runs: the planted number is not Pinocchio's
            assert "mujoco: the number the harness saw" in shown.output
        assert sorted(p.name for p in folder.rglob("*")) == ["assets", "meshed.xml", "tetra.obj"]
    finally:
        _writable(folder)


# A valid URDF with a massless "virtual" link between two joints (MuJoCo refuses it as written; Drake's
# parser aborts on it): every reader, in the harness and in the script, gets MuJoCo's boundmass/boundinertia.
MASSLESS = """<?xml version="1.0"?>
<robot name="virtual">
  <link name="base"/>
  <link name="virtual"/>
  <link name="arm"><inertial><origin xyz="0 0 -0.3"/><mass value="1.2"/>
    <inertia ixx="0.04" iyy="0.04" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="yaw" type="revolute"><parent link="base"/><child link="virtual"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="pitch" type="revolute"><parent link="virtual"/><child link="arm"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>
"""


def test_a_massless_urdf_link_gets_the_floors_in_every_library_of_the_script(tmp_path):
    system = System.model_only(_model(tmp_path, "virtual.urdf", MASSLESS))
    assert system.floors and "virtual" in system.floors[0]
    found = _planted_on(system, "M", "mujoco~pinocchio", "mujoco") | _planted_on(system, "M", "drake~mujoco", "mujoco")
    records = reproduce.write([found["M", "mujoco~pinocchio"], found["M", "drake~mujoco"]], tmp_path / "p")
    for record in records:
        assert "def bounded" in (tmp_path / "p" / record["file"]).read_text()
        shown = reproduce.run_reproducer(record["path"])
        assert shown.status == 0, shown.output  # MuJoCo compiles it and Drake's parser lives
        other = "pinocchio" if "pinocchio" in record["pair"] else "drake"
        assert f"{other}: the number the harness saw" in shown.output
        assert "mujoco: NOT the number the harness saw" in shown.output  # the planted one


# A hinge on an unaligned axis with armature: Pinocchio 4.1's computeKineticEnergy leaves its armature
# out (JointModelRevoluteUnaligned); the harness and the script take Pinocchio's T as 1/2 v^T M v on CRBA.
UNALIGNED = """<mujoco model="unaligned">
  <worldbody>
    <body name="link1">
      <joint name="j1" type="hinge" axis="0 0.6 0.8" armature="0.3"/>
      <inertial pos="0 0 -0.3" mass="1" diaginertia="0.01 0.01 0.002"/>
      <body name="link2" pos="0 0 -0.5">
        <joint name="j2" type="hinge" axis="1 0 0" armature="0.1"/>
        <inertial pos="0 0 -0.2" mass="0.5" diaginertia="0.004 0.004 0.001"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_pinocchios_t_on_an_unaligned_hinge_with_armature_is_its_crba_energy(tmp_path):
    system = System.model_only(_model(tmp_path, "unaligned.xml", UNALIGNED))
    found = _planted_on(system, "T", "mujoco~pinocchio", "mujoco", shift=0.5)
    (record,) = reproduce.write([found["T", "mujoco~pinocchio"]], tmp_path / "p")
    assert "JointModelRevoluteUnaligned" in (tmp_path / "p" / record["file"]).read_text()
    shown = reproduce.run_reproducer(record["path"])
    assert shown.status == 0, shown.output
    assert "pinocchio: the number the harness saw" in shown.output


# CLASS_MASS on a pedestal welded to the world: Pinocchio drops the pedestal's potential energy (a constant)
# and misreads the class masses (a real difference); V is compared up to the constant, in the script too.
PEDESTAL = CLASS_MASS.replace(
    '<body name="link1">',
    '<body name="pedestal" pos="0 0 1"><inertial pos="0 0 0.2" mass="5" diaginertia="0.1 0.1 0.1"/><body name="link1">',
).replace("</worldbody>", "</body></worldbody>")


def test_v_with_a_welded_body_is_reproduced_up_to_the_harness_constant(tmp_path):
    system = System.model_only(_model(tmp_path, "pedestal.xml", PEDESTAL))
    decision = decide(system, n_states=4, seed=0, probes=0)
    scales = compare.physical_scales(system, decision.states)
    (v,) = [
        f
        for f in reproduce.disagreements(decision.values, decision.states, scales=scales)
        if (f.quantity, f.pair) == ("V", "mujoco~pinocchio")
    ]
    assert abs(v.constant) > 1.0  # the pedestal's m g h, at least
    found = _by_pair(reproduce.write(reproduce.reproducers(decision), tmp_path / "proofs"))
    r = found["V", "mujoco~pinocchio"]
    shown = reproduce.run_reproducer(r["path"])
    assert shown.shows, shown.output
    assert "compared up to a constant" in shown.output
    printed = float(shown.output.split("largest difference ")[1].split(",")[0])
    expected = abs(r["numbers"]["mujoco"] - r["numbers"]["pinocchio"] - v.constant)
    assert printed == pytest.approx(expected, rel=1e-5) and printed < abs(v.constant)

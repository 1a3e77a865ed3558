"""The model audit (issues 29, 33): each reader of a file judged against what the file means.

One planted case per catalogue entry (validate/audit/importers.py), each in the reader that shows it
on the installed versions (MuJoCo 4.0.0, Pinocchio 4.1.0, Drake 1.51.1); the few faults no installed
reader shows any more (MuJoCo's URDF importer once dropped rotations) are planted in MuJoCo's input
only. Correct but tricky models must stay quiet. Faults that need a real robot are planted in copies of
example-robot-data's UR5.
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import numpy as np
import pytest
from lagrange_xval.audit import audit, importers
from lagrange_xval.cli import main
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.model.urdf import robots_folder
from lagrange_xval.systems import System, load

ROOT = Path(__file__).resolve().parents[3]
ROBOTS = robots_folder() or ROOT / "example-robot-data not installed"
pytestmark = [
    pytest.mark.skipif(
        importlib.util.find_spec("pydrake") is None and os.environ.get("CI") != "true", reason="pydrake not installed"
    ),
]
UR5 = ROBOTS / "ur_description/urdf/ur5_robot.urdf"
INERTIAL = '<inertial pos="0 0 0.5" mass="1" diaginertia="0.01 0.02 0.03"/>'
BODY = '<body name="b" pos="0 0 1"><joint name="j" axis="0 1 0"{joint}/>{inside}</body>'


def mjcf(inside: str = INERTIAL, head: str = "", joint: str = "", world: str | None = None) -> str:
    body = world if world is not None else BODY.format(joint=joint, inside=inside)
    return f'<mujoco model="m">{head}<worldbody>{body}</worldbody></mujoco>'


def urdf(tool_rpy: str = "0.5 0 0.3", tool_inertial_rpy: str = "0 0 0", tool_xyz: str = "0.01 0.02 0.05",
         l2_inertial: bool = True, extra: str = "", head: str = "", j1: str = "") -> str:  # fmt: skip
    l2 = (
        '<inertial><origin xyz="0 0 0.15"/><mass value="1"/>'
        '<inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.005"/></inertial>'
        if l2_inertial
        else ""
    )
    return f"""<robot name="arm">{head}
  <link name="base"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="1"/>{j1}</joint>
  <link name="l1"><inertial><origin xyz="0 0 0.2" rpy="0.3 0.2 0.1"/><mass value="1.5"/>
    <inertia ixx="0.05" ixy="0" ixz="0" iyy="0.04" iyz="0" izz="0.03"/></inertial></link>
  <joint name="j2" type="continuous"><parent link="l1"/><child link="l2"/><origin xyz="0.05 0 0.4"/><axis xyz="1 0 0"/>
  </joint>
  <link name="l2">{l2}</link>
  <joint name="tool_joint" type="fixed"><parent link="l2"/><child link="tool"/>
    <origin xyz="0 0.1 0.3" rpy="{tool_rpy}"/></joint>
  <link name="tool"><inertial><origin xyz="{tool_xyz}" rpy="{tool_inertial_rpy}"/><mass value="0.7"/>
    <inertia ixx="0.003" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.0015"/></inertial></link>
  {extra}
</robot>"""


PART = (
    '<mujocoinclude><body name="c" pos="0 0 1"><joint name="k" axis="1 0 0"/>'
    '<inertial pos="0 0 0.5" mass="1" diaginertia="0.01 0.02 0.025"/></body></mujocoinclude>'
)


def _audit(tmp_path: Path, text: str, fmt: str, **inputs: str) -> dict:
    path = tmp_path / ("m.urdf" if fmt == "urdf" else "m.xml")
    path.write_text(text)
    (tmp_path / "part.xml").write_text(PART)  # what a planted <include> reads
    own = {}
    for reader, copy in inputs.items():
        other = tmp_path / f"{reader}_{path.name}"
        other.write_text(copy)
        own[reader] = (other, copy)
    return audit.audit_file(path, text, fmt, inputs=own)


def _named(result: dict, entry: str) -> dict[str, set[str]]:
    """reader -> the fields the catalogue entry `entry` explains for it."""
    out: dict[str, set[str]] = {}
    for m in result["misreads"]:
        if m["entry"] == entry:
            out.setdefault(m["reader"], set()).add(m["field"])
    return out


MIMIC = '<mimic joint="j1" multiplier="0.5" offset="0.1"/>'
FINGER = """<joint name="j3" type="prismatic"><parent link="tool"/><child link="finger"/><origin xyz="0 0 0.1"/>
  <axis xyz="0 0 1"/><limit lower="0" upper="0.04" effort="1" velocity="1"/>{mimic}</joint>
  <link name="finger"><inertial><mass value="{mass}"/><inertia ixx="0.0001" ixy="0" ixz="0" iyy="0.0001" iyz="0"
  izz="0.0001"/></inertial></link>"""
TRANSMISSION = """<transmission name="t1"><type>transmission_interface/SimpleTransmission</type>
  <joint name="j1"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
  <actuator name="m1"><mechanicalReduction>50</mechanicalReduction></actuator></transmission>"""
TET = '<mesh name="tet" vertex="0 0 0 0.2 0 0 0 0.2 0 0 0 0.2"/>'
TIP = """<joint name="tip_joint" type="fixed"><parent link="l2"/><child link="tip"/><origin xyz="0 0 0.5"/></joint>
  <link name="tip"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>"""
NESTED = (
    '<default><default class="a"><joint damping="3"/><default class="b"><default class="c"><joint axis="0 1 0"/>'
    "</default></default></default></default>"
)
ROTATED = dict(l2_inertial=False, tool_xyz="0 0 0")  # the group is the tool alone: a lost rotation keeps its moments
# entry -> (model, format, {reader: a field the entry must explain}, None, or for an entry no installed reader
# shows any more, a copy given to MuJoCo only, or {reader: its copy})
PLANTED = {
    "<option gravity>": (mjcf(head='<option gravity="0 -9.81 0"/>'), "mjcf", {"pinocchio": "gravity"}, None),
    "geom mass from a default class": (
        mjcf('<geom fromto="0 0 0 0 0 1" size="0.05"/>', '<default><geom type="capsule" mass="1"/></default>'),
        "mjcf", {"pinocchio": "mass"}, None,
    ),
    "inertiafromgeom": (
        mjcf(INERTIAL + '<body name="tip" pos="0 0 1"><geom type="sphere" size="0.1"/></body>',
             '<compiler inertiafromgeom="false"/>'),
        "mjcf", {}, None,
    ),
    "inertiagrouprange": (
        mjcf('<geom type="sphere" size="0.1" pos="0 0 0.3" mass="0.5"/><geom type="box" size="0.1 0.1 0.1" group="1" '
             'mass="8"/>', '<compiler inertiagrouprange="0 0"/>'),
        "mjcf", {"pinocchio": "mass", "drake": "mass"}, None,
    ),
    "boundmass/boundinertia": (
        mjcf('<inertial pos="0 0 0.5" mass="0.1" diaginertia="0.001 0.001 0.001"/>',
             '<compiler boundmass="0.5" boundinertia="0.01"/>'),
        "mjcf", {"drake": "mass"}, None,
    ),
    "balanceinertia": (
        mjcf('<inertial pos="0 0 0.5" mass="1" diaginertia="0.01 0.01 0.1"/>', '<compiler balanceinertia="true"/>'),
        "mjcf", {"pinocchio": "inertia"}, None,
    ),
    "eulerseq": (
        mjcf('<inertial pos="0 0 0.5" euler="0.3 0.5 0.7" mass="1" diaginertia="0.01 0.02 0.03"/>',
             '<compiler angle="radian" eulerseq="XYZ"/>'),
        "mjcf", {"pinocchio": "inertia"}, None,
    ),
    "fusestatic": (urdf(**ROTATED), "urdf", {"mujoco": "inertia"}, urdf(tool_rpy="0 0 0", **ROTATED)),
    "an axisangle's axis": (
        mjcf(INERTIAL + f'<body name="c" pos="0 0.1 0.5" axisangle="1 1 0 30"><joint name="k"/>{INERTIAL}</body>'),
        "mjcf", {"pinocchio": "axis"}, None,
    ),
    "a fixed joint's rpy": (urdf(), "urdf", {"mujoco": "com"}, urdf(tool_rpy="0 0 0")),
    "an inertial's rpy": (
        urdf(tool_rpy="0 0 0", tool_inertial_rpy="0.4 0 0.2", **ROTATED), "urdf", {"mujoco": "inertia"},
        urdf(tool_rpy="0 0 0", **ROTATED),
    ),
    "mesh inertia and the 1 kg default": (
        mjcf('<geom type="mesh" mesh="tet"/>', f"<asset>{TET}</asset>"),
        "mjcf", {"pinocchio": "mass", "drake": "mass"}, None,
    ),
    "shell inertia": (
        mjcf('<geom type="sphere" size="0.1" pos="0 0 0.3" shellinertia="true"/>'), "mjcf", {"drake": "mass"}, None,
    ),
    "a joint without <limit>": (urdf().replace('<limit lower="-2" upper="2" effort="10" velocity="1"/>', ""), "urdf",
                                {}, None),
    "a continuous joint's <limit>": (
        urdf().replace('<axis xyz="1 0 0"/>', '<axis xyz="1 0 0"/><limit lower="-1" upper="1"/>'),
        "urdf", {"drake": "limits"}, None,
    ),
    "an invalid inertia replaced": (urdf(extra=FINGER.format(mimic="", mass="0")), "urdf", {"drake": "mass"}, None),
    "several joints in one body": (
        mjcf(INERTIAL + '<body name="c" pos="0.2 0 -0.3"><joint name="x" axis="1 0 0" pos="0 0 0.1"/><joint name="y" '
                        f'axis="0 1 0" pos="0 0 0.1"/>{INERTIAL}</body>'),
        "mjcf", {"pinocchio": "joint", "drake": "anchor"}, None,
    ),
    "a <compiler> after the bodies": (
        '<mujoco model="m"><worldbody><body name="b" pos="0 0 1" euler="1.2 0 0"><joint name="j" axis="0 1 0"/>'
        f'{INERTIAL}</body></worldbody><compiler angle="radian"/></mujoco>',
        "mjcf", {"pinocchio": "axis"}, None,
    ),
    "<include>": (
        mjcf(INERTIAL + '<include file="part.xml"/>'), "mjcf", {"pinocchio": "joint"}, None,
    ),
    "several root bodies": (
        mjcf(world=BODY.format(joint="", inside=INERTIAL) + f'<body name="c"><joint name="k"/>{INERTIAL}</body>'),
        "mjcf", {"pinocchio": "joint"}, None,
    ),
    "a fixed root's pose": (
        mjcf(world=f'<body name="base" pos="0.3 0.2 1" euler="0 0 30">{INERTIAL}<body name="b" pos="0 0 0.2">'
                   f'<joint name="j" axis="0 1 0"/>{INERTIAL}</body></body>'),
        "mjcf", {"pinocchio": "anchor"}, None,
    ),
    "a free root's coordinates": (
        mjcf(world=f'<body name="torso" pos="0 1 1" euler="0 0 30"><freejoint name="root"/>{INERTIAL}'
                   f'<body name="arm" pos="0.2 0 0"><joint name="j" axis="0 1 0"/>{INERTIAL}</body></body>'),
        "mjcf", {"pinocchio": "anchor"}, None,
    ),
    "stiffness and springref": (
        mjcf(joint=' stiffness="3" springref="20"'), "mjcf", {"pinocchio": "stiffness", "drake": "springref"}, None,
    ),
    "frictionloss": (mjcf(joint=' frictionloss="0.1"'), "mjcf", {"drake": "frictionloss"}, None),
    "springdamper": (
        mjcf(joint=' springdamper="0.5 1"'), "mjcf", {"pinocchio": "damping", "drake": "stiffness"}, None,
    ),
    "armature without a motor": (mjcf(joint=' armature="0.05"'), "mjcf", {"drake": "armature"}, None),
    "gravcomp": (
        mjcf(world=f'<body name="b" pos="0 0 1" gravcomp="0.5"><joint name="j" axis="0 1 0"/>{INERTIAL}</body>'),
        "mjcf", {"pinocchio": "gravcomp", "drake": "gravcomp"}, None,
    ),
    "mimic": (urdf(extra=FINGER.format(mimic=MIMIC, mass="0.1")), "urdf", {"pinocchio": "mimic"}, None),
    "an invalid mimic": (urdf(extra=FINGER.format(mimic='<mimic joint="none"/>', mass="0.1")), "urdf", {}, None),
    "a joint equality": (
        mjcf(INERTIAL + f'<body name="c" pos="0 0 1"><joint name="k" axis="1 0 0"/>{INERTIAL}</body>',
             '<equality><joint joint1="k" joint2="j" polycoef="0 2 0 0 0"/></equality>'),
        "mjcf", {"pinocchio": "mimic", "drake": "mimic"}, None,
    ),
    "a slide joint's range in degrees": (
        mjcf(INERTIAL + f'<body name="c" pos="0 0 1"><joint name="k" type="slide" range="-0.1 0.2"/>{INERTIAL}</body>'),
        "mjcf", {"pinocchio": "limits"}, None,
    ),
    'limited="false"': (mjcf(joint=' range="-30 30" limited="false"'), "mjcf", {"pinocchio": "limits"}, None),
    "a <limit> without lower and upper": (
        urdf().replace('<limit lower="-2" upper="2" effort="10" velocity="1"/>', '<limit effort="10" velocity="1"/>'),
        "urdf", {"mujoco": "limits", "drake": "limits"}, None,
    ),
    "<include> of the robot": ('<mujoco model="s"><worldbody><include file="part.xml"/></worldbody></mujoco>', "mjcf",
                               {}, None),
    "<frame> around the root": (
        mjcf(world=f'<frame pos="0 0 1"><body name="b"><joint name="j" axis="0 1 0"/>{INERTIAL}</body></frame>'),
        "mjcf", {}, None,
    ),
    "collision-free geoms": (
        mjcf('<geom type="sphere" size="0.1" pos="0 0 0.3" contype="0" conaffinity="0"/>'
             '<geom type="box" size="0.1 0.05 0.05" pos="0 0 0.5"/>'),
        "mjcf", {"pinocchio": "mass"}, None,
    ),
    "<frame>": (
        mjcf(INERTIAL + f'<frame pos="0 0 1" euler="0 0 30"><body name="c"><joint name="k" axis="1 0 0"/>{INERTIAL}'
                        "</body></frame>"),
        "mjcf", {"pinocchio": "joint", "drake": "joint"}, None,
    ),
    "joint ref": (mjcf(joint=' ref="20"'), "mjcf", {"drake": "ref"}, {"drake": mjcf()}),
    "nested default classes": (
        mjcf(joint=' class="c"', head=NESTED),
        "mjcf", {"drake": "damping"}, None,
    ),
    "settotalmass": (
        mjcf('<geom type="capsule" fromto="0 0 0 0 0 1" size="0.05"/>', '<compiler settotalmass="5"/>'),
        "mjcf", {"pinocchio": "mass", "drake": "mass"}, None,
    ),
    "geometry weighed for a link without <inertial>": (
        urdf(extra=TIP),
        "urdf", {"mujoco": "mass"}, None,
    ),
    "transmissions": (urdf(extra=TRANSMISSION), "urdf", {"mujoco": "target"}, None),
}  # fmt: skip


TWO_FAULTS = {  # one file, two readers at fault for two causes: each named with its own
    "gravity and bounds": (
        mjcf(head='<option gravity="0 0 -3"/><compiler boundmass="2"/>'),
        {("pinocchio", "<option gravity>"), ("drake", "boundmass/boundinertia")},
    ),
    "two roots and nested classes": (
        mjcf(joint=' class="c"', head=NESTED).replace(
            "</worldbody>", f'<body name="other" pos="2 0 1"><joint name="o"/>{INERTIAL}</body></worldbody>'
        ),
        {("pinocchio", "several root bodies"), ("drake", "nested default classes")},
    ),
}


@pytest.mark.parametrize("case", sorted(TWO_FAULTS))
def test_two_faults_in_one_file_are_each_named_with_their_cause(tmp_path, case):
    text, want = TWO_FAULTS[case]
    result = _audit(tmp_path, text, "mjcf")
    got = {(m["reader"], m["entry"]) for m in result["misreads"] if not m["key"].endswith(audit.INFORMATIONAL)}
    assert got == want, result["findings"]


def test_every_catalogue_entry_has_a_planted_case():
    assert set(PLANTED) == {b.key for b in importers.CATALOGUE}


@pytest.mark.parametrize("entry", sorted(PLANTED))
def test_each_planted_fault_names_its_readers_and_cause(tmp_path, entry):
    """The readers that show the fault are named, the catalogue entry explains it, and no other reader
    is named for that field."""
    text, fmt, fields, copy = PLANTED[entry]
    copies = copy if isinstance(copy, dict) else {"mujoco": copy} if copy else {}
    behaviour = next(b for b in importers.CATALOGUE if b.key == entry)
    assert bool(copies) == behaviour.fixed, "an entry the installed readers show is planted in the file itself"
    result = _audit(tmp_path, text, fmt, **copies)
    named = _named(result, entry)
    for reader, field in fields.items():
        assert field in named.get(reader, set()), (entry, reader, result["findings"], result["skipped"])
    wrong = {(m["reader"], m["field"]) for m in result["misreads"] if m["field"] in fields.values()}
    assert {r for r, _ in wrong} <= set(fields), (entry, result["findings"])
    refusing = {"inertiafromgeom": {"pinocchio", "drake"}, "shell inertia": {"pinocchio"}}
    refusing["a joint without <limit>"] = {"pinocchio"}
    refusing |= {"an invalid mimic": {"drake"}, "<include> of the robot": {"pinocchio"}}
    refusing["<frame> around the root"] = {"pinocchio"}
    if entry in refusing:  # the readers that refuse the file: each says why, with the entry
        assert set(result["skipped"]) == refusing[entry]
        assert all(f"[{entry}:" in why for why in result["skipped"].values()), result["skipped"]


@pytest.mark.parametrize(
    ("text", "fmt"),
    [
        (mjcf(joint=' pos="0.1 0 0.2"'), "mjcf"),  # a joint off its body origin
        (mjcf(joint=' pos="0.1 0 0.2" ref="25"'), "mjcf"),  # a joint ref (MuJoCo builds the frames at q = ref)
        (mjcf('<inertial pos="0.1 0 0.5" quat="0.9 0.3 0.2 0.1" mass="1" diaginertia="0.01 0.02 0.03"/>'), "mjcf"),
        (urdf(), "urdf"),  # rotated principal axes by rpy, a welded tool, a continuous joint
        (urdf(head='<mujoco><compiler fusestatic="false"/></mujoco>'), "urdf"),  # the welded tool kept separate
    ],
    ids=["joint-off-origin", "joint-ref", "rotated-principal-axes", "rpy-welded-continuous", "fusestatic-false"],
)
def test_correct_but_tricky_models_stay_quiet(tmp_path, text, fmt):
    result = _audit(tmp_path, text, fmt)
    dynamic = [m for m in result["misreads"] if not m["key"].endswith(audit.INFORMATIONAL)]
    assert not dynamic and not result["skipped"] and result["passed"], result["findings"]
    assert max(result["mass_matrix"]["max_abs"].values()) < 1e-12


def test_the_chain_dynamics_equal_mujocos_own(tmp_path):
    """audit/chain.py on MuJoCo's reading of a tree with rotations, a slide and armature gives MuJoCo's
    own M and bias (qfrc_bias) to 1e-12: the two-file audit's numbers are right."""
    import mujoco
    from lagrange_xval.audit.chain import chain, dynamics
    from lagrange_xval.sources.readers import read

    text = mjcf(
        world='<body name="a" pos="0 0 1" euler="10 20 30"><joint name="j" axis="0 1 0" pos="0.1 0 0" armature="0.1"/>'
        '<inertial pos="0 0.1 0.5" quat="0.9 0.3 0.2 0.1" mass="1.3" diaginertia="0.01 0.02 0.03"/>'
        '<body name="c" pos="0.2 0 1" euler="0 40 0"><joint name="k" type="slide" axis="1 1 0"/>'
        '<inertial pos="0.1 0 0.2" mass="0.7" diaginertia="0.01 0.01 0.02"/>'
        '<body name="d" pos="0 0 0.3"><joint name="l" axis="1 0 0" ref="15"/>'
        '<inertial pos="0 0 0.1" mass="0.4" diaginertia="0.003 0.002 0.001"/></body></body></body>'
    )
    path = tmp_path / "tree.xml"
    path.write_text(text)
    c = chain(read("mujoco", path, text, "mjcf"))
    m = mujoco.MjModel.from_xml_string(text)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    q, v = rng.uniform(-2, 2, (20, 3)), rng.uniform(-2, 2, (20, 3))
    out = dynamics(c, q, v)
    order = [m.joint(j).id for j in c.joints]
    for k in range(20):
        d.qpos[:] = m.qpos0
        d.qpos[order] += q[k]
        d.qvel[order] = v[k]
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        assert np.abs(M[np.ix_(order, order)] - out["M"][k]).max() < 1e-12
        assert np.abs(d.qfrc_bias[order] - out["bias"][k]).max() < 1e-12


def _saved(tmp_path: Path, text: str, name: str) -> Path:
    """The MJCF MuJoCo writes (mj_saveLastXML) from a URDF."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(text)
    path = tmp_path / name
    mujoco.mj_saveLastXML(str(path), model)
    return path


def test_a_urdf_and_the_mjcf_mujoco_writes_from_it_agree(tmp_path):
    from lagrange_xval.audit import twofiles

    a = tmp_path / "arm.urdf"
    a.write_text(urdf())
    result = twofiles.compare(a, _saved(tmp_path, urdf(), "arm.xml"))
    assert result["passed"] and result["matched_joints"] == ["j1", "j2"], result["findings"]
    assert result["unmatched_joints"] == {"A": [], "B": []} and "tool" in result["unmatched_bodies"]["A"]
    assert result["n_states"] == 1000 and result["max_gap"]["G"] < 1e-4


def test_a_dropped_fixed_joint_rpy_names_the_link_behind_the_phantom_torque(tmp_path):
    """B is the MJCF of a copy whose tool joint lost its rpy: the gravity torque gap is named with the link."""
    from lagrange_xval.audit import twofiles

    a = tmp_path / "arm.urdf"
    a.write_text(urdf())
    result = twofiles.compare(a, _saved(tmp_path, urdf(tool_rpy="0 0 0"), "arm_flat.xml"))
    assert not result["passed"]
    first = result["findings"][0]
    assert first.startswith("j1 gravity torque differs by up to") or first.startswith("j2 gravity torque"), first
    assert "link tool's inertial frame rotated by the fixed joint tool_joint's rpy in A, not in B" in first


@pytest.mark.skipif(not ROBOTS.is_dir() and os.environ.get("CI") != "true", reason="example-robot-data missing")
def test_the_ur5_and_the_mjcf_mujoco_writes_from_it_agree(tmp_path):
    """A real robot: MuJoCo's 6 significant digits stay within the agreement tolerance."""
    from lagrange_xval.audit import twofiles
    from lagrange_xval.model.urdf import without_geometry

    a = tmp_path / "ur5.urdf"
    a.write_text(without_geometry(UR5.read_text()))
    result = twofiles.compare(a, _saved(tmp_path, a.read_text(), "ur5.xml"))
    assert result["passed"] and len(result["matched_joints"]) == 6, result["findings"]


def test_two_files_differing_in_a_joints_damping_name_the_joint(tmp_path):
    from lagrange_xval.audit import twofiles

    a = tmp_path / "arm.urdf"
    a.write_text(urdf(j1='<dynamics damping="0.5"/>'))
    result = twofiles.compare(a, _saved(tmp_path, urdf(j1='<dynamics damping="0.2"/>'), "arm.xml"))
    assert not result["differences"] and result["joint_fields"] == ["joint j1 damping: 0.5 in A, 0.2 in B"]
    assert not result["passed"]


def test_the_two_file_command(tmp_path, capsys):
    a = tmp_path / "arm.urdf"
    a.write_text(urdf())
    b = _saved(tmp_path, urdf(tool_rpy="0 0 0"), "arm_flat.xml")
    assert main(["audit", str(a), str(b)]) == 1
    out = capsys.readouterr().out
    assert out.startswith("audit: A arm.urdf (URDF) against B arm_flat.xml (MJCF)")
    assert "DIFFERS j" in out and "tool_joint" in out
    assert main(["audit", str(a), str(tmp_path / "missing.xml")]) == 2
    assert "lagrange-xval: error: no model file" in capsys.readouterr().err
    notes = tmp_path / "notes.xml"
    notes.write_text("<notes/>")
    assert main(["audit", str(a), str(notes)]) == 2
    err = capsys.readouterr().err
    assert (
        err.startswith("lagrange-xval: error: notes.xml: not a model file (root element <notes>")
        and len(err.splitlines()) == 1
    )


def test_a_mimic_and_dry_friction_are_audited_not_refused(tmp_path, capsys):
    """The URDF is read; Pinocchio is named for the coupling (Drake makes a coupler constraint of it, whose
    joints pydrake does not expose: its count agrees), Drake for the friction; both are constraints (issue 32:
    compared without them), so they are information and the audit passes."""
    path = tmp_path / "gripper.urdf"
    path.write_text(urdf(extra=FINGER.format(mimic=MIMIC, mass="0.1"), j1='<dynamics damping="0.2" friction="0.1"/>'))
    assert main(["audit", str(path)]) == 0
    out = capsys.readouterr().out
    assert "Pinocchio misreads j3's mimic" in out and "Drake misreads j3's mimic" not in out
    assert "Pinocchio misreads world's couplings" in out and "Drake misreads world's couplings" not in out
    assert "Drake misreads j1's frictionloss" in out and "Drake warned" in out
    assert "(information: no smooth dynamics use it)" in out


def test_an_unknown_default_class_names_the_element_not_the_cpp_error(tmp_path):
    text = mjcf('<geom class="main" fromto="0 0 0 0 0 1" size="0.05"/>', '<default><geom type="capsule"/></default>')
    result = _audit(tmp_path, text, "mjcf")
    why = result["skipped"]["pinocchio"]
    assert why.startswith('m.xml: Pinocchio cannot read it; likely <geom class="main">'), why


def test_a_file_mujoco_refuses_is_one_line_naming_the_element(tmp_path):
    text = mjcf(head='<default><default class="main"/></default>')
    with pytest.raises(HarnessError, match=r"MuJoCo cannot read it at <default> \(line 1\)"):
        _audit(tmp_path, text, "mjcf")


@pytest.mark.skipif(not ROBOTS.is_dir() and os.environ.get("CI") != "true", reason="example-robot-data missing")
@pytest.mark.parametrize(
    ("path", "locked"),
    [
        ("ur_description/urdf/ur5_robot.urdf", ()),
        ("panda_description/urdf/panda.urdf", ("panda_finger_joint1", "panda_finger_joint2")),
    ],
    ids=["ur5", "panda"],
)
def test_the_real_robots_are_read_as_their_urdf_means(path, locked):
    result = audit.audit(System(name="robot", mjcf=ROBOTS / path, equations=None, locked=locked))
    assert result["readers"] == ["mujoco", "pinocchio", "drake"] and result["passed"], result["findings"]
    assert max(result["mass_matrix"]["max_abs"].values()) < 1e-12


@pytest.mark.skipif(not ROBOTS.is_dir() and os.environ.get("CI") != "true", reason="example-robot-data missing")
def test_damping_dropped_in_one_readers_input_names_it(tmp_path):
    text = UR5.read_text()
    i = text.index('<joint name="elbow_joint"')
    damped = text[:i] + text[i:].replace('<dynamics damping="0.0"', '<dynamics damping="0.7"', 1)
    result = _audit(tmp_path, damped, "urdf", pinocchio=text)
    dynamic = [(m["reader"], m["key"]) for m in result["misreads"] if not m["key"].endswith(audit.INFORMATIONAL)]
    assert dynamic == [("pinocchio", "joint/elbow_joint/damping")], result["findings"]
    assert "no known importer behaviour explains it" in result["findings"][0]


def test_a_repository_system_is_audited_and_the_command_prints_one_screen(capsys):
    """The notes' double pendulum falls along -y: Pinocchio's MJCF parser keeps its own gravity (the
    harness copies MuJoCo's into its source), which is the one finding; nothing else differs."""
    result = audit.audit(load("double_pendulum_bars"))
    assert result["format"] == "mjcf" and len(result["readers"]) == 3
    assert [(m["reader"], m["key"], m["entry"]) for m in result["misreads"]] == [
        ("pinocchio", "model/world/gravity", "<option gravity>")
    ]
    assert audit.set_aside(load("double_pendulum_bars")) == {}  # the harness aligns gravity: nothing set aside
    assert main(["audit", "double_pendulum_bars"]) == 1
    out = capsys.readouterr().out
    assert out.startswith("audit: double_pendulum_bars.xml (MJCF), read by MuJoCo, Pinocchio, Drake")
    assert "Pinocchio misreads world's gravity" in out and len(out.splitlines()) <= 25


ACROBOT = """<mujoco model="acrobot">
  <default><joint damping=".05"/><geom type="capsule" mass="1"/></default>
  <option timestep="0.01" integrator="RK4"><flag constraint="disable" energy="enable"/></option>
  <worldbody>
    <body name="upper_arm" pos="0 0 2"><joint name="shoulder" type="hinge" axis="0 1 0"/>
      <geom name="upper_arm" fromto="0 0 0 0 0 1" size="0.05"/>
      <body name="lower_arm" pos="0 0 1"><joint name="elbow" type="hinge" axis="0 1 0"/>
        <geom name="lower_arm" fromto="0 0 0 0 0 1" size="0.049"/></body>
    </body>
  </worldbody>
  <actuator><motor name="elbow" joint="elbow" gear="2"/></actuator>
</mujoco>"""


def test_a_misreading_reader_is_set_aside_and_named_in_the_verdict(tmp_path):
    """The acrobot of an RL suite (geom mass from a default class): Pinocchio reads 8.38 kg; MuJoCo and
    Drake agree with the MJCF, so Pinocchio is excluded, named with field and cause, and the model passes
    on the sources that agree; the verdict of a model alone speaks of no derivation."""
    from lagrange_xval.verdict.decide import decide

    path = tmp_path / "acrobot.xml"
    path.write_text(ACROBOT)
    decision = decide(System.model_only(path), n_states=4, seed=0, probes=1)
    assert set(decision.excluded or {}) == {"pinocchio"}
    statement = decision.statement
    assert statement.startswith(
        "Pinocchio misreads upper_arm's mass (8.38 kg, 1 kg by the MJCF: geom mass from a default class)"
    ), statement
    assert "excluded" in statement and "derivation assumes" not in statement
    assert decision.passed and all("pinocchio" not in r["pair"] for r in decision.pointwise["rows"])
    from lagrange_xval.cli.check import verdict_data

    assert verdict_data(decision)["excluded"] == dict(decision.excluded)


def test_run_shows_a_set_aside_readers_trajectory_without_judging_it():
    """`run` (pipeline.set_aside_runs): the trajectory of a reader the verdict set aside counts for nothing
    and says why; the others are judged as before."""
    from lagrange_xval.stages.pipeline import set_aside_runs

    traj = {"runs": [{"source": "pinocchio", "counts": True}, {"source": "mujoco", "counts": True}]}
    set_aside_runs(traj, {"pinocchio": "Pinocchio misreads upper_arm's mass (...): excluded"})
    assert traj["runs"][0]["counts"] is False and "misreads upper_arm's mass" in traj["runs"][0]["why_not_counted"]
    assert traj["runs"][1] == {"source": "mujoco", "counts": True}


def test_a_long_warning_is_cut_at_a_word_and_says_so():
    """Issue 44: a Drake warning was shown cut mid-word ("MultibodyPlant do")."""
    from lagrange_xval.audit.audit import cut_words

    text = "The tag 'flag' found as a child of 'option' is currently unsupported and will be ignored by "
    text += "MultibodyPlant docs"
    cut = cut_words(text)
    assert cut.endswith("MultibodyPlant ...") and len(cut) <= 114, cut
    assert cut_words("short warning") == "short warning"

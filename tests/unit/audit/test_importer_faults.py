"""Importer faults of the kinds users report, each in the forms published models take (issue 42): an MJCF
<frame> (around a child body, around geoms, around the root, nested), an <include> (a body, a scene that
includes its robot from another folder, an included default class, either spelling of the tag), a URDF
joint's <dynamics friction>, a <mimic> (and an MJCF joint equality, its MJCF form), joint limits of each
type (a continuous joint's <limit>, a <limit> without lower and upper, a slide joint's range in degrees,
limited="false"). Each fault must be flagged on the reader that shows it on the installed versions
(MuJoCo 4.0.0, Pinocchio 4.1.0, Drake 1.51.1; each checked against the library, not assumed) and named
with the catalogue entry (validate/audit/importers.py) behind it; correct models of the same kinds must
raise no alarm.

`python tests/unit/audit/test_importer_faults.py` prints the figures: flagged, right reader, cause, false
alarms.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

import pytest

pytestmark = [
    pytest.mark.skipif(
        importlib.util.find_spec("pydrake") is None and os.environ.get("CI") != "true", reason="pydrake not installed"
    ),
]

INERTIAL = '<inertial pos="0 0 0.5" mass="1" diaginertia="0.01 0.02 0.03"/>'
CHILD = f'<body name="c" pos="0 0 1"><joint name="k" axis="1 0 0"/>{INERTIAL}</body>'


def mjcf(inside: str = "", head: str = "", tail: str = "", world: str | None = None, joint: str = "") -> str:
    body = f'<body name="b" pos="0 0 1"><joint name="j" axis="0 1 0"{joint}/>{INERTIAL}{inside}</body>'
    return f'<mujoco model="m">{head}<worldbody>{body if world is None else world}</worldbody>{tail}</mujoco>'


LIMIT = '<limit lower="-1" upper="1" effort="5" velocity="2"/>'
LINK = (
    '<link name="{name}"><inertial><origin xyz="0 0 0.2"/><mass value="1"/>'
    '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.015"/></inertial></link>'
)


def urdf(j1: str = LIMIT, j2: str = LIMIT, kind1: str = "revolute", kind2: str = "revolute") -> str:
    """Two links on two joints; `j1`, `j2`: what is inside each joint besides its frame."""
    return (
        f'<robot name="arm"><link name="base"/>'
        f'<joint name="j1" type="{kind1}"><parent link="base"/><child link="l1"/><origin xyz="0 0 0.1"/>'
        f'<axis xyz="0 1 0"/>{j1}</joint>{LINK.format(name="l1")}'
        f'<joint name="j2" type="{kind2}"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.4"/>'
        f'<axis xyz="1 0 0"/>{j2}</joint>{LINK.format(name="l2")}</robot>'
    )


ARM = f"""<mujoco model="arm"><compiler angle="radian"/>
  <default><joint damping="0.3"/></default>
  <worldbody><body name="b" pos="0 0 1"><joint name="j" axis="0 1 0"/>{INERTIAL}{CHILD}</body></worldbody>
</mujoco>"""
SCENE = """<mujoco model="scene"><include file="{file}"/>
  <worldbody><light pos="0 0 3"/><geom type="plane" size="1 1 0.1"/></worldbody></mujoco>"""
PART = f"<mujocoinclude>{CHILD}</mujocoinclude>"
MIMIC = '<mimic joint="j1" multiplier="-0.5" offset="0.1"/>'
EQUALITY = '<equality><joint joint1="k" joint2="j" polycoef="0.1 0.5 0 0 0"/></equality>'

# name -> (model text, format, {file beside the model: its text}, {reader: catalogue entry that must name it})
FAULTS: dict[str, tuple[str, str, dict[str, str], dict[str, str]]] = {
    "frame around a child body": (
        mjcf(f'<frame pos="0.3 0 0.2" euler="0 0 30">{CHILD}</frame>'), "mjcf", {},
        {"pinocchio": "<frame>", "drake": "<frame>"},
    ),
    "frame around geoms": (
        mjcf(world='<body name="b" pos="0 0 1"><joint name="j" axis="0 1 0"/><geom type="box" size="0.1 0.1 0.1"/>'
                   '<frame pos="0.3 0 0.2"><geom type="sphere" size="0.1" mass="2"/></frame></body>'), "mjcf", {},
        {"pinocchio": "<frame>", "drake": "<frame>"},
    ),
    "frame around the root": (
        mjcf(world=f'<frame pos="0 0 1" euler="0 0 30"><body name="b"><joint name="j" axis="0 1 0"/>{INERTIAL}'
                   "</body></frame>"), "mjcf", {},
        {"pinocchio": "<frame> around the root", "drake": "<frame>"},
    ),
    "nested frames": (
        mjcf(f'<frame pos="0.1 0 0"><frame euler="0 30 0">{CHILD}</frame></frame>'), "mjcf", {},
        {"pinocchio": "<frame>", "drake": "<frame>"},
    ),
    "include of a body": (mjcf('<include file="part.xml"/>'), "mjcf", {"part.xml": PART}, {"pinocchio": "<include>"}),
    "include with a closing tag": (
        mjcf("<include file='part.xml'></include>"), "mjcf", {"part.xml": PART}, {"pinocchio": "<include>"},
    ),
    "scene that includes its robot": (
        SCENE.format(file="arm.xml"), "mjcf", {"arm.xml": ARM}, {"pinocchio": "<include> of the robot"},
    ),
    "scene that includes its robot from another folder": (
        SCENE.format(file="../robots/arm.xml"), "mjcf", {"../robots/arm.xml": ARM},
        {"pinocchio": "<include> of the robot"},
    ),
    "include of a default class": (
        mjcf(head='<include file="classes.xml"/>', joint=' class="arm"'), "mjcf",
        {"classes.xml": '<mujoco><default><default class="arm"><joint damping="0.7"/></default></default></mujoco>'},
        {"pinocchio": "<include>"},
    ),
    "include of joint defaults": (
        mjcf(head='<include file="defaults.xml"/>'), "mjcf",
        {"defaults.xml": '<mujoco><default><joint damping="0.7" frictionloss="0.2"/></default></mujoco>'},
        {"pinocchio": "<include>", "drake": "frictionloss"},
    ),
    "URDF dynamics friction": (
        urdf(j1=LIMIT + '<dynamics damping="0.2" friction="0.3"/>'), "urdf", {}, {"drake": "frictionloss"},
    ),
    "URDF friction on a continuous joint": (
        urdf(j2='<limit effort="5" velocity="2"/><dynamics friction="0.3"/>', kind2="continuous"), "urdf", {},
        {"drake": "frictionloss"},
    ),
    "MJCF frictionloss": (mjcf(joint=' frictionloss="0.1"'), "mjcf", {}, {"drake": "frictionloss"}),
    "mimic on a revolute joint": (urdf(j2=LIMIT + MIMIC), "urdf", {}, {"pinocchio": "mimic"}),
    "mimic on a prismatic finger": (
        urdf(j2='<limit lower="0" upper="0.04" effort="5" velocity="2"/><mimic joint="j1" multiplier="2"/>',
             kind2="prismatic"), "urdf", {}, {"pinocchio": "mimic"},
    ),
    "MJCF joint equality": (
        mjcf(CHILD, tail=EQUALITY), "mjcf", {}, {"pinocchio": "a joint equality", "drake": "a joint equality"},
    ),
    "continuous joint with limits": (
        urdf(j2=LIMIT, kind2="continuous"), "urdf", {}, {"drake": "a continuous joint's <limit>"},
    ),
    "continuous joint with limits but no effort": (
        urdf(j2='<limit lower="-1" upper="1"/>', kind2="continuous"), "urdf", {},
        {"pinocchio": "a joint without <limit>", "drake": "a continuous joint's <limit>"},
    ),
    "revolute limit with effort and velocity only": (
        urdf(j1='<limit effort="5" velocity="2"/>'), "urdf", {},
        {"mujoco": "a <limit> without lower and upper", "drake": "a <limit> without lower and upper"},
    ),
    "revolute limit with an upper bound only": (
        urdf(j1='<limit upper="1" effort="5" velocity="2"/>'), "urdf", {},
        {"mujoco": "a <limit> without lower and upper", "drake": "a <limit> without lower and upper"},
    ),
    "revolute limit with lower equal to upper": (
        urdf(j1='<limit lower="0.2" upper="0.2" effort="5" velocity="2"/>'), "urdf", {},
        {"mujoco": "a <limit> without lower and upper"},
    ),
    "slide range in degrees": (
        mjcf('<body name="c" pos="0 0 1"><joint name="k" type="slide" axis="1 0 0" range="-0.1 0.2"/>'
             f"{INERTIAL}</body>"), "mjcf", {}, {"pinocchio": "a slide joint's range in degrees"},
    ),
    'limited="false" with a range': (
        mjcf(joint=' range="-30 30" limited="false"'), "mjcf", {}, {"pinocchio": 'limited="false"'},
    ),
}  # fmt: skip

# name -> (model text, format, {file beside the model: its text}): models of the same kinds that every reader
# reads as the format means
CORRECT: dict[str, tuple[str, str, dict[str, str]]] = {
    "frame around a site": (mjcf('<frame pos="0.3 0 0.2" euler="0 0 30"><site name="s"/></frame>'), "mjcf", {}),
    "include of visual settings": (
        mjcf(head='<include file="visual.xml"/>'), "mjcf",
        {"visual.xml": '<mujoco><visual><global offwidth="800"/></visual></mujoco>'},
    ),
    "include of an actuator": (
        mjcf(tail='<include file="act.xml"/>'), "mjcf",
        {"act.xml": '<mujoco><actuator><motor name="m" joint="j" gear="20"/></actuator></mujoco>'},
    ),
    "URDF dynamics damping, zero friction": (urdf(j1=LIMIT + '<dynamics damping="0.2" friction="0.0"/>'), "urdf", {}),
    "MJCF equality fixing one joint": (
        mjcf(CHILD, tail='<equality><joint joint1="k" polycoef="0.1 0 0 0 0"/></equality>'), "mjcf", {},
    ),
    "MJCF joint equality switched off": (
        mjcf(CHILD, tail=EQUALITY.replace("polycoef", 'active="false" polycoef')), "mjcf", {},
    ),
    "continuous joint with effort and velocity": (
        urdf(j2='<limit effort="5" velocity="2"/>', kind2="continuous"), "urdf", {},
    ),
    "continuous joint without limit": (urdf(j2="", kind2="continuous"), "urdf", {}),
    "prismatic joint with limits": (urdf(j2='<limit lower="0" upper="0.3" effort="5" velocity="2"/>',
                                         kind2="prismatic"), "urdf", {}),
    "slide range in radians mode": (
        mjcf('<body name="c" pos="0 0 1"><joint name="k" type="slide" axis="1 0 0" range="-0.1 0.2"/>'
             f"{INERTIAL}</body>", head='<compiler angle="radian"/>'), "mjcf", {},
    ),
    "hinge range in degrees": (mjcf(joint=' range="-30 30"'), "mjcf", {}),
    'limited="true" with a range': (mjcf(joint=' range="-30 30" limited="true"'), "mjcf", {}),
}  # fmt: skip


def _audit(folder: Path, text: str, fmt: str, files: dict[str, str]) -> dict:
    from lagrange_xval.audit import audit

    model = folder / "models" / ("m.urdf" if fmt == "urdf" else "m.xml")
    for name, content in {**files, model.name: text}.items():
        target = model.parent / name
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(content)
    return audit.audit_file(model, text, fmt)


def named(result: dict) -> dict[str, set[str]]:
    """reader -> the catalogue entries behind what the audit says of it (a misreading, or a refusal; "" where
    none explains it)."""
    out: dict[str, set[str]] = {}
    for m in result["misreads"]:
        out.setdefault(m["reader"], set()).add(m["entry"])
    for reader, why in result["skipped"].items():
        entry = why.rsplit(" [", 1)[1].split(":", 1)[0] if why.endswith("]") and " [" in why else ""
        out.setdefault(reader, set()).add(entry)
    return out


def judged(result: dict, want: dict[str, str]) -> tuple[bool, bool, bool]:
    """(flagged: some reader is named; right reader: exactly the readers that show the fault; cause: each of
    them named with the fault's entry and nothing else)."""
    got = named(result)
    right = set(got) == set(want)
    return bool(got), right, right and all(got[r] == {entry} for r, entry in want.items())


def figures(folder: Path) -> dict[str, int]:
    """The catalogue's figures: faults flagged, with the right readers, with the right cause; correct models
    with an alarm (any reader named)."""
    out = {"faults": len(FAULTS), "flagged": 0, "right reader": 0, "cause": 0, "correct": len(CORRECT), "alarms": 0}
    for i, (text, fmt, files, want) in enumerate(FAULTS.values()):
        flagged, right, cause = judged(_audit(folder / f"f{i}", text, fmt, files), want)
        out["flagged"] += flagged
        out["right reader"] += right
        out["cause"] += cause
    for i, (text, fmt, files) in enumerate(CORRECT.values()):
        out["alarms"] += bool(named(_audit(folder / f"c{i}", text, fmt, files)))
    return out


@pytest.mark.parametrize("case", sorted(FAULTS))
def test_each_fault_is_flagged_on_its_reader_with_its_cause(tmp_path, case):
    text, fmt, files, want = FAULTS[case]
    result = _audit(tmp_path, text, fmt, files)
    assert named(result) == {reader: {entry} for reader, entry in want.items()}, (result["findings"], result["skipped"])


@pytest.mark.parametrize("case", sorted(CORRECT))
def test_a_correct_model_of_each_kind_raises_no_alarm(tmp_path, case):
    text, fmt, files = CORRECT[case]
    result = _audit(tmp_path, text, fmt, files)
    assert not result["misreads"] and not result["skipped"] and result["passed"], result["findings"]
    assert len(result["readers"]) == 3


def test_drake_reads_a_mimic_as_a_coupler_and_pinocchio_only_when_asked(tmp_path):
    """What the readers' couplings rest on, asked of the libraries: Drake's URDF parser makes a coupler
    constraint of a <mimic> (pydrake binds no accessor for its joints; a continuous plant then refuses to
    compute), Pinocchio's buildModel makes a mimic joint only with mimic=True, MuJoCo a joint equality."""
    import mujoco
    import pinocchio as pin
    from lagrange_xval.sources.readers import read
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    text = urdf(j2=LIMIT + MIMIC)
    plant = MultibodyPlant(time_step=0.0)
    Parser(plant).AddModelsFromString(text, "urdf")
    plant.Finalize()
    assert plant.num_constraints() == 1 and not hasattr(plant, "get_coupler_constraint_specs")
    with pytest.raises(RuntimeError, match="does not support constraints"):
        plant.EvalTimeDerivatives(plant.CreateDefaultContext())
    assert not any("Mimic" in j.shortname() for j in pin.buildModelFromXML(text).joints)
    assert any("Mimic" in j.shortname() for j in pin.buildModelFromXML(text, mimic=True).joints)
    assert mujoco.MjModel.from_xml_string(text).neq == 1
    path = tmp_path / "arm.urdf"
    path.write_text(text)
    drake = read("drake", path, text, "urdf")
    assert drake.couplings == 1 and drake.unread == ("mimic",)
    assert read("pinocchio", path, text, "urdf").couplings == 0 and read("mujoco", path, text, "urdf").couplings == 1


def test_the_five_kinds_each_name_an_entry_of_the_catalogue():
    from lagrange_xval.audit import importers

    keys = {b.key for b in importers.CATALOGUE}
    assert {entry for *_, want in FAULTS.values() for entry in want.values()} <= keys


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        got = figures(Path(tmp))
    n = got["faults"]
    print(
        f"importer faults: flagged {got['flagged']}/{n}, right reader {got['right reader']}/{n},"
        f" cause {got['cause']}/{n}; correct models with an alarm: {got['alarms']}/{got['correct']}"
    )
    sys.exit(0 if got["cause"] == got["faults"] and not got["alarms"] else 1)

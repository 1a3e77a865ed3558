"""The catalogue of known importer behaviours (issue 33): what MuJoCo, Pinocchio and Drake each do with
a model file that its format means otherwise, each entry with where it was reported and the reader
that shows it on the versions in requirements.lock (MuJoCo 4.0.0, Pinocchio 4.1.0, Drake 1.51.1;
each checked by a planted case in tests/unit/audit/test_audit.py, not assumed).

The audit (validate/audit/audit.py) names the entry that explains each difference between a reader
and the format's meaning: an entry applies when its reader, format and field match the difference and
the file has the feature the entry is about (validate/audit/features.py, read from the file's text
alone). A
difference no entry explains is said to be unexplained.
"""

from __future__ import annotations

from dataclasses import dataclass

INERTIAL = ("mass", "com", "inertia")


@dataclass(frozen=True)
class Behaviour:
    """One known importer behaviour.

    Attributes:
        key: a short name, shown with the finding.
        readers: the readers that show it on the installed versions.
        formats: "mjcf", "urdf" or both.
        fields: the audited fields it changes ("joint": the joint is missing).
        feature: the file feature it needs (`features`).
        cause: what the reader does, one clause.
        refusals: for an entry that explains a refusal ("read"), the words of the reader's message it
            explains (an entry explains no other refusal).
        fixed: no reader shows it on the installed versions (reported on earlier ones; the tests plant it in
            one reader's input): it still explains what an older reader, or a converter, did.
        rotation: its inertia differs by a rotation only (the same principal moments): it explains no
            other inertia difference.
        reported: where it was reported: an issue or pull request of the tracker that shows it, or the
            closest report found (another importer with the same fault, the parser's list of what it
            supports) where none of the reader's own trackers has one.
    """

    key: str
    readers: tuple[str, ...]
    formats: tuple[str, ...]
    fields: tuple[str, ...]
    feature: str
    cause: str
    reported: str
    rotation: bool = False
    fixed: bool = False
    refusals: tuple[str, ...] = ()


CATALOGUE: tuple[Behaviour, ...] = (
    Behaviour(
        "<option gravity>",
        ("pinocchio",),
        ("mjcf",),
        ("gravity",),
        "option gravity",
        "ignores <option gravity> and keeps its own (0, 0, -9.81) m/s^2",
        "https://github.com/RobotControlStack/robot-control-stack/issues/201",
    ),
    Behaviour(
        "geom mass from a default class",
        ("pinocchio",),
        ("mjcf",),
        INERTIAL,
        "default geom mass",
        "ignores the mass a default class gives the geoms and weighs them by density (1000 kg/m^3)",
        "https://github.com/newton-physics/newton/pull/1744",
    ),
    Behaviour(
        "collision-free geoms",
        ("pinocchio",),
        ("mjcf",),
        INERTIAL,
        "collision-free geom",
        'leaves out the mass of geoms that collide with nothing (contype="0" conaffinity="0": visual geoms, '
        "which MuJoCo weighs like any other)",
        "https://github.com/newton-physics/mujoco-usd-converter/issues/67",
    ),
    Behaviour(
        "inertiafromgeom",
        ("pinocchio", "drake"),
        ("mjcf",),
        (*INERTIAL, "read"),
        "compiler inertiafromgeom",
        'does not apply the compiler\'s inertiafromgeom (Pinocchio and Drake refuse inertiafromgeom="false" where a '
        "body has no <inertial>; MuJoCo gives that body no mass)",
        "https://github.com/RobotLocomotion/drake/issues/20232",
        refusals=("inertia from geom", "inertiafromgeom=false"),
    ),
    Behaviour(
        "inertiagrouprange",
        ("pinocchio", "drake"),
        ("mjcf",),
        INERTIAL,
        "compiler inertiagrouprange",
        "ignores the compiler's inertiagrouprange and weighs geoms of every group",
        "https://github.com/newton-physics/newton/issues/3593",
    ),
    Behaviour(
        "settotalmass",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("mass", "inertia"),
        "compiler settotalmass",
        "ignores the compiler's settotalmass (MuJoCo scales every body's mass and inertia to that total)",
        "https://github.com/newton-physics/newton/issues/3689",
    ),
    Behaviour(
        "boundmass/boundinertia",
        ("drake",),
        ("mjcf",),
        INERTIAL,
        "compiler bounds",
        "ignores the compiler's boundmass/boundinertia (the lower bounds MuJoCo applies)",
        "https://github.com/newton-physics/newton/issues/3741",
    ),
    Behaviour(
        "balanceinertia",
        ("mujoco", "pinocchio", "drake"),
        ("mjcf", "urdf"),
        ("inertia", "read"),
        "balanced inertia",
        "balanceinertia: MuJoCo replaces an inertia that violates A + B >= C (its compiler option, in a URDF's "
        "<mujoco> element too); Pinocchio keeps it, Drake refuses or replaces it",
        "https://github.com/google-deepmind/mujoco/issues/375",
        refusals=("A + B >= C", "IsPhysicallyValid", "rotational inertia"),
    ),
    Behaviour(
        "eulerseq",
        ("pinocchio",),
        ("mjcf",),
        (*INERTIAL, "anchor", "axis"),
        "compiler eulerseq",
        "reads euler angles in another sequence than the compiler's eulerseq",
        "https://github.com/stack-of-tasks/pinocchio/pull/2526",
    ),
    Behaviour(
        "fusestatic",
        ("mujoco",),
        ("urdf",),
        ("inertia",),
        "welded rotated body",
        "sums the inertia of a link fused across a rotated fixed joint in the wrong frame (fusestatic)",
        "https://github.com/google-deepmind/mujoco/issues/2982",
        rotation=True,
        fixed=True,
    ),
    Behaviour(
        "an axisangle's axis",
        ("pinocchio",),
        ("mjcf",),
        ("com", "inertia", "anchor", "axis"),
        "unnormalized axisangle",
        "does not normalize an axisangle's axis (MuJoCo does), so the rotation it builds is not the file's",
        "https://github.com/stack-of-tasks/pinocchio/pull/2526",
    ),
    Behaviour(
        "a fixed joint's rpy",
        ("mujoco",),
        ("urdf",),
        ("com", "inertia", "anchor", "axis"),
        "fixed joint rpy",
        "drops the rotation (rpy) of a fixed joint when it fuses the child link",
        "https://github.com/google-deepmind/mujoco/issues/1176",
        fixed=True,
    ),
    Behaviour(
        "an inertial's rpy",
        ("mujoco",),
        ("urdf",),
        ("inertia",),
        "inertial rpy",
        "drops the rotation of an <inertial>'s <origin rpy>",
        "https://github.com/google-deepmind/mujoco/issues/3559",
        rotation=True,
        fixed=True,
    ),
    Behaviour(
        "mesh inertia and the 1 kg default",
        ("pinocchio", "drake"),
        ("mjcf",),
        (*INERTIAL, "read"),
        "mesh geom",
        "does not compute a mesh geom's inertia (Pinocchio gives it 1 kg and a unit inertia; Drake drops an "
        "inline mesh and refuses a mesh file other than .obj)",
        "https://github.com/newton-physics/newton/issues/3753",
        refusals=("mesh",),
    ),
    Behaviour(
        "shell inertia",
        ("pinocchio", "drake"),
        ("mjcf",),
        (*INERTIAL, "read"),
        "shell inertia",
        'does not weigh a geom as a shell (shellinertia, mesh inertia="shell"): Pinocchio refuses it, Drake '
        "weighs it solid",
        "https://github.com/newton-physics/newton/issues/3753",
        refusals=("shell",),
    ),
    Behaviour(
        "a joint without <limit>",
        ("pinocchio",),
        ("urdf",),
        ("read",),
        "joint without limit",
        "refuses a revolute or prismatic joint without <limit>, or a <limit> without effort and velocity "
        "(urdfdom's rule; MuJoCo and Drake read it)",
        "https://github.com/ros/urdfdom/issues/138",
        refusals=("valid URDF",),
    ),
    Behaviour(
        "a continuous joint's <limit>",
        ("drake",),
        ("urdf",),
        ("limits",),
        "continuous with limit",
        "reads the <limit> of a continuous joint as position limits (urdfdom ignores them: a continuous joint has "
        "none)",
        "https://github.com/RobotLocomotion/drake/pull/16953",
    ),
    Behaviour(
        "an invalid inertia replaced",
        ("drake", "mujoco", "pinocchio"),
        ("urdf", "mjcf"),
        (*INERTIAL, "read"),
        "invalid inertia",
        "replaces or refuses an inertia that is not physically valid (zero mass with inertia, the triangle "
        "inequality violated, not positive definite)",
        "https://github.com/RobotLocomotion/drake/issues/16992",
        refusals=("A + B >= C", "positive", "IsPhysicallyValid", "mass and inertia of moving", "rotational inertia"),
    ),
    Behaviour(
        "several joints in one body",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("joint", "anchor", "axis"),
        "several joints in one body",
        "reads a body's several joints otherwise: Pinocchio makes one composite joint of them (their names are not "
        "joints of its model); Drake places the first in the parent's frame, without the body's pos",
        "https://github.com/RobotLocomotion/drake/issues/20367",
    ),
    Behaviour(
        "a <compiler> after the bodies",
        ("pinocchio",),
        ("mjcf",),
        ("com", "inertia", "anchor", "axis"),
        "late compiler",
        "applies a <compiler> (its angle unit, eulerseq) only to what follows it in the file: the bodies above "
        "it are read with its defaults (euler angles in degrees), where MuJoCo applies it to the whole model (an "
        '<include> of the assets after <worldbody>, as adroit_hand does, brings angle="radian" there)',
        "https://github.com/newton-physics/newton/pull/3030",
    ),
    Behaviour(
        "<include>",
        ("pinocchio",),
        ("mjcf",),
        ("joint", "read", *INERTIAL, "damping", "armature", "stiffness", "frictionloss", "limits", "gravcomp"),
        "include",
        "does not read <include>: the bodies, joints and default classes of an included file are not in its model",
        "https://github.com/RobotControlStack/robot-control-stack/issues/201",
        refusals=("unordered_map::at",),
    ),
    Behaviour(
        "<include> of the robot",
        ("pinocchio",),
        ("mjcf",),
        ("read",),
        "included root",
        "does not read <include>: a scene that includes its robot has no body for it, and it refuses a "
        "<worldbody> without one",
        "https://github.com/RobotControlStack/robot-control-stack/issues/201",
        refusals=("No such node",),
    ),
    Behaviour(
        "several root bodies",
        ("pinocchio",),
        ("mjcf",),
        ("joint",),
        "several root bodies",
        "reads only the first body of <worldbody>: the joints of the others are not in its model",
        "https://github.com/stack-of-tasks/pinocchio/issues/2364",
    ),
    Behaviour(
        "a fixed root's pose",
        ("pinocchio",),
        ("mjcf",),
        ("com", "inertia", "anchor", "axis"),
        "fixed root pose",
        "drops the pose of a root body welded to the world (no joint), so the chain below it moves",
        "https://github.com/stack-of-tasks/pinocchio/issues/2782",
    ),
    Behaviour(
        "a free root's coordinates",
        ("pinocchio",),
        ("mjcf",),
        ("com", "inertia", "anchor", "axis"),
        "free root pose",
        "reads a free joint's coordinates relative to the root body's pose in the file (MuJoCo's are in the "
        "world), so at MuJoCo's qpos0 the root's pos and orientation are applied twice",
        "https://github.com/stack-of-tasks/pinocchio/issues/2066",
    ),
    Behaviour(
        "stiffness and springref",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("stiffness", "springref"),
        "joint spring",
        "has no joint spring: stiffness and springref are dropped (Drake warns)",
        "https://github.com/RobotLocomotion/drake/pull/22493",
    ),
    Behaviour(
        "springdamper",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("damping", "stiffness"),
        "springdamper",
        "ignores a joint's springdamper (the time constant and damping ratio MuJoCo turns into stiffness and "
        "damping from the joint's inertia)",
        "https://github.com/RobotLocomotion/drake/pull/22493",
    ),
    Behaviour(
        "frictionloss",
        ("drake",),
        ("mjcf", "urdf"),
        ("frictionloss",),
        "joint friction",
        "drops dry joint friction (MJCF frictionloss, URDF <dynamics friction>; Drake warns)",
        "https://github.com/RobotLocomotion/drake/pull/16953",
    ),
    Behaviour(
        "armature without a motor",
        ("drake",),
        ("mjcf",),
        ("armature",),
        "joint armature",
        "reads armature only as a motor's reflected inertia, so a joint without a motor loses it",
        "https://github.com/RobotLocomotion/drake/pull/22493",
    ),
    Behaviour(
        "gravcomp",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("gravcomp",),
        "gravcomp",
        "drops a body's gravity compensation (gravcomp)",
        "https://github.com/RobotControlStack/robot-control-stack/issues/201",
    ),
    Behaviour(
        "mimic",
        ("pinocchio",),
        ("urdf",),
        ("mimic", "couplings"),
        "mimic",
        "ignores the <mimic> coupling unless the model is built with mimic=True (buildModel's default reading: the "
        "joint moves on its own; MuJoCo makes it a joint equality, Drake a coupler constraint)",
        "https://github.com/stack-of-tasks/pinocchio/pull/2441",
    ),
    Behaviour(
        "an invalid mimic",
        ("drake", "mujoco", "pinocchio"),
        ("urdf",),
        ("read", "couplings"),
        "mimic",
        "refuses or drops a <mimic> it cannot apply (a leader the file does not have, a joint without one degree "
        "of freedom)",
        "https://github.com/RobotLocomotion/drake/issues/21472",
        refusals=("mimic",),
    ),
    Behaviour(
        "a joint equality",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("mimic", "couplings"),
        "joint equality",
        "drops an <equality><joint> coupling two joints (MJCF's mimic): Pinocchio's MJCF parser reads connect and "
        "weld equalities only, Drake warns that it is unsupported",
        "https://github.com/RobotLocomotion/drake/issues/20232",
    ),
    Behaviour(
        "a slide joint's range in degrees",
        ("pinocchio",),
        ("mjcf",),
        ("limits",),
        "slide range in degrees",
        "converts a slide joint's range from degrees as if it were an angle (compiler angle=\"degree\", MuJoCo's "
        "default, converts the ranges of hinges only: a slide's is a length)",
        "https://github.com/krishauser/Klampt/issues/114",
    ),
    Behaviour(
        'limited="false"',
        ("pinocchio",),
        ("mjcf",),
        ("limits",),
        "limited false",
        'reads the range of a joint that limited="false" leaves without limits',
        "https://github.com/newton-physics/newton/pull/4263",
    ),
    Behaviour(
        "a <limit> without lower and upper",
        ("mujoco", "drake"),
        ("urdf",),
        ("limits",),
        "limit without bounds",
        "reads a revolute or prismatic joint's <limit> that lacks lower or upper as no limit (MuJoCo on both sides, "
        "Drake on the missing side; MuJoCo also ignores lower = upper, with a warning), where urdfdom's lower and "
        "upper default to 0: a <limit effort velocity> alone is the range [0, 0]",
        "https://github.com/gkjohnson/urdf-loaders/issues/9",
    ),
    Behaviour(
        "<frame>",
        ("pinocchio", "drake"),
        ("mjcf",),
        ("joint", *INERTIAL, "anchor", "axis"),
        "frame element",
        "drops an MJCF <frame> and what is inside it (bodies, joints, geoms; mj_saveLastXML writes one for a URDF's "
        "rotated fixed joint; Drake warns 'frame ... unsupported')",
        "https://github.com/RobotLocomotion/drake/issues/16369",
    ),
    Behaviour(
        "<frame> around the root",
        ("pinocchio",),
        ("mjcf",),
        ("read",),
        "frame root",
        "drops an MJCF <frame>: where the <worldbody>'s bodies are inside frames it finds no body and refuses the file",
        "https://github.com/RobotLocomotion/drake/issues/16369",
        refusals=("No such node",),
    ),
    Behaviour(
        "nested default classes",
        ("drake",),
        ("mjcf",),
        ("damping", "armature", "stiffness", "frictionloss", "axis", *INERTIAL),
        "nested default class",
        "drops what a default class passes on to a class nested two deep under it",
        "https://github.com/RobotLocomotion/drake/pull/22625",
    ),
    Behaviour(
        "geometry weighed for a link without <inertial>",
        ("mujoco",),
        ("urdf",),
        INERTIAL,
        "geometry without inertial",
        "weighs the collision geometry of a link without <inertial> (1000 kg/m^3), where URDF means no mass",
        "https://github.com/ros/urdfdom/issues/138",
    ),
    Behaviour(
        "transmissions",
        ("mujoco",),
        ("urdf",),
        ("target", "gear"),
        "transmission",
        "ignores a URDF's <transmission> elements: it makes no actuator (the harness adds them as motors in its "
        "own model)",
        "https://github.com/google-deepmind/mujoco_menagerie/issues/24",
    ),
    Behaviour(
        "joint ref",
        ("drake", "pinocchio"),
        ("mjcf",),
        ("ref",),
        "joint ref",
        "ignores a joint's ref: its q = 0 is the file's pose, so its coordinate is MuJoCo's minus ref (Drake before "
        "1.37)",
        "https://github.com/RobotLocomotion/drake/pull/22446",
        fixed=True,
    ),
)


def _scoped(feature: str, found: set[str], names: tuple[str, ...] | None) -> int:
    """2: the feature is on one of `names` (a body, link or joint); 1: on the file; 0: absent.
    `names` None: anywhere in the file."""
    if names is None:
        return 1 if any(f == feature or f.startswith(feature + ":") for f in found) else 0
    if any(f"{feature}:{n}" in found for n in names):
        return 2
    return 1 if feature in found else 0


def explain(
    reader: str,
    fmt: str,
    field: str,
    found: set[str],
    names: tuple[str, ...] | None = None,
    *,
    rotated: bool = True,
) -> list[Behaviour]:
    """The entries that explain `reader` differing from the format's meaning on `field` of the
    elements `names` (the group's links and joint) in a file with the features `found`: an entry on
    one of those elements first, then the more specific (fewer fields, then fewer readers). `rotated`: an
    inertia that differs by a rotation only (entries about a lost rotation explain nothing else)."""
    hits = [
        (score, b)
        for b in CATALOGUE
        if reader in b.readers
        and fmt in b.formats
        and field in b.fields
        and (rotated or not b.rotation or field != "inertia")
        and (score := _scoped(b.feature, found, names))
    ]
    return [b for _, b in sorted(hits, key=lambda h: (-h[0], len(h[1].fields), len(h[1].readers)))]

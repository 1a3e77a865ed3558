"""The text of a standalone reproducer: a Python script of MuJoCo's, Pinocchio's and Drake's own calls
(and the person's equations module, imported by path) that computes one quantity at one state with
two sources and says whether they disagree (validate/verdict/reproduce.py writes and runs them).

Text generation only: nothing here imports an engine. The blocks below are the script's parts; each
source's block loads the model from its path as a person would, applies the alignments the harness
applies (each commented with why) and computes the quantity in the harness's convention, the
coordinates mapped by joint name. Where the harness edits the file before a library reads it (free
and ball joints as slides and hinges, model/floating.py; one body tree for Pinocchio; a URDF's
geometry removed or a joint locked; an MJCF's includes expanded and its asset files made absolute), the
script makes the same edit with xml.etree (MjSpec.from_file names the asset files MuJoCo opens) and
writes the text in a temporary folder of its own, never beside the model, and says so.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

# --- the edits the harness makes to the file before a library reads it (xml.etree, in the script) ---

EDITS = {
    "slides_and_hinges": '''
def slides_and_hinges(root):
    """What the harness compares (lagrange-xval's model/floating.py): every free joint as three slides
    along the body's axes and three hinges about them (z, y, x: intrinsic Z-Y-X angles), a ball joint
    as the three hinges at its anchor, named <joint>_tx .. _rx; unnamed bodies and joints named by
    MuJoCo's ids (body#3, joint#5). The same bodies and freedom, one coordinate per degree of freedom."""
    joints = 0
    for b, body in enumerate(root.iter("body"), start=1):
        if not body.get("name"):
            body.set("name", f"body#{b}")
        for element in body:
            if element.tag in ("joint", "freejoint"):
                if not element.get("name"):
                    element.set("name", f"joint#{joints}")
                joints += 1
    count = {"free": 0, "ball": 0}
    for body in root.iter("body"):
        for i, element in reversed(list(enumerate(body))):
            kind = "free" if element.tag == "freejoint" else element.get("type") if element.tag == "joint" else None
            if kind not in ("free", "ball"):
                continue
            count[kind] += 1
            name = element.get("name") or f"{kind}#{count[kind]}"
            zeroed = ("damping", "armature", "stiffness", "frictionloss", "ref", "springref")
            kept = {k: element.get(k, "0") for k in zeroed}
            kept |= {k: x for k, x in element.attrib.items() if k in (*zeroed[:4], "group")}
            pos = {"pos": element.get("pos", "0 0 0")} if kind == "ball" else {}
            axes = ([("tx", "1 0 0"), ("ty", "0 1 0"), ("tz", "0 0 1")] if kind == "free" else [])
            axes += [("rz", "0 0 1"), ("ry", "0 1 0"), ("rx", "1 0 0")]
            body.remove(element)
            for k, (suffix, axis) in enumerate(axes):
                kind_of = "slide" if suffix.startswith("t") else "hinge"
                attrib = {"name": f"{name}_{suffix}", "type": kind_of, "axis": axis, "limited": "false"}
                attrib |= pos | kept
                body.insert(i + k, ET.Element("joint", attrib))
    # A <key>'s qpos holds a free joint's 7 numbers and a ball's 4 (the harness converts them with the
    # coordinates); the script sets its state itself, so the keys, which change no dynamics, are left out
    for section in root.findall("keyframe"):
        root.remove(section)
''',
    "one_tree": '''
def one_tree(root):
    """Pinocchio's MJCF parser reads the first body tree under <worldbody> only: the harness gathers
    every tree in one fixed body at the world's origin (the dynamics are unchanged)."""
    for world in root.iter("worldbody"):
        trees = [c for c in world if c.tag in ("body", "frame", "replicate")]
        if len(trees) > 1:
            wrapper = ET.Element("body", {"name": "pinocchio#world_bodies"})
            world.insert(list(world).index(trees[0]), wrapper)
            for tree in trees:
                world.remove(tree)
                wrapper.append(tree)
            return
''',
    "model_name": '''
def model_name(root):
    """Drake's MJCF parser requires a model name, which MuJoCo and Pinocchio do not."""
    if not root.get("model"):
        root.set("model", MODEL.stem)
''',
    "no_equality": '''
def no_equality(root):
    """Drake's continuous-mode plant refuses coupling constraints; the harness leaves constraints out of
    every comparison (MuJoCo's equality constraints are switched off too)."""
    for child in root.findall("equality"):
        root.remove(child)
''',
    "no_geometry": '''
def no_geometry(root):
    """A URDF's dynamics are its <inertial> elements: the harness removes <visual> and <collision> before
    any library reads it (meshes would have to be found; collision geometry would bring contacts)."""
    for link in root.iter("link"):
        for child in link.findall("visual") + link.findall("collision"):
            link.remove(child)
''',
    "no_mimic": '''
def no_mimic(root):
    """Drake's continuous-mode plant refuses a <mimic> coupling; constraints are left out of every comparison."""
    for joint in root.iter("joint"):
        for child in joint.findall("mimic"):
            joint.remove(child)
''',
    "bounded": '''
def bounded(root):
    """A moving link below MuJoCo's minimum mass or inertia (mjMINVAL, 1e-15: a massless link between two
    joints, a point mass; a valid URDF, which MuJoCo refuses as written) is given MuJoCo's boundmass and
    boundinertia by the harness for EVERY reader alike (lagrange-xval's model/inertia.py bound_urdf), so
    that no reader differs from another by the floor: its mass and an isotropic inertia, as BOUNDED."""
    for link in root.iter("link"):
        if link.get("name") not in BOUNDED:
            continue
        mass, moment = BOUNDED[link.get("name")]
        inertial = link.find("inertial")
        inertial = ET.SubElement(link, "inertial") if inertial is None else inertial
        element = inertial.find("mass")
        (ET.SubElement(inertial, "mass") if element is None else element).set("value", repr(mass))
        element = inertial.find("inertia")
        element = ET.SubElement(inertial, "inertia") if element is None else element
        element.attrib.update({k: "0" for k in ("ixy", "ixz", "iyz")})
        element.attrib.update({k: repr(moment) for k in ("ixx", "iyy", "izz")})
''',
    "locked": '''
def locked(root):
    """The joints the harness was told to lock (--lock), made fixed at their zero angle."""
    for joint in root.findall("joint"):
        if joint.get("name") in LOCKED:
            joint.set("type", "fixed")
            for tag in ("limit", "mimic", "axis", "dynamics"):
                for child in joint.findall(tag):
                    joint.remove(child)
    for tr in list(root.iter("transmission")):
        if any(j.get("name") in LOCKED for j in tr.findall("joint")):
            root.remove(tr)
''',
}

FLATTEN = '''
ASSETS = {"mesh": "meshes", "hfield": "hfields", "skin": "skins", "texture": "textures"}  # tag: MjSpec's list
CUBE = ("fileright", "fileleft", "fileup", "filedown", "filefront", "fileback")
MERGED = ("default", "asset", "worldbody", "contact", "equality", "tendon", "actuator", "sensor", "keyframe", "custom")


def flattened(path):
    """The model as one self-contained document, as the harness gives it to every reader (lagrange-xval's
    model/flatten.py): each <include> replaced by the included file's children (looked up in the model's
    folder, then the including file's, as MuJoCo does; Pinocchio's parser does not read includes), each
    asset's file the absolute path MuJoCo opens (MuJoCo's own parse, MjSpec.from_file, names it), the
    asset folders removed from <compiler>, and repeated top-level sections merged as MuJoCo merges them
    (Pinocchio's parser reads the first <worldbody> and <default> only). Returns (root, changed)."""
    root = ET.fromstring(path.read_text(encoding="utf-8-sig").lstrip())
    folder = path.resolve().parent
    included = _expand(root, folder, folder)
    files = {tag: _assets(root, tag) for tag in ASSETS}
    if not included and not any(files.values()):
        return root, False
    if any(files.values()):
        import mujoco

        spec = mujoco.MjSpec.from_file(str(path.resolve()))
        for tag, listed in ASSETS.items():
            theirs = [s for s in getattr(spec, listed) if s.file or any(getattr(s, "cubefiles", ()))]
            base = spec.texturedir if tag == "texture" else spec.meshdir
            for element, asset in zip(files[tag], theirs):
                if element.get("file"):
                    element.set("file", os.path.normpath(os.path.join(folder, base, asset.file)))
                for attribute, name in zip(CUBE, getattr(asset, "cubefiles", ())):
                    if element.get(attribute):
                        element.set(attribute, os.path.normpath(os.path.join(folder, base, name)))
    for compiler in root.iter("compiler"):
        for attribute in ("meshdir", "texturedir", "assetdir"):
            compiler.attrib.pop(attribute, None)
    if included:
        for tag in MERGED:
            sections = root.findall(tag)
            if len(sections) > 1 and (tag != "default" or _mergeable(sections)):
                for section in sections[1:]:
                    sections[0].extend(list(section))
                    root.remove(section)
    return root, True


def _expand(node, folder, here):
    count = 0
    for i, child in reversed(list(enumerate(node))):
        if child.tag != "include":
            count += _expand(child, folder, here)
            continue
        name = child.get("file", "")
        candidates = [Path(name)] if os.path.isabs(name) else [folder / name, here / name]
        found = Path(os.path.normpath(next(c for c in candidates if c.exists())))
        included = ET.fromstring(found.read_text(encoding="utf-8-sig").lstrip())
        count += 1 + _expand(included, folder, found.parent)
        node.remove(child)
        for k, part in enumerate(list(included)):
            node.insert(i + k, part)
    return count


def _assets(root, tag):
    return [e for a in root.findall("asset") for e in a.findall(tag) if any(e.get(k) for k in ("file", *CUBE))]


def _mergeable(sections):
    tags = [c.tag for d in sections for c in d if c.tag != "default"]
    return len(tags) == len(set(tags)) and all(d.get("class", "main") == "main" for d in sections)
'''

EDITED = '''
@contextlib.contextmanager
def edited(path, *edits):
    """The model file itself, or, where the harness reads another text (includes expanded, asset files
    absolute, or its edits below), that text written in a temporary folder of its own (never beside
    the model: a model's folder may be read-only), removed afterwards."""
    if URDF:
        root, changed = ET.fromstring(path.read_text(encoding="utf-8-sig").strip()), False
    else:
        root, changed = flattened(path)
    if not edits and not changed:
        yield path
        return
    for edit in edits:
        edit(root)
    with tempfile.TemporaryDirectory(prefix="reproducer_") as folder:
        copy = Path(folder) / path.name
        copy.write_text(ET.tostring(root, encoding="unicode"))
        yield copy
'''

# --- MuJoCo ---------------------------------------------------------------------------------------

MUJOCO_LOAD_MJCF = """
    with edited(MODEL{edits}) as path:
        m = mujoco.MjModel.from_xml_path(str(path))
"""
MUJOCO_LOAD_URDF = """
    with edited(MODEL{edits}) as path:
        spec = mujoco.MjSpec.from_file(str(path))
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_LIMIT)
    # A link whose inertia violates the triangle inequality, which MuJoCo refuses, is balanced as
    # MuJoCo's balanceinertia does (the harness's repair, for MuJoCo only)
    spec.compiler.balanceinertia = True
    m = spec.compile()
"""
MUJOCO = """
def mujoco_value():
    import mujoco
{load}
    # The smooth dynamics every library computes: contacts, joint limits, equality constraints and dry
    # friction switched off (the harness leaves them out of every comparison); the inputs as generalized
    # forces in qfrc_applied, the actuators switched off (the harness drives motors only: ctrl = tau / gear)
    off = mujoco.mjtDisableBit
    m.opt.disableflags |= int(off.mjDSBL_CONTACT | off.mjDSBL_LIMIT | off.mjDSBL_EQUALITY | off.mjDSBL_FRICTIONLOSS)
    m.opt.disableflags |= int(off.mjDSBL_ACTUATION)
    # What MuJoCo alone computes is set to zero, as the harness does: tendon springs and dampers, the
    # medium's fluid forces, gravity compensation
    m.tendon_stiffness[:] = 0.0
    m.tendon_damping[:] = 0.0
    m.opt.density, m.opt.viscosity = 0.0, 0.0
    m.body_gravcomp[:] = 0.0
    m.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)  # d.energy is computed only with this flag
    d = mujoco.MjData(m)
    ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in JOINTS]  # joints by name
    qadr, dadr = m.jnt_qposadr[ids], m.jnt_dofadr[ids]
    d.qpos[qadr], d.qvel[dadr], d.qfrc_applied[dadr] = q, v, tau
    mujoco.mj_forward(m, d)
{quantity}
"""
MUJOCO_QUANTITY = {
    "M": "    full = np.zeros((m.nv, m.nv))\n    mujoco.mj_fullM(m, d, full)\n    return full[np.ix_(dadr, dadr)]",
    "bias": "    return d.qfrc_bias[dadr].copy()  # C(q, v) v + G(q)",
    "passive": "    return d.qfrc_passive[dadr].copy()",
    "qacc": "    return d.qacc[dadr].copy()",
    "tau_inverse": "    d.qacc[:] = 0.0\n    d.qacc[dadr] = QACC\n"
    "    mujoco.mj_inverse(m, d)  # net of the passive forces\n    return d.qfrc_inverse[dadr].copy()",
    "T": "    return np.array(d.energy[1])",
    "V": "    return np.array(d.energy[0])  # zero at the world origin's height",
    "body_positions": "    bids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in BODIES]\n"
    "    return d.xipos[bids].copy()  # each body's centre of mass",
    "body_rotations": "    bids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in BODIES]\n"
    "    return d.xmat[bids].reshape(-1, 3, 3).copy()",
}

# --- Pinocchio ------------------------------------------------------------------------------------

PINOCCHIO_LOAD_MJCF = """
    with edited(MODEL{edits}) as path:
        model = pin.buildModelFromMJCF(str(path))
    # buildModelFromMJCF ignores <option gravity>: MuJoCo's compiled m.opt.gravity, as the harness sets it
    model.gravity.linear = np.array(GRAVITY)
"""
PINOCCHIO_LOAD_URDF = """
    with edited(MODEL{edits}) as path:
        model = pin.buildModelFromUrdf(str(path))
    # URDF states no gravity: MuJoCo's default, as the harness sets it
    model.gravity.linear = np.array(GRAVITY)
"""
PINOCCHIO = """
def pinocchio_value():
    import pinocchio as pin
{load}
    data = model.createData()
    qf, vf = pin.neutral(model), np.zeros(model.nv)
    vi = []
    for j, qj, vj in zip(JOINTS, q, v):  # joints by name
        if model.existJointName(j):
            joint, k = model.joints[model.getJointId(j)], 0
        else:  # several joints of one body are one composite joint in Pinocchio, named after the first
            first, k = COMPOSITE[j]
            joint = model.joints[model.getJointId(first)]
        if joint.nq == 2 and joint.nv == 1:  # a continuous (unbounded) joint: (cos q, sin q)
            qf[joint.idx_q : joint.idx_q + 2] = np.cos(qj), np.sin(qj)
        else:
            qf[joint.idx_q + k] = qj
        vf[joint.idx_v + k] = vj
        vi.append(joint.idx_v + k)
    # Joint damping and springs, which Pinocchio's algorithms ignore: the harness applies MuJoCo's
    # numbers as a generalized force (and the springs' energy in V)
    passive = -np.array(DAMPING) * v - np.array(STIFFNESS) * (q - np.array(SPRINGREF))
{quantity}
"""
PINOCCHIO_QUANTITY = {
    "M": "    full = pin.crba(model, data, qf)  # the upper triangle\n"
    "    full = np.triu(full) + np.triu(full, 1).T\n    return full[np.ix_(vi, vi)]",
    "bias": "    return pin.rnea(model, data, qf, vf, np.zeros(model.nv))[vi]  # C(q, v) v + G(q)",
    "passive": "    return passive",
    "qacc": "    tf = np.zeros(model.nv)\n    tf[vi] = tau + passive\n"
    "    return pin.aba(model, data, qf, vf, tf, convention=pin.Convention.LOCAL)[vi]",
    "tau_inverse": "    af = np.zeros(model.nv)\n    af[vi] = QACC\n"
    "    return pin.rnea(model, data, qf, vf, af)[vi] - passive",
    "T": "    # 1/2 v^T M v on CRBA's M, as the harness computes Pinocchio's T: Pinocchio 4.1's computeKineticEnergy\n"
    "    # leaves out the armature of a hinge on an unaligned axis (JointModelRevoluteUnaligned; it counts it\n"
    "    # on RX, RY, RZ) and disagrees with CRBA where a joint is composite; CRBA's M holds every armature\n"
    "    full = pin.crba(model, data, qf)\n    full = np.triu(full) + np.triu(full, 1).T\n"
    "    return np.array(0.5 * vf @ full @ vf)",
    "V": "    pin.forwardKinematics(model, data, qf, vf)\n"
    "    springs = 0.5 * np.array(STIFFNESS) @ (q - np.array(SPRINGREF)) ** 2\n"
    "    return np.array(pin.computePotentialEnergy(model, data) + springs)",
    "body_positions": "    pin.forwardKinematics(model, data, qf)\n    out = []\n    for b in BODIES:\n"
    "        frame = model.frames[model.getBodyId(b)]\n        jid = frame.parentJoint\n"
    "        # a body that carries welded bodies: its own centre (Pinocchio keeps one inertia per joint)\n"
    "        lever = model.inertias[jid].lever\n"
    "        if b in CARRIER_COM:\n            lever = frame.placement.act(np.array(CARRIER_COM[b]))\n"
    "        out.append(data.oMi[jid].act(lever))\n    return np.array(out)",
    "body_rotations": "    pin.forwardKinematics(model, data, qf)\n    out = []\n    for b in BODIES:\n"
    "        frame = model.frames[model.getBodyId(b)]\n"
    "        out.append(data.oMi[frame.parentJoint].rotation @ frame.placement.rotation)\n    return np.array(out)",
}

# --- Drake ----------------------------------------------------------------------------------------

DRAKE_LOAD_MJCF = """
    with edited(MODEL{edits}) as path:
        Parser(plant).AddModels(str(path))
"""
DRAKE_LOAD_URDF = """
    with edited(MODEL{edits}) as path:
        Parser(plant).AddModels(str(path))
    # The root link welded to the world: Drake's URDF parser would let it float, MuJoCo and Pinocchio fix it
    for root in URDF_ROOTS:
        plant.WeldFrames(plant.world_frame(), plant.GetBodyByName(root).body_frame())
"""
DRAKE = """
def drake_value():
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import MultibodyForces, PrismaticSpring, RevoluteSpring

    plant = MultibodyPlant(time_step=0.0)  # continuous mode
{load}
    # What the harness aligns (sources/drake.py): gravity as MuJoCo's where Drake's differs (a URDF says
    # none); each joint's damping as MuJoCo's where Drake read another; armature as a motor's rotor
    # inertia (Drake counts armature only through a motor); springs, which its MJCF parser does not read
    if not np.allclose(plant.gravity_field().gravity_vector(), GRAVITY, rtol=1e-12, atol=0.0) or URDF_ROOTS:
        plant.mutable_gravity_field().set_gravity_vector(np.array(GRAVITY))
    motors = {{plant.get_joint_actuator(a).joint().name() for a in plant.GetJointActuatorIndices()}}
    for j, damping, armature, k, ref, kind in zip(JOINTS, DAMPING, ARMATURE, STIFFNESS, SPRINGREF, KINDS):
        joint = plant.GetJointByName(j)
        if abs(joint.default_damping() - damping) > 1e-12 * max(abs(damping), abs(joint.default_damping())):
            joint.set_default_damping(damping)
        if armature and j not in motors:
            motor = plant.AddJointActuator(f"armature of {{j}}", joint)
            motor.set_default_rotor_inertia(armature)
            motor.set_default_gear_ratio(1.0)
        if k:
            plant.AddForceElement((RevoluteSpring if kind == "hinge" else PrismaticSpring)(joint, ref, k))
    plant.Finalize()
    ctx = plant.CreateDefaultContext()
    if plant.num_actuated_dofs():
        plant.get_actuation_input_port().FixValue(ctx, np.zeros(plant.num_actuated_dofs()))
    qi = [plant.GetJointByName(j).position_start() for j in JOINTS]  # joints by name
    vi = [plant.GetJointByName(j).velocity_start() for j in JOINTS]
    qf, vf, tf = np.array(plant.GetPositions(ctx)), np.zeros(plant.num_velocities()), np.zeros(plant.num_velocities())
    qf[qi], vf[vi], tf[vi] = q, v, tau
    plant.get_applied_generalized_force_input_port().FixValue(ctx, tf)
    plant.SetPositions(ctx, qf)
    plant.SetVelocities(ctx, vf)
{quantity}
"""
DRAKE_FIXED = """    # The potential energy of the bodies welded to the world: a constant Drake counts and MuJoCo and
    # Pinocchio do not (the harness removes it from Drake's V)
    fixed = 0.0
    for body in plant.GetBodiesWeldedTo(plant.world_body()):
        if body.index() != plant.world_body().index():
            X = plant.EvalBodyPoseInWorld(ctx, body)
            com = X @ np.asarray(body.CalcCenterOfMassInBodyFrame(ctx))
            fixed -= body.get_mass(ctx) * float(plant.gravity_field().gravity_vector() @ com)
    return np.array(plant.CalcPotentialEnergy(ctx) - fixed)"""
DRAKE_QUANTITY = {
    "M": "    return plant.CalcMassMatrix(ctx)[np.ix_(vi, vi)]",
    "bias": "    # Drake's tau_g is gravity's generalized force, on the right-hand side: G = -tau_g\n"
    "    return (plant.CalcBiasTerm(ctx) - plant.CalcGravityGeneralizedForces(ctx))[vi]",
    "passive": "    forces = MultibodyForces(plant)\n    plant.CalcForceElementsContribution(ctx, forces)\n"
    "    return forces.generalized_forces()[vi]",
    "qacc": "    return plant.get_generalized_acceleration_output_port().Eval(ctx)[vi]",
    "tau_inverse": "    forces = MultibodyForces(plant)\n"
    "    plant.CalcForceElementsContribution(ctx, forces)  # gravity and damping, as applied forces\n"
    "    af = np.zeros(plant.num_velocities())\n    af[vi] = QACC\n"
    "    return plant.CalcInverseDynamics(ctx, af, forces)[vi]",
    "T": "    return np.array(plant.CalcKineticEnergy(ctx))",
    "V": DRAKE_FIXED,
    "body_positions": "    out = []\n"
    "    for b in BODIES:  # each body's centre of mass, with the bodies MuJoCo fused into it\n"
    "        body = plant.GetBodyByName(b)\n"
    "        group = [w for w in plant.GetBodiesWeldedTo(body) if w.index() == body.index() or w.name() not in KEPT]\n"
    "        masses = [w.get_mass(ctx) for w in group]\n"
    "        poses = [plant.EvalBodyPoseInWorld(ctx, w) for w in group]\n"
    "        coms = [X @ np.asarray(w.CalcCenterOfMassInBodyFrame(ctx)) for X, w in zip(poses, group)]\n"
    "        total = sum(masses)\n"
    "        out.append(sum(mi * c for mi, c in zip(masses, coms)) / total if total > 0 else "
    "plant.EvalBodyPoseInWorld(ctx, body).translation())\n"
    "    return np.array(out)",
    "body_rotations": "    return np.array([plant.EvalBodyPoseInWorld(ctx, plant.GetBodyByName(b)).rotation().matrix() "
    "for b in BODIES])",
}

# --- the person's equations module ----------------------------------------------------------------

HAND = '''
def hand_value():
    """The person's own equations module, imported by path, at the numbers the harness's call of its
    parameters(view) read from the model."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("equations_module", EQUATIONS)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    p = parameters_of(module)
{quantity}
'''
HAND_QUANTITY = {
    "M": "    return np.asarray(module.mass_matrix(p, q), dtype=float)",
    "bias": "    return np.asarray(module.bias(p, q, v), dtype=float)",
    "passive": "    if not hasattr(module, 'passive'):\n        return np.zeros(len(q))\n"
    "    return np.asarray(module.passive(p, q, v), dtype=float)",
    "qacc": "    M = np.asarray(module.mass_matrix(p, q), dtype=float)\n"
    "    passive = np.asarray(module.passive(p, q, v), dtype=float) if hasattr(module, 'passive') else 0.0\n"
    "    return np.linalg.solve(M, tau + passive - np.asarray(module.bias(p, q, v), dtype=float))",
    "tau_inverse": "    M = np.asarray(module.mass_matrix(p, q), dtype=float)\n"
    "    passive = np.asarray(module.passive(p, q, v), dtype=float) if hasattr(module, 'passive') else 0.0\n"
    "    return M @ QACC + np.asarray(module.bias(p, q, v), dtype=float) - passive",
    "T": "    return np.asarray(module.kinetic_energy(p, q, v), dtype=float)",
    "V": "    return np.asarray(module.potential_energy(p, q), dtype=float)",
    "body_positions": "    pos = module.body_positions(p, q)\n"
    "    return np.array([np.asarray(pos[b], dtype=float) for b in BODIES])",
    "body_rotations": "    rot = module.body_rotations(p, q)\n"
    "    return np.array([np.asarray(rot[b], dtype=float) for b in BODIES])",
}
PARAMS_CLASS = '''
def parameters_of(module):
    """An instance of the module's parameter class to fill with the harness's numbers (its fields by name)."""
    import dataclasses

    cls = getattr(module, PARAMS_CLASS_NAME)
    return cls(**{f.name: PARAMS[f.name] for f in dataclasses.fields(cls) if f.init})
'''

LITERAL = '''
def {name}_value():
    """{why}"""
    numbers = {number}  # by state index where the script computes two states (V)
    return np.array(numbers[AT] if isinstance(numbers, dict) else numbers)
'''

JUDGE = """
def both():
    return tuple(np.asarray(f(), dtype=float) for f in ({a}_value, {b}_value))


def main():  # prints both numbers, their difference and the tolerance; 1 where the disagreement shows
    global q, v, tau, AT
    a, b = both()
    constant = 0.0
    if REFERENCE:
        # V is compared up to a constant (the zero of the potential energy, or bodies welded to the world
        # that one library counts and the other does not; no equation of motion holds it): the harness
        # removes the midrange of a - b over its states, so its error is half the spread of a - b between
        # the states where a - b is largest and smallest. The script computes a - b at both, and removes
        # their midrange likewise.
        here = q, v, tau
        q, v, tau = (np.array(REFERENCE[k]) for k in ("q", "v", "tau"))
        AT = REFERENCE["index"]
        a_ref, b_ref = both()
        q, v, tau, AT = *here, STATE
        constant = float(((a - b) + (a_ref - b_ref)) / 2)
    gap = np.abs(a - b - constant)
    difference = float(np.max(gap)) if a.size else 0.0
    entry = np.unravel_index(int(np.argmax(gap)), a.shape) if a.ndim else ()
    where = f"{{QUANTITY}}[{{', '.join(map(str, entry))}}]" if a.ndim else QUANTITY
    print(f"model: {{MODEL}}")
    print(f"state {{STATE}} of the harness's sample: q = {{q.tolist()}}, v = {{v.tolist()}}, tau = {{tau.tolist()}}")
    print(f"{{where}}: {a} {{float(a[entry])!r}}, {b} {{float(b[entry])!r}}")
    print(f"the harness saw: {a} {{HARNESS['{a}']!r}}, {b} {{HARNESS['{b}']!r}} at {{QUANTITY}}{{list(HARNESS_ENTRY)}}")
    if REFERENCE:
        print(f"compared up to a constant: {a} - {b} - {{constant!r}}, the midrange of {a} - {b} at states "
              f"{{STATE}} and {{REFERENCE['index']}} (the harness removed {{CONSTANT!r}} over its states)")
    print(f"largest difference {{difference:.6g}}, tolerance {{TOLERANCE:.6g}} "
          f"({{RELATIVE:g}} of the quantity's scale {{SCALE:.6g}} over the harness's states)")
    for name, x in (("{a}", a), ("{b}", b)):  # the same number as the harness's, or the harness computed another
        mine = float(x[tuple(HARNESS_ENTRY)])
        same = mine == HARNESS[name] or bool(np.isclose(mine, HARNESS[name], rtol=0, atol=TOLERANCE, equal_nan=True))
        print(f"{{name}}: {{'the number the harness saw' if same else 'NOT the number the harness saw'}}")
    shows = not np.isfinite(difference) or difference > TOLERANCE
    print("the disagreement shows" if shows else "no disagreement: the two agree within the tolerance")
    return 1 if shows else 0


if __name__ == "__main__":
    try:
        status = main()
    except Exception:  # a library that cannot read the model, or a call that fails: neither shows anything
        import traceback

        traceback.print_exc()
        status = 2
    sys.exit(status)
"""

IMPORTS = """
import contextlib
import os
import sys
import tempfile
import xml.etree.ElementTree as ET
from math import inf, nan  # noqa: F401 - a number the harness saw may be one
from pathlib import Path

import numpy as np
"""


@dataclass(frozen=True)
class ModelFacts:
    """What the script needs of the model and of what the harness did with it (from the System)."""

    path: str  # absolute
    urdf: bool
    joints: tuple[str, ...]
    bodies: tuple[str, ...]
    kinds: tuple[str, ...]  # "hinge" or "slide", per joint
    gravity: tuple[float, ...]
    damping: tuple[float, ...]
    stiffness: tuple[float, ...]
    springref: tuple[float, ...]
    armature: tuple[float, ...]
    locked: tuple[str, ...] = ()
    converted: bool = False  # free or ball joints (or unnamed elements) made slides and hinges
    several_trees: bool = False  # Pinocchio reads one tree: the harness gathers them
    named: bool = True  # the <mujoco> element has a model name (Drake needs one)
    equality: bool = False  # an MJCF <equality> (Drake refuses it)
    mimic: bool = False  # a URDF <mimic> (Drake refuses it)
    composite: Mapping[str, tuple[str, int]] = field(default_factory=dict)  # Pinocchio's composite joints
    carrier_com: Mapping[str, tuple[float, ...]] = field(default_factory=dict)  # bodies carrying welded ones
    kept: tuple[str, ...] = ()  # the bodies MuJoCo keeps (Drake's welded groups)
    urdf_roots: tuple[str, ...] = ()
    bounded: Mapping[str, tuple[float, float]] = field(default_factory=dict)  # URDF links given MuJoCo's floors


@dataclass(frozen=True)
class HandFacts:
    """The person's module: its file, its parameter class and the numbers parameters() read."""

    path: str
    class_name: str
    params: Mapping[str, object]


@dataclass(frozen=True)
class Case:
    """One disagreement: the quantity, the two sources, the state and the numbers the harness saw."""

    system: str
    quantity: str
    a: str
    b: str
    state_index: int
    q: Sequence[float]
    v: Sequence[float]
    tau: Sequence[float]
    qacc: Sequence[float] | None  # the accelerations tau_inverse is taken at
    entry: tuple[int, ...]
    numbers: Mapping[str, float]
    tolerance: float  # absolute: the tier's relative tolerance x scale
    relative: float
    scale: float
    literal: Mapping[str, tuple[object, str]] = field(default_factory=dict)  # source -> (its numbers, why)
    constant: float = 0.0  # what the harness removes from a - b (V: up to a constant)
    reference: Mapping[str, object] | None = None  # V: the state at a - b's other extreme (index, q, v, tau)


def _edits(facts: ModelFacts, reader: str) -> list[str]:
    """The edits the harness makes to the file before `reader` reads it (names of EDITS)."""
    if facts.urdf:  # every reader reads the same URDF text (System.urdf_text), without its geometry
        out = ["no_geometry"] + (["locked"] if facts.locked else []) + (["bounded"] if facts.bounded else [])
        return out + (["no_mimic"] if reader == "drake" and facts.mimic else [])
    out = ["slides_and_hinges"] if facts.converted else []
    if reader == "pinocchio" and facts.several_trees:
        out.append("one_tree")
    if reader == "drake":
        out += ([] if facts.named else ["model_name"]) + (["no_equality"] if facts.equality else [])
    return out


def _engine_block(reader: str, facts: ModelFacts, quantity: str) -> tuple[str, list[str]]:
    """The function computing `quantity` with `reader`, and the edits it uses."""
    edits = _edits(facts, reader)
    args = "".join(f", {e}" for e in edits)
    if reader == "mujoco":
        load = (MUJOCO_LOAD_URDF if facts.urdf else MUJOCO_LOAD_MJCF).format(edits=args)
        return MUJOCO.format(load=load.rstrip("\n"), quantity=MUJOCO_QUANTITY[quantity]), edits
    if reader == "pinocchio":
        load = (PINOCCHIO_LOAD_URDF if facts.urdf else PINOCCHIO_LOAD_MJCF).format(edits=args)
        return PINOCCHIO.format(load=load.rstrip("\n"), quantity=PINOCCHIO_QUANTITY[quantity]), edits
    load = (DRAKE_LOAD_URDF if facts.urdf else DRAKE_LOAD_MJCF).format(edits=args)
    return DRAKE.format(load=load.rstrip("\n"), quantity=DRAKE_QUANTITY[quantity]), edits


def _literal(name: str, number: object, why: str) -> str:
    return LITERAL.format(name=name, why=why, number=repr(number))  # nan and inf: the script imports them


def _data(case: Case, facts: ModelFacts, hand: HandFacts | None) -> str:
    """The script's numbers: the model, the joints and bodies by name, the state, the alignments' values."""
    lines = [
        f"MODEL = Path({facts.path!r})",
        f"URDF = {facts.urdf!r}",
        f"JOINTS = {list(facts.joints)!r}  # the compared coordinates, each by its joint's name in every library",
        f"BODIES = {list(facts.bodies)!r}",
        f"KINDS = {list(facts.kinds)!r}",
        f"STATE = {case.state_index}  # the index of the state in the harness's sample",
        f"AT = {case.state_index}  # the state the value functions compute at (STATE, or REFERENCE's index)",
        f"q = np.array({list(case.q)!r})  # rad (m for a slide)",
        f"v = np.array({list(case.v)!r})  # rad/s (m/s)",
        f"tau = np.array({list(case.tau)!r})  # N m (N): the generalized force on each coordinate",
    ]
    if case.qacc is not None:
        lines.append(f"QACC = np.array({list(case.qacc)!r})  # the accelerations the inverse dynamics is taken at")
    lines += [
        f"GRAVITY = {list(facts.gravity)!r}  # m/s^2, MuJoCo's compiled opt.gravity",
        f"DAMPING = {list(facts.damping)!r}  # each joint's, as MuJoCo compiled it",
        f"STIFFNESS = {list(facts.stiffness)!r}",
        f"SPRINGREF = {list(facts.springref)!r}",
        f"ARMATURE = {list(facts.armature)!r}",
        f"LOCKED = {list(facts.locked)!r}",
        f"COMPOSITE = {dict(facts.composite)!r}",
        f"CARRIER_COM = {dict(facts.carrier_com)!r}",
        f"KEPT = {sorted(facts.kept)!r}",
        f"URDF_ROOTS = {list(facts.urdf_roots)!r}",
        f"BOUNDED = {dict(facts.bounded)!r}  # link: (mass kg, moment kg m^2), MuJoCo's floors (bounded)",
        f"CONSTANT = {case.constant!r}  # what the harness removed from a - b over its states (V), for the record",
        f"REFERENCE = {dict(case.reference or {})!r}  # V: the state where a - b is at its other extreme",
        f"QUANTITY = {case.quantity!r}",
        f"HARNESS = {dict(case.numbers)!r}  # the numbers the harness saw, at HARNESS_ENTRY",
        f"HARNESS_ENTRY = {list(case.entry)!r}",
        f"RELATIVE = {case.relative!r}",
        f"SCALE = {case.scale!r}",
        f"TOLERANCE = {case.tolerance!r}  # RELATIVE x SCALE: what the harness allows",
    ]
    if hand is not None:
        lines += [
            f"EQUATIONS = Path({hand.path!r})",
            f"PARAMS_CLASS_NAME = {hand.class_name!r}",
            f"PARAMS = {dict(hand.params)!r}",
        ]
    return "\n".join(lines)


def _header(case: Case, facts: ModelFacts) -> str:
    a, b = case.a, case.b
    return (
        f'"""{case.quantity} of {a} and {b} disagree on {facts.path}\n\n'
        f"The harness (lagrange-xval) saw {a} give {case.numbers[a]!r} and {b} {case.numbers[b]!r}\n"
        f"for {case.quantity}{list(case.entry)} at state {case.state_index} of its sample. This script computes the\n"
        "same quantity at the same state with the libraries' own calls only, the joints mapped by name and\n"
        "only the alignments the harness applies (each commented with why), and prints both numbers.\n\n"
        "    python this_file.py      # exit status 1: the disagreement shows; 0: it does not; 2: a library raised\n"
        '"""\n'
    )


def script(case: Case, facts: ModelFacts, hand: HandFacts | None = None) -> str:
    """The reproducer's text for `case` (module docstring). A side in `case.literal` is written as the
    numbers the harness computed (the symbolic derivation, or a form of the person's module the script
    cannot call directly), with why."""
    parts, edits = [], []
    for side in (case.a, case.b):
        if side in case.literal:
            number, why = case.literal[side]
            parts.append(_literal(side, number, why))
        elif side == "hand":
            parts.append(HAND.format(quantity=HAND_QUANTITY[case.quantity]))
            parts.append(PARAMS_CLASS)
        else:
            block, used = _engine_block(side, facts, case.quantity)
            parts.append(block)
            edits += [e for e in used if e not in edits]
    text = _header(case, facts) + IMPORTS + "\n" + _data(case, facts, hand) + "\n"
    text += "".join(EDITS[e] for e in edits) + ("" if facts.urdf else FLATTEN) + EDITED
    text += "".join(parts) + JUDGE.format(a=case.a, b=case.b)
    return text

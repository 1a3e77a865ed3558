"""Two files of one robot compared (issue 33): `lagrange-xval audit A.urdf B.xml`.

A model author who converts a URDF into an MJCF (with MuJoCo's `mj_saveLastXML`, say), or keeps two
descriptions of one robot, wants to know whether they are the same robot. Each file is read by its
format's meaning (validate/model/meaning.py: urdfdom's reading of a URDF, MuJoCo's compiled model
of an MJCF); the joints are matched by what they are (issue 43, validate/audit/matching.py: the tree,
the kind, the axis and the anchor at the reference, after a common base offset; one name kept as before,
names otherwise a hint; `--map A=B,...` sets or corrects pairs), each pair with how sure it is, never by
force (two different robots are refused, naming `--map`); a partial match is compared on its matched
joints, the others welded at their reference (`sub_chain`), and the unmatched joints and bodies are
listed. A joint is named by A's name and B's where it differs, "joint2 (B: panda_joint2)". Then compared:

- the inertial fields of the group each matched joint moves (mass, centre of mass, inertia), at the
  reference configuration, in world coordinates;
- forward kinematics (each joint's anchor and axis, each group's centre of mass), the gravity torques
  G(q), the mass matrix M(q) and the bias C(q, v) v + G(q) at `N_STATES` seeded configurations
  (validate/audit/chain.py, numpy on each reading: no engine between the file and the numbers;
  unmatched joints held at their reference; anchors and centres of mass after the base offset);
- each matched joint's kind, damping, stiffness, springref, frictionloss, armature, mimic coupling and
  limits (limits are shown, and fail nothing: no smooth dynamics use them), and gravity.

Each joint whose torques differ is named with the size of the effect and the group that causes it:
"joint6 gravity torque differs by up to 1.02 N m: link gripper_end's inertial frame rotated by the
fixed joint gripper_joint's rpy in A, not in B". Two quantities agree within RTOL of their scale:
`mj_saveLastXML` writes 6 significant digits.
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import NotRequired, TypedDict

import numpy as np

from ..model.meaning import FieldValue, Inertial, Reading, composite, urdf_meaning
from ..model.modelfile import model_file
from ..sources.readers import read
from .chain import Chain, chain, dynamics, kinematics
from .matching import JointMap, Placement, match

N_STATES = 1000  # seeded configurations
RTOL = 1e-5  # of each quantity's scale: mj_saveLastXML writes 6 significant digits
SLIDE_SPAN = 0.5  # m: a slide joint without limits is sampled in +-SLIDE_SPAN


def load(path: Path) -> tuple[Reading, str, str]:
    """(the format's meaning of the file, its format, its text), the file read through the door every
    command uses (model/modelfile.py `model_file`: whitespace before the declaration, an undeclared
    prefix, the sizes and an MJCF's includes as the one-file commands read them)."""
    root, text = model_file(path)
    fmt = "urdf" if root == "robot" else "mjcf"
    reading = urdf_meaning(text, path.name) if fmt == "urdf" else read("mujoco", path, text, fmt)
    return reading, fmt, text


def _welds(text: str, fmt: str) -> dict[str, str]:
    """link -> its fixed joint's name where that joint has a non-zero rpy (a URDF's welded tools)."""
    if fmt != "urdf":
        return {}
    out = {}
    for j in ET.fromstring(text).findall("joint"):
        origin, child = j.find("origin"), j.find("child")
        rpy = (origin.get("rpy") or "0") if origin is not None else "0"
        if j.get("type") == "fixed" and child is not None and any(float(x) != 0.0 for x in rpy.split()):
            out[child.get("link", "?")] = j.get("name", "?")
    return out


def _states(c: Chain, reading: Reading, names: list[str], seed: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Seeded configurations and velocities over `names` (A's joints; within finite limits)."""
    rng = np.random.default_rng(seed)
    q, v = np.zeros((n, len(names))), rng.uniform(-1.0, 1.0, (n, len(names)))
    for i, j in enumerate(names):
        r = reading.joints[j]
        lo, hi = (-np.pi, np.pi) if r.kind == "hinge" else (-SLIDE_SPAN, SLIDE_SPAN)
        if np.all(np.isfinite(r.limits)) and r.limits[1] > r.limits[0]:
            lo, hi = float(r.limits[0]), float(r.limits[1])
        q[:, i] = rng.uniform(lo, hi, n)
    return q, v


def _columns(c: Chain, names: list[str], x: np.ndarray) -> np.ndarray:
    """States over `names` as the chain's full vectors (the chain's other joints at 0)."""
    out = np.zeros((len(x), len(c.joints)))
    for i, j in enumerate(names):
        out[:, c.joints.index(j)] = x[:, i]
    return out


def _evaluate(c: Chain, names: list[str], q: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
    full_q, full_v = _columns(c, names, q), _columns(c, names, v)
    idx = [c.joints.index(j) for j in names]
    out = dynamics(c, full_q, full_v)
    kin = kinematics(c, full_q)
    return {
        "G": out["G"][:, idx],
        "bias": out["bias"][:, idx],
        "M": out["M"][:, idx][:, :, idx],
        "anchor": kin["anchor"][:, idx],
        "axis": kin["axis"][:, idx],
        "com": kin["com"][:, idx],
    }


def _gap(a: np.ndarray, b: np.ndarray, axis: tuple[int, ...]) -> np.ndarray:
    return np.abs(a - b).max(axis=axis)


def _label(j: str, m: JointMap) -> str:
    """A's joint name, and B's where it differs: "joint2 (B: panda_joint2)"."""
    return j if m.pairs[j] == j else f"{j} (B: {m.pairs[j]})"


def _group_cause(j: str, ra: Reading, rb: Reading, m: JointMap, welds: dict[str, dict[str, str]]) -> str:
    """Why joint j's group differs: the link and field, or the fields alone."""
    ga, gb = ra.groups[j], rb.groups[m.pairs[j]]
    extent = max(float(np.abs(ga.com).max()), float(np.abs(gb.com).max()), 1.0)
    rotated = np.allclose(np.linalg.eigvalsh(ga.inertia), np.linalg.eigvalsh(gb.inertia), rtol=1e-4, atol=1e-12)
    parts = []
    if abs(ga.mass - gb.mass) > RTOL * max(ga.mass, gb.mass):
        parts.append(f"mass {ga.mass:.4g} kg in A, {gb.mass:.4g} kg in B")
    if np.abs(ga.com - gb.com).max() > RTOL * extent:
        parts.append(f"centre of mass {np.abs(ga.com - gb.com).max():.3g} m apart")
    if np.abs(ga.inertia - gb.inertia).max() > RTOL * max(np.abs(ga.inertia).max(), 1e-12):
        parts.append("inertia rotated (the same principal moments)" if rotated else "inertia different")
    if not parts:
        return ""
    for side, other, label, name in (("A", "B", ra, j), ("B", "A", rb, m.pairs[j])):
        for link in label.members.get(name, ()):
            if link in welds[side]:
                return (
                    f"link {link}'s inertial frame rotated by the fixed joint {welds[side][link]}'s rpy in "
                    f"{side}, not in {other} ({'; '.join(parts)})"
                )
    links = ", ".join(ra.members.get(j, ()) or (j,))
    theirs = ", ".join(rb.members.get(m.pairs[j], ()) or (m.pairs[j],))
    links += f" (B: {theirs})" if theirs != links else ""
    return f"the group joint {_label(j, m)} moves (links {links}): {'; '.join(parts)}"


def _frame_cause(j: str, ra: Reading, rb: Reading, m: JointMap, welds: dict[str, dict[str, str]]) -> str:
    """Why joint j's frame differs at the reference: a welded link with an rpy above it, or the sizes."""
    a, b = ra.joints[j], rb.joints[m.pairs[j]]
    apart = float(np.linalg.norm(a.anchor - b.anchor)) if a.kind == "hinge" else 0.0
    turned = float(np.linalg.norm(a.axis - b.axis))
    extent = max(float(np.abs(a.anchor).max()), 1.0)
    if apart <= RTOL * extent and turned <= RTOL:
        return ""
    size = (f"anchor {apart:.3g} m apart, " if a.kind == "hinge" else "") + f"axis {turned:.3g} apart at the reference"
    for side, other, reading, name in (("A", "B", ra, j), ("B", "A", rb, m.pairs[j])):
        for link in reading.members.get(reading.joints[name].parent, ()):
            if link in welds[side]:
                return (
                    f"joint {_label(j, m)} is placed through the fixed joint '{welds[side][link]}' whose rpy {side} "
                    f"applies and {other} does not ({size})"
                )
    return f"joint {_label(j, m)}'s frame differs ({size})"


def _culprits(j: str, ra: Reading, rb: Reading, m: JointMap, welds: dict[str, dict[str, str]]) -> list[str]:
    """The causes among the groups joint j moves (its own and those below it): a joint frame placed
    differently first, else the group's inertial fields."""
    below = [k for k in m.pairs if k == j or _above(j, k, ra)]
    return [cause for k in below if (cause := _frame_cause(k, ra, rb, m, welds) or _group_cause(k, ra, rb, m, welds))]


def _above(j: str, k: str, reading: Reading) -> bool:
    parent = reading.joints[k].parent
    while parent:
        if parent == j:
            return True
        parent = reading.joints[parent].parent if parent in reading.joints else ""
    return False


ORDER = ("G", "bias", "M", "anchor", "axis", "com")  # the torques first: what a person's equations feel


class JointGap(TypedDict):
    """One joint's quantity that differs between the two files, and why."""

    joint: str
    quantity: str  # one of ORDER
    gap: float
    what: str
    unit: str
    causes: NotRequired[list[str]]
    finding: NotRequired[str]


class FileRef(TypedDict):
    file: str
    format: str  # "mjcf" or "urdf"


class Match(TypedDict):
    """How A's joints were matched to B's (validate/audit/matching.py)."""

    how: str  # "name", "structure", "name and structure" or "map" (a --map pair among them)
    matched: int
    of: tuple[int, int]  # A's joints, B's
    joints: dict[str, str]  # A's joint -> "name", "anchor, axis, tree", "axis, tree", "tree" or "map"
    offset: list[float]  # m: B's placement of the robot is A's turned by yaw about z, then moved by offset
    yaw: float  # degrees
    reversed: list[str]  # A's joints whose axis B reverses


class TwoFiles(TypedDict):
    """Two files of one robot compared (`compare`)."""

    a: FileRef
    b: FileRef
    matched_joints: list[str]  # A's names
    joint_map: dict[str, str]  # A's joint -> B's
    match: Match
    unmatched_joints: dict[str, list[str]]  # "A", "B": the joints only that file has
    unmatched_bodies: dict[str, list[str]]
    n_states: int
    seed: int
    rtol: float
    max_gap: dict[str, float]
    scale: dict[str, float]
    differences: list[JointGap]
    joint_fields: list[str]
    findings: list[str]
    passed: bool


def _joint_lines(gaps: dict[str, np.ndarray], scale: dict[str, float], names: list[str]) -> list[JointGap]:
    units = {"G": "N m", "bias": "N m", "M": "kg m^2", "anchor": "m", "axis": "", "com": "m"}
    words = {"G": "gravity torque", "bias": "bias force", "M": "mass matrix row", "anchor": "anchor", "axis": "axis"}
    words["com"] = "group's centre of mass"
    out: list[JointGap] = []
    for key in ORDER:
        rows: list[JointGap] = [
            {"joint": j, "quantity": key, "gap": float(gaps[key][i]), "what": words[key], "unit": units[key]}
            for i, j in enumerate(names)
            if gaps[key][i] > RTOL * scale[key]
        ]
        out += sorted(rows, key=lambda r: -float(r["gap"]))
    return out


JOINT_FIELDS = ("kind", "damping", "stiffness", "springref", "frictionloss", "armature", "mimic", "limits")


def _joint_fields(m: JointMap, ra: Reading, rb: Reading) -> list[str]:
    """Each matched joint's passive and coupling fields that differ between the files (limits: shown)."""
    out = []
    for j, k in m.pairs.items():
        for field in JOINT_FIELDS:
            x, y = getattr(ra.joints[j], field), getattr(rb.joints[k], field)
            if isinstance(x, tuple):  # a mimic's leader compared through the map
                x = (m.pairs.get(x[0], x[0]), x[1], x[2])
            if isinstance(x, str) or x is None or y is None or isinstance(x, tuple):
                same = x == y or (isinstance(x, tuple) and isinstance(y, tuple) and np.allclose(x[1:], y[1:]))
            else:
                same = bool(np.allclose(x, y, rtol=RTOL, atol=0.0))
            if not same:
                shown = getattr(ra.joints[j], field)
                out.append(f"joint {_label(j, m)} {field}: {_text(shown)} in A, {_text(y)} in B")
    if not np.allclose(ra.gravity, rb.gravity, rtol=RTOL, atol=0.0):
        out.append(f"gravity: {_text(ra.gravity)} m/s^2 in A, {_text(rb.gravity)} in B")
    return out


def _text(x: FieldValue) -> str:
    if x is None or isinstance(x, str):
        return str(x)
    if isinstance(x, tuple):
        return f"{x[0]} x {x[1]:g} + {x[2]:g}"
    arr = np.atleast_1d(np.asarray(x, dtype=float))
    return " ".join(f"{v:.4g}" for v in arr) if arr.size > 1 else f"{arr[0]:.4g}"


def _gaps(ea: dict[str, np.ndarray], eb: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {
        "G": _gap(ea["G"], eb["G"], (0,)),
        "bias": _gap(ea["bias"], eb["bias"], (0,)),
        "M": _gap(ea["M"], eb["M"], (0, 2)),
        "anchor": np.linalg.norm(ea["anchor"] - eb["anchor"], axis=-1).max(axis=0),
        "axis": np.linalg.norm(ea["axis"] - eb["axis"], axis=-1).max(axis=0),
        "com": np.linalg.norm(ea["com"] - eb["com"], axis=-1).max(axis=0),
    }


def _match_info(m: JointMap, ra: Reading, rb: Reading) -> Match:
    hows = set(m.how.values())
    how = "name and structure" if "name" in hows else "structure"
    how = "name" if hows <= {"name"} else "map" if "map" in hows else how
    return {
        "how": how,
        "matched": len(m.pairs),
        "of": (len(ra.joints), len(rb.joints)),
        "joints": dict(m.how),
        "offset": [float(x) for x in m.placed.offset],
        "yaw": float(np.degrees(m.placed.yaw)),
        "reversed": list(m.reversed),
    }


def sub_chain(reading: Reading, kept: set[str]) -> Reading:
    """The reading with only the `kept` joints moving: each other joint welded at its reference, its group
    joined to the nearest kept joint above it (the world's, if none), so that the kept joints' groups,
    kinematics and dynamics are those of the whole chain with the others held at their reference."""
    if kept >= set(reading.joints):
        return reading

    def above(j: str) -> str:
        p = reading.joints[j].parent
        while p in reading.joints and p not in kept:
            p = reading.joints[p].parent
        return p if p in kept else ""

    owner = {j: (j if j in kept else above(j)) for j in reading.joints}
    joints = {j: dataclasses.replace(reading.joints[j], parent=above(j)) for j in reading.joints if j in kept}
    groups = {j: composite([reading.groups[k] for k in reading.joints if owner[k] == j]) for j in joints}
    members = {j: tuple(x for k in reading.joints if owner[k] == j for x in reading.members.get(k, ())) for j in joints}
    return dataclasses.replace(reading, joints=joints, groups=groups, members=members)


def in_a_frame(reading: Reading, at: Placement) -> Reading:
    """B's reading moved back by its placement of the robot (x = R^T (x_B - offset)), so that A's and B's
    anchors, axes, centres of mass and inertias are compared where A places the robot."""
    if not at.moved():
        return reading
    R = at.R
    joints = {
        j: dataclasses.replace(r, anchor=R.T @ (r.anchor - at.offset), axis=R.T @ r.axis)
        for j, r in reading.joints.items()
    }
    groups = {j: Inertial(g.mass, R.T @ (g.com - at.offset), R.T @ g.inertia @ R) for j, g in reading.groups.items()}
    return dataclasses.replace(reading, joints=joints, groups=groups, gravity=R.T @ reading.gravity)


def _bodies(m: JointMap, ra: Reading, rb: Reading) -> dict[str, list[str]]:
    """The bodies only one file has: neither of one name in the other, nor the body of a matched joint, nor
    one of as many renamed bodies in a matched joint's group."""
    body_a = {x for ms in ra.members.values() for x in ms}
    body_b = {x for ms in rb.members.values() for x in ms}
    seen_a = {ra.joints[j].body for j in m.pairs}
    seen_b = {rb.joints[k].body for k in m.pairs.values()}
    for j, k in m.pairs.items():  # a renamed welded body: as many in both groups
        ours = [x for x in ra.members.get(j, ()) if x not in body_b and x not in seen_a]
        theirs = [x for x in rb.members.get(k, ()) if x not in body_a and x not in seen_b]
        if len(ours) == len(theirs):
            seen_a |= set(ours)
            seen_b |= set(theirs)
    return {"A": sorted(body_a - body_b - seen_a), "B": sorted(body_b - body_a - seen_b)}


def compare(
    a: Path, b: Path, *, n_states: int = N_STATES, seed: int = 0, joint_map: dict[str, str] | None = None
) -> TwoFiles:
    """The two files compared (the module docstring); `passed` when every matched quantity agrees.

    Args:
        a, b: the two files (URDF or MJCF).
        n_states, seed: the seeded configurations.
        joint_map: A's joint -> B's (`--map`), kept as given; the other joints are matched by structure.
    """
    ra, fa, ta = load(a)
    rb, fb, tb = load(b)
    m = match(ra, rb, joint_map)
    names = [j for j in ra.joints if j in m.pairs]
    full_a, full_b = ra, rb
    ra, rb = sub_chain(ra, set(names)), in_a_frame(sub_chain(rb, set(m.pairs.values())), m.placed)
    ca, cb = chain(ra), chain(rb)
    q, v = _states(ca, ra, names, seed, n_states)
    ea, eb = _evaluate(ca, names, q, v), _evaluate(cb, [m.pairs[j] for j in names], q, v)
    gaps = _gaps(ea, eb)
    extent = max(float(np.abs(ea["anchor"]).max()), float(np.abs(ea["com"]).max()), 1e-3)
    scale = {k: max(float(np.abs(ea[k]).max()), 1e-12) for k in ("G", "bias", "M")} | {
        "anchor": extent,
        "com": extent,
        "axis": 1.0,
    }
    welds = {"A": _welds(ta, fa), "B": _welds(tb, fb)}
    rows = _joint_lines(gaps, scale, names)
    for row in rows:
        causes = _culprits(row["joint"], ra, rb, m, welds)
        row["causes"] = causes
        unit = f" {row['unit']}" if row["unit"] else ""
        row["finding"] = f"{_label(row['joint'], m)} {row['what']} differs by up to {row['gap']:.3g}{unit}" + (
            f": {causes[0]}" if causes else ": no known cause (the groups and frames agree at the reference)"
        )
    joint_fields = _joint_fields(m, ra, rb)
    return {
        "a": {"file": a.name, "format": fa},
        "b": {"file": b.name, "format": fb},
        "matched_joints": names,
        "joint_map": {j: m.pairs[j] for j in names},
        "match": _match_info(m, full_a, full_b),
        "unmatched_joints": {
            "A": [j for j in full_a.joints if j not in m.pairs],
            "B": [j for j in full_b.joints if j not in m.pairs.values()],
        },
        "unmatched_bodies": _bodies(m, ra, rb),
        "n_states": n_states,
        "seed": seed,
        "rtol": RTOL,
        "max_gap": {k: float(g.max()) for k, g in gaps.items()},
        "scale": scale,
        "differences": rows,
        "joint_fields": joint_fields,
        "findings": [r["finding"] for r in rows] + joint_fields,
        "passed": not rows and not [f for f in joint_fields if " limits: " not in f],
    }


STRONG = "anchor, axis, tree"


def _map_lines(result: TwoFiles) -> list[str]:
    """How the joints were matched: by name as before, or the map and how sure each pair is."""
    info, pairs = result["match"], result["joint_map"]
    unmatched = result["unmatched_joints"]
    if info["how"] == "name" and not unmatched["A"] and not unmatched["B"]:
        return [f"  matched by name: {len(pairs)} joints ({', '.join(pairs)})"]
    others = {h for h in info["joints"].values() if h != "name"}
    said = STRONG if others == {STRONG} else ""
    head = "--map and structure" if info["how"] == "map" else info["how"]
    head += " (anchor, axis, tree)" if said and info["how"] != "map" else ""
    entries = [
        j if h == "name" else f"{j} = {pairs[j]}" + ("" if h == said else f" ({h})") for j, h in info["joints"].items()
    ]
    of = max(info["of"])
    out = [f"  joints matched by {head}, {info['matched']} of {of}: {', '.join(entries)}"]
    if info["matched"] < of:
        only = "; ".join(f"joints only in {s}: {', '.join(unmatched[s])}" for s in ("A", "B") if unmatched[s])
        out.append(
            f"  partial match: {info['matched']} of {of} joints matched; {only} (compared on the matched joints, "
            "the others held at their reference)"
        )
    return out


def _placement_lines(result: TwoFiles) -> list[str]:
    out = []
    offset, yaw = np.array(result["match"]["offset"]), result["match"]["yaw"]
    if np.any(offset) or yaw:
        xyz = " ".join(f"{x:.4g}" for x in offset)
        turn = f"turned {yaw:.4g} degrees about the vertical, then " if yaw else ""
        out.append(
            f"  the two files place the robot differently in the world: B's is A's {turn}moved "
            f"{np.linalg.norm(offset):.3g} m ({xyz} m); frames, anchors and centres of mass compared after "
            "undoing that placement"
        )
    if result["match"]["reversed"]:
        out.append(f"  axes B reverses: {', '.join(result['match']['reversed'])}")
    return out


def lines(result: TwoFiles) -> list[str]:
    """The comparison in one screen."""
    a, b = result["a"], result["b"]
    out = [
        f"audit: A {a['file']} ({a['format'].upper()}) against B {b['file']} ({b['format'].upper()}), each read by "
        "its format's meaning",
    ]
    out += _map_lines(result) + _placement_lines(result)
    partial = result["match"]["matched"] < max(result["match"]["of"])
    for side in ("A", "B"):
        if result["unmatched_joints"][side] and not partial:
            out.append(f"  joints only in {side}: {', '.join(result['unmatched_joints'][side])}")
        if result["unmatched_bodies"][side]:
            bodies = ", ".join(result["unmatched_bodies"][side])
            out.append(f"  bodies only in {side} (fused into a neighbour, or missing): {bodies}")
    out.append(
        f"  compared at {result['n_states']} seeded configurations (seed {result['seed']}): forward kinematics, "
        f"gravity torques, M, bias; each joint's damping, stiffness, springref, frictionloss, armature, mimic and "
        f"limits; agreement within {result['rtol']:g} of each quantity's scale"
    )
    gaps = result["max_gap"]
    out.append(
        "  max gaps: "
        + ", ".join(f"{k} {gaps[k]:.3g}" for k in ("anchor", "axis", "com", "G", "M", "bias"))
        + " (m, -, m, N m, kg m^2, N m)"
    )
    if result["passed"]:
        out.append("  the two files describe the same robot")
    out += [f"  DIFFERS {f}" for f in result["findings"][:15]]
    if len(result["findings"]) > 15:
        out.append(f"  ... and {len(result['findings']) - 15} more (--json for all)")
    return out

"""What a model file may hold before it is compiled, and what its compiled numbers must be.

Before any engine reads a model (MJCF or URDF), its text is checked (`check_text`):

- no DOCTYPE: a model needs no entities, and entities are how an XML file expands itself (the billion
  laughs) or reads another file (XXE);
- each file an MJCF `<include>` reads (wherever MuJoCo accepts it: validate/model/flatten.py) a regular
  UTF-8 file without DOCTYPE, at most MAX_INCLUDES of them, the model and its includes together within
  MAX_MODEL_BYTES;
- at most MAX_JOINTS joints and MAX_BODIES bodies (MJCF: joints and bodies in the bodies' tree, each
  `<replicate count=n>` multiplying what it holds; URDF: links, and joints that are not fixed). A
  10,000-joint MJCF took a run to 3.7 GiB and `unexpected MemoryError`.

After MuJoCo compiles it (`check_numbers`), every number the dynamics read (gravity, the bodies' masses,
inertias, positions and orientations, the joints' axes, anchors, damping, armature, stiffness and
friction loss) must be finite and at most MAX_MAGNITUDE in size: `gravity="0 nan 0"`, an infinite axis
or a mass of 1e308 (whose products overflow: numpy's warnings, NaN differences) is one error line naming
the field and the element.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from typing import TYPE_CHECKING

from ..core.errors import HarnessError, shown

if TYPE_CHECKING:  # MuJoCo is imported when a model is first checked
    import mujoco

MAX_MODEL_BYTES = 16 * 2**20  # the model and its includes (the notes' models are ~3 kB; dm_control's dog 84 kB)
MAX_JOINTS = 500  # dm_control's dog has 147 (its defaults included)
MAX_BODIES = 1000
MAX_INCLUDES = 100
MAX_MAGNITUDE = 1e100  # past it, products of the model's numbers overflow a double
_DOCTYPE = re.compile(r"<!\s*(DOCTYPE|ENTITY)", re.IGNORECASE)


def check_text(text: str, source: str) -> None:
    """Refuses, on one line, a model text with a DOCTYPE or more joints or bodies than the limits (an
    MJCF's includes expanded first: validate/model/flatten.py)."""
    no_doctype(text, source)
    root = parse(text, source)
    if root.tag == "robot":  # URDF
        joints = sum(1 for j in root.iter("joint") if j.get("type", "") != "fixed")
        bodies = sum(1 for _ in root.iter("link"))
    else:
        joints, bodies = _mjcf_counts(root, source)
    if joints > MAX_JOINTS or bodies > MAX_BODIES:
        raise HarnessError(
            f"{source}: {joints:,} joints and {bodies:,} bodies; a model may have at most {MAX_JOINTS} joints "
            f"and {MAX_BODIES} bodies (refused before it is compiled)."
        )


def no_doctype(text: str, source: str) -> None:
    """Refuses a text that declares a DOCTYPE or an entity (before any XML parser reads it)."""
    found = _DOCTYPE.search(text)
    if found:
        raise HarnessError(
            f"{source}: declares <!{found.group(1).upper()} ...>; a model needs no DOCTYPE or entities (they can "
            "expand the file without bound or read another file): remove the declaration."
        )


_PREFIXED = re.compile(r"<\s*/?\s*([A-Za-z_][\w.-]*):[A-Za-z_]|\s([A-Za-z_][\w.-]*):[A-Za-z_][\w.-]*\s*=")
_DECLARED = re.compile(r"xmlns:([A-Za-z_][\w.-]*)\s*=")
_ROOT_TAG = re.compile(r"<(?![?!])\s*[A-Za-z_][\w.:-]*")


def declare_prefixes(text: str) -> str:
    """A namespace prefix the file uses but never declares (`<limit drake:acceleration=...>`, which the
    parsers of MuJoCo and urdfdom, tinyxml2, read as part of the name) declared on the root element, so
    that a namespace-aware parser reads the file as they do instead of refusing it."""
    used = {a or b for a, b in _PREFIXED.findall(re.sub(r"<!--.*?-->", "", text, flags=re.S))}
    missing = sorted(used - {"xml", "xmlns"} - set(_DECLARED.findall(text)))
    root = _ROOT_TAG.search(text)
    if not missing or root is None:
        return text
    names = "".join(f' xmlns:{p}="urn:undeclared:{p}"' for p in missing)
    return text[: root.end()] + names + text[root.end() :]


def parse(text: str, source: str) -> ET.Element:
    """The root element of a model text; not well-formed XML is one line."""
    try:
        return ET.fromstring(text)
    except ET.ParseError as exc:
        raise HarnessError(f"{source}: not well-formed XML ({exc}).") from None


def _mjcf_counts(root: ET.Element, source: str) -> tuple[int, int]:
    """(joints, bodies) of an MJCF tree, `<replicate>` counts multiplied in."""
    joints = bodies = 0
    stack: list[tuple[ET.Element, str, int]] = [(root, "", 1)]
    while stack:
        node, parent, times = stack.pop()
        if node.tag == "default":
            continue  # classes of defaults: no joint or body of the model
        if node.tag == "replicate":
            times *= _count(node, source)
        if node.tag in ("joint", "freejoint") and parent == "body":
            joints += times
        elif node.tag == "body":
            bodies += times
        stack += [(child, node.tag, times) for child in node]
    return joints, bodies


def _count(node: ET.Element, source: str) -> int:
    text = node.get("count", "1").strip()
    if not text.isdigit():
        raise HarnessError(f"{source}: <replicate count={shown(text, 40)!r}>: the count must be a whole number.")
    return int(text)


MAX_NAME_CHARS = 100


def check_system_name(name: str) -> None:
    """Refuses a system name outside the rule: the stem its files share, 1 to MAX_NAME_CHARS printable
    characters (spaces, `:` and any Unicode letter are fine), not starting with `_` or `.` (the
    harness's helpers start so, like validate/forms.py, and hidden files), without `/` or `\\`."""
    ok = (
        0 < len(name) <= MAX_NAME_CHARS
        and name.isprintable()
        and name[0] not in "_."
        and not any(c in name for c in "/\\")
        and name.strip() == name
    )
    if not ok:
        raise HarnessError(
            f"{shown(name, 120)!r} is not a system name: a system is named after the stem its files share, 1 to "
            f"{MAX_NAME_CHARS} printable characters, not starting with _ or . (the harness's helpers and hidden "
            "files do), without / or \\ or spaces at either end; rename its files."
        )


# ---- the compiled numbers -------------------------------------------------------------------------------

_FIELDS = (  # (MjModel array, the kind of element that holds each row, what it is)
    ("body_mass", "body", "mass"),
    ("body_inertia", "body", "inertia"),
    ("body_ipos", "body", "centre of mass"),
    ("body_iquat", "body", "inertia orientation"),
    ("body_pos", "body", "position"),
    ("body_quat", "body", "orientation"),
    ("jnt_axis", "joint", "axis"),
    ("jnt_pos", "joint", "anchor"),
    ("jnt_stiffness", "joint", "stiffness"),
    ("dof_damping", "dof", "damping"),
    ("dof_armature", "dof", "armature"),
    ("dof_frictionloss", "dof", "friction loss"),
)


def check_numbers(model: mujoco.MjModel, source: str) -> mujoco.MjModel:
    """`model`, refused if its gravity or a number of a body or joint is not finite or exceeds
    MAX_MAGNITUDE, naming each such field (the first three) and the element."""
    import mujoco
    import numpy as np

    bad = _bad("gravity", "option", model.opt.gravity)
    for array, kind, what in _FIELDS:
        rows = {"body": model.nbody, "joint": model.njnt, "dof": model.nv}[kind]
        values = np.asarray(getattr(model, array), dtype=float).reshape(rows, -1) if rows else np.zeros((0, 1))
        for i, row in enumerate(values):
            if bad_row := _bad(what, kind, row):
                owner = int(model.dof_jntid[i]) if kind == "dof" else i
                obj = mujoco.mjtObj.mjOBJ_BODY if kind == "body" else mujoco.mjtObj.mjOBJ_JOINT
                name = mujoco.mj_id2name(model, obj, owner) or f"#{owner}"
                bad += [f"{'body' if kind == 'body' else 'joint'} {shown(name, 80)!r} {bad_row[0]}"]
    if bad:
        more = f" (and {len(bad) - 3} more)" if len(bad) > 3 else ""
        raise HarnessError(
            f"{source}: {'; '.join(bad[:3])}{more}; every number the dynamics read must be finite and at most "
            f"{MAX_MAGNITUDE:.0e} in size."
        )
    return model


def _bad(what: str, kind: str, row: Iterable[float]) -> list[str]:
    values = [float(x) for x in row]
    if all(math.isfinite(x) and abs(x) <= MAX_MAGNITUDE for x in values):
        return []
    text = " ".join(f"{x:.6g}" for x in values)
    why = "is not finite" if not all(math.isfinite(x) for x in values) else f"exceeds {MAX_MAGNITUDE:.0e}"
    return [f"{what} ({text}) {why}" if kind != "option" else f"gravity ({text}) {why}"]

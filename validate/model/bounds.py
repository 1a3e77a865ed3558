"""What a model file may hold before it is compiled, and what its compiled numbers must be.

Before any engine reads a model (MJCF or URDF), its text is checked (`check_text`):

- no DOCTYPE: a model needs no entities, and entities are how an XML file expands itself (the billion
  laughs) or reads another file (XXE);
- every MJCF `<include file=...>` a relative path inside the model's folder (an absolute path, or one
  that leaves the folder, would make the model read any file the user can), each included file a
  regular file and all of them together within MAX_MODEL_BYTES;
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
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from ..core.errors import HarnessError, shown
from ..core.inputs import regular_file

if TYPE_CHECKING:  # MuJoCo is imported when a model is first checked
    import mujoco

MAX_MODEL_BYTES = 16 * 2**20  # the model and its includes (the notes' models are ~3 kB; dm_control's dog 84 kB)
MAX_JOINTS = 500  # dm_control's dog has 147 (its defaults included)
MAX_BODIES = 1000
MAX_INCLUDES = 100
MAX_MAGNITUDE = 1e100  # past it, products of the model's numbers overflow a double
_DOCTYPE = re.compile(r"<!\s*(DOCTYPE|ENTITY)", re.IGNORECASE)


def check_text(text: str, source: str, folder: Path | None) -> None:
    """Refuses, on one line, a model text with a DOCTYPE, an include outside `folder` (None: text with
    no folder of its own, where any include is refused), or more joints or bodies than the limits."""
    _no_doctype(text, source)
    root = _parse(text, source)
    if root.tag == "robot":  # URDF
        joints = sum(1 for j in root.iter("joint") if j.get("type", "") != "fixed")
        bodies = sum(1 for _ in root.iter("link"))
    else:
        joints, bodies = _mjcf_counts(root, source, folder, [len(text.encode())])
    if joints > MAX_JOINTS or bodies > MAX_BODIES:
        raise HarnessError(
            f"{source}: {joints:,} joints and {bodies:,} bodies; a model may have at most {MAX_JOINTS} joints "
            f"and {MAX_BODIES} bodies (refused before it is compiled)."
        )


def _no_doctype(text: str, source: str) -> None:
    found = _DOCTYPE.search(text)
    if found:
        raise HarnessError(
            f"{source}: declares <!{found.group(1).upper()} ...>; a model needs no DOCTYPE or entities (they can "
            "expand the file without bound or read another file): remove the declaration."
        )


def _parse(text: str, source: str) -> ET.Element:
    try:
        return ET.fromstring(text)
    except ET.ParseError as exc:
        raise HarnessError(f"{source}: not well-formed XML ({exc}).") from None


def _mjcf_counts(root: ET.Element, source: str, folder: Path | None, sizes: list[int]) -> tuple[int, int]:
    """(joints, bodies) of an MJCF tree and the files it includes, `<replicate>` counts multiplied in;
    `sizes`: the bytes read so far (the model first), bounded by MAX_MODEL_BYTES."""
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
        elif node.tag == "include":
            j, b = _mjcf_counts(_include(node, source, folder, sizes), source, folder, sizes)
            joints, bodies = joints + times * j, bodies + times * b
        stack += [(child, node.tag, times) for child in node]
    return joints, bodies


def _count(node: ET.Element, source: str) -> int:
    text = node.get("count", "1").strip()
    if not text.isdigit():
        raise HarnessError(f"{source}: <replicate count={shown(text, 40)!r}>: the count must be a whole number.")
    return int(text)


def _include(node: ET.Element, source: str, folder: Path | None, sizes: list[int]) -> ET.Element:
    """The root of the file an `<include>` names, if it is a relative path inside `folder`."""
    name = node.get("file", "")
    shown_name = shown(name, 200)
    if folder is None or not name or os.path.isabs(name):
        raise HarnessError(
            f'{source}: <include file="{shown_name}">: an include must be a relative path inside the model\'s '
            "folder (an absolute path would make the model read any file)."
        )
    path = (folder / name).resolve()
    if not path.is_relative_to(folder.resolve()):
        raise HarnessError(f'{source}: <include file="{shown_name}"> leaves the model\'s folder; keep it inside.')
    if len(sizes) > MAX_INCLUDES:
        raise HarnessError(f"{source}: more than {MAX_INCLUDES} includes (one including itself?).")
    data = regular_file(path, "included model file", max_bytes=MAX_MODEL_BYTES - sum(sizes))
    sizes.append(len(data))
    try:
        text = data.decode()
    except UnicodeDecodeError:
        raise HarnessError(f"{source}: the included {shown_name} is not UTF-8 text.") from None
    _no_doctype(text, f"{source} (included {shown_name})")
    return _parse(text, f"{source} (included {shown_name})")


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

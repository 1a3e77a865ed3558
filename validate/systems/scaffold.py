"""`lagrange-xval new NAME --model PATH`: a starting equations module for a person's own model.

Everything the harness can read off the compiled model (its `--lock` joints made fixed first) is
written out: the coordinates (one per hinge or slide joint, in the model's order), the bodies (the
physics the scene uses is read from the model), a `Params` dataclass with one field per number the
dynamics can depend on (each body's mass, centre of mass, inertia about it and position in its
parent; each joint's anchor, damping, armature and stiffness; each actuator's gear; the gravity's
magnitude; the names are `field_of`'s, which `derive --python` uses too), `parameters(model)`
reading every field by MuJoCo name, and `assumptions(p)` stating the whole model in those fields, so
that the harness's probes can move every one. Orientations (body frames, joint axes, the direction of
gravity) are conventions of the derivation: written as constants, and described in the module's
docstring. The module meets the minimal contract (equations/__init__.py): no USES, no DESCRIPTION
(its docstring's first paragraph is the description).

The dynamics, energies and body poses are left to the person: stubs marked `not_provided` that the
harness counts as absent. Until one of the four forms is written, checking the module says so.
"""

from __future__ import annotations

import keyword
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..core.errors import HarnessError, shown
from ..core.files import create_file
from ..model.modelview import ModelView, key_parts, names
from . import System


def identifier(name: str) -> str:
    """A Python identifier from a MuJoCo name (`arm/theta` is `arm_theta`, `φ elbow` is `φ_elbow`)."""
    out = re.sub(r"\W", "_", name)
    out = out if out and not out[0].isdigit() else f"_{out}"
    return f"{out}_" if keyword.iskeyword(out) else out


def _vec(x: npt.ArrayLike) -> str:
    return "(" + ", ".join(repr(float(v)) for v in np.ravel(x)) + ")"


_BODY_FIELDS = {"mass": "m", "com": "c", "inertia": "I", "pos": "p"}
_JOINT_FIELDS = {"pos": "j", "damping": "d", "armature": "arm", "stiffness": "k", "springref": "q0"}


def field_of(key: str, entry: int | tuple[int, ...] | str | None = None) -> str:
    """The Params field `new` writes for one number of the model, given as its model key and the entry
    of the key's value (None: the value itself; "norm": gravity's magnitude; i: a vector's; (i, j): an
    inertia's): `field_of("body/link/com", 1)` is "cy_link". `derive --python` binds its symbols so."""
    if key == "gravity":
        return "g"
    parts = key_parts(key)
    if parts is None:
        raise ValueError(f"not a key of a body, joint or actuator: {key!r}")
    kind, name, what = parts
    table = {"body": _BODY_FIELDS, "joint": _JOINT_FIELDS, "actuator": {"gear": "gear"}}[kind]
    if isinstance(entry, tuple):
        suffix = "".join("xyz"[k] for k in sorted(entry))
    else:
        suffix = "" if entry is None or isinstance(entry, str) else "xyz"[entry]  # "norm" is gravity's alone
    return f"{table[what]}{suffix}_{identifier(name)}"


def _body_fields(b: str) -> list[tuple[str, str, str]]:
    """(field, model expression, comment) of one body's mass, centre of mass, inertia and position."""
    out = [(field_of(f"body/{b}/mass"), f'model["body/{b}/mass"]', f"kg, mass of body {b}")]
    out += [
        (field_of(f"body/{b}/com", k), f'model["body/{b}/com"][{k}]', f"m, centre of mass of {b} in its frame")
        for k in range(3)
    ]
    out += [
        (
            field_of(f"body/{b}/inertia", (r, c)),
            f'model["body/{b}/inertia"][{r}][{c}]',
            f"kg m^2, inertia of {b} about its centre of mass",
        )
        for r, c in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    ]
    out += [
        (field_of(f"body/{b}/pos", k), f'model["body/{b}/pos"][{k}]', f"m, origin of {b} in its parent's frame")
        for k in range(3)
    ]
    return out


def _joint_fields(view: ModelView, j: str) -> list[tuple[str, str, str]]:
    """(field, model expression, comment) of one joint's anchor, damping, armature and stiffness."""
    unit = "N s/m" if view[f"joint/{j}/type"] == "slide" else "N m s/rad"
    out = [
        (field_of(f"joint/{j}/pos", k), f'model["joint/{j}/pos"][{k}]', f"m, anchor of joint {j} in its body's frame")
        for k in range(3)
    ]
    out += [
        (field_of(f"joint/{j}/damping"), f'model["joint/{j}/damping"]', f"{unit}, viscous damping of {j}"),
        (field_of(f"joint/{j}/armature"), f'model["joint/{j}/armature"]', f"armature of {j} (added to M's diagonal)"),
        (field_of(f"joint/{j}/stiffness"), f'model["joint/{j}/stiffness"]', f"stiffness of {j}"),
    ]
    if f"joint/{j}/springref" in view:  # the model has a key for it only where it is not 0
        where = "rad" if view[f"joint/{j}/type"] == "hinge" else "m"
        relaxed = f"{where}, where the spring of {j} is relaxed"
        out.append((field_of(f"joint/{j}/springref"), f'model["joint/{j}/springref"]', relaxed))
    return out


def _fields(view: ModelView, parts: _Parts) -> list[tuple[str, str, str]]:
    """(field, model expression, comment) for every number of the Params dataclass."""
    out = [f for b in parts.bodies for f in _body_fields(b)]
    out += [f for j in parts.joints for f in _joint_fields(view, j)]
    out += [
        (
            field_of(f"actuator/{a}/gear"),
            f'model["actuator/{a}/gear"]',
            f"gear of actuator {a} (on joint {view[f'actuator/{a}/joint']})",
        )
        for a in parts.actuators
    ]
    return out + [("g", 'float(np.linalg.norm(model["gravity"]))', "m/s^2, magnitude of gravity")]


@dataclass(frozen=True)
class _Parts:
    """What the module is written for: the model file, the locked joints and the compiled model's names."""

    model: Path
    locked: tuple[str, ...]
    bodies: list[str]
    joints: list[str]
    actuators: list[str]
    down: np.ndarray  # the direction of gravity in world coordinates


def _parts(view: ModelView, model: Path, locked: tuple[str, ...]) -> _Parts:
    keys = list(view)

    def named(kind: str, last: str) -> list[str]:
        return names(keys, kind, last)

    gravity = np.asarray(view["gravity"], dtype=float)
    g = float(np.linalg.norm(gravity))
    down = gravity / g if g > 0 else np.array([0.0, 0.0, -1.0])
    return _Parts(model, locked, named("body", "mass"), named("joint", "type"), named("actuator", "gear"), down)


def _docstring(name: str, view: ModelView, parts: _Parts) -> list[str]:
    """The module docstring: its first paragraph is the system's description (the contract's default)."""
    coords = tuple(identifier(j) for j in parts.joints)
    lock = f" --lock {','.join(parts.locked)}" if parts.locked else ""
    t = [f'"""{name}: the equations of motion of {parts.model.name}, derived by hand.', ""]
    t.append(f"Written by `lagrange-xval new` from {parts.model}{lock}. Every number is read from the compiled")
    t.append("model by name (`parameters`); `assumptions` states the model in the Params fields, so the harness")
    t.append("can move each one independently. Conventions (constants of the derivation, from the model):")
    t += ["", f"    gravity: g (Params.g) along {_vec(parts.down)} in world coordinates"]
    for b in parts.bodies:
        t.append(
            f"    body {b}: child of {view[f'body/{b}/parent']}, its frame rotated by quat (w, x, y, z) "
            f"{_vec(view[f'body/{b}/quat'])} in its parent's frame at q = ref"
        )
    for j in parts.joints:
        t.append(
            f"    joint {j} ({view[f'joint/{j}/type']}): moves body {view[f'joint/{j}/body']} along/about axis "
            f"{_vec(view[f'joint/{j}/axis'])} of its frame by {j} - ref, ref = {_ref(view, j)!r} "
            f"(the file writes the body where it is at {j} = ref: MuJoCo's qpos0)"
        )
    if parts.locked:
        t.append(f"    locked (fixed at zero, not coordinates): {', '.join(parts.locked)}; check with{lock}")
    t += ["", "Coordinates q = (" + ", ".join(coords) + "), one per joint, in rad (hinge) or m (slide). Write the"]
    t.append("dynamics in ONE of the four forms, with numpy on arrays whose last axis is the coordinate:")
    t.append("    (a) mass_matrix(p, q) and bias(p, q, v) (+ passive(p, q, v))")
    t.append("    (b) residual(p, q, v, a, tau): M a + C v + G - passive - tau, row by row")
    t.append("    (c) qacc(p, q, v, tau)")
    t.append("    (d) kinetic_energy(p, q, v) and potential_energy(p, q) (+ passive(p, q, v))")
    t.append("and kinetic_energy, potential_energy, body_positions (centres of mass in the world) and")
    t.append("body_rotations (body frames in the world). The stubs below are counted as not provided: until")
    t.append("the dynamics are written, checking this module says so. The model's own form (a), in these")
    t.append(f"Params fields: `lagrange-xval derive --model {parts.model}{lock} --python`.")
    return [*t, '"""']


def _header(parts: _Parts) -> list[str]:
    """The imports and the constants: coordinates, joints and bodies (the physics is read from the model)."""
    t = [
        "",
        "from __future__ import annotations",
        "",
        "from dataclasses import dataclass",
        "from typing import Any",
        "",
    ]
    t += ["import numpy as np", "from lagrange_xval.forms import not_provided", ""]
    t.append(f"COORDINATES = {tuple(identifier(j) for j in parts.joints)!r}")
    t.append(f"JOINTS = {tuple(parts.joints)!r}")
    t.append(f"BODIES = {tuple(parts.bodies)!r}")
    return [*t, f"GRAVITY_DIRECTION = np.array({_vec(parts.down)})"]


def _parameters(fields: list[tuple[str, str, str]]) -> list[str]:
    """The Params dataclass and parameters(model), one field per number."""
    t = ["", "", "@dataclass(frozen=True)", "class Params:"]
    t += [f"    {f}: float  # {c}" for f, _, c in fields]
    t += ["", "", "def parameters(model: Any) -> Params:"]
    t += ['    """Every number of the dynamics, read from the compiled model by name."""', "    return Params("]
    t += [f"        {f}=float({e})," for f, e, _ in fields]
    return [*t, "    )"]


def _body_assumptions(view: ModelView, b: str) -> list[str]:
    i = identifier(b)
    return [
        f'        "body/{b}/parent": {view[f"body/{b}/parent"]!r},',
        f'        "body/{b}/mass": p.m_{i},',
        f'        "body/{b}/com": np.array([p.cx_{i}, p.cy_{i}, p.cz_{i}]),',
        f'        "body/{b}/inertia": np.array([[p.Ixx_{i}, p.Ixy_{i}, p.Ixz_{i}], '
        f"[p.Ixy_{i}, p.Iyy_{i}, p.Iyz_{i}], [p.Ixz_{i}, p.Iyz_{i}, p.Izz_{i}]]),",
        f'        "body/{b}/pos": np.array([p.px_{i}, p.py_{i}, p.pz_{i}]),',
        f'        "body/{b}/quat": np.array({_vec(view[f"body/{b}/quat"])}),',
    ]


def _ref(view: ModelView, j: str) -> float:
    """Joint j's `ref` (MuJoCo's qpos0, compiled: rad or m): 0 where the model has no key for it."""
    return float(view[f"joint/{j}/ref"]) if f"joint/{j}/ref" in view else 0.0


def _joint_assumptions(view: ModelView, j: str) -> list[str]:
    i = identifier(j)
    optional = [f'        "joint/{j}/ref": {_ref(view, j)!r},'] if f"joint/{j}/ref" in view else []
    if f"joint/{j}/springref" in view:
        optional.append(f'        "joint/{j}/springref": p.q0_{i},')
    return optional + [
        f'        "joint/{j}/type": {view[f"joint/{j}/type"]!r},',
        f'        "joint/{j}/body": {view[f"joint/{j}/body"]!r},',
        f'        "joint/{j}/axis": np.array({_vec(view[f"joint/{j}/axis"])}),',
        f'        "joint/{j}/pos": np.array([p.jx_{i}, p.jy_{i}, p.jz_{i}]),',
        f'        "joint/{j}/damping": p.d_{i},',
        f'        "joint/{j}/armature": p.arm_{i},',
        f'        "joint/{j}/frictionloss": 0.0,',
        f'        "joint/{j}/stiffness": p.k_{i},',
    ]


def _assumptions(view: ModelView, parts: _Parts) -> list[str]:
    """assumptions(p): the whole compiled model in the Params fields, so that probes can move each."""
    t = ["", "", "def assumptions(p: Params) -> dict[str, Any]:"]
    t += ['    """The compiled model this derivation describes, in the Params fields."""', "    return {"]
    t.append('        "gravity": p.g * GRAVITY_DIRECTION,')
    t += [line for b in parts.bodies for line in _body_assumptions(view, b)]
    t += [line for j in parts.joints for line in _joint_assumptions(view, j)]
    for a in parts.actuators:
        t.append(f'        "actuator/{a}/joint": {view[f"actuator/{a}/joint"]!r},')
        t.append(f'        "actuator/{a}/gear": p.gear_{identifier(a)},')
    return [*t, "    }"]


_STUBS = (
    ("kinetic_energy", "p: Params, q: np.ndarray, v: np.ndarray", "np.ndarray", "T(q, v), J, one value per state."),
    ("potential_energy", "p: Params, q: np.ndarray", "np.ndarray", "V(q), J, one value per state."),
    (
        "body_positions",
        "p: Params, q: np.ndarray",
        "dict[str, np.ndarray]",
        "{body: (..., 3) centre of mass in world coordinates}, for every body of BODIES.",
    ),
    (
        "body_rotations",
        "p: Params, q: np.ndarray",
        "dict[str, np.ndarray]",
        "{body: (..., 3, 3) body frame in world coordinates}, for every body of BODIES.",
    ),
)


def module_text(name: str, model: Path, *, locked: tuple[str, ...] = ()) -> str:
    """The text of the starting equations module for the model (MJCF or URDF) at `model`, its `locked`
    joints made fixed. The model is read as `check` reads it: what no source could compare (a model in
    which nothing moves, say) is refused here, in one line, before anything is written."""
    from ..model.scope import NOTHING_MOVES  # reads mujoco: loaded when first needed

    system = System.model_only(model, locked=locked)
    if not system.nv:
        raise HarnessError(f"{Path(model).name}: {NOTHING_MOVES}.")
    view = system.view
    parts = _parts(view, model, locked)
    t = [*_docstring(name, view, parts), *_header(parts), *_parameters(_fields(view, parts))]
    t += _assumptions(view, parts)
    for fn, args, ret, doc in _STUBS:
        t += ["", "", "@not_provided", f"def {fn}({args}) -> {ret}:", f'    """{doc}"""']
    return "\n".join(t) + "\n"


def write_module(name: str, model: Path, folder: Path | None = None, *, locked: tuple[str, ...] = ()) -> Path:
    """Writes FOLDER/NAME.py (default: the model's folder) for the model with its `locked` joints made
    fixed; refuses to overwrite a file."""
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name) or keyword.iskeyword(name):
        raise HarnessError(
            f"{shown(name, 120)!r} is not a valid module name: use letters, digits and _ (first a letter: a system "
            "named _x is refused, the harness's helpers start with _)."
        )
    model = Path(model)
    if not model.is_file():
        raise HarnessError(f"model file not found: {model} (give an MJCF .xml or a URDF .urdf file).")
    path = Path(folder or model.parent) / f"{name}.py"
    if path.parent.exists() and not path.parent.is_dir():
        raise HarnessError(f"--dir {path.parent} is a file, not a folder.")
    exists = f"{path} exists already; choose another NAME or --dir (nothing is overwritten)."
    if os.path.lexists(path):  # a link, even a dangling one, is something there
        raise HarnessError(exists)
    text = module_text(name, model, locked=locked)  # everything checked before anything is written
    try:
        create_file(path, text)  # never through a link, never over a file
    except FileExistsError:
        raise HarnessError(exists) from None
    return path

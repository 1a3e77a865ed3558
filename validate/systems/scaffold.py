"""`lagrange-xval new NAME --model PATH`: a starting equations module for a person's own model.

Everything the harness can read off the compiled model (its `--lock` joints made fixed first) is
written out: the coordinates (one per hinge or slide joint, in the model's order), the bodies (the
physics the scene uses is read from the model), a `Params` dataclass with one field per number the
equations of motion read (systems/usage.py: non-zero, and T, V, the passive forces or the actuation
depend on it; a planar chain's bar has its mass, the centre of mass and offsets in the plane of motion
and the inertia about the hinge axis, not the other five inertia entries; the names are `field_of`'s,
which `derive --python` uses too, and its parameters are the same set), `parameters(model)` reading
each field by MuJoCo name, and `assumptions(p)` stating every key of the model in those fields (the
contract's strict form, validate/verdict/modelsync.py `states_every_key`): NaN for a number the
dynamics do not depend on, 0.0 for a zero they rely on, so that the harness's probes move every field
and leave the rest as the model has it. Orientations (body frames, joint axes, the direction of
gravity) are conventions of the derivation: written as constants, and described in the module's
docstring. The module meets the minimal contract (equations/__init__.py): no USES, no DESCRIPTION
(its docstring's first paragraph is the description).

The dynamics, energies and body poses are left to the person: stubs marked `not_provided` that the
harness counts as absent, `mass_matrix` and `bias` first (form a, the README's; the docstring lists
the five forms). `passive` has no stub: a stub of it would be taken as written. Until one of the five
forms is written, checking the module says so.
"""

from __future__ import annotations

import keyword
import os
import re
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from ..core.errors import HarnessError, shown
from ..core.files import create_file
from ..model.modelview import ModelView, key_parts, names
from . import System
from .usage import INERTIA_ENTRIES, Entry, Number, depended_on, is_zero


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


class _Field(NamedTuple):
    """One number of the model a Params field may hold: its model key, the entry of the key's value and
    what it is (unit first)."""

    key: str
    entry: Entry
    meaning: str

    @property
    def name(self) -> str:
        return field_of(self.key, self.entry)

    @property
    def read(self) -> str:
        """How parameters(model) reads it."""
        if self.entry == "norm":
            return f'np.linalg.norm(model["{self.key}"])'
        index = "" if self.entry is None else "".join(f"[{i}]" for i in np.atleast_1d(self.entry))
        return f'model["{self.key}"]{index}'


def _body_fields(b: str) -> list[_Field]:
    """One body's mass, centre of mass, inertia and position."""
    where = f"m, centre of mass of {b} in its frame"
    about = f"kg m^2, inertia of {b} about its centre of mass"
    out = [_Field(f"body/{b}/mass", None, f"kg, mass of body {b}")]
    out += [_Field(f"body/{b}/com", k, where) for k in range(3)]
    out += [_Field(f"body/{b}/inertia", e, about) for e in INERTIA_ENTRIES]
    return out + [_Field(f"body/{b}/pos", k, f"m, origin of {b} in its parent's frame") for k in range(3)]


def _joint_fields(view: ModelView, j: str) -> list[_Field]:
    """One joint's anchor, damping, armature, stiffness and spring reference."""
    slide = view[f"joint/{j}/type"] == "slide"
    out = (
        [] if slide else [_Field(f"joint/{j}/pos", k, f"m, anchor of joint {j} in its body's frame") for k in range(3)]
    )
    out += [
        _Field(f"joint/{j}/damping", None, f"{'N s/m' if slide else 'N m s/rad'}, viscous damping of {j}"),
        _Field(f"joint/{j}/armature", None, f"{'kg' if slide else 'kg m^2'}, armature of {j} (added to M's diagonal)"),
        _Field(f"joint/{j}/stiffness", None, f"{'N/m' if slide else 'N m/rad'}, stiffness of {j}"),
    ]
    if f"joint/{j}/springref" in view:  # the model has a key for it only where it is not 0
        out.append(
            _Field(f"joint/{j}/springref", None, f"{'m' if slide else 'rad'}, where the spring of {j} is relaxed")
        )
    return out


def _fields(view: ModelView, parts: _Parts) -> list[_Field]:
    """The Params fields: every number of the model the equations of motion read (non-zero, and T, V, M,
    the passive forces or B depend on it: systems/usage.py), in the model's order."""
    out = [f for b in parts.bodies for f in _body_fields(b)]
    out += [f for j in parts.joints for f in _joint_fields(view, j)]
    out += [
        _Field(f"actuator/{a}/gear", None, f"gear of actuator {a} (on joint {view[f'actuator/{a}/joint']})")
        for a in parts.actuators
    ]
    out.append(_Field("gravity", "norm", "m/s^2, magnitude of gravity"))
    return [f for f in out if _stated(view, parts, f.key, f.entry).startswith("p.")]


def _stated(view: ModelView, parts: _Parts, key: str, entry: Entry) -> str:
    """What assumptions(p) states for one number: its Params field where the dynamics read it, 0.0 for a
    zero they depend on (the form of the equations relies on it), NaN where they do not depend on it."""
    if (key, entry) not in parts.depends:
        return "np.nan"
    return "0.0" if is_zero(view, key, entry) else f"p.{field_of(key, entry)}"


@dataclass(frozen=True)
class _Parts:
    """What the module is written for: the model file, the locked joints, the compiled model's names and
    the numbers its equations of motion depend on."""

    model: Path
    locked: tuple[str, ...]
    bodies: list[str]
    joints: list[str]
    actuators: list[str]
    down: np.ndarray  # the direction of gravity in world coordinates
    depends: frozenset[Number]


def _parts(view: ModelView, model: Path, locked: tuple[str, ...]) -> _Parts:
    keys = list(view)

    def named(kind: str, last: str) -> list[str]:
        return names(keys, kind, last)

    gravity = np.asarray(view["gravity"], dtype=float)
    g = float(np.linalg.norm(gravity))
    down = gravity / g if g > 0 else np.array([0.0, 0.0, -1.0])
    bodies, joints, actuators = named("body", "mass"), named("joint", "type"), named("actuator", "gear")
    return _Parts(model, locked, bodies, joints, actuators, down, depended_on(view))


def _wrapped(line: str) -> list[str]:
    """A convention's line of the docstring, wrapped at 100 characters under its own indent."""
    return textwrap.wrap(line, 100, initial_indent="    ", subsequent_indent="        ", break_on_hyphens=False)


def _conventions(view: ModelView, parts: _Parts) -> list[str]:
    """The docstring's conventions: gravity's direction, each body's parent and orientation, each joint's axis."""
    t = _wrapped(f"gravity: g (Params.g) along {_vec(parts.down)} in world coordinates")
    for b in parts.bodies:
        quat = np.asarray(view[f"body/{b}/quat"], dtype=float)
        turned = "aligned with" if np.array_equal(quat, [1.0, 0.0, 0.0, 0.0]) else f"turned by quat {_vec(quat)} in"
        t += _wrapped(f"body {b}: child of {view[f'body/{b}/parent']}, its frame {turned} its parent's at q = ref")
    for j in parts.joints:
        how = "turns" if view[f"joint/{j}/type"] == "hinge" else "moves"
        axis, along = _vec(view[f"joint/{j}/axis"]), "about" if how == "turns" else "along"
        t += _wrapped(
            f"joint {j}: {view[f'joint/{j}/type']}, {how} {view[f'joint/{j}/body']} {along} {axis} in its frame "
            f"by {j} - ref, ref = {_ref(view, j)!r}"
        )
    t += _wrapped("(the file writes each body where it is at q = ref: MuJoCo's qpos0; (w, x, y, z) quaternions)")
    if parts.locked:
        t += _wrapped(f"locked (fixed at zero, not coordinates): {', '.join(parts.locked)}")
    return t


# The five forms of README.md ("Your own system") and equations/__init__.py: the first a module defines is its form.
FORMS = (
    "(a) mass_matrix(p, q) and bias(p, q, v) = C(q, v) v + G(q): the stubs below",
    "(b) residual(p, q, v, a, tau) = M a + bias - passive - tau, row by row",
    "(c) qacc(p, q, v, tau) = M^-1 (tau + passive - bias)",
    "(d) kinetic_energy(p, q, v) and potential_energy(p, q) alone: M, C v and G are derived from them",
    "(e) hamiltonian(p, q, pm) = pm^T M^-1 pm / 2 + V, pm = M v",
)


def _passive_line(view: ModelView, parts: _Parts) -> str:
    """What the docstring says of passive(p, q, v): which joints have damping or a spring."""
    forced = [j for j in parts.joints if any(float(view[f"joint/{j}/{w}"]) != 0.0 for w in ("damping", "stiffness"))]
    if not forced:
        return "No joint of the model has damping or a spring: passive(p, q, v) is not needed."
    return (
        f"passive(p, q, v), the joints' damping and spring forces (in every form but b and c), has no stub (a stub "
        f"would be taken as written): write it, as the model damps or springs {', '.join(forced)}."
    )


def _docstring(name: str, view: ModelView, parts: _Parts, n_fields: int) -> list[str]:
    """The module docstring: its first paragraph is the system's description (the contract's default)."""
    lock = f" --lock {','.join(parts.locked)}" if parts.locked else ""
    t = [f'"""{name}: the equations of motion of {parts.model.name}, derived by hand.', ""]
    t += textwrap.wrap(
        f"Written by `lagrange-xval new` from {parts.model}{lock}. `parameters` reads from the compiled model, by "
        f"name, the {n_fields} numbers its equations of motion depend on (the Params fields); `assumptions` states "
        "the whole model in them (np.nan where the equations do not depend on a number, 0.0 for a zero they rely "
        "on), so that the harness's probes move each field on its own. Conventions (constants of the derivation):",
        100,
    )
    t += ["", *_conventions(view, parts), ""]
    coords = ", ".join(identifier(j) for j in parts.joints)
    t += textwrap.wrap(
        f"Coordinates q = ({coords}), one per joint, in rad (hinge) or m (slide). Write the dynamics in ONE of "
        "the five forms, with numpy on arrays whose last axis is the coordinate:",
        100,
    )
    t += [f"    {form}" for form in FORMS]
    t += textwrap.wrap(
        f"{_passive_line(view, parts)} Optional in every form: kinetic_energy, potential_energy, body_positions "
        "(centres of mass in the world) and body_rotations (body frames in the world). The stubs below are counted "
        "as not provided: until the dynamics are written, checking this module says so. The model's own form (a), in "
        f"these Params fields: `lagrange-xval derive --model {parts.model}{lock} --python`.",
        100,
    )
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


def _parameters(fields: list[_Field]) -> list[str]:
    """The Params dataclass and parameters(model), one field per number the dynamics read."""
    t = ["", "", "@dataclass(frozen=True)", "class Params:"]
    t += [f"    {f.name}: float  # {f.meaning}" for f in fields] or ["    pass"]
    t += ["", "", "def parameters(model: Any) -> Params:"]
    t += ['    """Every number the equations of motion read, from the compiled model by name."""', "    return Params("]
    t += [f"        {f.name}=float({f.read})," for f in fields]
    return [*t, "    )"]


def _vector(view: ModelView, parts: _Parts, key: str) -> str:
    """A 3-vector key as assumptions(p) states it, entry by entry."""
    entries = [_stated(view, parts, key, i) for i in range(3)]
    return "np.full(3, np.nan)" if set(entries) == {"np.nan"} else f"np.array([{', '.join(entries)}])"


def _inertia(view: ModelView, parts: _Parts, key: str) -> str:
    """An inertia as assumptions(p) states it, entry by entry (symmetric)."""
    rows = [[_stated(view, parts, key, (min(r, c), max(r, c))) for c in range(3)] for r in range(3)]
    if {e for row in rows for e in row} == {"np.nan"}:
        return "np.full((3, 3), np.nan)"
    return "np.array([" + ", ".join("[" + ", ".join(row) + "]" for row in rows) + "])"


def _body_assumptions(view: ModelView, parts: _Parts, b: str) -> list[str]:
    return [
        f'        "body/{b}/parent": {view[f"body/{b}/parent"]!r},',
        f'        "body/{b}/mass": {_stated(view, parts, f"body/{b}/mass", None)},',
        f'        "body/{b}/com": {_vector(view, parts, f"body/{b}/com")},',
        f'        "body/{b}/inertia": {_inertia(view, parts, f"body/{b}/inertia")},',
        f'        "body/{b}/pos": {_vector(view, parts, f"body/{b}/pos")},',
        f'        "body/{b}/quat": np.array({_vec(view[f"body/{b}/quat"])}),',
    ]


def _ref(view: ModelView, j: str) -> float:
    """Joint j's `ref` (MuJoCo's qpos0, compiled: rad or m): 0 where the model has no key for it."""
    return float(view[f"joint/{j}/ref"]) if f"joint/{j}/ref" in view else 0.0


def _joint_assumptions(view: ModelView, parts: _Parts, j: str) -> list[str]:
    optional = [f'        "joint/{j}/ref": {_ref(view, j)!r},'] if f"joint/{j}/ref" in view else []
    if f"joint/{j}/springref" in view:
        optional.append(f'        "joint/{j}/springref": {_stated(view, parts, f"joint/{j}/springref", None)},')
    anchor = _vector(view, parts, f"joint/{j}/pos")  # a slide's anchor is no number of its dynamics: NaN
    return optional + [
        f'        "joint/{j}/type": {view[f"joint/{j}/type"]!r},',
        f'        "joint/{j}/body": {view[f"joint/{j}/body"]!r},',
        f'        "joint/{j}/axis": np.array({_vec(view[f"joint/{j}/axis"])}),',
        f'        "joint/{j}/pos": {anchor},',
        *(f'        "joint/{j}/{w}": {_stated(view, parts, f"joint/{j}/{w}", None)},' for w in _JOINT_NUMBERS),
        f'        "joint/{j}/frictionloss": np.nan,  # left out of every comparison',
    ]


_JOINT_NUMBERS = ("damping", "armature", "stiffness")


def _gravity(view: ModelView, parts: _Parts) -> str:
    if not np.any(np.asarray(view["gravity"], dtype=float)):
        return "np.zeros(3)"  # no gravity: the equations rely on it
    stated = _stated(view, parts, "gravity", "norm")
    return "np.full(3, np.nan)" if stated == "np.nan" else f"{stated} * GRAVITY_DIRECTION"


def _assumptions(view: ModelView, parts: _Parts) -> list[str]:
    """assumptions(p): the whole compiled model in the Params fields, so that probes can move each."""
    t = ["", "", "def assumptions(p: Params) -> dict[str, Any]:"]
    t += [
        '    """The compiled model this derivation describes, in the Params fields (np.nan: a number the',
        '    equations of motion do not depend on; 0.0: a zero they rely on)."""',
        "    return {",
    ]
    t.append(f'        "gravity": {_gravity(view, parts)},')
    t += [line for b in parts.bodies for line in _body_assumptions(view, parts, b)]
    t += [line for j in parts.joints for line in _joint_assumptions(view, parts, j)]
    for a in parts.actuators:
        t.append(f'        "actuator/{a}/joint": {view[f"actuator/{a}/joint"]!r},')
        t.append(f'        "actuator/{a}/gear": {_stated(view, parts, f"actuator/{a}/gear", None)},')
    return [*t, "    }"]


_STUBS = (
    (
        "mass_matrix",
        "p: Params, q: np.ndarray",
        "np.ndarray",
        "M(q), (..., n, n): symmetric positive definite, the joints' armature on its diagonal.",
    ),
    (
        "bias",
        "p: Params, q: np.ndarray, v: np.ndarray",
        "np.ndarray",
        "C(q, v) v + G(q), (..., n): the velocity and gravity terms (damping and springs: passive).",
    ),
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
    fields = _fields(view, parts)
    t = [*_docstring(name, view, parts, len(fields)), *_header(parts), *_parameters(fields)]
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

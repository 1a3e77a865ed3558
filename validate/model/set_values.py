"""`set_values(text, {key: value})`: ModelView keys (validate/model/modelview.py) written into the
MJCF text at full precision, each to an absolute value, and verified by recompiling: what the
probes use to build a model at a derivation's own parameters (mass, centre of mass, full inertia,
body position and orientation, joint axis, position, damping, armature, stiffness, gear, gravity).
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping
from typing import TypeAlias

import numpy as np

from ..core.arrays import Floats
from ..core.errors import HarnessError, unknown_name
from .modelview import ModelView, from_mujoco
from .overrides import MUJOCO_DEFAULT_GRAVITY

# The numeric keys set_values writes, per kind of element, and the structure keys it only checks.
SETTABLE_FIELDS = {
    "body": ("mass", "com", "inertia", "pos", "quat"),
    "joint": ("axis", "pos", "damping", "armature", "frictionloss", "stiffness", "springref"),
    "actuator": ("gear",),
}
# a joint's ref (qpos0) fixes where its coordinate's zero is: a convention of the derivation, not moved
STRUCTURE_FIELDS = {"body": ("parent",), "joint": ("type", "body", "ref"), "actuator": ("joint",)}
_SHAPES = {
    "gravity": (3,),
    "com": (3,),
    "inertia": (3, 3),
    "pos": (3,),
    "quat": (4,),
    "axis": (3,),
}
_ORIENTATION_ATTRS = ("quat", "axisangle", "euler", "xyaxes", "zaxis")
MJ_MINVAL = 1e-15  # mjMINVAL: MuJoCo refuses a moving body whose mass or a principal moment is below it
MJ_EPS = 1e-14  # mjEPS: MuJoCo's fullinertia refuses a smallest eigenvalue below it (diaginertia does not)
TRIANGLE_MARGIN = 0.05  # principal moments the writer chooses satisfy A + B >= (1 + margin) C
# ... that is, (A + B - C) / (A + B + C) >= this for the largest moment C (see _margin)
_TARGET_MARGIN = TRIANGLE_MARGIN / (2.0 + TRIANGLE_MARGIN)
READBACK_RTOL = 1e-13  # the compiled model gives back what was written, relative to the array's largest entry
SYMMETRY_RTOL = 1e-10  # an inertia's (i, j) and (j, i) may differ by rounding (R D R^T); they are averaged
UNIT_RTOL = 1e-13  # quat and axis must be unit vectors to this (MuJoCo normalizes them)


_PROLOG_ITEM = re.compile(r"\s*(<\?.*?\?>|<!--.*?-->|<!DOCTYPE[^>]*>)", re.S)


def _prolog(text: str) -> str:
    """What precedes the root element (an XML declaration, the model's header comment), kept as it was."""
    end = 0
    while match := _PROLOG_ITEM.match(text, end):
        end = match.end()
    return text[:end] + "\n" if end else ""


def _show(x: object) -> str:
    if isinstance(x, str):
        return repr(x)
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        return repr(x)
    return repr(float(arr)) if arr.ndim == 0 else str(arr.tolist())


def _bad(key: str, value: object, why: str) -> HarnessError:
    return HarnessError(f"set_values: {key} = {_show(value)}: {why}.")


def _floats(values: Floats) -> str:
    return " ".join(repr(float(x)) for x in np.ravel(values))


def _attr_vector(el: ET.Element | None, attr: str, n: int) -> np.ndarray | None:
    """The element's own attribute as n floats (None when absent: a default class or the compiled model holds it)."""
    if el is None or attr not in el.attrib:
        return None
    try:
        out = np.array([float(x) for x in el.get(attr, "").split()], dtype=float)
    except ValueError:
        return None
    return out if out.shape == (n,) else None


def _mat_to_quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z), w >= 0, of a rotation matrix (Shepperd's method)."""
    t = np.trace(R)
    if t > 0:
        s = 2.0 * np.sqrt(1.0 + t)
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif R[0, 0] >= R[1, 1] and R[0, 0] >= R[2, 2]:
        s = 2.0 * np.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        q = [(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif R[1, 1] >= R[2, 2]:
        s = 2.0 * np.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s]
    quat = np.array(q) / np.linalg.norm(q)
    return -quat if quat[0] < 0 else quat


def _accepted(p: np.ndarray) -> bool:
    """MuJoCo's test of the principal moments it compiles: each above mjMINVAL, and A + B >= C exactly."""
    a, b, c = (float(x) for x in p)
    return min(a, b, c) > MJ_MINVAL and a + b >= c and a + c >= b and b + c >= a


def _inertia_attrs(inertia: np.ndarray) -> dict[str, str] | None:
    """The <inertial> attributes that compile to `inertia` (body axes), or None where MuJoCo would refuse it.

    A diagonal tensor is written as diaginertia, exactly (fullinertia would be diagonalised and its axes
    permuted, largest moment first). Otherwise fullinertia, unless MuJoCo's own diagonalisation could
    refuse it (a principal moment near mjEPS, or the triangle inequality within rounding): then the
    principal moments and axes computed here, as diaginertia and quat, so that MuJoCo tests exactly the
    moments the check above passed.
    """
    off = inertia[np.triu_indices(3, 1)]
    if not np.any(off):
        p = np.diag(inertia).copy()
        return {"diaginertia": _floats(p)} if _accepted(p) else None
    p, axes = np.linalg.eigh(inertia)
    scale = float(np.sum(np.abs(p)))
    slack = p[0] + p[1] - p[2]
    if p[0] >= 10 * MJ_EPS and slack >= 1e-12 * scale:
        i = inertia
        return {"fullinertia": _floats([i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]])}
    if -1e-14 * scale <= slack < 0:  # rounding of the eigenvalues of a tensor on the boundary (a lamina)
        p[2] = p[0] + p[1]
    if not _accepted(p):
        return None
    if np.linalg.det(axes) < 0:
        axes[:, 0] = -axes[:, 0]
    return {"diaginertia": _floats(p), "quat": _floats(_mat_to_quat(axes))}


def _why_refused(inertia: np.ndarray) -> str:
    p = np.linalg.eigvalsh(inertia)
    if p[0] <= 0:
        return f"not positive definite (principal moments {_floats(p)})"
    if p[0] <= MJ_MINVAL:
        return f"a principal moment is below MuJoCo's minimum {MJ_MINVAL:g} (principal moments {_floats(p)})"
    return f"principal moments {_floats(p)} violate the triangle inequality A + B >= C"


def _margin(inertia: np.ndarray) -> float:
    """(A + B - C) / (A + B + C) for the largest principal moment C: positive iff the tensor is a body's
    (positive definite and triangle inequality); quasi-concave in the entries."""
    tr = float(np.trace(inertia))
    if not np.isfinite(tr) or tr <= 0:
        return -np.inf
    return (tr - 2.0 * float(np.linalg.eigvalsh(inertia)[-1])) / tr


def _complete_inertia(key: str, given: np.ndarray, current: np.ndarray) -> np.ndarray:
    """The tensor to write: the given entries, and for the NaN ones the current values if the result is a
    valid body, else values chosen so that it is (with TRIANGLE_MARGIN); a HarnessError if none is."""
    inertia = np.array(given, dtype=float)
    scale = float(np.nanmax(np.abs(inertia))) if np.any(np.isfinite(inertia)) else 0.0
    for i, j in ((0, 1), (0, 2), (1, 2)):
        a, b = inertia[i, j], inertia[j, i]
        if np.isnan(a):
            a = b
        elif not np.isnan(b):
            if abs(a - b) > SYMMETRY_RTOL * scale:
                raise _bad(key, given, f"not symmetric (entries ({i}, {j}) and ({j}, {i}) differ)")
            a = 0.5 * (a + b)
        inertia[i, j] = inertia[j, i] = a
    free = np.isnan(inertia)
    if not free.any():
        if _inertia_attrs(inertia) is None:
            raise _bad(key, given, _why_refused(inertia))
        return inertia
    start = np.where(free, current, inertia)
    if _inertia_attrs(start) is not None:
        return start
    best = _most_valid(inertia, free, start)
    target = _TARGET_MARGIN
    if _margin(best) < target:
        raise _bad(key, given, "no values of the NaN entries make it a valid inertia (triangle inequality)")
    # The margin is quasi-concave, so along start -> best the valid tensors are one interval ending at best:
    # take its end nearest the current values.
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if _margin(start + mid * (best - start)) >= target:
            hi = mid
        else:
            lo = mid
    chosen = start + hi * (best - start)
    if _inertia_attrs(chosen) is None:
        raise _bad(key, given, "no values of the NaN entries make it a valid inertia")
    return chosen


def _most_valid(inertia: np.ndarray, free: np.ndarray, start: np.ndarray) -> np.ndarray:
    """Free entries with a large margin: free products of inertia zero and free moments equal, scanned over
    that common moment; then, if that is not enough, a pattern search over every free entry (the margin is
    quasi-concave, so a local search climbs to its maximum up to stalls at kinks, which the random
    directions get past)."""
    fixed = np.where(free, 0.0, inertia)
    scale = max(float(np.abs(fixed).max()), float(np.abs(start).max()), MJ_MINVAL)
    diag = np.eye(3, dtype=bool)

    def with_moment(c: float) -> np.ndarray:
        return np.where(free & diag, c, fixed)

    best = max((with_moment(c) for c in scale * np.logspace(-3, 1.5, 121)), key=_margin)
    if _margin(best) >= _TARGET_MARGIN:
        return best
    rows, cols = np.nonzero(np.triu(free))

    def tensor(y: np.ndarray) -> np.ndarray:
        out = fixed.copy()
        out[rows, cols] = out[cols, rows] = y * scale
        return out

    rng = np.random.default_rng(0)  # deterministic: the same text for the same values
    y, value, step = best[rows, cols] / scale, _margin(best), 0.5
    while step > 1e-9 and value < 2 * _TARGET_MARGIN:
        directions = np.vstack([np.eye(len(y)), -np.eye(len(y)), rng.normal(size=(2 * len(y), len(y)))])
        trials = [y + step * d / np.linalg.norm(d) for d in directions]
        margins = [_margin(tensor(t)) for t in trials]
        i = int(np.argmax(margins))
        if margins[i] > value:
            y, value = trials[i], margins[i]
        else:
            step /= 2
    return tensor(y)


class _Model:
    """The named elements of an MJCF tree that set_values edits."""

    def __init__(self, root: ET.Element) -> None:
        self.root = root
        self.parent = {child: el for el in root.iter() for child in el}
        self.bodies: dict[str, ET.Element] = {}
        self.joints: dict[str, ET.Element] = {}
        for world in root.findall("worldbody"):
            for el in world.iter():
                if el.tag == "body" and el.get("name"):
                    self.bodies[el.get("name", "")] = el
                elif el.tag in ("joint", "freejoint") and el.get("name"):
                    self.joints[el.get("name", "")] = el
        self.actuators = {
            el.get("name", ""): el for section in root.findall("actuator") for el in section if el.get("name")
        }

    def keys(self) -> list[str]:
        out = ["gravity"]
        for kind, names in (("body", self.bodies), ("joint", self.joints), ("actuator", self.actuators)):
            out += [f"{kind}/{n}/{f}" for n in names for f in SETTABLE_FIELDS[kind] + STRUCTURE_FIELDS[kind]]
        return out

    def element(self, kind: str, name: str) -> ET.Element:
        table = {"body": self.bodies, "joint": self.joints, "actuator": self.actuators}[kind]
        if name not in table:
            raise unknown_name(kind, name, table)
        return table[name]

    def compiler(self, attr: str) -> str | None:
        found = [c.get(attr) for c in self.root.findall("compiler") if c.get(attr) is not None]
        return found[-1] if found else None

    def flags(self) -> list[ET.Element]:
        return [f for option in self.root.findall("option") for f in option.findall("flag")]

    def disabled(self, flag: str) -> bool:
        return any(f.get(flag) == "disable" for f in self.flags())

    def enable(self, flag: str) -> None:
        for f in self.flags():
            f.attrib.pop(flag, None)

    def in_frame(self, body: ET.Element) -> bool:
        el = self.parent.get(body)
        while el is not None and el.tag not in ("body", "worldbody"):
            if el.tag == "frame":
                return True
            el = self.parent.get(el)
        return False


def _split(key: str, model: _Model) -> tuple[str, str, str]:
    """(kind, name, field) of a key; names may contain '/', so the field is the last part."""
    if not isinstance(key, str):
        raise HarnessError(f"set_values: keys are ModelView keys (strings); got {key!r}.")
    if key == "gravity":
        return "gravity", "", "gravity"
    kind, _, rest = key.partition("/")
    name, _, field_ = rest.rpartition("/")
    if kind not in SETTABLE_FIELDS or not name:
        raise unknown_name("model key", key, model.keys())
    model.element(kind, name)
    if field_ not in SETTABLE_FIELDS[kind] + STRUCTURE_FIELDS[kind]:
        raise unknown_name(f"{kind} key", key, [k for k in model.keys() if k.startswith(f"{kind}/{name}/")])
    return kind, name, field_


def _number(key: str, field_: str, value: object) -> np.ndarray:
    """The value as a float array of the key's shape; NaN allowed (keep or choose), infinities not."""
    shape = _SHAPES.get(field_, ())
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise _bad(key, value, "not a number" if not shape else f"not an array of numbers of shape {shape}") from None
    if arr.shape != shape:
        raise _bad(key, value, f"shape {arr.shape}, expected {shape or 'a scalar'}")
    if np.isinf(arr).any():
        raise _bad(key, value, "not finite (NaN entries mean 'leave as is'; infinities are refused)")
    return arr


def _same(expected: object, actual: object) -> bool:
    if isinstance(expected, str) or isinstance(actual, str):
        return bool(expected == actual)
    e, a = np.asarray(expected, dtype=float), np.asarray(actual, dtype=float)
    if e.shape != a.shape:
        return False
    scale = max(float(np.abs(e).max(initial=0.0)), float(np.abs(a).max(initial=0.0)))
    return bool(np.all(np.abs(e - a) <= READBACK_RTOL * scale))


def compiled_view(text: str) -> ModelView:
    """MuJoCo's compiled model of `text`, as a ModelView; a model MuJoCo refuses is a one-line HarnessError."""
    import mujoco

    try:
        model = mujoco.MjModel.from_xml_string(text)
    except Exception as exc:  # mujoco raises ValueError with a multi-line message
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise HarnessError(f"set_values: MuJoCo refuses the edited model: {first}") from None
    return from_mujoco(model, "set_values")


def _parse(text: str) -> ET.Element:
    """The MJCF document's root element, comments kept; not XML or not MJCF is a one-line HarnessError."""
    try:
        root = ET.fromstring(text, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))
    except ET.ParseError as exc:
        raise HarnessError(f"set_values: not well-formed XML ({exc}).") from None
    if root.tag != "mujoco":
        raise HarnessError(f"set_values: not an MJCF document (root element <{root.tag}>, expected <mujoco>).")
    return root


def _unit(key: str, given: object, arr: np.ndarray) -> np.ndarray:
    """`arr`, which must be a unit vector (MuJoCo would normalize it and not give back what was written)."""
    if not abs(float(np.linalg.norm(arr)) - 1.0) <= UNIT_RTOL:
        raise _bad(key, given, f"not a unit vector (norm {float(np.linalg.norm(arr))!r}; MuJoCo normalizes it)")
    return arr


# A body's mass, com or inertia as given: (key, the value given, it as a float array)
Given: TypeAlias = tuple[str, object, np.ndarray]


class _Edit:
    """One set_values call: the parsed model, its compiled view before the edit (compiled once, when first
    needed), what has been written, and the inertial fields and damped joints left for after the loop."""

    def __init__(self, text: str, root: ET.Element, model_view: ModelView | None) -> None:
        self.text, self.root, self.model = text, root, _Model(root)
        self.view = model_view
        self.written: dict[str, float | np.ndarray] = {}  # key -> the full value the compiled model must give back
        self.inertials: dict[str, dict[str, Given]] = {}
        self.damping_set: set[str] = set()

    def current(self) -> ModelView:
        """The compiled model of the text before the edit."""
        if self.view is None:
            self.view = compiled_view(self.text)
        return self.view

    def filled(self, key: str, arr: np.ndarray, held: np.ndarray | None) -> np.ndarray:
        """`arr` with its NaN entries from `held` (the element's own attribute), else from the compiled model."""
        if not np.isnan(arr).any():
            return arr
        return np.where(np.isnan(arr), held if held is not None else np.asarray(self.current()[key], dtype=float), arr)

    def set(self, key: str, value: object) -> None:
        """One key: a structure key checked, gravity, a body's pose, a joint's field or a gear written, or a
        body's mass, com or inertia kept for its <inertial>."""
        kind, name, field_ = _split(key, self.model)
        if field_ in STRUCTURE_FIELDS.get(kind, ()):
            have = self.current()[key]
            if value != have:
                raise HarnessError(
                    f"set_values: {key} is {have!r} in the model, got {value!r}; the writer cannot change the "
                    "tree's structure (parents, joint types, which body a joint moves, which joint an actuator drives) "
                    "or a joint's ref."
                )
            return
        arr = _number(key, field_, value)
        if kind == "gravity":
            self.gravity(key, arr)
            return
        el = self.model.element(kind, name)
        if kind == "body" and field_ in ("mass", "com", "inertia"):
            self.inertials.setdefault(name, {})[field_] = (key, value, arr)
        elif kind == "body":
            self.body_pose(el, key, name, field_, value, arr)
        elif kind == "joint":
            self.joint(el, key, name, field_, value, arr)
        elif not np.isnan(arr):  # actuator gear: the first entry
            gear = (el.get("gear") or "").split() or [repr(float(arr))]
            gear[0] = repr(float(arr))
            el.set("gear", " ".join(gear))
            self.written[key] = float(arr)

    def gravity(self, key: str, arr: np.ndarray) -> None:
        """<option gravity>, enabling gravity where the scene disables it and the new value is not zero."""
        off = self.model.disabled("gravity")
        option = self.root.find("option")
        held = np.zeros(3) if off else _attr_vector(option, "gravity", 3)
        if held is None:
            held = np.array([float(x) for x in MUJOCO_DEFAULT_GRAVITY.split()])
        g = self.filled(key, arr, held)
        self.written[key] = g
        if off and not np.any(g):
            return  # the scene's gravity stays disabled, and zero is what the model has
        if off:
            self.model.enable("gravity")
        if option is None:
            option = ET.Element("option")
            self.root.insert(0, option)
        option.set("gravity", _floats(g))

    def body_pose(self, el: ET.Element, key: str, name: str, field_: str, value: object, arr: np.ndarray) -> None:
        """A body's pos, or its quat (replacing any other orientation attribute)."""
        if self.model.in_frame(el):
            raise _bad(key, value, f"body '{name}' sits inside a <frame>, whose transform the writer does not invert")
        if field_ == "pos":
            self.written[key] = self.filled(key, arr, _attr_vector(el, "pos", 3))
            el.set("pos", _floats(self.written[key]))
            return
        quat = _unit(key, value, self.filled(key, arr, _attr_vector(el, "quat", 4)))
        for attr in _ORIENTATION_ATTRS:
            el.attrib.pop(attr, None)
        el.set("quat", _floats(quat))
        self.written[key] = quat

    def joint(self, el: ET.Element, key: str, name: str, field_: str, value: object, arr: np.ndarray) -> None:
        """A joint's axis or pos, or a non-negative damping, armature, frictionloss or stiffness."""
        if el.tag == "freejoint":
            raise _bad(key, value, f"joint '{name}' is a <freejoint>, which takes no {field_}")
        if field_ in ("axis", "pos"):
            vec = self.filled(key, arr, _attr_vector(el, field_, 3))
            self.written[key] = _unit(key, value, vec) if field_ == "axis" else vec
            el.set(field_, _floats(self.written[key]))
        elif field_ == "springref":
            self.springref(el, key, name, arr)
        elif not np.isnan(arr):
            if arr < 0:
                raise _bad(key, value, "must be non-negative")
            el.set(field_, repr(float(arr)))
            self.written[key] = float(arr)
            if field_ == "damping":
                self.damping_set.add(name)

    def springref(self, el: ET.Element, key: str, name: str, arr: np.ndarray) -> None:
        """A joint's springref, given as compiled (rad for a hinge), written in the file's <compiler angle>
        (degrees unless it says radian: MJCF's default)."""
        if np.isnan(arr):
            return
        degrees = self.current()[f"joint/{name}/type"] == "hinge" and self.model.compiler("angle") != "radian"
        el.set("springref", repr(float(np.degrees(arr)) if degrees else float(arr)))
        self.written[key] = float(arr)

    def enable_dampers(self) -> None:
        """Dampers enabled where the scene disables them and a damping set is not zero; the other joints'
        damping set to 0, which is what the model had."""
        model = self.model
        if any(self.written[f"joint/{n}/damping"] != 0 for n in self.damping_set) and model.disabled("damper"):
            model.enable("damper")
            for n, joint in model.joints.items():
                if n not in self.damping_set and joint.tag == "joint":
                    joint.set("damping", "0")  # what the model had while dampers were disabled


def set_values(
    text: str, values: Mapping[str, object], *, model_view: ModelView | None = None, verify: bool = True
) -> str:
    """The MJCF `text` edited so that its compiled model (`modelview.from_mujoco`) has `values`.

    Args:
        text: an MJCF document.
        values: ModelView keys (see validate/model/modelview.py) to their new values, at full precision. NaN
            entries (or a NaN scalar) mean "leave as is"; an inertia's NaN entries may be chosen: the current
            ones are kept where the tensor stays a body's, else values are chosen that make it one, with
            principal moments satisfying A + B >= 1.05 C. Structure keys (parent, type, body, joint) must
            equal what the model has.
        model_view: the compiled model of `text`, for what the text does not hold (a body without
            <inertial>, an orientation given as euler, a default class's joint axis); compiled here if absent.
        verify: compile the result and check that every key reads back as written (to READBACK_RTOL)
            and every other key is unchanged.

    Setting a non-zero damping where the scene disables dampers, or a non-zero gravity where it disables
    gravity, enables that flag (the other joints' damping is set to 0 explicitly, which is what the model
    had). An unknown key or name, a bad shape, an infinite or unphysical value, or an edit the MJCF
    compiler would not give back (a body inside a <frame>, inertia from geoms) is a one-line HarnessError.
    """
    root = _parse(text)
    edit = _Edit(text, root, model_view)
    for key, value in values.items():
        edit.set(key, value)
    edit.enable_dampers()
    if edit.inertials and edit.model.compiler("inertiafromgeom") == "true":
        _inertia_as_compiled(edit.model, edit.current())
    for name, fields in edit.inertials.items():
        _write_inertial(edit.model, name, fields, edit.current, edit.written)
    edited = _prolog(text) + ET.tostring(root, encoding="unicode")
    if verify:
        _verify(edited, edit.current(), edit.written)
    return edited


def _inertia_as_compiled(model: _Model, view: ModelView) -> None:
    """<compiler inertiafromgeom="true"> (every body's inertia from its geoms, <inertial> ignored) made
    "auto", each <inertial> the model has set to what the geoms gave: the compiled model is unchanged,
    and a body's inertia can now be written."""
    for compiler in model.root.findall("compiler"):
        if compiler.get("inertiafromgeom") is not None:
            compiler.set("inertiafromgeom", "auto")
    for name, body in model.bodies.items():
        inertial = body.find("inertial")
        if inertial is None:
            continue
        attrs = _inertia_attrs(np.asarray(view[f"body/{name}/inertia"], dtype=float))
        assert attrs is not None  # a tensor MuJoCo compiled
        inertial.attrib.clear()
        inertial.attrib.update(
            {"mass": repr(float(view[f"body/{name}/mass"])), "pos": _floats(view[f"body/{name}/com"]), **attrs}
        )


def _write_inertial(
    model: _Model,
    name: str,
    fields: dict[str, Given],
    current: Callable[[], ModelView],
    written: dict[str, float | np.ndarray],
) -> None:
    """Mass, com and inertia of one body into its <inertial> (created, from the compiled model, if absent)."""
    body = model.bodies[name]
    for key, value, _ in fields.values():
        if float(model.compiler("settotalmass") or "-1") > 0:
            raise _bad(key, value, "<compiler settotalmass> rescales every mass")
    inertial = body.find("inertial")
    if inertial is None and all(np.isnan(arr).all() for _, _, arr in fields.values()):
        return
    if inertial is None:
        inertial = ET.Element("inertial")
        body.insert(0, inertial)
        fields = {
            f: fields.get(f, (f"body/{name}/{f}", None, np.full(_SHAPES.get(f, ()), np.nan)))
            for f in ("com", "mass", "inertia")
        }
    if "mass" in fields:
        key, value, arr = fields["mass"]
        mass = float(current()[key]) if np.isnan(arr) else float(arr)
        if not mass > 0:
            raise _bad(key, value, "must be positive")
        inertial.set("mass", repr(mass))
        written[key] = mass
    if "com" in fields:
        key, value, arr = fields["com"]
        held = _attr_vector(inertial, "pos", 3)
        com = np.where(np.isnan(arr), held if held is not None else current()[key], arr) if np.isnan(arr).any() else arr
        inertial.set("pos", _floats(com))
        written[key] = com
    if "inertia" in fields:
        key, value, arr = fields["inertia"]
        tensor = _complete_inertia(key, arr, np.asarray(current()[key], dtype=float))
        attrs = _inertia_attrs(tensor)
        assert attrs is not None  # _complete_inertia returns only tensors MuJoCo accepts
        for attr in ("diaginertia", "fullinertia", *_ORIENTATION_ATTRS):
            inertial.attrib.pop(attr, None)
        inertial.attrib.update(attrs)
        written[key] = tensor


def _verify(edited: str, before: ModelView, written: dict[str, float | np.ndarray]) -> None:
    """Every written key reads back as written and every other key as it was."""
    after = compiled_view(edited)
    for key in sorted(set(before) | set(after)):
        want = written.get(key, before.get(key))
        got = after.get(key)
        if want is None or got is None or not _same(want, got):
            raise HarnessError(
                f"set_values: {key} compiles to {_show(got)}, not {_show(want)}; the MJCF compiler changes it "
                "(a <compiler> setting such as boundmass, boundinertia or balanceinertia?)."
            )

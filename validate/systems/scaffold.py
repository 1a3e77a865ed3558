"""`lagrange-xval new NAME --model PATH`: a starting equations module for a person's own model.

Everything the harness can read off the compiled model is written out: the coordinates (one per
hinge or slide joint, in the model's order), the bodies, what the scene uses, a `Params` dataclass
with one field per number the dynamics can depend on (each body's mass, centre of mass, inertia
about it and position in its parent; each joint's anchor, damping, armature and stiffness; each
actuator's gear; the gravity's magnitude), `parameters(model)` reading every field by MuJoCo name,
and `assumptions(p)` stating the whole model in those fields, so that the harness's probes can move
every one. Orientations (body frames, joint axes, the direction of gravity) are conventions of the
derivation: written as constants, and described in the module's docstring.

The dynamics, energies and body poses are left to the person: stubs marked `not_provided` that the
harness counts as absent. Until one of the four forms is written, checking the module says so.
"""

from __future__ import annotations

import keyword
import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import HarnessError
from ..files import create_file
from . import compile_model
from .modelview import ModelView, from_mujoco


def _ident(name: str) -> str:
    """A Python identifier from a MuJoCo name."""
    out = re.sub(r"\W", "_", name)
    out = out if out and not out[0].isdigit() else f"_{out}"
    return f"{out}_" if keyword.iskeyword(out) else out


def _vec(x: Any) -> str:
    return "(" + ", ".join(repr(float(v)) for v in np.ravel(x)) + ")"


def _fields(view: ModelView, bodies: list[str], joints: list[str], actuators: list[str]) -> list[tuple[str, str, str]]:
    """(field, model expression, comment) for every number of the Params dataclass."""
    out = []
    for b in bodies:
        i = _ident(b)
        out.append((f"m_{i}", f'model["body/{b}/mass"]', f"kg, mass of body {b}"))
        out += [
            (f"c{a}_{i}", f'model["body/{b}/com"][{k}]', f"m, centre of mass of {b} in its frame")
            for k, a in enumerate("xyz")
        ]
        for r, c, name in ((0, 0, "xx"), (1, 1, "yy"), (2, 2, "zz"), (0, 1, "xy"), (0, 2, "xz"), (1, 2, "yz")):
            out.append(
                (
                    f"I{name}_{i}",
                    f'model["body/{b}/inertia"][{r}][{c}]',
                    f"kg m^2, inertia of {b} about its centre of mass",
                )
            )
        out += [
            (f"p{a}_{i}", f'model["body/{b}/pos"][{k}]', f"m, origin of {b} in its parent's frame")
            for k, a in enumerate("xyz")
        ]
    for j in joints:
        i = _ident(j)
        out += [
            (f"j{a}_{i}", f'model["joint/{j}/pos"][{k}]', f"m, anchor of joint {j} in its body's frame")
            for k, a in enumerate("xyz")
        ]
        unit = "N s/m" if view[f"joint/{j}/type"] == "slide" else "N m s/rad"
        out.append((f"d_{i}", f'model["joint/{j}/damping"]', f"{unit}, viscous damping of {j}"))
        out.append((f"arm_{i}", f'model["joint/{j}/armature"]', f"armature of {j} (added to M's diagonal)"))
        out.append((f"k_{i}", f'model["joint/{j}/stiffness"]', f"stiffness of {j}"))
    for a in actuators:
        out.append(
            (
                f"gear_{_ident(a)}",
                f'model["actuator/{a}/gear"]',
                f"gear of actuator {a} (on joint {view[f'actuator/{a}/joint']})",
            )
        )
    out.append(("g", 'float(np.linalg.norm(model["gravity"]))', "m/s^2, magnitude of gravity"))
    return out


def module_text(name: str, model: Path) -> str:
    """The text of the starting equations module for the MJCF at `model`."""
    mj = compile_model(model)
    view = from_mujoco(mj, model.name)
    keys = list(view)
    bodies = [k.split("/")[1] for k in keys if k.startswith("body/") and k.endswith("/mass")]
    joints = [k.split("/")[1] for k in keys if k.startswith("joint/") and k.endswith("/type")]
    actuators = [k.split("/")[1] for k in keys if k.startswith("actuator/") and k.endswith("/gear")]
    bad = [j for j in joints if view[f"joint/{j}/type"] not in ("hinge", "slide")]
    if bad:
        raise HarnessError(
            f"{model.name}: joint '{bad[0]}' is a {view[f'joint/{bad[0]}/type']} joint; only hinge and slide joints."
        )
    gravity = np.asarray(view["gravity"], dtype=float)
    g = float(np.linalg.norm(gravity))
    down = gravity / g if g > 0 else np.array([0.0, 0.0, -1.0])
    uses = sorted(
        ({"gravity"} if g > 0 else set())
        | ({"damping"} if any(view[f"joint/{j}/damping"] > 0 for j in joints) else set())
        | ({"actuation"} if actuators else set())
    )
    fields = _fields(view, bodies, joints, actuators)
    lines_conv = [f"    gravity: g (Params.g) along {_vec(down)} in world coordinates"]
    for b in bodies:
        lines_conv.append(
            f"    body {b}: child of {view[f'body/{b}/parent']}, its frame rotated by quat (w, x, y, z) "
            f"{_vec(view[f'body/{b}/quat'])} in its parent's frame at q = 0"
        )
    for j in joints:
        lines_conv.append(
            f"    joint {j} ({view[f'joint/{j}/type']}): moves body {view[f'joint/{j}/body']} along/about axis "
            f"{_vec(view[f'joint/{j}/axis'])} of its frame; {j} = 0 at the model's reference pose"
        )
    coords = tuple(_ident(j) for j in joints)
    t = []
    t.append(f'"""{name}: the equations of motion of {model.name}, to be derived by hand.')
    t.append("")
    t.append(f"Written by `lagrange-xval new` from {model}. Every number is read from the compiled model by")
    t.append("name (`parameters`); `assumptions` states the model in the Params fields, so the harness can")
    t.append("move each one independently. Conventions (constants of the derivation, from the model):")
    t.append("")
    t += lines_conv
    t.append("")
    t.append("Coordinates q = (" + ", ".join(coords) + "), one per joint, in rad (hinge) or m (slide). Write the")
    t.append("dynamics in ONE of the four forms, with numpy on arrays whose last axis is the coordinate:")
    t.append("    (a) mass_matrix(p, q) and bias(p, q, v) (+ passive(p, q, v))")
    t.append("    (b) residual(p, q, v, a, tau): M a + C v + G - passive - tau, row by row")
    t.append("    (c) qacc(p, q, v, tau)")
    t.append("    (d) kinetic_energy(p, q, v) and potential_energy(p, q) (+ passive(p, q, v))")
    t.append("and kinetic_energy, potential_energy, body_positions (centres of mass in the world) and")
    t.append("body_rotations (body frames in the world). The stubs below are counted as not provided: until")
    t.append("the dynamics are written, checking this module says so.")
    t.append('"""')
    t.append("")
    t.append("from __future__ import annotations")
    t.append("")
    t.append("from dataclasses import dataclass")
    t.append("from typing import Any")
    t.append("")
    t.append("import numpy as np")
    t.append("from lagrange_xval.equations._forms import not_provided")
    t.append("")
    t.append(f"DESCRIPTION = {f'{name}: the model {model.name}, derived by hand.'!r}")
    t.append(f"COORDINATES = {coords!r}")
    t.append(f"JOINTS = {tuple(joints)!r}")
    t.append(f"BODIES = {tuple(bodies)!r}")
    t.append(f"USES = frozenset({set(uses)!r})" if uses else "USES: frozenset[str] = frozenset()")
    t.append(f"GRAVITY_DIRECTION = np.array({_vec(down)})")
    t.append("VARIANTS = ()")
    t.append("")
    t.append("")
    t.append("@dataclass(frozen=True)")
    t.append("class Params:")
    t += [f"    {f}: float  # {c}" for f, _, c in fields]
    t.append("")
    t.append("")
    t.append("def parameters(model: Any) -> Params:")
    t.append('    """Every number of the dynamics, read from the compiled model by name."""')
    t.append("    return Params(")
    t += [f"        {f}=float({e})," for f, e, _ in fields]
    t.append("    )")
    t.append("")
    t.append("")
    t.append("def assumptions(p: Params) -> dict[str, Any]:")
    t.append('    """The compiled model this derivation describes, in the Params fields."""')
    t.append("    return {")
    t.append('        "gravity": p.g * GRAVITY_DIRECTION,')
    for b in bodies:
        i = _ident(b)
        t.append(f'        "body/{b}/parent": {view[f"body/{b}/parent"]!r},')
        t.append(f'        "body/{b}/mass": p.m_{i},')
        t.append(f'        "body/{b}/com": np.array([p.cx_{i}, p.cy_{i}, p.cz_{i}]),')
        t.append(
            f'        "body/{b}/inertia": np.array([[p.Ixx_{i}, p.Ixy_{i}, p.Ixz_{i}], '
            f"[p.Ixy_{i}, p.Iyy_{i}, p.Iyz_{i}], [p.Ixz_{i}, p.Iyz_{i}, p.Izz_{i}]]),"
        )
        t.append(f'        "body/{b}/pos": np.array([p.px_{i}, p.py_{i}, p.pz_{i}]),')
        t.append(f'        "body/{b}/quat": np.array({_vec(view[f"body/{b}/quat"])}),')
    for j in joints:
        i = _ident(j)
        t.append(f'        "joint/{j}/type": {view[f"joint/{j}/type"]!r},')
        t.append(f'        "joint/{j}/body": {view[f"joint/{j}/body"]!r},')
        t.append(f'        "joint/{j}/axis": np.array({_vec(view[f"joint/{j}/axis"])}),')
        t.append(f'        "joint/{j}/pos": np.array([p.jx_{i}, p.jy_{i}, p.jz_{i}]),')
        t.append(f'        "joint/{j}/damping": p.d_{i},')
        t.append(f'        "joint/{j}/armature": p.arm_{i},')
        t.append(f'        "joint/{j}/frictionloss": 0.0,')
        t.append(f'        "joint/{j}/stiffness": p.k_{i},')
    for a in actuators:
        t.append(f'        "actuator/{a}/joint": {view[f"actuator/{a}/joint"]!r},')
        t.append(f'        "actuator/{a}/gear": p.gear_{_ident(a)},')
    t.append("    }")
    stubs = (
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
    for fn, args, ret, doc in stubs:
        t += ["", "", "@not_provided", f"def {fn}({args}) -> {ret}:", f'    """{doc}"""']
    return "\n".join(t) + "\n"


def write_module(name: str, model: Path, folder: Path | None = None) -> Path:
    """Writes FOLDER/NAME.py (default: the model's folder); refuses to overwrite a file."""
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name) or keyword.iskeyword(name):
        raise HarnessError(f"'{name}' is not a valid module name: use letters, digits and _ (not first a digit).")
    model = Path(model)
    if not model.is_file():
        raise HarnessError(f"model file not found: {model} (give an MJCF .xml or a URDF .urdf file).")
    path = Path(folder or model.parent) / f"{name}.py"
    if path.parent.exists() and not path.parent.is_dir():
        raise HarnessError(f"--dir {path.parent} is a file, not a folder.")
    exists = f"{path} exists already; choose another NAME or --dir (nothing is overwritten)."
    if os.path.lexists(path):  # a link, even a dangling one, is something there
        raise HarnessError(exists)
    text = module_text(name, model)  # everything checked before anything is written
    try:
        create_file(path, text)  # never through a link, never over a file
    except FileExistsError:
        raise HarnessError(exists) from None
    return path

"""A person's Matlab function as an equations module: run by GNU Octave as written, judged in form (c).

The notes simulate their equations with `ode45(@double_bob_pendulum, ...)`, a function of the state
y = [q; v] that returns dydt = [v; a]. Such a file is a form of the contract, read against its model:

    function dydt = double_bob_pendulum(t, y)          % parameters written inside: nothing to probe
    function dydt = cart_pole(t, y, p)                 % a struct p of named parameters: probed
    function dydt = arm(t, y, tau)                     % inputs: a generalized force on every coordinate
    function dydt = arm(t, y, p, tau)                  % (named u: the actuators' controls, in the model's order)

and comment lines anywhere in the file say what the harness cannot read off Matlab text:

    % coordinates: theta, phi          the order of q in y (default: the model's joints, in order)
    % joints: shoulder, elbow          the model joint each coordinate is (default: the coordinates)
    % p.m = body/pole/mass             a field of p bound to a model key, as a text form binds a symbol:
    % p.g = -gravity[2]                [-][factor*]key[i][j] (validate/handwritten/textform.py)

Nothing of the file is evaluated here. Its signature and comment lines are read as text; the function
is run by Octave (handwritten/octave.py) in the worker process of a small generated module (`qacc`, form
c), under the module's time limit, all the states of a call in one request. A function with no input
(the notes' two) gives no mass matrix: it is judged in accelerations (gravity, velocity, friction),
as explicit accelerations with the actuators' controls are (forms.accelerations_only). A function
whose parameters are written inside it gives the probes nothing to move (the verdict says what that
hides: verdict/words.py NOTHING_TO_PROBE); a struct p gives them its bound fields. Octave computes on
numbers, so the stages that integrate the equations as expressions (the Taylor reference, chaos, the
notes' experiments) are not run for it (`NUMBERS_ONLY` says why).
"""

from __future__ import annotations

import dataclasses
import re
import types
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from ..core.errors import HarnessError, shown
from ..core.guard import DEFAULT_TIME_LIMIT
from ..core.inputs import regular_file
from ..model import modelview
from .octave import CALLS, EXECUTABLE, INSTALL_HINT, NUMBERS_ONLY
from .reads import ModelValue
from .textform import Binding, bound_assumptions, moved_bodies, parse_binding, uses_of

MAX_BYTES = 2**20
STRUCT_NAMES = frozenset({"p", "P", "par", "params", "param", "parameters"})  # a third input read as the struct
_FUNCTION = re.compile(r"^\s*function\s+(?:(\[[^\]]*\]|[A-Za-z]\w*)\s*=\s*)?([A-Za-z]\w*)\s*(?:\(([^)]*)\))?")
_DIRECTIVE = re.compile(r"^\s*[%#]+\s*(coordinates|joints)\s*:\s*(.*?)\s*$", re.IGNORECASE)
_FIELD = re.compile(r"^\s*[%#]+\s*([A-Za-z]\w*)\.([A-Za-z]\w*)\s*=\s*(.*?)\s*;?\s*$")


@dataclass(frozen=True)
class Signature:
    """What the file's first function line and comment lines say."""

    name: str
    mode: str  # one of octave.CALLS
    input_name: str  # "tau" or "u" (the stand-in's last parameter)
    coordinates: tuple[str, ...] | None
    joints: tuple[str, ...] | None
    bindings: tuple[Binding, ...]


def _text(path: Path) -> str:
    raw = regular_file(path, "equations file", max_bytes=MAX_BYTES)
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw.decode("latin-1")  # Matlab's own files are often in the platform's 8-bit encoding


def _function_line(text: str, where: str) -> re.Match[str]:
    """The first line of code, which must declare a function (a script cannot be called with a state)."""
    for line in text.splitlines():
        code = line.split("%", 1)[0].split("#", 1)[0].strip()
        if not code:
            continue
        match = _FUNCTION.match(code)
        if match is None:
            raise HarnessError(
                f"{where}: the first line of code is not a function declaration ({shown(code, 60)!r}); "
                "write `function dydt = NAME(t, y)` (or (t, y, p), (t, y, tau), (t, y, p, tau)) as ode45 calls it."
            )
        return match
    raise HarnessError(f"{where}: no code; write `function dydt = NAME(t, y)` returning [dq; dv].")


def _mode(inputs: list[str], struct: str | None, where: str) -> tuple[str, str]:
    """(how the function is called, the stand-in's input name) from its inputs after (t, y)."""
    extra = inputs[2:]
    if len(inputs) < 2 or len(inputs) > 4:
        raise HarnessError(
            f"{where}: the function takes {len(inputs)} inputs ({', '.join(inputs) or 'none'}); valid: (t, y), "
            "(t, y, p) with a struct of parameters, (t, y, tau) with inputs, or (t, y, p, tau)."
        )
    if len(extra) == 2:
        return "t,y,p,tau", "u" if extra[1] == "u" else "tau"
    if len(extra) == 1 and (extra[0] == struct or (struct is None and extra[0] in STRUCT_NAMES)):
        return "t,y,p", "u"
    if len(extra) == 1:
        return "t,y,tau", "u" if extra[0] == "u" else "tau"
    return "t,y", "u"  # no input: judged in accelerations, as controls the function leaves out


def read_signature(path: Path) -> Signature:
    """The function's name, how it is called, and what its comment lines declare (nothing evaluated)."""
    where = str(path)
    if not path.stem.isidentifier() or not path.stem.isascii():
        raise HarnessError(
            f"{where}: Matlab and Octave call a function by its file's name, and {path.stem!r} is not one "
            "(letters, digits and _, starting with a letter); rename the file."
        )
    text = _text(path)
    match = _function_line(text, where)
    inputs = [a.strip() for a in (match.group(3) or "").split(",") if a.strip()]
    lines = text.splitlines()
    fields = [m for m in (_FIELD.match(x) for x in lines) if m is not None]
    structs = {m.group(1) for m in fields}
    struct = inputs[2] if len(inputs) >= 3 and inputs[2] in structs else None
    mode, input_name = _mode(inputs, struct, where)
    if "p" not in mode.split(",") and fields:
        raise HarnessError(
            f"{where}: `% {fields[0].group(1)}.{fields[0].group(2)} = ...` binds a struct the function does not take; "
            "declare it: function dydt = NAME(t, y, p)."
        )
    if "p" in mode.split(",") and not fields:
        raise HarnessError(
            f"{where}: the function takes a struct {inputs[2]} of parameters; bind each field it reads to a model key "
            f"with a comment line, e.g. `% {inputs[2]}.m = body/pole/mass` or `% {inputs[2]}.g = -gravity[2]`."
        )
    bindings = tuple(parse_binding(m.group(2), m.group(3), where) for m in fields)
    names = {d.group(1).lower(): _names(d.group(2)) for d in (_DIRECTIVE.match(x) for x in lines) if d is not None}
    return Signature(path.stem, mode, input_name, names.get("coordinates"), names.get("joints"), bindings)


def _names(text: str) -> tuple[str, ...]:
    return tuple(n for n in re.split(r"[\s,;]+", text.strip("[](){} ")) if n)


def _coordinates(sig: Signature, joints_of_model: tuple[str, ...], where: str) -> tuple[tuple[str, ...], ...]:
    """(coordinates, joints): declared, or the model's joints in order; every joint checked."""
    coordinates = sig.coordinates or sig.joints or joints_of_model
    joints = sig.joints or coordinates
    if len(joints) != len(coordinates):
        raise HarnessError(f"{where}: {len(joints)} joints for {len(coordinates)} coordinates.")
    missing = [j for j in joints if j not in joints_of_model]
    if missing:
        hint = "" if sig.joints else " (the coordinates are joint names unless a `% joints: ...` line says which)"
        raise HarnessError(
            f"{where}: {missing[0]!r} is not a joint of the model{hint}; its joints: {', '.join(joints_of_model)}."
        )
    return coordinates, joints


SOURCE = '''"""The worker side of {file}: its function run by GNU Octave (written by lagrange-xval)."""

from lagrange_xval.handwritten.octave import Octave

_OCTAVE = Octave({folder!r}, {name!r}, {mode!r})


def qacc(p, q, v, {input}):
    return _OCTAVE.accelerations(p, q, v, {input}, {fields!r})
'''


def module_from_file(
    path: Path, view: Mapping[str, ModelValue], *, time_limit: float = DEFAULT_TIME_LIMIT
) -> types.ModuleType:
    """The equations module (form c) a Matlab function file is, read against the model `view`; its function
    runs in Octave in the module's worker (handwritten/octave.py), within `time_limit` s for all its calls."""
    import shutil

    path = Path(path).absolute()
    sig = read_signature(path)
    if shutil.which(EXECUTABLE) is None:
        raise HarnessError(f"{path}: {INSTALL_HINT}.")
    coordinates, joints = _coordinates(sig, tuple(modelview.names(view, "joint", "type")), str(path))
    for b in sig.bindings:  # every key and index must exist now, not at the first parameters() call
        try:
            b.read(view)
        except HarnessError as exc:
            raise HarnessError(f"{path}: {exc}") from None
    fields = [b.symbol for b in sig.bindings]
    source = SOURCE.format(
        file=path.name, folder=str(path.parent), name=sig.name, mode=sig.mode, input=sig.input_name, fields=fields
    )
    from .proxy import worker_module

    module = worker_module(path, time_limit, source=source)
    Params = dataclasses.make_dataclass("Params", [(f, float) for f in fields], frozen=True)
    description = f"{path.name}: a Matlab function, run by GNU Octave"
    module.__doc__ = description
    module.__dict__.update(
        {
            "DESCRIPTION": description,
            "COORDINATES": coordinates,
            "JOINTS": joints,
            "BODIES": moved_bodies(view, joints),
            "USES": uses_of(view, joints),
            "Params": Params,
            "parameters": lambda model: Params(**{b.symbol: b.read(model) for b in sig.bindings}),
            "assumptions": bound_assumptions(view, sig.bindings),
            "MATLAB": {"function": sig.name, "call": CALLS[sig.mode]},
            "NUMBERS_ONLY": NUMBERS_ONLY,
        }
    )
    return module

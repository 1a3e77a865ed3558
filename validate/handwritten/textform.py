"""Equations as text: the energies from paper in a TOML file, checked without writing Python.

A student writes T and V (and, optionally, the generalized friction forces) as expressions in their
own symbols, and binds each symbol to a key of the compiled model (validate/model/modelview.py):

    # cart_pole.toml: a cart-pole, energies from paper
    description = "Cart-pole from my notes"          # optional
    coordinates = ["x", "theta"]                      # optional: default the model's joints in order
    velocities = ["dx", "dtheta"]                     # optional: default "d" + coordinate
    joints = ["x", "theta"]                           # optional: default the coordinates (joint names)
    T = "(mc + mp)/2*dx^2 + mp*lc*cos(theta)*dx*dtheta + (mp*lc^2 + I)/2*dtheta^2"
    V = "mc*g*(h + ccz) + mp*g*(h + pz + lc*cos(theta))"   # from the world origin's height, as the engines
    friction = ["-kx*dx", "0"]                        # optional: one generalized force per coordinate
    [symbols]                                         # symbol = [-][factor*]key[i][j]
    mc = "body/cart/mass"
    mp = "body/pole/mass"
    lc = "body/pole/com[2]"
    I = "body/pole/inertia[1][1]"
    kx = "joint/x/damping"
    g = "-gravity[2]"
    h = "body/cart/pos[2]"
    ccz = "body/cart/com[2]"
    pz = "body/pole/pos[2]"

Nothing is evaluated: each expression is read by validate/handwritten/expression.py, and only numbers, the
declared names, + - * / ** (or ^), unary -, pi and the functions in FUNCTIONS are turned into sympy;
anything else is a one-line HarnessError naming the expression, the offending part and what is
valid. Its size, depth and number of terms are bounded, powers of numbers are judged by their size
before they are computed, and a division by zero or any constant that is not a finite real number is
named. Names are NFKC-normalised (µ is μ); two declared names that normalise to one are refused,
naming both spellings. The file is read against its model (`System.from_files`): the coordinates must be joints of
the model (or `joints` names them), and every key must exist. It becomes an equations module in
form (d) (validate/handwritten/forms.py differentiates T and V): `Params` of the symbols, `parameters`
reading the bound keys, and `assumptions` stating the bound numbers (so that the probes move them)
and every other number of the model as not depended on (NaN: a text file cannot state the geometry
its T and V assume; the model's other numbers are taken as they are).
"""

from __future__ import annotations

import dataclasses
import keyword
import re
import tomllib
import types
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import HarnessError, shown
from ..core.guard import DEFAULT_TIME_LIMIT
from ..core.inputs import regular_file
from ..model import modelview
from . import textcode
from .expression import CONSTANTS, FUNCTIONS, lambdified, normalized, to_sympy
from .reads import ModelValue

MAX_BYTES = 2**20
KEYS = ("description", "coordinates", "velocities", "joints", "T", "V", "friction", "symbols")
_BINDING = re.compile(  # the key may hold spaces inside a name (body/upper arm/mass), not at its ends
    r"^\s*(-)?\s*(?:(\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)\s*\*\s*)?([^\s\[\]*](?:[^\[\]*]*[^\s\[\]*])?)"
    r"((?:\[\s*\d+\s*\])*)\s*$"
)


@dataclass(frozen=True)
class Binding:
    """symbol = scale * model[key][index]."""

    symbol: str
    key: str
    index: tuple[int, ...]
    scale: float

    def read(self, model: Mapping[str, ModelValue]) -> float:
        value = np.asarray(model[self.key])
        try:
            entry = value[self.index] if self.index else value
        except IndexError:
            shape = value.shape
            raise HarnessError(f"symbol {self.symbol}: {self.key} has shape {shape}; no entry {self.index}.") from None
        if entry.shape != () or entry.dtype.kind not in "fiu":
            raise HarnessError(
                f"symbol {self.symbol}: {self.key}{_index_text(self.index)} is not a number (shape {entry.shape}); "
                "give an index, [i] or [i][j]."
            )
        return self.scale * float(entry)


def _index_text(index: tuple[int, ...]) -> str:
    return "".join(f"[{i}]" for i in index)


def parse_binding(symbol: str, text: object, where: str) -> Binding:
    """A [symbols] entry: `[-][factor*]key[i][j]`."""
    match = _BINDING.match(text) if isinstance(text, str) else None
    if match is None:
        raise HarnessError(
            f"{where}: symbols.{symbol} = {text!r} is not a model key; write [-][factor*]key[i][j], "
            'e.g. "body/pole/mass", "-gravity[2]", "2*body/pole/com[2]".'
        )
    sign, factor, key, index = match.groups()
    scale = (-1.0 if sign else 1.0) * (float(factor) if factor else 1.0)
    return Binding(symbol, key, tuple(int(i) for i in re.findall(r"\d+", index)), scale)


@dataclass(frozen=True)
class Spec:
    """What the file says, checked: names, expressions (text) and bindings."""

    description: str
    coordinates: tuple[str, ...]
    velocities: tuple[str, ...]
    joints: tuple[str, ...]
    T: str
    V: str
    friction: tuple[str, ...] | None
    bindings: tuple[Binding, ...]


def _read(path: Path) -> dict[str, object]:
    try:
        data = tomllib.loads(regular_file(path, "equations file", max_bytes=MAX_BYTES).decode())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise HarnessError(f"{path}: not a valid TOML file ({exc}).") from None
    unknown = sorted(set(data) - set(KEYS))
    if unknown:
        raise HarnessError(f"{path}: unknown key {unknown[0]!r}; valid: {', '.join(KEYS)}.")
    for key in ("T", "V"):
        if key not in data:
            raise HarnessError(f'{path}: no {key}; write {key} = "..." (an expression in your symbols).')
    return data


def _names(data: dict[str, object], key: str, default: list[str], where: str) -> tuple[str, ...]:
    value = data.get(key, default)
    if not isinstance(value, list) or not all(isinstance(x, str) for x in value):
        raise HarnessError(f"{where}: {key} must be a list of names, e.g. {key} = {default!r}.")
    return tuple(value)


def _expression_text(value: object, what: str, where: str) -> str:
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise HarnessError(f'{where}: {what} must be an expression in a string, e.g. "m*g*l*cos(theta)".')
    return str(value)


def read_spec(path: Path, joints_of_model: tuple[str, ...]) -> Spec:
    """The file's content, with every name and binding checked (not yet the expressions)."""
    where = str(path)
    data = _read(path)
    coordinates = _names(data, "coordinates", list(joints_of_model), where)
    velocities = _names(data, "velocities", [f"d{c}" for c in coordinates], where)
    joints = _names(data, "joints", list(coordinates), where)
    symbols = data.get("symbols", {})
    if not isinstance(symbols, dict):
        raise HarnessError(f'{where}: [symbols] must be a table of symbol = "model key".')
    friction = data.get("friction")
    if friction is not None and (not isinstance(friction, list) or len(friction) != len(coordinates)):
        raise HarnessError(f"{where}: friction must be a list of {len(coordinates)} expressions, one per coordinate.")
    for what, names in (("velocities", velocities), ("joints", joints)):
        if len(names) != len(coordinates):
            raise HarnessError(f"{where}: {len(names)} {what} for {len(coordinates)} coordinates.")
    plain = _check_names(where, [*coordinates, *velocities, *symbols])
    missing = [j for j in joints if j not in joints_of_model]
    if missing:
        hint = "" if "joints" in data else " (the coordinates are joint names unless joints = [...] says which)"
        raise HarnessError(
            f"{where}: {missing[0]!r} is not a joint of the model{hint}; its joints: {', '.join(joints_of_model)}."
        )
    description = data.get("description", f"{path.name}: T and V from paper")
    return Spec(
        str(description),
        plain[: len(coordinates)],
        plain[len(coordinates) : 2 * len(coordinates)],
        joints,
        _expression_text(data["T"], "T", where),
        _expression_text(data["V"], "V", where),
        None if friction is None else tuple(_expression_text(f, "friction", where) for f in friction),
        tuple(parse_binding(normalized(s), t, where) for s, t in symbols.items()),
    )


def _check_names(where: str, names: list[str]) -> tuple[str, ...]:
    """The declared names, NFKC-normalised as the expressions read them, each valid and declared once."""
    reserved = set(FUNCTIONS) | set(CONSTANTS)
    seen: dict[str, str] = {}
    for name in names:
        plain = normalized(name)
        if not plain.isidentifier() or keyword.iskeyword(plain) or plain.startswith("_") or plain in reserved:
            raise HarnessError(
                f"{where}: {shown(name, 100)!r} cannot be a symbol (a name of letters, digits and _, not starting "
                f"with _, not a Python keyword, not {', '.join(sorted(reserved))}); name the coordinates yourself."
            )
        if plain in seen:
            both = (
                f"{seen[plain]!r} and {name!r} are one name" if seen[plain] != name else f"{name!r} is declared twice"
            )
            raise HarnessError(
                f"{where}: {both} (names are read NFKC-normalised, as Python reads them: {plain!r}); "
                "coordinates, velocities and symbols must be distinct."
            )
        seen[plain] = name
    return tuple(seen)


def uses_of(view: Mapping[str, ModelValue], joints: tuple[str, ...]) -> frozenset[str]:
    found = {
        "gravity": any(float(x) != 0.0 for x in np.asarray(view["gravity"], dtype=float)),
        "damping": any(float(view[f"joint/{j}/damping"]) > 0 for j in joints),
        "actuation": any(k.startswith("actuator/") for k in view),
    }
    return frozenset(k for k, on in found.items() if on)


def moved_bodies(view: Mapping[str, ModelValue], joints: tuple[str, ...]) -> tuple[str, ...]:
    """The bodies the joints move, in the model's order (what the engines are compared on)."""
    moved = {view[f"joint/{j}/body"] for j in joints}
    bodies = modelview.names(view, "body", "mass")
    return tuple(b for b in bodies if b in moved)


def bound_assumptions(
    view: Mapping[str, ModelValue], bindings: tuple[Binding, ...]
) -> Callable[[object], dict[str, ModelValue]]:
    """assumptions(p): the bound numbers from p, every other number NaN, structure as the model's."""
    base = {k: v if isinstance(v, str) else np.full(np.shape(v), np.nan) for k, v in view.items()}

    def assumptions(p: object) -> dict[str, ModelValue]:
        numbers = {k: np.array(v, dtype=float) for k, v in base.items() if not isinstance(v, str)}
        for b in bindings:
            numbers[b.key][b.index] = getattr(p, b.symbol) / b.scale  # index (): the whole 0-d array
        return {**base, **numbers}

    return assumptions


def module_from_file(
    path: Path, view: Mapping[str, ModelValue], *, time_limit: float = DEFAULT_TIME_LIMIT
) -> types.ModuleType:
    """The equations module (form d) a TOML file describes, read against the model `view`. The expressions
    are read here (bounded, nothing evaluated); their numpy code is imported and called in a worker
    process within `time_limit` seconds for all its calls (handwritten/textcode.py), like a person's module."""
    import sympy as sp

    path = Path(path)
    joints_of_model = tuple(modelview.names(view, "joint", "type"))
    spec = read_spec(path, joints_of_model)
    for b in spec.bindings:  # every key and index must exist now, not at the first parameters() call
        try:
            b.read(view)
        except HarnessError as exc:
            raise HarnessError(f"{path}: symbols.{b.symbol}: {exc}") from None
    n = len(spec.coordinates)
    params = [sp.Symbol(b.symbol, real=True) for b in spec.bindings]
    qs = [sp.Symbol(c, real=True) for c in spec.coordinates]
    vs = [sp.Symbol(c, real=True) for c in spec.velocities]
    names = {str(s): s for s in [*params, *qs, *vs]}
    T = to_sympy(spec.T, names, f"{path.name}: T")
    V = to_sympy(spec.V, {str(s): s for s in [*params, *qs]}, f"{path.name}: V")
    friction = (
        None
        if spec.friction is None
        else [to_sympy(f, names, f"{path.name}: friction[{i}]") for i, f in enumerate(spec.friction)]
    )
    fields = [b.symbol for b in spec.bindings]
    source = textcode.module_source(
        fields,
        n,
        lambdified([*params, *qs, *vs], [T], common=False),
        lambdified([*params, *qs], [V], common=False),
        None if friction is None else lambdified([*params, *qs, *vs], friction, common=False),
    )
    from .proxy import worker_module

    module = worker_module(path, time_limit, source=source)  # the code has no file: a forked copy imports it again
    Params = dataclasses.make_dataclass("Params", [(f, float) for f in fields], frozen=True)
    module.__doc__ = f"{spec.description} (equations as text: {path.name})"
    attributes: dict[str, object] = {
        "DESCRIPTION": spec.description,
        "COORDINATES": spec.coordinates,
        "JOINTS": spec.joints,
        "BODIES": moved_bodies(view, spec.joints),
        "USES": uses_of(view, spec.joints),
        "Params": Params,
        "parameters": lambda model: Params(**{b.symbol: b.read(model) for b in spec.bindings}),
        "assumptions": bound_assumptions(view, spec.bindings),
        "EXPRESSIONS": {"T": T, "V": V, **({} if friction is None else {"friction": tuple(friction)})},
    }
    module.__dict__.update(attributes)
    return module

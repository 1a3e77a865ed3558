"""A person's equations module as the harness sees it: a stand-in whose functions call the worker.

`worker_module(path, time_limit)` imports the module in a worker process (validate/handwritten/worker.py,
handwritten/child.py) and builds, in this process, a module with the same contract: its upper-case data
(COORDINATES, JOINT_MAP, VARIANTS, ...), its docstring, and each function of the contract and of the
printed forms as a function of the same name and parameter names that calls the worker. Everything
downstream (forms.normalize, the sources, the tracer, the fast path, the Taylor reference) reads it as
it read the module; none of the person's code runs here.

Calls on numbers send the arrays and get arrays back. Calls on traced values (tracing.Traced, the
sympy or heyoka expressions of the fast path, the energies' derivatives and the reference) send each
distinct expression as a placeholder; the worker runs the module on a tree backend and sends back a
table of operations, rebuilt here with this process's backend from a fixed list of operations
(`OPERATIONS`): no text is evaluated, no object unpickled.
"""

from __future__ import annotations

import copy
import dataclasses
import inspect
import json
import operator
import types
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.errors import HarnessError
from ..core.guard import Stopped
from ..core.memo import Memo
from . import tracing
from .worker import Message, ModuleWorker, Raised, Tagged, escape, pack, unpack

if TYPE_CHECKING:
    from ..core.arrays import Json
    from .tracing import Arithmetic

FORMS_MODULE = "lagrange_xval.forms"
MAX_NODES = 5_000_000
_ARITHMETIC: dict[str, Callable[[Arithmetic, Arithmetic], Arithmetic]] = {
    "+": operator.add,
    "-": operator.sub,
    "*": operator.mul,
    "/": operator.truediv,
    "**": operator.pow,
}
_COMPARE = frozenset(tracing.COMPARISONS.values())
_LOGICAL = frozenset({"and", "or", "not"})
OPERATIONS = frozenset({"c", "p", "neg", "select", "arctan2", *_ARITHMETIC, *tracing.UNARY, *_COMPARE, *_LOGICAL})


def worker_module(path: Path, time_limit: float, *, source: str | None = None) -> types.ModuleType:
    """The module at `path` (or of `source`, standing in as the module of `path`), imported in a worker
    of its own, as a stand-in module; a syntax error, an exception on import and a stopped import are
    one-line HarnessErrors."""
    try:
        worker = ModuleWorker(path, time_limit, where=str(path), source=source)
    except Stopped as stop:
        raise HarnessError(str(stop)) from None
    except Raised as exc:
        if exc.kind == "SyntaxError":
            line, _, msg = exc.message.partition(":")
            raise HarnessError(f"{path}:{line}: syntax error: {msg}.") from None
        said = f"{exc.kind}: {exc}" if str(exc) else exc.kind
        raise HarnessError(f"{path}: importing it raised {said}") from None
    return _stand_in(worker, worker.description, Path(path))


def _stand_in(worker: ModuleWorker, raw: object, path: Path) -> types.ModuleType:
    decoder = _Described(worker, worker.description_blobs)
    try:
        described = unpack(raw, worker.description_blobs, decoder)
    except (ValueError, KeyError, TypeError, IndexError, RecursionError) as exc:
        worker.close()
        raise HarnessError(f"{path}: the module's worker sent what is not data ({escape(str(exc), 120)}).") from None
    if not isinstance(described, dict):
        raise HarnessError(f"{path}: the module's worker did not describe it.")
    module = types.ModuleType(escape(str(described.get("name") or path.stem), 200))
    module.__file__ = str(path)
    doc = described.get("doc")
    module.__doc__ = doc if isinstance(doc, str) else None
    for part in ("data", "functions"):
        for name, value in dict(described.get(part) or {}).items():
            if isinstance(name, str) and name.isidentifier() and (part == "functions" or name.isupper()):
                setattr(module, name, value)
    params = dict(described.get("data") or {}).get("Params")
    if isinstance(params, dict) and all(isinstance(f, str) and f.isidentifier() for f in params.get("fields", [])):
        module.Params = _record_class(str(params.get("class", "Params")), tuple(params["fields"]))  # type: ignore[attr-defined]
    module.GUARD = worker  # type: ignore[attr-defined]  # its time_limit travels with the system's key
    module.WORKER = worker  # type: ignore[attr-defined]
    return module


class _Described:
    """The worker's description decoded: functions as stand-ins, printed forms as the contract's classes."""

    def __init__(self, worker: ModuleWorker, blobs: list[bytes]) -> None:
        self.worker, self.blobs = worker, blobs

    def __call__(self, data: Tagged) -> object:
        if "F" in data:
            names = [str(n) for n in data.get("p", []) if isinstance(n, str) and n.isidentifier()]
            return stand_in_function(self.worker, str(data["F"]), names, bool(data.get("n")))
        if "C" in data:
            fields = {str(k): unpack(v, self.blobs, self) for k, v in data["f"]}
            return _printed_form(str(data["C"]), str(data.get("m", "")), fields)
        return NotImplemented


def _printed_form(name: str, where: str, fields: dict[str, object]) -> object:
    """A printed form (Implicit, Explicit, DerivationStep of lagrange_xval.forms) rebuilt from its fields;
    another dataclass as a plain record of its fields."""
    from .. import forms as _forms

    cls = getattr(_forms, name, None) if where == FORMS_MODULE else None
    if not (isinstance(cls, type) and dataclasses.is_dataclass(cls)):
        return _record_class(name, tuple(fields))(**fields)
    known = {f.name for f in dataclasses.fields(cls) if f.init}
    try:
        form = cls(**{k: v for k, v in fields.items() if k in known})
    except TypeError as exc:
        raise HarnessError(f"a printed form {name} that cannot be read ({exc})") from None
    for key, value in fields.items():  # named as the in-process guard named them: "<form>: residual"
        if callable(value) and hasattr(value, "__signature__"):
            value.__dict__["label"] = f"{getattr(form, 'name', name)}: {key}"  # a stand-in function's
    return form


_RECORDS = Memo(maxsize=256)  # one stand-in class per (name, fields) a module's Params has


def _record_class(name: str, fields: tuple[str, ...]) -> type:
    """A frozen dataclass of these fields, standing in for the module's own (its Params): the harness
    reads, replaces and traces its fields; the worker rebuilds the module's class from them."""
    safe = name if name.isidentifier() else "Params"
    return _RECORDS.get(
        (name, fields), lambda: dataclasses.make_dataclass(safe, [(f, Any) for f in fields], frozen=True)
    )


def stand_in_function(worker: ModuleWorker, path: str, names: list[str], not_provided: bool) -> Callable[..., object]:
    """A function of the parameters `names` that calls the module's function at `path` in the worker."""
    signature = inspect.Signature([inspect.Parameter(n, inspect.Parameter.POSITIONAL_OR_KEYWORD) for n in names])

    def fn(*args: object, **kwargs: object) -> object:
        if kwargs:
            args = signature.bind(*args, **kwargs).args
        return invoke(worker, path, args, getattr(fn, "label", path))

    fn.__name__ = fn.__qualname__ = path.rsplit(".", 1)[-1]
    fn.__signature__ = signature  # type: ignore[attr-defined]
    fn.in_worker = (worker, path)  # type: ignore[attr-defined]  # for `together`
    if not_provided:
        fn.not_provided = True  # type: ignore[attr-defined]
    return fn


def invoke(worker: ModuleWorker, path: str, args: tuple[object, ...], label: str | None = None) -> object:
    """The module's function at `path` on `args`, in the worker: numbers in, data out; traced values
    as placeholders in, their expressions rebuilt in this process's backend out."""
    blobs: list[bytes] = []
    encoder = _Encoder(blobs)
    packed = [pack(a, blobs, encoder) for a in args]
    backend = encoder.backend
    message: Message = {"op": "call", "name": path, "args": packed, "backend": backend.name if backend else None}
    decoder = _Result(backend, encoder.placeholders)
    if backend is not None or encoder.model is not None:
        return worker.request(message, label or path, blobs, model=encoder.model, unpack_hook=decoder)
    return _recent(worker, (path, json.dumps(packed), *blobs), lambda: worker.request(message, label or path, blobs))


def together(calls: list[tuple[Callable[..., object], tuple[object, ...]]]) -> list[object] | None:
    """[fn(*args) for fn, args in calls], the stand-ins of one worker called on numbers in one round trip
    (a step's passive, bias and mass matrix: one request, not three; a function of the harness, such as
    the zero friction of a module without passive, called here); None where fewer than two are stand-ins
    (the caller calls them one by one)."""
    targets = [getattr(fn, "in_worker", None) for fn, _ in calls]
    remote = [i for i, t in enumerate(targets) if t is not None]
    workers = {id(targets[i][0]) for i in remote}  # type: ignore[index]
    plain = (np.ndarray, float, int)
    numbers = all(isinstance(a, plain) or dataclasses.is_dataclass(a) for i in remote for a in calls[i][1])
    if len(remote) < 2 or len(workers) != 1 or not numbers:
        return None
    worker = targets[remote[0]][0]  # type: ignore[index]
    paths = [targets[i][1] for i in remote]  # type: ignore[index]
    answers = iter(worker.batch([(p, calls[i][1]) for p, i in zip(paths, remote, strict=True)], ", ".join(paths)))
    return [next(answers) if t is not None else fn(*args) for t, (fn, args) in zip(targets, calls, strict=True)]


RECENT = 4  # answers kept per worker: a per-step mirror asks bias and passive at the same states in a row


def _recent(worker: ModuleWorker, key: tuple[str | bytes, ...], call: Callable[[], object]) -> object:
    """call(), or a copy of its answer when the same function was just called on the same bytes (the
    facade of forms b and c derives bias and passive from one batch of calls: asked twice per step)."""
    kept: dict[tuple[str | bytes, ...], object] = worker.__dict__.setdefault("recent", {})
    if key in kept:
        kept[key] = kept.pop(key)  # most recent last
        return copy.deepcopy(kept[key])
    out = call()
    kept[key] = out
    while len(kept) > RECENT:
        kept.pop(next(iter(kept)))
    return copy.deepcopy(out)


class _Encoder:
    """The arguments' own kinds: traced values as placeholders, the model view as a remote mapping,
    dataclasses (Params) by class name and fields."""

    def __init__(self, blobs: list[bytes]) -> None:
        self.blobs = blobs
        self.backend: tracing.Backend[Arithmetic] | None = None
        self.placeholders: list[tracing.Traced[Arithmetic]] = []
        self.index: dict[int, int] = {}
        self.model: Mapping[str, object] | None = None

    def __call__(self, value: object) -> Json | None:
        if isinstance(value, tracing.Traced):
            self.backend = self.backend or value.backend
            if id(value) not in self.index:
                self.index[id(value)] = len(self.placeholders)
                self.placeholders.append(value)
            return {"P": self.index[id(value)]}
        if isinstance(value, Mapping) and not isinstance(value, dict):
            self.model = value
            return {"M": 1}
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            fields: list[Json] = [
                [f.name, pack(getattr(value, f.name), self.blobs, self)] for f in dataclasses.fields(value)
            ]
            return {"C": type(value).__name__, "f": fields}
        return None


class _Result:
    """The worker's answer decoded: Params as a stand-in dataclass, traced nodes rebuilt in `backend`."""

    def __init__(
        self, backend: tracing.Backend[Arithmetic] | None, placeholders: list[tracing.Traced[Arithmetic]]
    ) -> None:
        self.backend, self.placeholders = backend, placeholders
        self.built: list[Arithmetic] = []
        self.blobs: list[bytes] = []

    def prepare(self, header: Message, blobs: list[bytes]) -> None:
        self.blobs = blobs
        nodes = header.get("nodes") or []
        if nodes and self.backend is None:
            raise ValueError("expressions in answer to a call on numbers")
        if len(nodes) > MAX_NODES:
            raise ValueError(f"{len(nodes)} expression nodes")
        self.built = []
        for node in nodes:
            self.built.append(self._build(node))

    def _build(self, node: list[str | float]) -> Arithmetic:
        bk = self.backend
        assert bk is not None
        op, *args = node
        if not isinstance(op, str) or op not in OPERATIONS:  # (every operation is a name)
            raise ValueError(f"an unknown operation {escape(str(op), 20)!r}")
        if op == "c":
            return bk.lift(float(args[0]))
        if op == "p":
            return self.placeholders[int(args[0])].value
        if any(not isinstance(a, int) or not 0 <= a < len(self.built) for a in args):
            raise ValueError("an operand that is not an earlier node")
        xs = [self.built[int(a)] for a in args]
        if op in _ARITHMETIC:
            return _ARITHMETIC[op](*xs)
        if op == "neg":
            return -xs[0]
        if op in _COMPARE:
            return bk.compare(op, *xs)
        if op == "select":
            return bk.select(*xs)
        if op in _LOGICAL:
            return bk.logical(op, xs)
        return bk.function(op)(*xs)

    def __call__(self, data: Tagged) -> object:
        if "N" in data:
            if self.backend is None:
                raise ValueError("an expression in answer to a call on numbers")
            return tracing.Traced(self.built[int(data["N"])], self.backend, condition=bool(data.get("c")))
        if "C" in data:
            fields = {str(k): unpack(v, self.blobs, self) for k, v in data["f"]}
            return _record_class(str(data["C"]), tuple(fields))(**fields)
        if "O" in data and self.backend is not None:
            import numpy as np

            items = [unpack(x, self.blobs, self) for x in data["v"]]
            arr = np.empty(len(items), dtype=object)
            arr[:] = items if items else arr
            return arr.reshape(tuple(int(k) for k in data["O"])).view(tracing.TracedArray)
        return NotImplemented

"""The worker side of validate/handwritten/worker.py: the process a person's equations module runs in.

It imports the module, describes it (its contract functions with their parameter names, its
upper-case data, its printed forms), and answers calls: numbers in, arrays out; for tracing, the
parent's symbolic values arrive as placeholders and the module's code runs on `Traced` values of a
tree backend (`Node`), whose expression graph goes back as a table of operations the parent
rebuilds in its own backend (sympy, heyoka) from a fixed list (handwritten/proxy.py). Nothing of the
judge is here: the module may patch this process's numpy, it changes nothing the parent computes.

What the module prints goes to stderr (file descriptor 1 is stderr here). `sys.exit` and `os._exit`
inside a call are answered as such, naming the function; any other exception, BaseExceptions
included, is answered with its type's name and message (the parent escapes and cuts it).
"""

from __future__ import annotations

import ctypes
import dataclasses
import importlib.util
import inspect
import os
import signal
import sys
from collections.abc import Callable, Iterator, Mapping
from types import ModuleType
from typing import TYPE_CHECKING

from ..core.guard import CONTRACT_FUNCTIONS
from ..core.memo import Memo
from .worker import Message, Tagged, pack, receive, send, unpack

if TYPE_CHECKING:
    from typing_extensions import TypeIs

    from ..core.arrays import Json
    from .tracing import Backend

_REAL_EXIT = os._exit
CONTRACT = CONTRACT_FUNCTIONS  # the contract's functions (equations/__init__.py), as the guard names them


class _Exit(BaseException):  # noqa: N818 - os._exit called inside a call: answered, then the process ends
    def __init__(self, code: object) -> None:
        self.code = code


def _exit(code: object) -> None:
    """os._exit inside a call of the main thread: answered as such; anywhere else, the real one."""
    import threading

    if _STATE.calling and threading.current_thread() is threading.main_thread():
        raise _Exit(code)
    _REAL_EXIT(int(code) if isinstance(code, int) else 1)


class _State:
    calling = False
    module: ModuleType | None = None
    classes: dict[str, type] = {}  # noqa: RUF012 - the dataclasses the module's functions returned, by name


_STATE = _State()


def main(rfd: int, wfd: int, parent: int = 0, main_thread: bool = True, memory: int = 0) -> None:
    """Serve the parent until the pipe closes; `memory`: the address space limit, bytes (0: none)."""
    _die_with_parent(parent or os.getppid(), main_thread)
    if memory > 0:
        import resource

        try:
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
        except (ValueError, OSError):
            pass
    os.dup2(2, 1)  # what the module prints goes to stderr
    sys.stdout = sys.stderr
    signal.signal(signal.SIGINT, signal.default_int_handler)
    os._exit = _exit  # type: ignore[assignment]
    while True:
        try:
            header, blobs = receive(rfd)
        except (EOFError, OSError):
            _REAL_EXIT(0)
        _serve(rfd, wfd, header, blobs)


def _die_with_parent(parent: int, main_thread: bool) -> None:
    """This process ended when its parent ends, even in the middle of a call: PR_SET_PDEATHSIG where the
    parent started it from its main thread (the signal follows the starting thread), and a thread that
    looks for the parent every second (a forked copy or a thread of the parent may have started it)."""
    import threading
    import time

    if main_thread:
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass

    namespaced = os.getppid() == 1 and parent != 1  # in a PID namespace of its own, under its shell

    def alive() -> bool:
        # In the worker's PID namespace the harness is no parent (the namespace's shell is): it is looked
        # for in /proc, which is still the harness's namespace's (unshare mounts no other).
        return os.path.exists(f"/proc/{parent}") if namespaced else os.getppid() == parent

    def watch() -> None:
        while alive():
            time.sleep(1.0)
        _REAL_EXIT(0)

    threading.Thread(target=watch, daemon=True, name="lagrange-xval-parent-watch").start()


def _serve(rfd: int, wfd: int, header: Message, blobs: list[bytes]) -> None:
    reply_blobs: list[bytes] = []
    _STATE.calling = True
    try:
        if header["op"] == "import":
            answer = _import(header["path"], reply_blobs, header.get("source"))
        elif header["op"] == "batch":
            answer = _batch(rfd, wfd, header, blobs, reply_blobs)
        else:
            answer = _call(rfd, wfd, header, blobs, reply_blobs)
    except _Exit as exc:
        answer, reply_blobs = {"exit": "os", "code": repr(exc.code)}, []
    except SystemExit as exc:
        answer, reply_blobs = {"exit": "sys", "code": "" if exc.code is None else repr(exc.code)}, []
    except BaseException as exc:  # noqa: BLE001 - the module's failure, whatever it is: named to the parent
        answer, reply_blobs = _raised(exc, header), []
    finally:
        _STATE.calling = False
    try:
        send(wfd, answer, reply_blobs)
    except (TypeError, ValueError, RecursionError) as exc:  # an answer that is not data
        send(wfd, {"raised": type(exc).__name__, "message": f"the answer could not be sent: {exc}"})
    if "exit" in answer:
        _REAL_EXIT(0)


def _raised(exc: BaseException, header: Message) -> Message:
    from ..core.errors import HarnessError
    from . import tracing

    backend = header.get("backend")
    if isinstance(exc, SyntaxError) and header["op"] == "import":
        return {"raised": "SyntaxError", "message": f"{exc.lineno}:{exc.msg}"}
    try:
        text = str(exc)
    except BaseException:  # noqa: BLE001 - a __str__ that raises
        text = ""
    if backend and isinstance(exc, Exception) and not type(exc).__name__ == "NotApplicable":
        said = text if isinstance(exc, HarnessError) else tracing.describe(exc, header["name"], _tree(backend))
        return {"raised": type(exc).__name__, "message": said[:2000], "harness": True}
    return {"raised": type(exc).__name__, "message": text[:100_000], "function": header.get("name")}


def _import(path: str, blobs: list[bytes], source: str | None = None) -> Message:
    import hashlib

    name = "lagrange_xval_user_" + hashlib.sha256(path.encode()).hexdigest()[:12]
    module = _new_module(name, path, source is not None)
    sys.modules[name] = module
    # compiled from the source, never __pycache__ (keyed by whole-second mtime and size: `watch` saves faster)
    if source is None:
        with open(path, "rb") as f:
            text = f.read()
    else:
        text = source.encode()
    code = compile(text, path, "exec", dont_inherit=True)
    exec(code, vars(module))  # noqa: S102 - the person's own module, in this worker alone
    _STATE.module = module
    return {"ok": pack(_describe(module), blobs, _Describer(blobs))}


def _new_module(name: str, path: str, generated: bool) -> ModuleType:
    """An empty module for the file at `path`, or for code the parent generated (the text form's, whose
    file is the TOML)."""
    import types

    if generated:
        module = types.ModuleType(name)
        module.__file__ = path
        return module
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"{path}: not a Python module")
    return importlib.util.module_from_spec(spec)


def _describe(module: ModuleType) -> dict[str, object]:
    """What the parent builds its stand-in module from: the contract's functions, the upper-case
    attributes (data; printed forms' functions by path), the docstring and the name."""
    functions = {n: _function(getattr(module, n), n) for n in CONTRACT if callable(getattr(module, n, None))}
    data = {}
    for key, value in vars(module).items():
        if key.isupper() and not key.startswith("_") and not inspect.ismodule(value):
            data[key] = _with_paths(value, key)
    params = getattr(module, "Params", None)  # the parameters' class: its fields (a Hamiltonian is checked by it)
    if isinstance(params, type) and dataclasses.is_dataclass(params):
        _STATE.classes[params.__name__] = params
        data["Params"] = {"fields": [f.name for f in dataclasses.fields(params)], "class": params.__name__}
    return {"functions": functions, "data": data, "doc": module.__doc__, "name": module.__name__}


class _Fn:
    def __init__(self, fn: Callable[..., object], path: str) -> None:
        self.fn, self.path = fn, path


def _function(fn: Callable[..., object], path: str) -> _Fn:
    return _Fn(fn, path)


def _with_paths(value: object, path: str) -> object:
    """`value` with every function in it (a printed form's residual, ...) replaced by its path."""
    if callable(value) and not isinstance(value, type):
        return _Fn(value, path)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = {f.name: _with_paths(getattr(value, f.name), f"{path}.{f.name}") for f in dataclasses.fields(value)}
        return ("__dataclass__", type(value).__name__, type(value).__module__, fields)
    if isinstance(value, (list, tuple)):
        return type(value)(_with_paths(x, f"{path}.{i}") for i, x in enumerate(value))
    return value


class _Describer:
    """Functions as their paths and parameter names; dataclasses (printed forms) by class and fields."""

    def __init__(self, blobs: list[bytes]) -> None:
        self.blobs = blobs

    def __call__(self, value: object) -> Json | None:
        if isinstance(value, _Fn):
            try:
                names: list[Json] = list(inspect.signature(value.fn).parameters)
            except (TypeError, ValueError):
                names = []
            return {"F": value.path, "p": names, "n": bool(getattr(value.fn, "not_provided", False))}
        if isinstance(value, tuple) and len(value) == 4 and value[0] == "__dataclass__":
            _, name, where, fields = value
            return {"C": name, "m": where, "f": [[k, pack(v, self.blobs, self)] for k, v in fields.items()]}
        return None


def _resolve(path: str) -> Callable[..., object]:
    """The module's object at `path` ("mass_matrix", "VARIANTS.2.residual")."""
    head, *rest = path.split(".")
    obj = getattr(_STATE.module, head)
    for part in rest:
        obj = obj[int(part)] if part.isdigit() else getattr(obj, part)
    return obj


def _batch(rfd: int, wfd: int, header: Message, blobs: list[bytes], out: list[bytes]) -> Message:
    """Several calls on numbers in one round trip (a step's passive, bias and mass matrix): their answers
    in order; the first that raises ends the batch, the function named in `header` for the answer."""
    answers = []
    for name, args in header["calls"]:
        header["name"] = name
        answers.append(_call(rfd, wfd, {"name": name, "args": args}, blobs, out)["ok"])
    return {"ok": {"L": answers}}


def _call(rfd: int, wfd: int, header: Message, blobs: list[bytes], out: list[bytes]) -> Message:
    fn = _resolve(header["name"])
    backend_name = header.get("backend")
    backend = _tree(backend_name) if backend_name else None
    args = [unpack(a, blobs, _Decoder(rfd, wfd, backend, blobs)) for a in header["args"]]
    if backend is not None:
        import numpy as np

        from .tracing import TracedArray

        args = [a.view(TracedArray) if isinstance(a, np.ndarray) and a.dtype == object else a for a in args]
    result = fn(*args)
    encoder = _Encoder(out)
    packed = pack(result, out, encoder)
    return {"ok": packed, "nodes": encoder.nodes} if backend else {"ok": packed}


class _Remote(Mapping[str, object]):
    """The parent's model view, key by key (the parent records which keys parameters() reads)."""

    def __init__(self, rfd: int, wfd: int) -> None:
        self.rfd, self.wfd = rfd, wfd

    def _ask(self, key: str | None) -> Message:
        send(self.wfd, {"get": key})
        header, blobs = receive(self.rfd)
        header["blobs"] = blobs
        return header

    def __getitem__(self, key: str) -> object:
        if not isinstance(key, str):
            raise KeyError(key)
        got = self._ask(key)
        if "value" not in got:
            raise KeyError(key)
        return unpack(got["value"], got["blobs"])

    def __iter__(self) -> Iterator[str]:
        return iter(self._ask(None).get("keys", []))

    def __len__(self) -> int:
        return len(self._ask(None).get("keys", []))


class _Decoder:
    """The parent's tags: the model view, the module's own dataclasses, placeholders of traced values."""

    def __init__(self, rfd: int, wfd: int, backend: Backend[Node] | None, blobs: list[bytes]) -> None:
        self.rfd, self.wfd, self.backend, self.blobs = rfd, wfd, backend, blobs

    def __call__(self, data: Tagged) -> object:
        if "M" in data:
            return _Remote(self.rfd, self.wfd)
        if "P" in data and self.backend is not None:
            from .tracing import Traced

            return Traced(Node("p", int(data["P"])), self.backend)
        if "C" in data:
            fields = {k: unpack(v, self.blobs, self) for k, v in data["f"]}
            cls = _STATE.classes.get(data["C"])
            return cls(**fields) if cls is not None else _Namespace(**fields)
        return NotImplemented


class _Namespace:
    def __init__(self, **fields: object) -> None:
        self.__dict__.update(fields)


class _Encoder:
    """Traced values as nodes of one table; the module's dataclasses (Params) by name and fields."""

    def __init__(self, blobs: list[bytes]) -> None:
        self.blobs = blobs
        self.nodes: list[list[str | float]] = []
        self.index: dict[int, int] = {}
        self.keep: list[Node] = []

    def __call__(self, value: object) -> Json | None:
        from .tracing import Traced

        if isinstance(value, Traced):
            return {"N": self.node(value.e), "c": bool(value.condition)}
        if isinstance(value, Node):
            return {"N": self.node(value), "c": False}
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            _STATE.classes[type(value).__name__] = type(value)
            fields: list[Json] = [
                [f.name, pack(getattr(value, f.name), self.blobs, self)] for f in dataclasses.fields(value)
            ]
            return {"C": type(value).__name__, "f": fields}
        return None

    def node(self, root: Node) -> int:
        """The index of `root` in the table, its operands first (iteratively: deep sums do not recurse)."""
        stack = [(root, False)]
        while stack:
            node, ready = stack.pop()
            if id(node) in self.index:
                continue
            if node.op in ("c", "p"):
                self.index[id(node)] = len(self.nodes)
                leaf = node.args[0]  # a number: the constant's value, the placeholder's index
                assert not isinstance(leaf, Node)
                self.nodes.append([node.op, leaf])
                self.keep.append(node)
                continue
            if not ready:
                stack.append((node, True))
                stack.extend((a, False) for a in node.args if isinstance(a, Node) and id(a) not in self.index)
                continue
            self.index[id(node)] = len(self.nodes)
            self.nodes.append([node.op, *(self.index[id(a)] for a in node.args)])
            self.keep.append(node)
        return self.index[id(root)]


class Node:
    """An operation of the tree backend: `op` and its operands (Nodes; a number for "c", an index for "p")."""

    __slots__ = ("op", "args")

    def __init__(self, op: str, *args: Node | float) -> None:
        self.op, self.args = op, args

    def _bin(self, op: str, other: Node | float, reflected: bool = False) -> Node:
        other = other if isinstance(other, Node) else Node("c", float(other))
        return Node(op, other, self) if reflected else Node(op, self, other)

    def __add__(self, o: Node | float) -> Node:
        return self._bin("+", o)

    def __radd__(self, o: Node | float) -> Node:
        return self._bin("+", o, True)

    def __sub__(self, o: Node | float) -> Node:
        return self._bin("-", o)

    def __rsub__(self, o: Node | float) -> Node:
        return self._bin("-", o, True)

    def __mul__(self, o: Node | float) -> Node:
        return self._bin("*", o)

    def __rmul__(self, o: Node | float) -> Node:
        return self._bin("*", o, True)

    def __truediv__(self, o: Node | float) -> Node:
        return self._bin("/", o)

    def __rtruediv__(self, o: Node | float) -> Node:
        return self._bin("/", o, True)

    def __pow__(self, o: Node | float) -> Node:
        return self._bin("**", o)

    def __rpow__(self, o: Node | float) -> Node:
        return self._bin("**", o, True)

    def __neg__(self) -> Node:
        return Node("neg", self)


_TREES = Memo(maxsize=64)  # one backend per name the parent traces for


def _is_node(x: object) -> TypeIs[Node]:
    return isinstance(x, Node)


def _tree(name: str) -> Backend[Node]:
    """The tree backend, named after the parent's (its refusals say what the trace was for)."""
    from .tracing import Backend

    return _TREES.get(
        name,
        lambda: Backend(
            str(name),
            lambda x: Node("c", float(x)),
            lambda fn: lambda *a: Node(fn, *a),
            _is_node,
            lambda op, a, b: Node(op, a, b),
            lambda c, a, b: Node("select", c, a, b),
            lambda op, cs: Node(op, *cs),
        ),
    )

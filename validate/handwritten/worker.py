"""A person's equations module in a worker process of its own; the judge stays in this one.

An equations module is the person's own Python: it may loop in C, switch off alarms, start threads,
fork, register atexit handlers, call `os._exit`, patch numpy or raise anything. So it is imported, and
every call into it is made, in a child process (`ModuleWorker`) that holds nothing of the judge: the
parent sends arrays (and, for tracing, placeholders of its symbolic values) over a pipe, and reads
back only data, never pickles: arrays as raw bytes with a dtype from a short list and a shape that must
match their length, numbers, strings, lists and dicts, and the names of exceptions with an escaped,
cut message (`escape`). The parent compares, decides and prints with its own numpy.

The parent keeps the watchdog. The time limit is per system: one budget for every call into the
module, its import included (`DEFAULT_TIME_LIMIT`, `--time-limit SECONDS`). A call is charged its wall
time less `LATENCY` and less the time the worker and the calling thread stood waiting for a CPU
(Linux's /proc schedstat, `waited`): that is the machine's load, not the module's; computing and
blocking are charged. A worker that does not answer within what is left of it is ended with its
whole process group (SIGTERM, then SIGKILL after `GRACE` s) and the call raises `Stopped`
("mass_matrix did not return within 30 s (the time limit per system; ...)"); so does a worker that
ends (a crash, a signal, `os._exit` from a thread) and a call of `sys.exit`/`os._exit` inside a
function. After a stop the worker is spent: every later call raises the same `Stopped` at once. The
worker is in a session of its own (the person's Ctrl-C reaches the command, never the module), dies
with its parent (PR_SET_PDEATHSIG, and a thread watching for it), and is killed, with whatever it
forked, when closed or when the command exits: no thread, atexit handler or child of the module
outlives the verdict.

Cost: one worker per module for its whole life (about 0.5 s to start and import), one round trip per
call (0.15 ms for a small array here, 0.3 ms for one state of a form-(c) module, against 0.02 ms for the
call in-process; milliseconds on a loaded machine, which is why each call's first `LATENCY` s are not
charged to the budget). The harness batches states, so a `check` makes about 80 calls; the proxy
(handwritten/proxy.py) answers a call repeated on the same bytes from the last few answers.

    worker = ModuleWorker("my_arm.py", time_limit=30.0)
    M = worker.call("mass_matrix", params, q)      # the functions by their path in the module
    worker.close()
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import json
import os
import select
import signal
import struct
import subprocess
import sys
import threading
import time
import weakref
from collections import OrderedDict
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import IO, TYPE_CHECKING, NoReturn, Protocol, TypedDict, cast

from ..core.guard import DEFAULT_TIME_LIMIT, Stopped

if TYPE_CHECKING:  # the worker imports this module: numpy is loaded when first used
    import numpy as np

    from ..core.arrays import Json, JsonObject

HINT = "the time limit per system; --time-limit SECONDS sets it"
GRACE = 1.0  # s between SIGTERM and SIGKILL
# s of each call's wall time not charged to the budget: the pipe's round trip, which on a loaded machine
# is milliseconds (measured 1 ms a call at load 8 on 2 cores), is the harness's cost, not the module's;
# per-step mirrors make ~10^4 calls per system
LATENCY = 0.005
MAX_MESSAGE = 300  # characters of a module's exception message shown (escaped)
MAX_HEADER = 256 * 2**20  # bytes of one message's JSON part from the worker
MAX_BLOB = 2**31  # bytes of one array from the worker
MAX_BLOBS = 100_000
# the dtypes an array from the worker may have (anything else is refused: no object, no record)
DTYPES = frozenset(
    {"|b1", "|i1", "|u1"} | {f"{e}{k}{n}" for e in "<>" for k in "iuf" for n in (2, 4, 8)} | {"<c8", "<c16"}
)
MEMORY_ENV = "LAGRANGE_XVAL_WORKER_MEMORY"  # bytes of address space a worker may use (default below)
_HEAD = struct.Struct("!II")
_LEN = struct.Struct("!Q")


def escape(text: str, limit: int = MAX_MESSAGE) -> str:
    """`text` on one line with no control characters (written as \\n, \\x1b, ...), cut to `limit`
    characters with the number left out said: text a module controls is data, never layout."""
    out = "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)
    return out if len(out) <= limit else f"{out[:limit]}... ({len(out) - limit} more characters)"


class Raised(Exception):  # noqa: N818 - the module's exception, by name: not one of ours
    """An exception of any kind raised by the person's function `function`, as its type's name and its
    escaped, cut message (KeyboardInterrupt, SystemExit subclasses and BaseExceptions included: the
    module's failure, never the person's Ctrl-C). Made by `raised`, as a subclass named after the
    module's exception, so that `type(exc).__name__` says "ZeroDivisionError" where the harness names it."""

    def __init__(self, function: str, kind: str, message: str) -> None:
        self.function, self.kind, self.message = function, kind, escape(message)
        super().__init__(function, kind, message)
        self._lagrange_xval_function = function

    def __str__(self) -> str:
        return self.message


_KINDS: OrderedDict[str, type[Raised]] = OrderedDict()  # one class per exception name, the newest 256 kept
KINDS_KEPT = 256


def raised(function: str, kind: str, message: str) -> Raised:
    """The `Raised` for an exception named `kind` (an identifier, else "Exception") out of `function`."""
    kind = kind if kind.isidentifier() and len(kind) <= 80 else "Exception"
    cls = _KINDS.pop(kind, None) or type(kind, (Raised,), {"__module__": "lagrange_xval.user"})
    _KINDS[kind] = cls
    while len(_KINDS) > KINDS_KEPT:
        _KINDS.popitem(last=False)
    return cls(function, kind, message)


# ----------------------------------------------------------------------------------------------
# The wire: a JSON header and raw array bytes, length-prefixed


class Message(TypedDict, total=False):
    """A header on the pipe: a request to the worker, its answer, or a model lookup in between (JSON; a
    pair is a JSON array of two)."""

    op: str  # a request: "import", "call" or "batch"
    path: str
    source: str | None
    name: str
    args: list[Json]  # packed
    calls: list[tuple[str, list[Json]]]  # a batch: (function path, packed args)
    backend: str | None
    ok: Json  # an answer: the value packed
    nodes: list[list[str | float]]  # traced answers: [operation, operand, ...] each
    raised: str
    message: str
    function: str | None
    harness: bool
    exit: str
    code: str
    get: str | None  # a lookup of the model view (None: its keys)
    keys: list[str]
    value: Json
    missing: bool
    blobs: list[bytes]  # the arrays' bytes, attached to a lookup's answer where it is read (not sent)


class Tagged(TypedDict, total=False):
    """A packed value that is not plain JSON, by its tag: `pack`'s own, and its callers' (hooks)."""

    A: int  # an array: its blob, dtype and shape
    d: str
    s: list[int]
    K: str  # an array of a kind that is not numbers (shape in `s`)
    O: list[int]  # an object array: its shape and packed elements
    v: list[Json]
    L: list[Json]  # a list, a tuple
    T: list[Json]
    D: list[tuple[Json, Json]]  # a dict: (key, value) pairs
    R: str  # what cannot be sent: its type's name
    F: str  # a function of the module: its path, parameter names and whether it is a stub
    p: list[str]
    n: bool
    C: str  # a dataclass: its class's name, module and (field, packed value) pairs
    m: str
    f: list[tuple[str, Json]]
    N: int  # a traced value: its node, and whether it is a condition
    c: bool
    P: int  # a placeholder of a traced value the parent sent
    M: int  # the model view


class Decoder(Protocol):
    """An answer's reader: `prepare` with its header and arrays, then called on each tagged value
    (NotImplemented: left to `unpack`)."""

    def prepare(self, header: Message, blobs: list[bytes]) -> None: ...
    def __call__(self, data: Tagged) -> object: ...


def _tagged(data: JsonObject) -> Tagged:
    """A JSON object from the pipe read by its tags (its fields are checked where they are read)."""
    return cast(Tagged, data)


def pack(value: object, blobs: list[bytes], hook: Callable[[object], Json | None] | None = None) -> Json:
    """`value` as JSON-able data, arrays' bytes appended to `blobs`; `hook(value)` encodes what the
    caller knows (traced values, mappings) and returns None to leave it to `pack`."""
    import numpy as np

    if hook is not None:
        coded = hook(value)
        if coded is not None:
            return coded
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    if isinstance(value, np.ndarray):
        if value.dtype == object:
            return {"O": list(value.shape), "v": [pack(x, blobs, hook) for x in value.ravel()]}
        if value.dtype.str not in DTYPES:  # strings, dates, records: their kind and shape, for the message
            return {"K": value.dtype.kind, "s": list(value.shape)}
        blobs.append(np.ascontiguousarray(value).tobytes())
        return {"A": len(blobs) - 1, "d": value.dtype.str, "s": list(value.shape)}
    if isinstance(value, (list, tuple)):
        return {"L" if isinstance(value, list) else "T": [pack(x, blobs, hook) for x in value]}
    if isinstance(value, dict):
        return {"D": [[pack(k, blobs, hook), pack(v, blobs, hook)] for k, v in value.items()]}
    if isinstance(value, complex):
        return {"A": _blob(blobs, np.asarray(value)), "d": "<c16", "s": []}
    return {"R": type(value).__name__}


def _blob(blobs: list[bytes], arr: np.ndarray) -> int:
    blobs.append(arr.astype("<c16").tobytes())
    return len(blobs) - 1


class Opaque:
    """What the worker could not send as data (a class, a module, an object of the person's)."""

    def __init__(self, kind: str) -> None:
        self.kind = kind

    def __repr__(self) -> str:
        return f"<{self.kind}>"


def unpack(data: object, blobs: list[bytes], hook: Callable[[Tagged], object] | None = None) -> object:
    """The value `pack` encoded; arrays checked (dtype from DTYPES, bytes equal to the shape's) and
    copied; `hook(tagged)` decodes the caller's own tags (returns NotImplemented to leave it here)."""
    if not isinstance(data, dict):
        if isinstance(data, list):
            raise ValueError("an untagged list")
        return data
    data = _tagged(data)
    if hook is not None:
        out = hook(data)
        if out is not NotImplemented:
            return out
    if "A" in data:
        return _array(data, blobs)
    if "K" in data:
        return _kind_only(data)
    if "O" in data:
        import numpy as np

        items = [unpack(x, blobs, hook) for x in data["v"]]
        arr = np.empty(len(items), dtype=object)
        arr[:] = items if items else arr
        return arr.reshape(tuple(int(k) for k in data["O"]))
    if "L" in data:
        return [unpack(x, blobs, hook) for x in data["L"]]
    if "T" in data:
        return tuple(unpack(x, blobs, hook) for x in data["T"])
    if "D" in data:
        return {_key(unpack(k, blobs, hook)): unpack(v, blobs, hook) for k, v in data["D"]}
    if "R" in data:
        return Opaque(escape(str(data["R"]), 80))
    raise ValueError(f"unknown tag {sorted(data)[:3]}")


_KIND_DTYPES = {"U": "U1", "S": "S1", "M": "M8[s]", "m": "m8[s]", "V": "V1", "c": "c16"}


def _kind_only(data: Tagged) -> np.ndarray:
    """An array of a kind that is not numbers, as that kind and shape without its contents (a view of
    one element: no memory), so that the reader names what it is (values.real_array)."""
    import numpy as np

    kind = _KIND_DTYPES.get(str(data["K"]), "V1")
    return np.broadcast_to(np.zeros((), dtype=kind), tuple(int(k) for k in data["s"]))


def _key(k: object) -> str | int | float | bool | tuple[object, ...] | None:
    return k if isinstance(k, (str, int, float, bool, tuple)) or k is None else escape(repr(k), 80)


def _array(data: Tagged, blobs: list[bytes]) -> np.ndarray:
    import numpy as np

    dtype, shape = str(data["d"]), tuple(int(k) for k in data["s"])
    if dtype not in DTYPES or any(k < 0 for k in shape):
        raise ValueError(f"an array of dtype {escape(dtype, 20)} and shape {shape}")
    raw = blobs[int(data["A"])]
    dt = np.dtype(dtype)
    if len(raw) != dt.itemsize * int(np.prod(shape, dtype=np.int64)):
        raise ValueError(f"an array of shape {shape} with {len(raw)} bytes")
    return np.frombuffer(raw, dtype=dt).reshape(shape).astype(dt.newbyteorder("="), copy=True)


def send(fd: int, header: Message, blobs: list[bytes] = ()) -> None:  # type: ignore[assignment]
    """One message: its JSON header and its arrays' bytes."""
    body = json.dumps(header, separators=(",", ":")).encode()
    parts = [_HEAD.pack(len(body), len(blobs)), body]
    for b in blobs:
        parts += [_LEN.pack(len(b)), b]
    view = memoryview(b"".join(parts))
    while view:
        view = view[os.write(fd, view) :]


def waited(schedstat: str) -> float:
    """The run-queue wait of a task in seconds: the second field of its /proc schedstat (nanoseconds);
    0 where there is none (not Linux, a task that ended)."""
    try:
        fd = os.open(schedstat, os.O_RDONLY)
    except OSError:
        return 0.0
    try:
        return int(os.pread(fd, 100, 0).split()[1]) / 1e9
    except (OSError, ValueError, IndexError):
        return 0.0
    finally:
        os.close(fd)


def receive(fd: int, deadline: float | None = None) -> tuple[Message, list[bytes]]:
    """One message (header, arrays' bytes), bounded in size; TimeoutError past `deadline`
    (time.monotonic), EOFError when the other end is gone."""
    size, count = _HEAD.unpack(_read(fd, _HEAD.size, deadline))
    if size > MAX_HEADER or count > MAX_BLOBS:
        raise ValueError(f"a message of {size} bytes and {count} arrays")
    header: Message = json.loads(_read(fd, size, deadline))  # our own protocol's JSON
    blobs = []
    for _ in range(count):
        (n,) = _LEN.unpack(_read(fd, _LEN.size, deadline))
        if n > MAX_BLOB:
            raise ValueError(f"an array of {n} bytes")
        blobs.append(_read(fd, n, deadline))
    return header, blobs


_BUFFERS: dict[int, bytearray] = {}  # what was read from each pipe ahead of the part asked for


def _read(fd: int, n: int, deadline: float | None) -> bytes:
    """n bytes from `fd`, read ahead in chunks (one read for a whole small message, not one per part)."""
    buf = _BUFFERS.setdefault(fd, bytearray())
    while len(buf) < n:
        if deadline is not None:
            wait = deadline - time.monotonic()
            if wait <= 0 or not select.select([fd], [], [], wait)[0]:
                raise TimeoutError
        chunk = os.read(fd, max(n - len(buf), 1 << 16))
        if not chunk:
            raise EOFError
        buf += chunk
    out = bytes(buf[:n])
    del buf[:n]
    return out


def forget(fd: int) -> None:
    """`fd` closed: what was read ahead from it is dropped (its number will be reused)."""
    _BUFFERS.pop(fd, None)
    with contextlib.suppress(OSError):
        os.close(fd)


# ----------------------------------------------------------------------------------------------
# The worker, seen from the parent

# The worker's first lines: the package `lagrange_xval` stands as an empty package over its own folder, so
# that the worker imports its side (handwritten/child.py) and the contract's helpers (`lagrange_xval.forms`)
# without the public API, the checks and the engines (the judge; 0.6 s of imports).
BOOT = """
import importlib.util, sys, types
sys.path[:0] = [p for p in sys.argv[6:] if p not in sys.path]
spec = importlib.util.find_spec("lagrange_xval")
package = types.ModuleType("lagrange_xval")
package.__path__, package.__spec__ = list(spec.submodule_search_locations), spec
sys.modules["lagrange_xval"] = package
from lagrange_xval.handwritten.child import main
main(int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4] == "1", int(sys.argv[5]))
"""
_LIVE: weakref.WeakSet[ModuleWorker] = weakref.WeakSet()

# The worker in PID and network namespaces of its own (util-linux's unshare): a process the module starts,
# in any session, a daemon after a double fork included, is in the worker's PID namespace, and the kernel
# ends every process of a namespace when its first one (the worker) ends; the module has no network.
# `--kill-child`: the worker is killed when `unshare` is (the harness kills unshare's process group).
# The namespace's first process is a shell that waits for the worker: the first process of a namespace
# takes no signal it has no handler for from inside it, so a module's os.kill(os.getpid(), SIGKILL) would
# not end a worker that were it; the worker ends as any process does, and the namespace with the shell.
INIT = ("/bin/sh", "-c", '"$@" & wait $!', "sh")
NAMESPACES = ("unshare", "--pid", "--fork", "--kill-child", "--net", "--", *INIT)
USER_NAMESPACES = ("unshare", "--user", "--map-root-user", "--pid", "--fork", "--kill-child", "--net", "--", *INIT)


@functools.cache
def sandbox() -> tuple[str, ...]:
    """The command prefix that starts a worker in namespaces of its own (NAMESPACES, or through a user
    namespace where the harness is not privileged); () where this machine allows neither, said once."""
    for prefix in (NAMESPACES, USER_NAMESPACES):
        try:
            done = subprocess.run([*prefix, "true"], capture_output=True, timeout=10)  # the namespaces and the shell
        except (OSError, subprocess.TimeoutExpired):
            continue
        if done.returncode == 0:
            return prefix
    print(
        "lagrange-xval: note: this machine allows no PID namespace (unshare --pid failed): a process a "
        "person's module starts in a session of its own can outlive the command",
        file=sys.stderr,
    )
    return ()


class ModuleWorker:
    """A person's equations module imported in a process of its own; `call` runs one of its functions.

    Args:
        path: the module's file (.py).
        time_limit: seconds for every call into the module together, its import included (0: none).
        where: how messages name the module (default: the path).
        source: the module's text, where it is not read from `path` (the text form's generated code).

    Raises (from the constructor and `call`): `Stopped` when the module hangs past the budget, exits or
    ends its process; `Raised` when a function raises (its type's name and escaped message).
    """

    def __init__(
        self,
        path: str | Path,
        time_limit: float = DEFAULT_TIME_LIMIT,
        *,
        where: str | None = None,
        source: str | None = None,
    ) -> None:
        self.path, self.where, self.source = str(path), where or str(path), source
        self.time_limit = float(time_limit)
        self.left = self.time_limit or float("inf")
        self.stopped: str | None = None
        self.calls = 0
        self.description: object = None
        self.description_blobs: list[bytes] = []
        self._start()

    def _start(self) -> None:
        """The worker process started and the module imported in it (within the budget)."""
        to_child, self._send = os.pipe()
        self._receive, from_child = os.pipe()
        self._owner = os.getpid()
        main = threading.current_thread() is threading.main_thread()
        from ..core.parallel import parent_death_signal  # the child imports this module: not at its start

        prefix = sandbox()
        self._proc = subprocess.Popen(
            [
                *prefix,
                sys.executable,
                *(["-B"] if sys.dont_write_bytecode else []),  # the parent's -B: nothing written beside the module
                "-c",
                BOOT,
                str(to_child),
                str(from_child),
                str(os.getpid()),
                str(int(main)),
                str(memory_limit()),
                *sys.path,
            ],
            pass_fds=(to_child, from_child),
            stdin=subprocess.DEVNULL,
            stdout=sys.stderr.fileno() if _has_fileno(sys.stderr) else subprocess.DEVNULL,
            start_new_session=True,  # its own process group: killed whole; the terminal's Ctrl-C is not its
            preexec_fn=parent_death_signal() if prefix and main else None,  # noqa: PLW1509 - unshare dies with us
        )
        self._namespaced = bool(prefix)
        os.close(to_child)
        os.close(from_child)
        _LIVE.add(self)
        raw = _Raw()
        message: Message = {"op": "import", "path": self.path, "source": self.source}
        self.description = self.request(message, "importing it", unpack_hook=raw)
        self.description_blobs = raw.blobs  # the description is decoded by its reader (handwritten/proxy.py)

    def renew(self) -> None:
        """The whole budget again (a new check of the same system in the API); a stopped worker stays stopped."""
        if self.stopped is None:
            self.left = self.time_limit or float("inf")

    def call(self, name: str, *args: object, model: Mapping[str, object] | None = None) -> object:
        """The module's function at `name` ("mass_matrix", "VARIANTS.2.residual") called on `args`
        (arrays, numbers, the Params the worker gave, `MODEL` where the model view goes); `model` answers
        the lookups of `parameters(model)`. Traced values: handwritten/proxy.py `invoke`."""
        blobs: list[bytes] = []
        packed = [pack(a, blobs, functools.partial(_plain_hook, blobs)) for a in args]
        message: Message = {"op": "call", "name": name, "args": packed, "backend": None}
        return self.request(message, name, blobs, model=model, unpack_hook=_Records())

    def batch(self, calls: list[tuple[str, tuple[object, ...]]], name: str) -> list[object]:
        """Several calls on numbers (`call`'s arguments, no model view) in one round trip, their answers
        in order; `name` says what the batch is for in a stop ("passive, bias and mass_matrix")."""
        blobs: list[bytes] = []
        hook = functools.partial(_plain_hook, blobs)
        packed = [(path, [pack(a, blobs, hook) for a in args]) for path, args in calls]
        message: Message = {"op": "batch", "name": name, "calls": packed, "backend": None}
        out = self.request(message, name, blobs, unpack_hook=_Records())
        if not isinstance(out, list) or len(out) != len(calls):
            self._stop(f"{name}: the module's worker sent what is not data (a batch of {len(calls)} answers)")
        return out

    def request(
        self,
        message: Message,
        name: str,
        blobs: list[bytes] = (),  # type: ignore[assignment]
        *,
        model: Mapping[str, object] | None = None,
        unpack_hook: Decoder | None = None,
    ) -> object:
        """One request answered within what is left of the budget (model lookups served meanwhile)."""
        if self.stopped is not None:
            raise Stopped(self.where, self.stopped)
        if self._owner != os.getpid():  # a forked copy of the harness: a worker of its own, never the parent's
            for fd in (self._send, self._receive):
                forget(fd)
            self._start()
        self.calls += 1
        start, queued = time.monotonic(), self._queued()
        try:
            send(self._send, message, blobs)
            while True:
                header, got = receive(self._receive, start + self.left + LATENCY)
                if "get" not in header:
                    break
                self._lookup(model, header)
        except TimeoutError:
            self._stop(f"{name} did not return within {self.time_limit:g} s ({HINT})")
        except (EOFError, BrokenPipeError):
            self._stop(self._ended(name))
        except (ValueError, KeyError, TypeError, OverflowError) as exc:
            self._stop(f"{name}: the module's worker sent what is not data ({escape(str(exc), 120)})")
        except BaseException:  # Ctrl-C, SIGTERM: a request cut in the middle leaves the pipe out of step
            self.stopped = f"{name} was interrupted"
            self.close()
            raise
        finally:
            self.left -= max(0.0, time.monotonic() - start - LATENCY - (self._queued() - queued))
        return self._answer(name, header, got, unpack_hook, batch=message.get("op") == "batch")

    @functools.cached_property
    def _worker_pid(self) -> int:
        """The worker's process id (this namespace's): unshare's grandchild where it runs in namespaces."""
        pid = self._proc.pid
        for _ in ("the shell", "the worker") if self._namespaced else ():
            try:
                children = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
            except OSError:
                return self._proc.pid
            if not children:
                return self._proc.pid
            pid = int(children[0])
        return pid

    def _queued(self) -> float:
        """Seconds the worker and this thread have stood waiting for a CPU, summed (0 where unknown)."""
        return waited(f"/proc/{self._worker_pid}/schedstat") + waited(
            f"/proc/self/task/{threading.get_native_id()}/schedstat"
        )

    def _lookup(self, model: Mapping[str, object] | None, header: Message) -> None:
        key = header["get"]
        blobs: list[bytes] = []
        if model is None:
            reply: Message = {"missing": True}
        elif key is None:
            reply = {"keys": [k for k in model]}
        elif not isinstance(key, str) or key not in model:
            reply = {"missing": True}
        else:
            reply = {"value": pack(model[key], blobs)}
        send(self._send, reply, blobs)

    def _answer(
        self,
        name: str,
        header: Message,
        blobs: list[bytes],
        unpack_hook: Decoder | None,
        *,
        batch: bool = False,
    ) -> object:
        if "ok" in header:
            try:
                if unpack_hook is not None and hasattr(unpack_hook, "prepare"):
                    unpack_hook.prepare(header, blobs)
                return unpack(header["ok"], blobs, unpack_hook)
            except (ValueError, KeyError, TypeError, IndexError, OverflowError, RecursionError) as exc:
                self._stop(f"{name}: the module's worker sent what is not data ({escape(str(exc), 120)})")
        if "exit" in header:
            how = "os._exit" if header["exit"] == "os" else "sys.exit"
            self._stop(f"{name} called {how}({escape(str(header.get('code', '')), 40)})")
        kind, text = str(header.get("raised", "Exception")), str(header.get("message", ""))
        function = header.get("function")  # in a batch: the function that raised
        name = escape(function, 80) if batch and isinstance(function, str) else name
        raise _exception(name, kind, text, header.get("harness", False))

    def _ended(self, name: str) -> str:
        status = self._proc.wait(timeout=5) if self._proc.poll() is None else self._proc.returncode
        if self._namespaced and status > 128:  # the shell in the namespace reports a signal as 128 + its number
            status = 128 - status
        try:
            cause = f"killed by {signal.Signals(-status).name}" if status < 0 else f"exit status {status}"
        except ValueError:
            cause = f"status {status}"
        return f"the module's worker process ended ({cause}) during {name}"

    def _stop(self, why: str) -> NoReturn:
        self.stopped = why
        self.close(graceful=True)
        raise Stopped(self.where, why)

    def close(self, *, graceful: bool = False) -> None:
        """The worker and everything in its process group ended (`graceful`: SIGTERM, then SIGKILL after
        GRACE s; else SIGKILL at once); idempotent."""
        proc = self._proc
        if proc.returncode is None and self._owner == os.getpid():  # a forked copy never kills the parent's
            _kill_group(proc, graceful=graceful)
        for fd in (self._send, self._receive):
            forget(fd)
        self._send = self._receive = -1
        if self.stopped is None:
            self.stopped = "the module's worker was closed"
        _LIVE.discard(self)

    def __del__(self) -> None:
        with contextlib.suppress(Exception):
            self.close()


MODEL = object()  # in `ModuleWorker.call`'s arguments: the model view `model=` answers for


def _plain_hook(blobs: list[bytes], value: object) -> Json | None:
    import dataclasses

    if value is MODEL:
        return {"M": 1}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        hook = functools.partial(_plain_hook, blobs)
        return {
            "C": type(value).__name__,
            "f": [[f.name, pack(getattr(value, f.name), blobs, hook)] for f in dataclasses.fields(value)],
        }
    return None


class _Raw:
    """An answer left encoded, with its arrays' bytes."""

    blobs: list[bytes] = []  # noqa: RUF012 - set by prepare

    def prepare(self, header: Message, blobs: list[bytes]) -> None:
        self.blobs = blobs

    def __call__(self, data: Tagged) -> Tagged:
        return data


class _Records:
    """Dataclasses from the worker (Params) as records of their fields, with their class's name."""

    def prepare(self, header: Message, blobs: list[bytes]) -> None:
        self.blobs = blobs

    def __call__(self, data: Tagged) -> object:
        import dataclasses

        if "C" not in data:
            return NotImplemented
        fields = {str(k): unpack(v, self.blobs, self) for k, v in data["f"]}
        cls = dataclasses.make_dataclass(str(data["C"]) if str(data["C"]).isidentifier() else "Record", list(fields))
        return cls(**fields)


def memory_limit() -> int:
    """The worker's address space limit (RLIMIT_AS), bytes: `LAGRANGE_XVAL_WORKER_MEMORY` where set, else
    half the machine's memory, at most 16 GiB: a module that allocates without bound raises MemoryError
    (its own failure) instead of taking the machine."""
    given = os.environ.get(MEMORY_ENV, "").strip()
    if given.isdigit() and int(given) > 0:
        return int(given)
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError):
        return 16 * 2**30
    return min(total // 2, 16 * 2**30)


def _exception(name: str, kind: str, text: str, harness: bool) -> Exception:
    """The exception the parent raises for one the module raised: the contract's own NotApplicable,
    a tracing refusal (`harness`: written by the harness's tracer in the worker), or `Raised`."""
    from ..core.errors import HarnessError

    if kind == "NotApplicable":
        from ..forms import NotApplicable

        return NotApplicable(escape(text))
    if harness:
        return HarnessError(escape(text, 2 * MAX_MESSAGE))
    return raised(name, kind, text)


def _kill_group(proc: subprocess.Popen[bytes], *, graceful: bool) -> None:
    for sig in (signal.SIGTERM, signal.SIGKILL) if graceful else (signal.SIGKILL,):
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, sig)
        try:
            proc.wait(timeout=GRACE)
            break
        except subprocess.TimeoutExpired:
            continue
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)  # what the worker forked, in its group, after it is gone
    if proc.poll() is None:
        proc.wait()


def _has_fileno(stream: IO[str]) -> bool:
    try:
        stream.fileno()
    except (AttributeError, OSError, ValueError):
        return False
    return True


@atexit.register
def close_all() -> None:
    """Every live worker ended (the command exits right after its verdict, whatever the modules left)."""
    for worker in list(_LIVE):
        worker.close()

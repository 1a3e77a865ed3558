"""Tracing the equations modules' numpy code with symbolic values, for code generation.

numpy applies a ufunc to an object array by calling the element's method of the same name
(`np.sin(x)` -> `x.sin()`) and binary operators element by element, so a module's functions run
unmodified on object arrays of `Traced` values (`_forms.stack_*` keep objects as objects). A
backend supplies the expression type: sympy for the generated scalar `math` right-hand sides
(fastpath.py), heyoka for the Taylor reference (reference.py).

Branches are the exception: numpy's object loops of np.sign, np.minimum, np.maximum, np.clip,
np.where and of comparisons ask `bool(x < 0)`, which no expression can answer. So the arrays a
module is given are `TracedArray`s and the values `Traced`s, both with numpy's override protocols
(`__array_ufunc__`, `__array_function__`): these functions are computed element by element as
the backend's own conditional (sympy's Piecewise, heyoka's select), and a comparison is a
condition expression. Where numpy still branches on a traced value (an array made plain by
np.asarray, an `if`), or where a ufunc has no expression, the trace is refused in one line naming
the numpy function and the module's line (`Untraceable`).
"""

from __future__ import annotations

import functools
import linecache
import operator
import os
import re
import sys
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from types import FrameType
from typing import Any, NamedTuple, Protocol

import numpy as np

from ..core.errors import HarnessError

# numpy ufunc names (the methods numpy calls) that a backend may name differently
UNARY = ("sin", "cos", "tan", "arcsin", "arccos", "arctan", "sinh", "cosh", "tanh", "exp", "log", "sqrt")
# ufuncs whose object loops only do arithmetic on the elements (no branch on a traced value)
ARITHMETIC = frozenset(
    {"add", "subtract", "multiply", "divide", "power", "negative", "positive", "square", "matmul", "arctan2"}
    | {"reciprocal", "bitwise_and", "bitwise_or", "invert"}
)
COMPARISONS = {"less": "lt", "less_equal": "le", "greater": "gt", "greater_equal": "ge", "equal": "eq"}
COMPARISONS |= {"not_equal": "ne"}
PURPOSE = {"heyoka": "for the Taylor reference", "sympy": "symbolically (generated code, energy derivatives)"}


@dataclass(frozen=True)
class Backend:
    name: str
    lift: Callable[[float], Any]  # a number -> a constant expression
    function: Callable[[str], Callable[..., Any]]  # a numpy ufunc name -> the backend's function
    is_expression: Callable[[Any], bool]
    compare: Callable[[str, Any, Any], Any]  # ("lt" | "le" | "gt" | "ge" | "eq" | "ne", a, b) -> a condition
    select: Callable[[Any, Any, Any], Any]  # (condition, a, b) -> a where the condition holds, else b
    logical: Callable[[str, list[Any]], Any]  # ("and" | "or" | "not", conditions) -> a condition


class Untraceable(HarnessError):
    """A module's code that a backend cannot express: the message names the numpy function and the line."""


# ----------------------------------------------------------------------------------------------
# Where in the person's module: the innermost frame outside numpy, the backends and the harness

_SKIP = tuple(
    os.path.dirname(p) + os.sep for p in (np.__file__, os.path.dirname(os.path.dirname(__file__)) + os.sep, os.__file__)
)


def _is_user_file(filename: str) -> bool:
    skip = _SKIP + tuple(
        os.path.dirname(m.__file__) + os.sep
        for name in ("sympy", "heyoka")
        if (m := sys.modules.get(name)) is not None and m.__file__
    )
    return not filename.startswith(skip) and not filename.startswith("<")


def _frame_location(frame: FrameType | None) -> tuple[str, str, int] | None:
    while frame is not None:
        if _is_user_file(frame.f_code.co_filename):
            return frame.f_code.co_filename, frame.f_code.co_name, frame.f_lineno
        frame = frame.f_back
    return None


def _traceback_location(exc: BaseException) -> tuple[str, str, int] | None:
    frames = [f for f in traceback.extract_tb(exc.__traceback__) if _is_user_file(f.filename)]
    return (frames[-1].filename, frames[-1].name, frames[-1].lineno or 0) if frames else None


def _at(where: tuple[str, str, int] | None) -> str:
    return "" if where is None else f" in {where[1]}() at {os.path.basename(where[0])}:{where[2]}"


def refusal(what: str | None, backend: Backend, hint: str) -> Untraceable:
    """ "np.sign in passive() at my_arm.py:42 cannot be traced for the Taylor reference; <hint>"."""
    where = _frame_location(sys._getframe(1))
    if what is None:  # a truth value asked inside numpy: the numpy function on the module's line
        line = linecache.getline(where[0], where[2]) if where else ""
        names = [f"np.{n}" for n in re.findall(r"\bnp\.(\w+)\s*\(", line) if n in _BRANCHING_NAMES]
        what = " / ".join(dict.fromkeys(names)) or "a comparison used as a truth value"
    return Untraceable(f"{what}{_at(where)} cannot be traced {PURPOSE.get(backend.name, '')}; {hint}")


def describe(exc: BaseException, function: str, backend: Backend) -> str:
    """One line for an exception raised while tracing `function`: the module's line, no class of ours."""
    if isinstance(exc, HarnessError):
        return str(exc)
    where = _traceback_location(exc)
    text = re.sub(r"\bTraced(Array)?\b", "symbolic value", (str(exc).strip().splitlines() or [""])[0])
    said = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    place = f"{function}()" if where is None else _at(where).removeprefix(" in ")
    return f"{place} cannot be traced {PURPOSE.get(backend.name, '')} ({said})"


def traced_call(backend: Backend, function: str, fn: Callable[..., Any], *args: Any) -> Any:
    """fn(*args) on traced values; any failure a HarnessError naming the module's function and line."""
    try:
        return fn(*args)
    except Exception as exc:  # noqa: BLE001 - the person's code: said in one line, never a traceback
        raise (exc if isinstance(exc, Untraceable) else HarnessError(describe(exc, function, backend))) from None


# ----------------------------------------------------------------------------------------------
# Traced values


class Traced:
    """A backend expression that numpy's object loops can compute with; `condition`: a comparison's
    truth expression (1 or 0 where used as a number)."""

    __slots__ = ("e", "backend", "condition")
    __hash__ = object.__hash__

    def __init__(self, e: Any, backend: Backend, condition: bool = False) -> None:
        self.e, self.backend, self.condition = e, backend, condition

    @property
    def value(self) -> Any:
        """The expression as a number (a condition as 1 or 0)."""
        bk = self.backend
        return bk.select(self.e, bk.lift(1.0), bk.lift(0.0)) if self.condition else self.e

    @property
    def truth(self) -> Any:
        """The expression as a condition (a number: nonzero)."""
        return self.e if self.condition else self.backend.compare("ne", self.e, self.backend.lift(0.0))

    def _op(self, other: Any, op: Callable[[Any, Any], Any], reflected: bool = False) -> Any:
        if isinstance(other, np.ndarray) and other.shape != ():
            return NotImplemented  # arrays go back to numpy, which broadcasts
        a, b = (unwrap(other, self.backend), self.value) if reflected else (self.value, unwrap(other, self.backend))
        return Traced(op(a, b), self.backend)

    def __add__(self, o: Any) -> Any:
        return self._op(o, operator.add)

    def __radd__(self, o: Any) -> Any:
        return self._op(o, operator.add, True)

    def __sub__(self, o: Any) -> Any:
        return self._op(o, operator.sub)

    def __rsub__(self, o: Any) -> Any:
        return self._op(o, operator.sub, True)

    def __mul__(self, o: Any) -> Any:
        return self._op(o, operator.mul)

    def __rmul__(self, o: Any) -> Any:
        return self._op(o, operator.mul, True)

    def __truediv__(self, o: Any) -> Any:
        return self._op(o, operator.truediv)

    def __rtruediv__(self, o: Any) -> Any:
        return self._op(o, operator.truediv, True)

    def __pow__(self, o: Any) -> Any:
        return self._op(o, operator.pow)

    def __rpow__(self, o: Any) -> Any:
        return self._op(o, operator.pow, True)

    def __neg__(self) -> Traced:
        return Traced(-self.value, self.backend)

    def __pos__(self) -> Traced:
        return self

    def __abs__(self) -> Any:
        return _abs(self)

    def _compare(self, other: Any, op: str) -> Any:
        if isinstance(other, np.ndarray) and other.shape != ():
            return NotImplemented
        return compare(op, self, other)

    def __lt__(self, o: Any) -> Any:
        return self._compare(o, "lt")

    def __le__(self, o: Any) -> Any:
        return self._compare(o, "le")

    def __gt__(self, o: Any) -> Any:
        return self._compare(o, "gt")

    def __ge__(self, o: Any) -> Any:
        return self._compare(o, "ge")

    def __eq__(self, o: Any) -> Any:  # type: ignore[override]
        return self._compare(o, "eq")

    def __ne__(self, o: Any) -> Any:  # type: ignore[override]
        return self._compare(o, "ne")

    def __and__(self, o: Any) -> Any:
        return logical("and", self, o)

    __rand__ = __and__

    def __or__(self, o: Any) -> Any:
        return logical("or", self, o)

    __ror__ = __or__

    def __invert__(self) -> Any:
        return logical("not", self)

    def __bool__(self) -> bool:
        raise refusal(
            None,
            self.backend,
            "numpy asked whether a symbolic value is true (an `if`, or a function on an array made plain by "
            "np.asarray/np.array): compute on the arrays the harness passes, and write branches with np.where.",
        )

    def square(self) -> Traced:
        return Traced(self.value * self.value, self.backend)

    def arctan2(self, other: Any) -> Traced:
        return Traced(self.backend.function("arctan2")(self.value, unwrap(other, self.backend)), self.backend)

    def __getattr__(self, name: str) -> Any:  # sin, cos, ...: what np.<ufunc> calls on objects
        if name in UNARY:
            return lambda: Traced(self.backend.function(name)(self.value), self.backend)
        raise AttributeError(name)

    def __array_ufunc__(self, ufunc: np.ufunc, method: str, *inputs: Any, **kwargs: Any) -> Any:
        return apply_ufunc(ufunc, method, inputs, kwargs)

    def __array_function__(self, func: Any, types: Any, args: Any, kwargs: Any) -> Any:
        return apply_function(func, args, kwargs)


class TracedArray(np.ndarray):
    """An object array of traced values whose ufuncs and numpy functions go through the tracer."""

    def __array_ufunc__(self, ufunc: np.ufunc, method: str, *inputs: Any, **kwargs: Any) -> Any:
        return apply_ufunc(ufunc, method, inputs, kwargs)

    def __array_function__(self, func: Any, types: Any, args: Any, kwargs: Any) -> Any:
        return apply_function(func, args, kwargs)


def _backend_of(xs: tuple[Any, ...]) -> Backend | None:
    return next((x.backend for x in xs if isinstance(x, Traced)), None)


def compare(op: str, a: Any, b: Any) -> Any:
    """a <op> b: a condition expression where either is traced, else numpy's answer."""
    backend = _backend_of((a, b))
    if backend is None:
        return bool(getattr(operator, op)(a, b))
    return Traced(backend.compare(op, unwrap(a, backend), unwrap(b, backend)), backend, condition=True)


def select(c: Any, a: Any, b: Any) -> Any:
    """a where c holds, else b (np.where's element)."""
    if not isinstance(c, Traced):
        return a if bool(c) else b
    bk = c.backend
    return Traced(bk.select(c.truth, unwrap(a, bk), unwrap(b, bk)), bk)


def logical(op: str, *xs: Any) -> Any:
    """and / or / not of conditions; a known truth value among traced ones decides or drops out."""
    backend = _backend_of(xs)
    if backend is None:
        truths = [bool(x) for x in xs]
        return not truths[0] if op == "not" else (all(truths) if op == "and" else any(truths))
    known = [bool(x) for x in xs if not isinstance(x, Traced)]
    traced = [x.truth for x in xs if isinstance(x, Traced)]
    if known and (not all(known) if op == "and" else any(known)):
        return op == "or"  # False and ..., True or ...
    if len(traced) == 1 and op != "not":
        return Traced(traced[0], backend, condition=True)
    return Traced(backend.logical(op, traced), backend, condition=True)


def _sign(x: Any) -> Any:
    return select(compare("gt", x, 0.0), 1.0, select(compare("lt", x, 0.0), -1.0, 0.0))


def _abs(x: Any) -> Any:
    return select(compare("lt", x, 0.0), -x, x) if isinstance(x, Traced) else abs(x)


def _minimum(a: Any, b: Any) -> Any:
    return select(compare("lt", b, a), b, a)


def _maximum(a: Any, b: Any) -> Any:
    return select(compare("gt", b, a), b, a)


def _clip(x: Any, low: Any, high: Any) -> Any:
    return _minimum(_maximum(x, low), high)


# the ufuncs numpy's object loops compute by branching, computed here as conditional expressions
SCALAR_UFUNCS: dict[str, Callable[..., Any]] = {
    "sign": _sign,
    "absolute": _abs,
    "fabs": _abs,
    "minimum": _minimum,
    "maximum": _maximum,
    "fmin": _minimum,
    "fmax": _maximum,
    "clip": _clip,
    "logical_and": lambda a, b: logical("and", a, b),
    "logical_or": lambda a, b: logical("or", a, b),
    "logical_not": lambda a: logical("not", a),
    **{name: functools.partial(compare, op) for name, op in COMPARISONS.items()},
}
# what may have asked for a truth value (np.abs calls the element's __abs__: it never does)
_BRANCHING_NAMES = (frozenset(SCALAR_UFUNCS) - {"absolute", "fabs"}) | {"where", "amin", "amax", "min", "max", "select"}


def _plain(x: Any) -> Any:
    """What numpy computes on without coming back here: a plain object array (a scalar as 0-d)."""
    if isinstance(x, TracedArray):
        return x.view(np.ndarray)
    if isinstance(x, Traced):
        out = np.empty((), dtype=object)
        out[()] = x
        return out
    if isinstance(x, tuple | list):
        return type(x)(_plain(e) for e in x)
    return x


def _rewrap(x: Any) -> Any:
    """numpy's answer with object arrays traced again (0-d: the element, as numpy's ufuncs answer)."""
    if isinstance(x, tuple):
        return tuple(_rewrap(e) for e in x)
    if isinstance(x, np.ndarray) and x.dtype == object:
        return x[()] if x.shape == () else x.view(TracedArray)
    return x


def apply_ufunc(ufunc: np.ufunc, method: str, inputs: tuple[Any, ...], kwargs: dict[str, Any]) -> Any:
    """A numpy ufunc on traced operands: the branching ones element by element as conditional
    expressions, the arithmetic and elementary ones by numpy's object loops; others refused by name."""
    name = ufunc.__name__
    backend = _backend_of(inputs) or _backend_in_arrays(inputs)
    plain = [_plain(x) for x in inputs]
    kwargs = {k: _plain(v) for k, v in kwargs.items()}
    if name in SCALAR_UFUNCS:
        fn: Any = np.frompyfunc(SCALAR_UFUNCS[name], ufunc.nin, 1)
    elif name in ARITHMETIC or name in UNARY:
        fn = ufunc
    else:
        raise refusal(f"np.{name}", backend, _HINT) if backend else TypeError(f"np.{name}: no symbolic form")
    return _rewrap(getattr(fn, method)(*plain, **kwargs))


_HINT = (
    "write it with arithmetic, np.sin, np.cos, np.sqrt, np.exp, np.log, ..., np.abs, np.sign, np.minimum, "
    "np.maximum, np.clip and np.where."
)


def _backend_in_arrays(xs: tuple[Any, ...]) -> Backend | None:
    for x in xs:
        if isinstance(x, np.ndarray) and x.dtype == object:
            found = _backend_of(tuple(x.flat))
            if found is not None:
                return found
    return None


def _where(condition: Any, *xy: Any) -> Any:
    if len(xy) != 2:
        backend = _backend_in_arrays((np.asarray(condition),)) or _backend_of((condition,))
        hint = "give np.where both branches, np.where(condition, x, y)."
        raise refusal("np.where(condition)", backend, hint) if backend else TypeError(hint)
    pick: Any = np.frompyfunc(select, 3, 1)
    return _rewrap(pick(*(_plain(a) for a in (condition, *xy))))


def apply_function(func: Any, args: tuple[Any, ...], kwargs: dict[str, Any]) -> Any:
    """A numpy function on traced arguments: np.where and np.clip as conditional expressions, any
    other by numpy itself on plain object arrays (traced arrays out)."""
    if func is np.where:
        return _where(*args, **kwargs)
    if func is np.clip:
        x, low, high = (*args, *kwargs.values())[:3]
        return _rewrap(np.frompyfunc(_clip, 3, 1)(_plain(x), _plain(low), _plain(high)))
    return _rewrap(func(*_plain(tuple(args)), **{k: _plain(v) for k, v in kwargs.items()}))


def unwrap(x: Any, backend: Backend) -> Any:
    """The backend expression of a traced value, a number or a 0-d array."""
    if isinstance(x, np.ndarray):
        if x.shape != ():
            raise TypeError(f"expected a scalar, got an array of shape {x.shape}")
        x = x[()]
    if isinstance(x, Traced):
        return x.value
    if backend.is_expression(x):
        return x
    return backend.lift(float(x))


def wrap(symbols: list[Any], backend: Backend) -> np.ndarray:
    out = np.empty(len(symbols), dtype=object)
    for i, s in enumerate(symbols):
        out[i] = Traced(s, backend)
    return out.view(TracedArray)


def vector(x: Any, n: int, backend: Backend) -> list[Any]:
    """A module function's (n,) output as a list of backend expressions."""
    return [unwrap(e, backend) for e in np.broadcast_to(np.asarray(x, dtype=object), (n,))]


class Traceable(Protocol):
    """What `dynamics` reads of a system: a `System`, or the `SystemParts` of one."""

    @property
    def nv(self) -> int: ...
    @property
    def equations(self) -> Any: ...
    @property
    def params(self) -> Any: ...


class SystemParts(NamedTuple):
    """The three parts of a system `dynamics` traces, where no `System` is at hand (a cached module)."""

    nv: int
    equations: Any
    params: Any


def dynamics(
    system: Traceable, qs: list[Any], vs: list[Any], backend: Backend
) -> tuple[list[list[Any]], list[Any], list[Any]]:
    """The hand equations' M, bias and passive as backend expressions in the symbols qs, vs; a
    HarnessError naming the module's function and line where they cannot be traced."""
    n = system.nv
    q, v = wrap(qs, backend), wrap(vs, backend)
    eq, p = system.equations, system.params
    m = np.asarray(traced_call(backend, "mass_matrix", eq.mass_matrix, p, q), dtype=object)
    if m.shape != (n, n):
        raise HarnessError(f"mass_matrix() traced to shape {m.shape}; expected {(n, n)}")
    return (
        [[unwrap(m[i, j], backend) for j in range(n)] for i in range(n)],
        vector(traced_call(backend, "bias", eq.bias, p, q, v), n, backend),
        vector(traced_call(backend, "passive", eq.passive, p, q, v), n, backend),
    )


def solve_spd(matrix: list[list[Any]], b: list[Any]) -> list[Any]:
    """x with matrix x = b by Gaussian elimination without pivoting (M is symmetric positive definite)."""
    n = len(b)
    a = [row[:] for row in matrix]
    b = b[:]
    for k in range(n):
        for i in range(k + 1, n):
            ratio = a[i][k] / a[k][k]
            for j in range(k + 1, n):
                a[i][j] = a[i][j] - ratio * a[k][j]
            b[i] = b[i] - ratio * b[k]
    x: list[Any] = [None] * n
    for i in reversed(range(n)):
        acc = b[i]
        for j in range(i + 1, n):
            acc = acc - a[i][j] * x[j]
        x[i] = acc / a[i][i]
    return x


def sympy_backend() -> Backend:
    import sympy as sp

    names = {"arcsin": "asin", "arccos": "acos", "arctan": "atan", "arctan2": "atan2"}
    relations = {"lt": sp.Lt, "le": sp.Le, "gt": sp.Gt, "ge": sp.Ge, "eq": sp.Eq, "ne": sp.Ne}
    logic = {"and": sp.And, "or": sp.Or, "not": sp.Not}
    return Backend(
        "sympy",
        lambda x: sp.Float(x, 17) if x != 0 else sp.Integer(0),
        lambda name: getattr(sp, names.get(name, name)),
        lambda x: isinstance(x, sp.Basic),
        lambda op, a, b: relations[op](a, b),
        lambda c, a, b: sp.Piecewise((a, c), (b, True)),
        lambda op, cs: logic[op](*cs),
    )


def heyoka_backend() -> Backend:
    import heyoka as hy

    names = {"arcsin": "asin", "arccos": "acos", "arctan": "atan", "arctan2": "atan2"}
    relations = {"lt": hy.lt, "le": hy.lte, "gt": hy.gt, "ge": hy.gte, "eq": hy.eq, "ne": hy.neq}
    logic = {
        "and": hy.logical_and,
        "or": hy.logical_or,
        "not": lambda cs: hy.eq(cs[0], hy.expression(0.0)),  # a condition is 1 or 0
    }
    return Backend(
        "heyoka",
        lambda x: hy.expression(x),
        lambda name: getattr(hy, names.get(name, name)),
        lambda x: isinstance(x, hy.expression),
        lambda op, a, b: relations[op](a, b),
        hy.select,
        lambda op, cs: logic[op](cs),
    )


def sympy_params(
    params_type: Any, numeric: tuple[tuple[str, float], ...] | None
) -> tuple[tuple[str, ...], list[Any], Any]:
    """(field names, their sympy symbols, a Params instance) for tracing a module with sympy: every
    field a symbol, or the `numeric` values as given (names and symbols then empty)."""
    import dataclasses

    import sympy as sp

    if numeric is not None:
        return (), [], params_type(**dict(numeric))
    backend = sympy_backend()
    names = tuple(f.name for f in dataclasses.fields(params_type))
    symbols = [sp.Symbol(k) for k in names]
    return names, symbols, params_type(**{k: Traced(s, backend) for k, s in zip(names, symbols, strict=True)})

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
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from types import FrameType
from typing import TYPE_CHECKING, Generic, NamedTuple, Protocol, Self, SupportsFloat, TypeVar, cast

import numpy as np

from ..core.errors import HarnessError

if TYPE_CHECKING:
    import heyoka as hy
    import sympy as sp
    from _typeshed import DataclassInstance
    from typing_extensions import TypeIs

    from ..forms import FormA


class Arithmetic(Protocol):
    """What a backend's expressions (and numbers) compute with."""

    def __neg__(self) -> Self: ...
    def __sub__(self, other: Self, /) -> Self: ...
    def __mul__(self, other: Self, /) -> Self: ...
    def __truediv__(self, other: Self, /) -> Self: ...


E = TypeVar("E", bound=Arithmetic)  # a backend's expression type: sympy's Basic, heyoka's expression
R = TypeVar("R")
N = TypeVar("N", bound=Arithmetic)  # what Gaussian elimination computes with: numbers or expressions
P = TypeVar("P", bound="DataclassInstance")  # a module's Params dataclass

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
class Backend(Generic[E]):
    name: str
    lift: Callable[[float], E]  # a number -> a constant expression
    function: Callable[[str], Callable[..., E]]  # a numpy ufunc name -> the backend's function
    is_expression: Callable[[object], TypeIs[E]]
    compare: Callable[[str, E, E], E]  # ("lt" | "le" | "gt" | "ge" | "eq" | "ne", a, b) -> a condition
    select: Callable[[E, E, E], E]  # (condition, a, b) -> a where the condition holds, else b
    logical: Callable[[str, list[E]], E]  # ("and" | "or" | "not", conditions) -> a condition


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


def refusal(what: str | None, backend: Backend[E], hint: str) -> Untraceable:
    """ "np.sign in passive() at my_arm.py:42 cannot be traced for the Taylor reference; <hint>"."""
    where = _frame_location(sys._getframe(1))
    if what is None:  # a truth value asked inside numpy: the numpy function on the module's line
        line = linecache.getline(where[0], where[2]) if where else ""
        names = [f"np.{n}" for n in re.findall(r"\bnp\.(\w+)\s*\(", line) if n in _BRANCHING_NAMES]
        what = " / ".join(dict.fromkeys(names)) or "a comparison used as a truth value"
    return Untraceable(f"{what}{_at(where)} cannot be traced {PURPOSE.get(backend.name, '')}; {hint}")


def describe(exc: BaseException, function: str, backend: Backend[E]) -> str:
    """One line for an exception raised while tracing `function`: the module's line, no class of ours."""
    if isinstance(exc, HarnessError):
        return str(exc)
    where = _traceback_location(exc)
    text = re.sub(r"\bTraced(Array)?\b", "symbolic value", (str(exc).strip().splitlines() or [""])[0])
    said = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    place = f"{function}()" if where is None else _at(where).removeprefix(" in ")
    return f"{place} cannot be traced {PURPOSE.get(backend.name, '')} ({said})"


def traced_call(backend: Backend[E], function: str, fn: Callable[..., R], *args: object) -> R:
    """fn(*args) on traced values; any failure a HarnessError naming the module's function and line."""
    try:
        return fn(*args)
    except Exception as exc:  # noqa: BLE001 - the person's code: said in one line, never a traceback
        raise (exc if isinstance(exc, Untraceable) else HarnessError(describe(exc, function, backend))) from None


# ----------------------------------------------------------------------------------------------
# Traced values


class Traced(Generic[E]):
    """A backend expression that numpy's object loops can compute with; `condition`: a comparison's
    truth expression (1 or 0 where used as a number)."""

    __slots__ = ("e", "backend", "condition")
    __hash__ = object.__hash__

    def __init__(self, e: E, backend: Backend[E], condition: bool = False) -> None:
        self.e, self.backend, self.condition = e, backend, condition

    @property
    def value(self) -> E:
        """The expression as a number (a condition as 1 or 0)."""
        bk = self.backend
        return bk.select(self.e, bk.lift(1.0), bk.lift(0.0)) if self.condition else self.e

    @property
    def truth(self) -> E:
        """The expression as a condition (a number: nonzero)."""
        return self.e if self.condition else self.backend.compare("ne", self.e, self.backend.lift(0.0))

    def _op(self, other: object, op: Callable[[E, E], E], reflected: bool = False) -> Traced[E]:
        if isinstance(other, np.ndarray) and other.shape != ():
            return NotImplemented  # arrays go back to numpy, which broadcasts
        a, b = (unwrap(other, self.backend), self.value) if reflected else (self.value, unwrap(other, self.backend))
        return Traced(op(a, b), self.backend)

    def __add__(self, o: object) -> Traced[E]:
        return self._op(o, operator.add)

    def __radd__(self, o: object) -> Traced[E]:
        return self._op(o, operator.add, True)

    def __sub__(self, o: object) -> Traced[E]:
        return self._op(o, operator.sub)

    def __rsub__(self, o: object) -> Traced[E]:
        return self._op(o, operator.sub, True)

    def __mul__(self, o: object) -> Traced[E]:
        return self._op(o, operator.mul)

    def __rmul__(self, o: object) -> Traced[E]:
        return self._op(o, operator.mul, True)

    def __truediv__(self, o: object) -> Traced[E]:
        return self._op(o, operator.truediv)

    def __rtruediv__(self, o: object) -> Traced[E]:
        return self._op(o, operator.truediv, True)

    def __pow__(self, o: object) -> Traced[E]:
        return self._op(o, operator.pow)

    def __rpow__(self, o: object) -> Traced[E]:
        return self._op(o, operator.pow, True)

    def __neg__(self) -> Traced[E]:
        return Traced(-self.value, self.backend)

    def __pos__(self) -> Traced[E]:
        return self

    def __abs__(self) -> object:
        return _abs(self)

    def _compare(self, other: object, op: str) -> Traced[Arithmetic] | bool:
        if isinstance(other, np.ndarray) and other.shape != ():
            return NotImplemented
        return compare(op, self, other)

    def __lt__(self, o: object) -> Traced[Arithmetic] | bool:
        return self._compare(o, "lt")

    def __le__(self, o: object) -> Traced[Arithmetic] | bool:
        return self._compare(o, "le")

    def __gt__(self, o: object) -> Traced[Arithmetic] | bool:
        return self._compare(o, "gt")

    def __ge__(self, o: object) -> Traced[Arithmetic] | bool:
        return self._compare(o, "ge")

    def __eq__(self, o: object) -> Traced[Arithmetic] | bool:  # type: ignore[override]
        return self._compare(o, "eq")

    def __ne__(self, o: object) -> Traced[Arithmetic] | bool:  # type: ignore[override]
        return self._compare(o, "ne")

    def __and__(self, o: object) -> Traced[Arithmetic] | bool:
        return logical("and", self, o)

    __rand__ = __and__

    def __or__(self, o: object) -> Traced[Arithmetic] | bool:
        return logical("or", self, o)

    __ror__ = __or__

    def __invert__(self) -> Traced[Arithmetic] | bool:
        return logical("not", self)

    def __bool__(self) -> bool:
        raise refusal(
            None,
            self.backend,
            "numpy asked whether a symbolic value is true (an `if`, or a function on an array made plain by "
            "np.asarray/np.array): compute on the arrays the harness passes, and write branches with np.where.",
        )

    def square(self) -> Traced[E]:
        return Traced(self.value * self.value, self.backend)

    def arctan2(self, other: object) -> Traced[E]:
        return Traced(self.backend.function("arctan2")(self.value, unwrap(other, self.backend)), self.backend)

    def __getattr__(self, name: str) -> Callable[[], Traced[E]]:  # sin, cos, ...: what np.<ufunc> calls on objects
        if name in UNARY:
            return lambda: Traced(self.backend.function(name)(self.value), self.backend)
        raise AttributeError(name)

    def __array_ufunc__(self, ufunc: np.ufunc, method: str, *inputs: object, **kwargs: object) -> object:
        return apply_ufunc(ufunc, method, inputs, kwargs)

    def __array_function__(
        self, func: Callable[..., object], types: object, args: Iterable[object], kwargs: Mapping[str, object]
    ) -> object:
        return apply_function(func, args, kwargs)


class TracedArray(np.ndarray):
    """An object array of traced values whose ufuncs and numpy functions go through the tracer."""

    def __array_ufunc__(self, ufunc: np.ufunc, method: str, *inputs: object, **kwargs: object) -> object:
        return apply_ufunc(ufunc, method, inputs, kwargs)

    def __array_function__(
        self, func: Callable[..., object], types: object, args: Iterable[object], kwargs: Mapping[str, object]
    ) -> object:
        return apply_function(func, args, kwargs)


def _backend_of(xs: tuple[object, ...]) -> Backend[Arithmetic] | None:
    return next((x.backend for x in xs if isinstance(x, Traced)), None)


def compare(op: str, a: object, b: object) -> Traced[Arithmetic] | bool:
    """a <op> b: a condition expression where either is traced, else numpy's answer."""
    backend = _backend_of((a, b))
    if backend is None:
        return bool(getattr(operator, op)(a, b))
    return Traced(backend.compare(op, unwrap(a, backend), unwrap(b, backend)), backend, condition=True)


def select(c: object, a: object, b: object) -> object:
    """a where c holds, else b (np.where's element)."""
    if not isinstance(c, Traced):
        return a if bool(c) else b
    bk = c.backend
    return Traced(bk.select(c.truth, unwrap(a, bk), unwrap(b, bk)), bk)


def logical(op: str, *xs: object) -> Traced[Arithmetic] | bool:
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


def _sign(x: object) -> object:
    return select(compare("gt", x, 0.0), 1.0, select(compare("lt", x, 0.0), -1.0, 0.0))


def _abs(x: Traced[E] | float) -> object:
    return select(compare("lt", x, 0.0), -x, x) if isinstance(x, Traced) else abs(x)


def _minimum(a: object, b: object) -> object:
    return select(compare("lt", b, a), b, a)


def _maximum(a: object, b: object) -> object:
    return select(compare("gt", b, a), b, a)


def _clip(x: object, low: object, high: object) -> object:
    return _minimum(_maximum(x, low), high)


# the ufuncs numpy's object loops compute by branching, computed here as conditional expressions
SCALAR_UFUNCS: dict[str, Callable[..., object]] = {
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


def _plain(x: object) -> object:
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


def _rewrap(x: object) -> object:
    """numpy's answer with object arrays traced again (0-d: the element, as numpy's ufuncs answer)."""
    if isinstance(x, tuple):
        return tuple(_rewrap(e) for e in x)
    if isinstance(x, np.ndarray) and x.dtype == object:
        return x[()] if x.shape == () else x.view(TracedArray)
    return x


def apply_ufunc(ufunc: np.ufunc, method: str, inputs: tuple[object, ...], kwargs: dict[str, object]) -> object:
    """A numpy ufunc on traced operands: the branching ones element by element as conditional
    expressions, the arithmetic and elementary ones by numpy's object loops; others refused by name."""
    name = ufunc.__name__
    backend = _backend_of(inputs) or _backend_in_arrays(inputs)
    plain = [_plain(x) for x in inputs]
    kwargs = {k: _plain(v) for k, v in kwargs.items()}
    if name in SCALAR_UFUNCS:
        fn: np.ufunc = np.frompyfunc(SCALAR_UFUNCS[name], ufunc.nin, 1)
    elif name in ARITHMETIC or name in UNARY:
        fn = ufunc
    else:
        raise refusal(f"np.{name}", backend, _HINT) if backend else TypeError(f"np.{name}: no symbolic form")
    return _rewrap(getattr(fn, method)(*plain, **kwargs))


_HINT = (
    "write it with arithmetic, np.sin, np.cos, np.sqrt, np.exp, np.log, ..., np.abs, np.sign, np.minimum, "
    "np.maximum, np.clip and np.where."
)


def _backend_in_arrays(xs: tuple[object, ...]) -> Backend[Arithmetic] | None:
    for x in xs:
        if isinstance(x, np.ndarray) and x.dtype == object:
            found = _backend_of(tuple(x.flat))
            if found is not None:
                return found
    return None


def _where(condition: object, *xy: object) -> object:
    if len(xy) != 2:
        backend = _backend_in_arrays((np.asarray(condition),)) or _backend_of((condition,))
        hint = "give np.where both branches, np.where(condition, x, y)."
        raise refusal("np.where(condition)", backend, hint) if backend else TypeError(hint)
    pick: Callable[..., object] = np.frompyfunc(select, 3, 1)
    return _rewrap(pick(*(_plain(a) for a in (condition, *xy))))


def apply_function(func: Callable[..., object], args: Iterable[object], kwargs: Mapping[str, object]) -> object:
    """A numpy function on traced arguments: np.where and np.clip as conditional expressions, any
    other by numpy itself on plain object arrays (traced arrays out)."""
    if func is np.where:
        return _where(*args, **kwargs)
    if func is np.clip:
        x, low, high = (*args, *kwargs.values())[:3]
        clip: Callable[..., object] = np.frompyfunc(_clip, 3, 1)
        return _rewrap(clip(_plain(x), _plain(low), _plain(high)))
    return _rewrap(func(*(_plain(a) for a in args), **{k: _plain(v) for k, v in kwargs.items()}))


def unwrap(x: object, backend: Backend[E]) -> E:
    """The backend expression of a traced value, a number or a 0-d array."""
    if isinstance(x, np.ndarray):
        if x.shape != ():
            raise TypeError(f"expected a scalar, got an array of shape {x.shape}")
        x = x[()]
    if isinstance(x, Traced):
        return x.value
    if backend.is_expression(x):
        return x
    return backend.lift(float(cast(SupportsFloat, x)))  # a number: float() refuses anything else


def wrap(symbols: list[E], backend: Backend[E]) -> np.ndarray:
    out = np.empty(len(symbols), dtype=object)
    for i, s in enumerate(symbols):
        out[i] = Traced(s, backend)
    return out.view(TracedArray)


def vector(x: object, n: int, backend: Backend[E]) -> list[E]:
    """A module function's (n,) output as a list of backend expressions."""
    return [unwrap(e, backend) for e in np.broadcast_to(np.asarray(x, dtype=object), (n,))]


class Traceable(Protocol):
    """What `dynamics` reads of a system: a `System`, or the `SystemParts` of one."""

    @property
    def nv(self) -> int: ...
    @property
    def equations(self) -> FormA | None: ...
    @property
    def params(self) -> object: ...


class SystemParts(NamedTuple):
    """The three parts of a system `dynamics` traces, where no `System` is at hand (a cached module)."""

    nv: int
    equations: FormA
    params: object


def dynamics(
    system: Traceable, qs: list[E], vs: list[E], backend: Backend[E]
) -> tuple[list[list[E]], list[E], list[E]]:
    """The hand equations' M, bias and passive as backend expressions in the symbols qs, vs; a
    HarnessError naming the module's function and line where they cannot be traced."""
    n = system.nv
    q, v = wrap(qs, backend), wrap(vs, backend)
    eq, p = system.equations, system.params
    if eq is None:
        raise HarnessError("the model alone has no hand equations to trace")
    m = np.asarray(traced_call(backend, "mass_matrix", eq.mass_matrix, p, q), dtype=object)
    if m.shape != (n, n):
        raise HarnessError(f"mass_matrix() traced to shape {m.shape}; expected {(n, n)}")
    return (
        [[unwrap(m[i, j], backend) for j in range(n)] for i in range(n)],
        vector(traced_call(backend, "bias", eq.bias, p, q, v), n, backend),
        vector(traced_call(backend, "passive", eq.passive, p, q, v), n, backend),
    )


def solve_spd(matrix: list[list[N]], b: list[N]) -> list[N]:
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
    x = b[:]  # every entry computed before it is read
    for i in reversed(range(n)):
        acc = b[i]
        for j in range(i + 1, n):
            acc = acc - a[i][j] * x[j]
        x[i] = acc / a[i][i]
    return x


def sympy_backend() -> Backend[sp.Basic]:
    import sympy as sp

    names = {"arcsin": "asin", "arccos": "acos", "arctan": "atan", "arctan2": "atan2"}
    relations = {"lt": sp.Lt, "le": sp.Le, "gt": sp.Gt, "ge": sp.Ge, "eq": sp.Eq, "ne": sp.Ne}
    logic = {"and": sp.And, "or": sp.Or, "not": sp.Not}

    def is_expression(x: object) -> TypeIs[sp.Basic]:
        return isinstance(x, sp.Basic)

    return Backend(
        "sympy",
        lambda x: sp.Float(x, 17) if x != 0 else sp.Integer(0),
        lambda name: getattr(sp, names.get(name, name)),
        is_expression,
        lambda op, a, b: relations[op](a, b),
        lambda c, a, b: sp.Piecewise((a, c), (b, True)),
        lambda op, cs: logic[op](*cs),
    )


def heyoka_backend() -> Backend[hy.expression]:
    import heyoka as hy

    names = {"arcsin": "asin", "arccos": "acos", "arctan": "atan", "arctan2": "atan2"}
    relations = {"lt": hy.lt, "le": hy.lte, "gt": hy.gt, "ge": hy.gte, "eq": hy.eq, "ne": hy.neq}
    logic = {
        "and": hy.logical_and,
        "or": hy.logical_or,
        "not": lambda cs: hy.eq(cs[0], hy.expression(0.0)),  # a condition is 1 or 0
    }

    def is_expression(x: object) -> TypeIs[hy.expression]:
        return isinstance(x, hy.expression)

    return Backend(
        "heyoka",
        lambda x: hy.expression(x),
        lambda name: getattr(hy, names.get(name, name)),
        is_expression,
        lambda op, a, b: relations[op](a, b),
        hy.select,
        lambda op, cs: logic[op](cs),
    )


def sympy_params(
    params_type: type[P], numeric: tuple[tuple[str, float], ...] | None
) -> tuple[tuple[str, ...], list[sp.Symbol], P]:
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

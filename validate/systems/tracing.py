"""Tracing the equations modules' numpy code with symbolic values, for code generation.

numpy applies a ufunc to an object array by calling the element's method of the same name
(`np.sin(x)` -> `x.sin()`) and binary operators element by element, so a module's functions run
unmodified on object arrays of `Traced` values (`_forms.stack_*` keep objects as objects). A
backend supplies the expression type: sympy for the generated scalar `math` right-hand sides
(fastpath.py), heyoka for the Taylor reference (reference.py).
"""

from __future__ import annotations

import operator
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

# numpy ufunc names (the methods numpy calls) that a backend may name differently
UNARY = ("sin", "cos", "tan", "arcsin", "arccos", "arctan", "sinh", "cosh", "tanh", "exp", "log", "sqrt")


@dataclass(frozen=True)
class Backend:
    name: str
    lift: Callable[[float], Any]  # a number -> a constant expression
    function: Callable[[str], Callable[..., Any]]  # a numpy ufunc name -> the backend's function
    is_expression: Callable[[Any], bool]


class Traced:
    """A backend expression that numpy's object loops can compute with."""

    __slots__ = ("e", "backend")

    def __init__(self, e: Any, backend: Backend) -> None:
        self.e, self.backend = e, backend

    def _op(self, other: Any, op: Callable[[Any, Any], Any], reflected: bool = False) -> Any:
        if isinstance(other, np.ndarray) and other.shape != ():
            return NotImplemented  # arrays go back to numpy, which broadcasts
        a, b = (unwrap(other, self.backend), self.e) if reflected else (self.e, unwrap(other, self.backend))
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
        return Traced(-self.e, self.backend)

    def __pos__(self) -> Traced:
        return self

    def square(self) -> Traced:
        return Traced(self.e * self.e, self.backend)

    def arctan2(self, other: Any) -> Traced:
        return Traced(self.backend.function("arctan2")(self.e, unwrap(other, self.backend)), self.backend)

    def __getattr__(self, name: str) -> Any:  # sin, cos, ...: what np.<ufunc> calls on objects
        if name in UNARY:
            return lambda: Traced(self.backend.function(name)(self.e), self.backend)
        raise AttributeError(name)


def unwrap(x: Any, backend: Backend) -> Any:
    """The backend expression of a traced value, a number or a 0-d array."""
    if isinstance(x, np.ndarray):
        if x.shape != ():
            raise TypeError(f"expected a scalar, got an array of shape {x.shape}")
        x = x[()]
    if isinstance(x, Traced):
        return x.e
    if backend.is_expression(x):
        return x
    return backend.lift(float(x))


def wrap(symbols: list[Any], backend: Backend) -> np.ndarray:
    out = np.empty(len(symbols), dtype=object)
    for i, s in enumerate(symbols):
        out[i] = Traced(s, backend)
    return out


def vector(x: Any, n: int, backend: Backend) -> list[Any]:
    """A module function's (n,) output as a list of backend expressions."""
    return [unwrap(e, backend) for e in np.broadcast_to(np.asarray(x, dtype=object), (n,))]


def dynamics(
    system: Any, qs: list[Any], vs: list[Any], backend: Backend
) -> tuple[list[list[Any]], list[Any], list[Any]]:
    """The hand equations' M, bias and passive as backend expressions in the symbols qs, vs."""
    n = system.nv
    q, v = wrap(qs, backend), wrap(vs, backend)
    eq, p = system.equations, system.params
    m = np.asarray(eq.mass_matrix(p, q), dtype=object)
    if m.shape != (n, n):
        raise TypeError(f"mass_matrix traced to shape {m.shape}, expected {(n, n)}")
    return (
        [[unwrap(m[i, j], backend) for j in range(n)] for i in range(n)],
        vector(eq.bias(p, q, v), n, backend),
        vector(eq.passive(p, q, v), n, backend),
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
    return Backend(
        "sympy",
        lambda x: sp.Float(x, 17) if x != 0 else sp.Integer(0),
        lambda name: getattr(sp, names.get(name, name)),
        lambda x: isinstance(x, sp.Basic),
    )


def heyoka_backend() -> Backend:
    import heyoka as hy

    names = {"arcsin": "asin", "arccos": "acos", "arctan": "atan", "arctan2": "atan2"}
    return Backend(
        "heyoka",
        lambda x: hy.expression(x),
        lambda name: getattr(hy, names.get(name, name)),
        lambda x: isinstance(x, hy.expression),
    )

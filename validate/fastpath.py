"""A scalar fast path for the hand equations, generated from the equations module itself.

The module's numpy functions are traced with symbolic inputs (numpy calls `sin`/`cos` methods on
object arrays), giving M(q), bias(q, v) and passive(q, v) as sympy expressions with the compiled
MJCF's parameters as numbers. The right-hand side a = M^-1 (tau + passive - bias) is then solved
symbolically (n <= 3), reduced by common-subexpression elimination and printed as plain Python
with `math`: one call costs what a hand-written scalar `math` implementation costs. The numpy
path (`HandSource.forward`) stays the reference; tests compare the two at random states.
"""

from __future__ import annotations

from typing import Any

import numpy as np


class _Sym:
    """A sympy expression that numpy's object-array ufuncs can call sin/cos/sqrt on."""

    __slots__ = ("e",)

    def __init__(self, e: Any) -> None:
        import sympy as sp

        self.e = sp.sympify(e)

    @staticmethod
    def _w(o: Any) -> Any:
        if isinstance(o, np.ndarray) and o.ndim == 0:  # x[..., 0] of a 1-d array is a 0-d array
            o = o.item()
        if isinstance(o, np.ndarray):
            return NotImplemented
        return o.e if isinstance(o, _Sym) else o

    def __add__(self, o: Any) -> _Sym:
        return _Sym(self.e + _Sym._w(o))

    __radd__ = __add__

    def __sub__(self, o: Any) -> _Sym:
        return _Sym(self.e - _Sym._w(o))

    def __rsub__(self, o: Any) -> _Sym:
        return _Sym(_Sym._w(o) - self.e)

    def __mul__(self, o: Any) -> _Sym:
        return _Sym(self.e * _Sym._w(o))

    __rmul__ = __mul__

    def __truediv__(self, o: Any) -> _Sym:
        return _Sym(self.e / _Sym._w(o))

    def __rtruediv__(self, o: Any) -> _Sym:
        return _Sym(_Sym._w(o) / self.e)

    def __pow__(self, o: Any) -> _Sym:
        return _Sym(self.e ** _Sym._w(o))

    def __neg__(self) -> _Sym:
        return _Sym(-self.e)

    def __pos__(self) -> _Sym:
        return self

    def _fn(self, name: str) -> _Sym:
        import sympy as sp

        return _Sym(getattr(sp, name)(self.e))

    def sin(self) -> _Sym:
        return self._fn("sin")

    def cos(self) -> _Sym:
        return self._fn("cos")

    def tan(self) -> _Sym:
        return self._fn("tan")

    def sqrt(self) -> _Sym:
        return self._fn("sqrt")


def _expr(x: Any) -> Any:
    import sympy as sp

    if isinstance(x, np.ndarray):
        x = x.item()
    if isinstance(x, _Sym):
        return x.e
    return sp.Float(float(x), 17) if x != 0 else sp.Integer(0)


def _symbols(n: int) -> tuple[list[Any], list[Any], list[Any], list[Any]]:
    import sympy as sp

    return (list(sp.symbols(f"q0:{n}")), list(sp.symbols(f"v0:{n}")), list(sp.symbols(f"a0:{n}")),
            list(sp.symbols(f"tau0:{n}")))


def _wrap(symbols: list[Any]) -> np.ndarray:
    return np.array([_Sym(x) for x in symbols], dtype=object)


def _vector(x: Any, n: int) -> Any:
    import sympy as sp

    return sp.Matrix([_expr(e) for e in np.broadcast_to(np.asarray(x, dtype=object), (n,))])


def _solve(A: Any, b: Any) -> list[Any]:
    """A^-1 b; Cramer's rule for n <= 2 (short, no pivoting needed for these SPD matrices)."""
    n = A.shape[0]
    if n == 1:
        return [b[0] / A[0, 0]]
    if n == 2:
        det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
        return [(A[1, 1] * b[0] - A[0, 1] * b[1]) / det, (A[0, 0] * b[1] - A[1, 0] * b[0]) / det]
    return list(A.LUsolve(b))


def hand_accelerations(system: Any) -> tuple[list[Any], list[Any], list[Any], list[Any]]:
    """a = M^-1 (tau + passive - bias) of the hand equations, symbolically."""
    import sympy as sp

    n = system.nv
    qs, vs, _, taus = _symbols(n)
    q, v = _wrap(qs), _wrap(vs)
    eq, p = system.equations, system.params
    M = sp.Matrix(n, n, [_expr(x) for x in np.asarray(eq.mass_matrix(p, q), dtype=object).ravel()])
    rhs = sp.Matrix(taus) + _vector(eq.passive(p, q, v), n) - _vector(eq.bias(p, q, v), n)
    return _solve(M, rhs), qs, vs, taus


def variant_accelerations(system: Any, variant: Any) -> tuple[list[Any], list[Any], list[Any], list[Any]]:
    """The accelerations a printed dynamic form implies, symbolically (implicit forms solved for a)."""
    import sympy as sp

    from ..equations._forms import Implicit

    n = system.nv
    qs, vs, as_, taus = _symbols(n)
    q, v, a, tau = _wrap(qs), _wrap(vs), _wrap(as_), _wrap(taus)
    p = system.params
    if isinstance(variant, Implicit):
        r = _vector(variant.residual(p, q, v, a, tau), n)
        A = r.jacobian(sp.Matrix(as_))  # the printed residual is linear in a
        b = r.subs({x: 0 for x in as_})
        return _solve(A, -b), qs, vs, taus
    return list(_vector(variant.acceleration(p, q, v, tau), n)), qs, vs, taus


def rhs_source(acc: list[Any], qs: list[Any], vs: list[Any], taus: list[Any]) -> str:
    """Python source of `rhs(t, y, tau)` -> [v..., a...] using only `math`."""
    import sympy as sp
    from sympy.printing.pycode import PythonCodePrinter

    subs, (reduced,) = sp.cse([sp.Matrix(acc)], optimizations="basic")
    printer = PythonCodePrinter({"standard": "python3", "fully_qualified_modules": True})
    lines = ["def rhs(t, y, tau):",
             f"    {', '.join(map(str, qs + vs))}, = y",
             f"    {', '.join(map(str, taus))}, = tau"]
    lines += [f"    {sym} = {printer.doprint(e)}" for sym, e in subs]
    lines.append(f"    return [{', '.join(map(str, vs))}, {', '.join(printer.doprint(e) for e in reduced)}]")
    return "\n".join(lines) + "\n"


def _compile(source: str, label: str) -> Any:
    import math

    namespace: dict[str, Any] = {"math": math}
    exec(compile(source, f"<fastpath {label}>", "exec"), namespace)  # noqa: S102 - code we generated
    return namespace["rhs"]


def scalar_rhs(system: Any, variant: Any = None) -> Any:
    """The compiled scalar right-hand side `rhs(t, y, tau) -> list` of the hand equations, or of a
    printed dynamic form; cached on the System."""
    key = ("scalar_rhs", None if variant is None else variant.name)
    cache = system._cache
    if key not in cache:
        acc = hand_accelerations(system) if variant is None else variant_accelerations(system, variant)
        cache[key] = _compile(rhs_source(*acc), f"{system.name} {variant.name if variant else 'hand'}")
    return cache[key]

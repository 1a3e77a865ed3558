"""A scalar fast path for the hand equations, generated from the equations module itself.

The module's numpy functions are traced with sympy symbols (validate/handwritten/tracing.py), giving M(q),
bias(q, v) and passive(q, v) as sympy expressions with the compiled MJCF's parameters as numbers.
The right-hand side a = M^-1 (tau + passive - bias) is then solved symbolically (n <= 3), reduced
by common-subexpression elimination and printed as plain Python with `math`: one call costs what a
hand-written scalar `math` implementation costs. The numpy path (`HandSource.forward`) stays the
reference; tests compare the two at random states.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from typing import TYPE_CHECKING, TypeAlias, cast

import numpy as np

from ..forms import Explicit, Implicit
from ..handwritten import tracing
from ..systems import System

if TYPE_CHECKING:  # sympy is imported when first used
    import sympy as sp

# the generated one-state right-hand side: rhs(t, y, tau) -> [v..., a...]
ScalarRhs: TypeAlias = Callable[[float, np.ndarray | Sequence[float], Sequence[float]], list[float]]
# a = M^-1 f symbolically, and the symbols of q, v and tau it is in
Accelerations: TypeAlias = "tuple[list[sp.Expr], list[sp.Symbol], list[sp.Symbol], list[sp.Symbol]]"


def _symbols(n: int) -> tuple[list[sp.Symbol], list[sp.Symbol], list[sp.Symbol], list[sp.Symbol]]:
    import sympy as sp

    return (
        list(sp.symbols(f"q0:{n}")),
        list(sp.symbols(f"v0:{n}")),
        list(sp.symbols(f"a0:{n}")),
        list(sp.symbols(f"tau0:{n}")),
    )


def _solve(A: list[list[sp.Expr]], b: list[sp.Expr]) -> list[sp.Expr]:
    """A^-1 b; Cramer's rule for n <= 2 (shortest expressions), elimination beyond."""
    n = len(b)
    if n == 1:
        return [b[0] / A[0][0]]
    if n == 2:
        det = A[0][0] * A[1][1] - A[0][1] * A[1][0]
        return [(A[1][1] * b[0] - A[0][1] * b[1]) / det, (A[0][0] * b[1] - A[1][0] * b[0]) / det]
    return tracing.solve_spd(A, b)


def hand_accelerations(system: System, damped_step: float | None = None) -> Accelerations:
    """a = M^-1 (tau + passive - bias) of the hand equations, symbolically; with `damped_step` h,
    MuJoCo's Euler with implicit joint damping instead: a = (M + h D)^-1 (tau + passive - bias),
    D = diag(-d passive_i / d v_i) (exact: the derivative is symbolic)."""
    import sympy as sp

    qs, vs, _, taus = _symbols(system.nv)
    M, bias, passive = tracing.dynamics(system, qs, vs, tracing.sympy_backend())
    if damped_step is not None:
        h = sp.Float(damped_step, 17)
        M = [
            [M[i][j] - (h * sp.diff(passive[i], vs[i]) if i == j else 0) for j in range(len(qs))]
            for i in range(len(qs))
        ]
    return _solve(M, [t + p - b for t, p, b in zip(taus, passive, bias, strict=True)]), qs, vs, taus


def variant_accelerations(system: System, variant: Implicit | Explicit) -> Accelerations:
    """The accelerations a printed dynamic form implies, symbolically (implicit forms solved for a)."""
    import sympy as sp

    n = system.nv
    backend = tracing.sympy_backend()
    qs, vs, as_, taus = _symbols(n)
    q, v, a, tau = (tracing.wrap(x, backend) for x in (qs, vs, as_, taus))
    p = system.params
    if isinstance(variant, Implicit):
        r = sp.Matrix(tracing.vector(variant.residual(p, q, v, a, tau), n, backend))
        A = r.jacobian(sp.Matrix(as_))  # the printed residual is linear in a
        b = r.subs({x: 0 for x in as_})
        return _solve(A.tolist(), [-x for x in b]), qs, vs, taus
    return tracing.vector(variant.acceleration(p, q, v, tau), n, backend), qs, vs, taus


def rhs_source(acc: list[sp.Expr], qs: list[sp.Symbol], vs: list[sp.Symbol], taus: list[sp.Symbol]) -> str:
    """Python source of `rhs(t, y, tau)` -> [v..., a...] using only `math`."""
    import sympy as sp
    from sympy.printing.pycode import PythonCodePrinter

    subs, (reduced,) = sp.cse([sp.Matrix(acc)])  # "basic" optimizations: 30x the time, more operations
    printer = PythonCodePrinter({"standard": "python3", "fully_qualified_modules": True})
    lines = [
        "def rhs(t, y, tau):",
        f"    {', '.join(map(str, qs + vs))}, = y",
        f"    {', '.join(map(str, taus))}, = tau",
    ]
    lines += [f"    {sym} = {printer.doprint(e)}" for sym, e in subs]
    lines.append(f"    return [{', '.join(map(str, vs))}, {', '.join(printer.doprint(e) for e in reduced)}]")
    return "\n".join(lines) + "\n"


def _compile(source: str, label: str) -> ScalarRhs:
    import math

    namespace: dict[str, object] = {"math": math}
    exec(compile(source, f"<fastpath {label}>", "exec"), namespace)  # noqa: S102 - code we generated
    return cast(ScalarRhs, namespace["rhs"])  # the function `rhs_source` wrote


def _key(system: System, variant: Implicit | Explicit | None, damped_step: float | None = None) -> tuple[Hashable, ...]:
    """What the generated code depends on, by identity: the equations module and the functions traced
    (a mutated or reloaded module of the same name has other function objects), the parameter values
    and the variant's own function. Never the system's name alone: a module's functions replaced in
    place (a mutation) leave the System, and its memo, as they were."""
    eq = system.derivation
    params = tuple((k, float(v).hex()) for k, v in sorted(vars(system.params).items()))
    if variant is None:
        return ("scalar_rhs", eq, eq.mass_matrix, eq.bias, eq.passive, params, None, damped_step)
    own = getattr(variant, "residual", None) or getattr(variant, "acceleration", None)
    return ("scalar_rhs", eq, params, variant.name, own, id(variant))


def scalar_rhs(
    system: System, variant: Implicit | Explicit | None = None, *, damped_step: float | None = None
) -> ScalarRhs:
    """The compiled scalar right-hand side `rhs(t, y, tau) -> list` of the hand equations, or of a
    printed dynamic form; kept in the System's memo, keyed by what it was generated from (`_key`).
    `damped_step` h (hand equations only): the accelerations of MuJoCo's Euler step with implicit
    joint damping, (M + h D)^-1 f (see `hand_accelerations`).

    The code is plain `math`: on a wrong derivation it can raise ZeroDivisionError (a singular M),
    OverflowError or ValueError (a math domain error); the integrators turn these into a finding
    (validate/dynamics/integrate.py EQUATION_ERRORS)."""

    def make() -> tuple[Implicit | Explicit | None, ScalarRhs]:

        acc = hand_accelerations(system, damped_step) if variant is None else variant_accelerations(system, variant)
        label = f"{system.name} ({system.derivation.__name__}) {variant.name if variant else 'hand'}"
        return variant, _compile(rhs_source(*acc), label)  # the variant kept alive: id() in the key

    return system.memo.get(_key(system, variant, damped_step), make)[1]

"""Form (e): the Hamiltonian H(q, pm), brought to the energies of form (d).

A mechanical system's Hamiltonian is H(q, pm) = pm^T M^-1(q) pm / 2 + V(q), pm = M(q) v the
generalized momenta. The module's numpy code is traced with sympy symbols for the parameters, q
and pm (validate/handwritten/tracing.py), and read exactly:

    M^-1(q) = d2H/dpm2            must not depend on pm (else H is not quadratic in the momenta)
    dH/dpm at pm = 0              must be zero (a term linear in pm: qdot = dH/dpm would not be v)
    V(q) = H(q, 0)

Together these make Hamilton's first equation, qdot = dH/dpm = M^-1 pm, give back v at pm = M v;
a Hamiltonian of another shape is a one-line HarnessError naming what is wrong. The kinetic energy
is T(q, v) = v^T M v / 2, with M v found from M^-1 by elimination (arithmetic only, so that it
traces too), and handwritten/forms.py differentiates T and V as it does form (d): a wrong entry of M^-1
is found in the mass matrix, a wrong V in gravity. `hamilton_equations` gives both of Hamilton's
equations, (dH/dpm, -dH/dq), for a comparison in the momenta.
"""

from __future__ import annotations

import dataclasses
import functools
import types
from collections.abc import Callable, Hashable
from typing import TYPE_CHECKING, Protocol

import numpy as np

from ..core.errors import HarnessError
from . import tracing

if TYPE_CHECKING:
    import numpy.typing as npt
    import sympy as sp
    from _typeshed import DataclassInstance

WHERE = "hamiltonian(p, q, pm)"  # the function a form-(e) module provides: H, shape (...)


class Hamiltonian(Hashable, Protocol):
    """A form-(e) module."""

    def hamiltonian(self, p: object, q: np.ndarray, pm: np.ndarray) -> np.ndarray: ...


@dataclasses.dataclass(frozen=True)
class _Terms:
    fields: tuple[str, ...]  # Params fields passed first (empty: the parameters were numbers when traced)
    inverse_mass: Callable[..., list[np.ndarray | float]]  # (*params, *q) -> [M^-1 entries (n*n), V]
    rates: Callable[..., list[np.ndarray | float]]  # (*params, *q, *pm) -> [dH/dpm (n), -dH/dq (n)]
    n: int


def _integer_powers(expr: sp.Expr) -> sp.Expr:
    """x**2.0 as x**2 (the tracer lifts every number to a Float; as in handwritten/forms.py)."""
    import sympy as sp

    return expr.replace(
        lambda e: e.is_Pow and e.exp.is_Float and float(e.exp).is_integer(),
        lambda e: sp.Pow(e.base, int(e.exp)),
    )


@functools.lru_cache(maxsize=256)  # one per module and parameter set: probes make many
def _terms(
    module: Hamiltonian,
    params_type: type[DataclassInstance],
    n: int,
    numeric_params: tuple[tuple[str, float], ...] | None,
) -> _Terms:
    """M^-1, V and Hamilton's equations of `module`, from its H traced with sympy and generated as
    numpy code; parameters are symbols unless `numeric_params` are given."""
    import sympy as sp

    backend = tracing.sympy_backend()
    qs, ps = list(sp.symbols(f"q0:{n}")), list(sp.symbols(f"pm0:{n}"))
    names, psyms, p = tracing.sympy_params(params_type, numeric_params)
    traced = module.hamiltonian(p, tracing.wrap(qs, backend), tracing.wrap(ps, backend))
    H = _integer_powers(sp.sympify(tracing.unwrap(np.asarray(traced, dtype=object), backend)))
    dH_dpm = [sp.diff(H, x) for x in ps]
    inverse_mass = [[sp.diff(dH_dpm[i], ps[j]) for j in range(n)] for i in range(n)]
    _check_quadratic(inverse_mass, dH_dpm, ps)
    at_rest = dict.fromkeys(ps, 0)
    V = H.xreplace(at_rest)
    flat = [inverse_mass[i][j] for i in range(n) for j in range(n)] + [V]
    rates = dH_dpm + [-sp.diff(H, x) for x in qs]
    return _Terms(
        tuple(names),
        sp.lambdify([*psyms, *qs], flat, modules="numpy", cse=True),
        sp.lambdify([*psyms, *qs, *ps], rates, modules="numpy", cse=True),
        n,
    )


def _check_quadratic(inverse_mass: list[list[sp.Expr]], dH_dpm: list[sp.Expr], ps: list[sp.Symbol]) -> None:
    """A one-line HarnessError unless H = pm^T A(q) pm / 2 + V(q): A free of pm, no term linear in pm."""
    import sympy as sp

    momenta = set(ps)
    for i, row in enumerate(inverse_mass):
        for j, entry in enumerate(row):
            if entry.free_symbols & momenta:
                raise HarnessError(
                    f"{WHERE} is not quadratic in the momenta pm: d2H/dpm{i}dpm{j} depends on pm "
                    "(form e is H = pm^T M^-1(q) pm / 2 + V(q))."
                )
    at_rest = dict.fromkeys(ps, 0)
    for i, d in enumerate(dH_dpm):
        linear = d.xreplace(at_rest)
        if linear != 0 and sp.simplify(linear) != 0:
            raise HarnessError(
                f"{WHERE} has a term linear in the momenta: dH/dpm{i} = {linear} at pm = 0, so "
                "qdot = dH/dpm is not v at pm = M v (form e is H = pm^T M^-1(q) pm / 2 + V(q))."
            )


@functools.lru_cache(maxsize=64)  # one per equations module loaded (a watch loads one per save), parameters symbolic
def _symbolic(module: Hamiltonian, params_type: type[DataclassInstance], n: int) -> _Terms | None:
    """The terms with symbolic parameters, or None where the module's code needs numbers for them
    (a shape error of H, such as a term linear in pm, is raised here, once)."""
    try:
        return _terms(module, params_type, n, None)
    except HarnessError:
        raise
    except Exception:  # noqa: BLE001 - code that needs numbers for its parameters: traced per parameter set
        return None


def _terms_at(module: Hamiltonian, p: DataclassInstance, n: int) -> _Terms:
    kind = _params_type(p)
    found = _symbolic(module, kind, n)
    if found is not None:
        return found
    values = tuple((f.name, float(getattr(p, f.name))) for f in dataclasses.fields(p))
    try:
        return _terms(module, kind, n, values)
    except HarnessError:
        raise
    except Exception as exc:
        raise HarnessError(
            f"cannot differentiate {WHERE} symbolically ({type(exc).__name__}: {exc}); "
            "only numpy arithmetic and elementary functions are supported."
        ) from None


def _columns(x: npt.ArrayLike, n: int) -> list[np.ndarray]:
    x = np.asarray(x)
    return [x[..., i] for i in range(n)]


def inverse_mass_and_potential(
    module: Hamiltonian, p: DataclassInstance, q: np.ndarray
) -> tuple[list[list[np.ndarray]], np.ndarray]:
    """(M^-1 as n rows of n entries, V), each entry broadcast over q's leading axes."""
    terms = _terms_at(module, p, np.shape(q)[-1])
    n = terms.n
    out = terms.inverse_mass(*[getattr(p, k) for k in terms.fields], *_columns(q, n))
    zero = np.zeros(np.shape(q)[:-1])
    return [[out[i * n + j] + zero for j in range(n)] for i in range(n)], out[-1] + zero


def hamilton_equations(
    module: Hamiltonian, p: DataclassInstance, q: np.ndarray, pm: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Hamilton's equations of a form-(e) module (or its facade) at (q, pm): (dH/dpm, -dH/dq), each
    (..., n); with friction and inputs, pdot = -dH/dq + passive + tau."""
    module = getattr(module, "ORIGINAL", module)
    terms = _terms_at(module, p, np.shape(q)[-1])
    n = terms.n
    out = terms.rates(*[getattr(p, k) for k in terms.fields], *_columns(q, n), *_columns(pm, n))
    shape = np.broadcast_shapes(np.shape(q), np.shape(pm))
    zero = np.zeros(shape[:-1])
    qdot = np.stack([out[i] + zero for i in range(n)], axis=-1)
    pdot = np.stack([out[n + i] + zero for i in range(n)], axis=-1)
    return qdot, pdot


def energies(module: Hamiltonian) -> types.ModuleType:
    """`module` as form (d): its own attributes, with kinetic_energy(p, q, v) and
    potential_energy(p, q) derived from its Hamiltonian. A Hamiltonian of the wrong shape is a
    HarnessError here (where its parameters can be symbols)."""
    if hasattr(module, "Params") and hasattr(module, "COORDINATES"):  # else checked at the first use
        _symbolic(module, module.Params, len(module.COORDINATES))
    out = types.ModuleType(f"{getattr(module, '__name__', 'equations')}.energies")
    out.__dict__.update({k: v for k, v in vars(module).items() if not k.startswith("__")})
    out.__file__ = getattr(module, "__file__", None)  # type: ignore[assignment]

    def kinetic_energy(p: DataclassInstance, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """T = v^T M v / 2, M v solved from M^-1 = d2H/dpm2 by elimination."""
        inverse_mass, _ = inverse_mass_and_potential(module, p, q)
        vs = _columns(v, len(inverse_mass))
        momenta = tracing.solve_spd(inverse_mass, vs)
        return 0.5 * sum(a * b for a, b in zip(vs, momenta, strict=True))

    def potential_energy(p: DataclassInstance, q: np.ndarray) -> np.ndarray:
        """V = H(q, 0)."""
        return inverse_mass_and_potential(module, p, q)[1]

    out.kinetic_energy = kinetic_energy  # type: ignore[attr-defined]
    out.potential_energy = potential_energy  # type: ignore[attr-defined]
    return out


def _params_type(p: DataclassInstance) -> type[DataclassInstance]:
    """The class of what parameters() returned (a key of the derivation caches)."""
    return type(p)

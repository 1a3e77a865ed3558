"""The forms a derivation can take, brought to one: M(q), bias(q, v) and passive(q, v).

People write their equations of motion as the notes print them, in one of four forms. A module
provides exactly one; the harness derives the others' functions from it, so that everything
downstream (the pointwise check, the term verdict, the probes, the traced fast path and Taylor
reference) reads one interface:

    (a) mass_matrix(p, q), bias(p, q, v) [, passive(p, q, v)]      as written
    (b) residual(p, q, v, a, tau) = M a + bias - passive - tau        implicit, like eqs (33)-(34)
    (c) qacc(p, q, v, tau) = M^-1 (tau + passive - bias)              explicit, like eqs (35)-(36)
    (d) kinetic_energy(p, q, v), potential_energy(p, q) [, passive]   energies only, like eqs (19), (22)
    (e) hamiltonian(p, q, pm) [, passive]                              H(q, pm), to its energies (hamiltonian.py)

(b) and (c) are linear in a and tau, so M comes from unit accelerations (inputs); at v = 0 what is
left is gravity; the rest splits by parity in v: the Coriolis and centrifugal forces are even in v
(quadratic), viscous friction odd (linear). (d) is differentiated symbolically: the module's own
numpy code is traced with sympy symbols for the parameters, q and v (validate/handwritten/tracing.py), and
M = d2T/dv2, G = dV/dq, C v = (d/dq dT/dv) v - dT/dq are exact, then generated as numpy code.
Every derived function uses only arithmetic on the module's outputs (or generated numpy code), so
it can itself be traced for the fast path and the Taylor reference.
"""

from __future__ import annotations

import dataclasses
import functools
import types
from collections.abc import Callable, Hashable, Mapping, Sequence
from typing import TYPE_CHECKING, NoReturn, Protocol, cast

import numpy as np
import numpy.typing as npt

from ..core.errors import HarnessError
from ..forms import Variant, not_provided, stack_matrix, stack_vector
from . import hamiltonian, tracing
from .expression import lambdified
from .values import real_array

if TYPE_CHECKING:
    import sympy as sp
    from _typeshed import DataclassInstance

    from ..forms import FormA
    from .tracing import Backend, E


class _Residual(Protocol):
    """A form-(b) module."""

    def residual(self, p: object, q: np.ndarray, v: np.ndarray, a: np.ndarray, tau: np.ndarray) -> np.ndarray: ...


class _Explicit(Protocol):
    """A form-(c) module."""

    def qacc(self, p: object, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray: ...


class Energies(Hashable, Protocol):
    """A form-(d) module (a form-(e) one as hamiltonian.energies gives it)."""

    def kinetic_energy(self, p: object, q: np.ndarray, v: np.ndarray) -> np.ndarray: ...
    def potential_energy(self, p: object, q: np.ndarray) -> np.ndarray: ...


FORMS = {
    "a": ("mass_matrix", "bias"),
    "b": ("residual",),
    "c": ("qacc",),
    "d": ("kinetic_energy", "potential_energy"),
    "e": ("hamiltonian",),
}
FORM_NAMES = {
    "a": "mass matrix and bias forces",
    "b": "implicit residual",
    "c": "explicit accelerations",
    "d": "kinetic and potential energy",
    "e": "Hamiltonian",
}


def form_of(module: object) -> str:
    """Which form a module is written in: the first of a, b, c, d, e whose functions it defines."""
    for form, names in FORMS.items():
        if all(provided(getattr(module, n, None)) for n in names):
            return form
    raise HarnessError(
        f"{getattr(module, '__file__', module)}: the dynamics are not provided (yet); write one of: mass_matrix + "
        "bias (form a), residual(p, q, v, a, tau) (b), qacc(p, q, v, tau) (c), or kinetic_energy + "
        "potential_energy (d), or hamiltonian(p, q, pm) (e)."
    )


def input_name(module: object) -> str:
    """What the dynamics take as inputs: "u" where the written function's last parameter is named `u`
    (the model's actuator controls, in the model's actuator order), else "tau" (a generalized force on
    every coordinate; forms a, d and e take none: "tau" too)."""
    import inspect

    form = written_form(module)
    fn = {"b": "residual", "c": "qacc"}.get(form)
    original = getattr(module, "ORIGINAL", module)
    if fn is None:
        return "tau"
    try:
        names = list(inspect.signature(getattr(original, fn)).parameters)
    except (TypeError, ValueError):
        return "tau"
    return "u" if names and names[-1] == "u" else "tau"


def accelerations_only(module: object) -> bool:
    """Explicit accelerations with inputs `u` on the actuated coordinates only: they give M^-1 B, not M,
    so the derivation is judged in accelerations (gravity, velocity, friction, actuation: M^-1 times
    each force) and M and the forces themselves are not checked."""
    return written_form(module) == "c" and input_name(module) == "u"


def written_function(module: object, name: str) -> Callable[..., np.ndarray]:
    """The function `name` as the person wrote it (form b's residual, form c's qacc): the original
    module's, behind the facade normalize made of it."""
    original = module.ORIGINAL if isinstance(module, _Facade) else module
    fn: Callable[..., np.ndarray] = getattr(original, name)
    return fn


def provided(fn: object) -> bool:
    """A function the module really defines: callable and not a `not_provided` stub."""
    return callable(fn) and not getattr(fn, "not_provided", False)


def written_form(module: object) -> str:
    """The form the person wrote (a facade remembers it; anything else is read off its functions)."""
    return str(module.FORM) if isinstance(module, _Facade) else form_of(module)


def _unit(q: np.ndarray, j: int, n: int) -> np.ndarray:
    """e_j broadcast to q's leading shape (floats; object entries stay objects where q is traced)."""
    e = np.zeros(np.shape(q)[:-1] + (n,))
    e[..., j] = 1.0
    return e


def _zeros(q: np.ndarray) -> np.ndarray:
    return np.zeros(np.shape(q))


def _rows_of(fn: Callable[..., object], p: object, calls: list[tuple[np.ndarray, ...]]) -> list[np.ndarray]:
    """[fn(p, *args) for args in calls], in one call of `fn` on the calls' states concatenated along
    the batch axis where every argument is a float array of one shape (the module computes state by
    state: the same values, at a fraction of the calls' overhead; the mirrors call these per step);
    call by call otherwise (traced arguments) or where the answer's shape is not one row per state."""
    arrays = [np.asarray(x) for args in calls for x in args]
    shape = arrays[0].shape
    if len(calls) > 1 and shape and all(a.dtype.kind == "f" and a.shape == shape for a in arrays):
        k, width = len(calls), len(calls[0])
        flat = [np.concatenate([np.reshape(args[i], (-1, shape[-1])) for args in calls]) for i in range(width)]
        out = real_array(f"{fn.__name__}()", fn(p, *flat))
        rows = int(np.prod(shape[:-1], dtype=int))
        if out.shape == (k * rows, shape[-1]):
            return [x.reshape(shape) for x in np.split(out, k)]
    return [_answer(fn, p, args) for args in calls]


def _answer(fn: Callable[..., object], p: object, args: tuple[np.ndarray, ...]) -> np.ndarray:
    """fn(p, *args): real floats (values.real_array) where the arguments are numbers, as it is where traced."""
    out = fn(p, *args)
    numeric = all(np.asarray(x).dtype.kind in "biuf" for x in args)
    return real_array(f"{fn.__name__}()", out) if numeric else np.asarray(out)


def _stack_columns(cols: list[npt.ArrayLike]) -> np.ndarray:
    return np.stack([np.asarray(c) for c in np.broadcast_arrays(*[np.asarray(c) for c in cols])], axis=-1)


def inverse(A: np.ndarray) -> np.ndarray:
    """A^-1 for (..., n, n) arrays by Gauss-Jordan elimination without pivoting (A is a mass
    matrix or its inverse: symmetric positive definite), with arithmetic only, so that it works
    on float arrays and on traced object arrays alike."""
    A = np.array(A, dtype=object if np.asarray(A).dtype == object else float)
    n = A.shape[-1]
    inv = np.zeros_like(A)
    for i in range(n):
        inv[..., i, i] = 1.0
    a = A.copy()
    for k in range(n):
        pivot = a[..., k, k].copy()
        for j in range(n):
            a[..., k, j] = a[..., k, j] / pivot
            inv[..., k, j] = inv[..., k, j] / pivot
        for i in range(n):
            if i == k:
                continue
            factor = a[..., i, k].copy()
            for j in range(n):
                a[..., i, j] = a[..., i, j] - factor * a[..., k, j]
                inv[..., i, j] = inv[..., i, j] - factor * inv[..., k, j]
    return inv


def _matvec(M: np.ndarray, x: np.ndarray) -> np.ndarray:
    n = M.shape[-1]
    return _stack_columns([sum(M[..., i, j] * x[..., j] for j in range(n)) for i in range(n)])


class _Facade(types.ModuleType):
    """The module as form (a): its own attributes, plus mass_matrix, bias and passive derived from
    its form. `FORM` says which form it was written in; `ORIGINAL` is the module itself."""

    FORM: str
    ORIGINAL: object
    mass_matrix: Callable[..., np.ndarray]
    bias: Callable[..., np.ndarray]
    passive: Callable[..., np.ndarray]
    kinetic_energy: Callable[..., np.ndarray]
    potential_energy: Callable[..., np.ndarray]
    VARIANTS: Sequence[Variant]
    assumptions: Callable[[object], Mapping[str, object]]
    STATES_ASSUMPTIONS: bool


# What a module may leave out: it is then "not checked (not provided)", never an answer.
OPTIONAL_FUNCTIONS = ("kinetic_energy", "potential_energy", "body_positions", "body_rotations")


def not_provided_in(module: object) -> list[str]:
    """The optional functions `module` does not provide (absent, or a `not_provided` stub)."""
    return [name for name in OPTIONAL_FUNCTIONS if not provided(getattr(module, name, None))]


def _stub(name: str) -> Callable[..., NoReturn]:
    def fn(*args: object) -> NoReturn:
        raise NotImplementedError

    fn.__name__ = name
    return not_provided(fn)


def normalize(module: object) -> FormA:
    """The module with mass_matrix, bias and passive (form a), and a `not_provided` stub for every
    optional function it leaves out (VARIANTS defaults to none); a complete form-(a) module is
    returned as it is."""
    return cast("FormA", _form_a(module))  # built dynamically: what _form_a guarantees is what FormA says


def _form_a(module: object) -> object:
    if isinstance(module, _Facade):
        return module
    form = form_of(module)
    missing = [n for n in OPTIONAL_FUNCTIONS if not callable(getattr(module, n, None))]
    complete = all(hasattr(module, n) for n in ("VARIANTS", "assumptions"))
    if form == "a" and callable(getattr(module, "passive", None)) and not missing and complete:
        return module
    facade = _facade(module, form)
    for name in [n for n in missing if not callable(getattr(facade, n, None))]:  # form e derives the energies
        setattr(facade, name, _stub(name))
    if not hasattr(module, "VARIANTS"):
        facade.VARIANTS = ()
    if not callable(getattr(module, "assumptions", None)):
        facade.assumptions = _no_assumptions
        facade.STATES_ASSUMPTIONS = False
    return facade


def _no_assumptions(p: object) -> dict[str, object]:
    """A module that states no assumptions: every number it uses is read from the model."""
    return {}


def _facade(module: object, form: str) -> _Facade:
    """The module as form (a)."""
    facade = _Facade(getattr(module, "__name__", "equations"))
    facade.__dict__.update({k: v for k, v in vars(module).items() if not k.startswith("__")})
    facade.__file__ = getattr(module, "__file__", None)  # type: ignore[assignment]
    facade.__doc__ = module.__doc__
    facade.__package__ = getattr(module, "__package__", None)
    facade.FORM = form
    facade.ORIGINAL = module
    if form == "a":
        if not callable(getattr(module, "passive", None)):
            facade.passive = _no_friction
        return facade
    if form == "b":
        return _residual_facade(facade, cast(_Residual, module))  # form_of found its residual
    if form == "c" and input_name(module) == "u":
        return _accelerations_facade(facade, cast(_Explicit, module))  # form_of found its qacc
    if form == "c":
        return _qacc_facade(facade, cast(_Explicit, module))
    if form == "e":  # the Hamiltonian, as its energies (validate/handwritten/hamiltonian.py), then as form d
        energies = hamiltonian.energies(cast(hamiltonian.Hamiltonian, module))  # form_of found its hamiltonian
        facade.kinetic_energy, facade.potential_energy = energies.kinetic_energy, energies.potential_energy
        return _energies_facade(facade, energies)
    return _energies_facade(facade, cast(Energies, module))  # form_of found its energies


def _residual_facade(facade: _Facade, module: _Residual) -> _Facade:
    """Form (b), the residual r(p, q, v, a, tau), as form (a): M column by column from unit
    accelerations; gravity at rest; the velocity terms and friction as r's parts even and odd in v."""
    r = module.residual

    def mass_matrix_b(p: object, q: np.ndarray) -> np.ndarray:
        z, n = _zeros(q), np.shape(q)[-1]
        r0, *cols = _rows_of(r, p, [(q, z, z, z)] + [(q, z, _unit(q, j, n), z) for j in range(n)])
        return _stack_columns([c - r0 for c in cols])

    def parts_b(p: object, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        z = _zeros(q)
        g, at_v, at_minus_v = _rows_of(r, p, [(q, z, z, z), (q, v, z, z), (q, -np.asanyarray(v), z, z)])
        plus, minus = at_v - g, at_minus_v - g
        return g, (plus + minus) / 2, -(plus - minus) / 2

    facade.mass_matrix = mass_matrix_b
    facade.bias = lambda p, q, v: _bias_of(*parts_b(p, q, v))
    if not callable(getattr(module, "passive", None)):
        facade.passive = lambda p, q, v: parts_b(p, q, v)[2]
    return facade


def _bias_of(gravity: np.ndarray, velocity: np.ndarray, passive: np.ndarray) -> np.ndarray:
    """bias = gravity + the velocity terms (the passive forces are apart)."""
    return gravity + velocity


def _qacc_facade(facade: _Facade, module: _Explicit) -> _Facade:
    """Form (c), explicit accelerations qacc(p, q, v, tau), as form (a): M^-1 column by column from
    unit torques, inverted; gravity, velocity terms and friction from qacc at rest and at +-v."""
    f = module.qacc

    def calls_c(
        p: object, q: np.ndarray, extra: list[tuple[np.ndarray, ...]]
    ) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
        """qacc at rest, at each unit torque and at the `extra` arguments, in one batched call:
        (qacc at rest, M^-1 column by column, the answers at `extra`)."""
        z, n = _zeros(q), np.shape(q)[-1]
        a0, *rest = _rows_of(f, p, [(q, z, z)] + [(q, z, _unit(q, j, n)) for j in range(n)] + extra)
        return a0, _stack_columns([c - a0 for c in rest[:n]]), rest[n:]

    def mass_matrix_c(p: object, q: np.ndarray) -> np.ndarray:
        return inverse(calls_c(p, q, [])[1])

    def parts_c(p: object, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        z = _zeros(q)
        a0, minv, (at_v, at_minus_v) = calls_c(p, q, [(q, v, z), (q, -np.asanyarray(v), z)])
        M = inverse(minv)
        plus, minus = at_v - a0, at_minus_v - a0
        return -_matvec(M, a0), -_matvec(M, (plus + minus) / 2), _matvec(M, (plus - minus) / 2)

    facade.mass_matrix = mass_matrix_c
    facade.bias = lambda p, q, v: _bias_of(*parts_c(p, q, v))
    if not callable(getattr(module, "passive", None)):
        facade.passive = lambda p, q, v: parts_c(p, q, v)[2]
    return facade


def _energies_facade(facade: _Facade, module: Energies) -> _Facade:
    """Form (d), the energies T and V (form (e) after its Hamiltonian is turned into them), as form (a):
    M, gravity and the velocity terms by Lagrange's equations (`_energy_terms`); no friction unless given."""

    def mass_matrix_d(p: DataclassInstance, q: np.ndarray) -> np.ndarray:
        return _energy_terms(module, p, q, None)[0]

    def bias_d(p: DataclassInstance, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        _, g, cv = _energy_terms(module, p, q, v)
        return g + cv

    facade.mass_matrix = mass_matrix_d
    facade.bias = bias_d
    if not callable(getattr(module, "passive", None)):
        facade.passive = _no_friction
    return facade


def _accelerations_facade(facade: _Facade, module: _Explicit) -> _Facade:
    """Explicit accelerations with inputs `u` as form (a) at zero input: M = I, bias = -(the part of
    qacc(q, v, 0) even in v), passive = the odd part; so I a + bias - passive = 0 is the person's motion
    without inputs (what the trajectories integrate). M^-1 B, the response to the inputs, is judged
    apart (validate/verdict/verdict.py); the mass matrix is not checked."""
    f = module.qacc

    def parts(p: object, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        z = _zeros(q)
        a0, at_v, at_minus_v = _rows_of(f, p, [(q, z, z), (q, v, z), (q, -np.asarray(v), z)])
        return a0 + ((at_v - a0) + (at_minus_v - a0)) / 2, ((at_v - a0) - (at_minus_v - a0)) / 2

    def mass_matrix_u(p: object, q: np.ndarray) -> np.ndarray:
        n = np.shape(q)[-1]
        eye = np.zeros(np.shape(q)[:-1] + (n, n))
        for i in range(n):
            eye[..., i, i] = 1.0
        return eye

    facade.mass_matrix = mass_matrix_u
    facade.bias = lambda p, q, v: -parts(p, q, v)[0]
    facade.passive = lambda p, q, v: parts(p, q, v)[1]  # in accelerations, like the rest: M = I
    return facade


def _no_friction(p: object, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    return _zeros(np.broadcast_arrays(np.asarray(q), np.asarray(v))[0])


@dataclasses.dataclass(frozen=True)
class _Derived:
    fields: tuple[str, ...]  # Params fields passed to `fn` (empty: parameters were numbers when traced)
    fn: Callable[..., list[np.ndarray | float]]  # (*params, *q, *v) -> [M entries (n*n), G (n), C v (n)]
    n: int


@functools.lru_cache(maxsize=256)  # one per module and parameter set: probes make many
def _derive(
    module: Energies, params_type: type[DataclassInstance], n: int, numeric_params: tuple[tuple[str, float], ...] | None
) -> _Derived:
    """M, G and C v of an energies-only module, differentiated symbolically and generated as numpy
    code. Parameters are symbols where the module's code allows it (one derivation for every probe),
    else the numbers given."""
    import sympy as sp

    backend = tracing.sympy_backend()
    qs, vs = list(sp.symbols(f"q0:{n}")), list(sp.symbols(f"v0:{n}"))
    q, v = tracing.wrap(qs, backend), tracing.wrap(vs, backend)
    names, psyms, p = tracing.sympy_params(params_type, numeric_params)
    T = _integer_powers(_traced_scalar(backend, "kinetic_energy", module.kinetic_energy, p, q, v))
    V = _integer_powers(_traced_scalar(backend, "potential_energy", module.potential_energy, p, q))
    dT_dv = [sp.diff(T, x) for x in vs]
    M = [[sp.diff(dT_dv[i], vs[j]) for j in range(n)] for i in range(n)]
    G = [sp.diff(V, x) for x in qs]
    Cv = [sum(sp.diff(dT_dv[i], qs[j]) * vs[j] for j in range(n)) - sp.diff(T, qs[i]) for i in range(n)]
    flat = [M[i][j] for i in range(n) for j in range(n)] + G + Cv
    fn = lambdified([*psyms, *qs, *vs], flat)  # cse, and long sums in parts (a 3,000-term V)
    return _Derived(tuple(names), fn, n)


def _traced_scalar(backend: Backend[E], name: str, fn: Callable[..., object], *args: object) -> E:
    return tracing.unwrap(np.asarray(tracing.traced_call(backend, name, fn, *args), dtype=object), backend)


def _integer_powers(expr: sp.Basic) -> sp.Basic:
    """x**2.0 as x**2: the tracer lifts every number to a Float, and d/dx x**2.0 = 2.0 x**2.0 / x is
    0/0 at x = 0 where d/dx x**2 = 2 x is not."""
    import sympy as sp

    if not isinstance(expr, sp.Basic):
        return expr
    return expr.replace(
        lambda e: e.is_Pow and e.exp.is_Float and float(e.exp).is_integer(),
        lambda e: sp.Pow(e.base, int(e.exp)),
    )


def _energy_terms(
    module: Energies, p: DataclassInstance, q: np.ndarray, v: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(M, G, C v) of an energies-only module at (q, v) (v None: zero)."""

    n, kind = np.shape(q)[-1], _params_type(p)
    try:
        derived = _derive(module, kind, n, None)
    except Exception:  # noqa: BLE001 - code that needs numbers for its parameters: derive per parameter set
        values = tuple((f.name, float(getattr(p, f.name))) for f in dataclasses.fields(p))
        try:
            derived = _derive(module, kind, n, values)
        except HarnessError:
            raise
        except Exception as exc:
            raise HarnessError(
                f"cannot differentiate kinetic_energy/potential_energy symbolically ({type(exc).__name__}: {exc}); "
                "only numpy arithmetic and elementary functions are supported."
            ) from None
    n = derived.n
    q = np.asarray(q)
    v = _zeros(q) if v is None else np.asarray(v)
    args = [getattr(p, k) for k in derived.fields] + [q[..., i] for i in range(n)] + [v[..., i] for i in range(n)]
    out = derived.fn(*args)
    M = stack_matrix([[out[i * n + j] for j in range(n)] for i in range(n)])
    G = stack_vector(out[n * n : n * n + n])
    Cv = stack_vector(out[n * n + n :])
    shape = np.broadcast_shapes(np.shape(q), np.shape(v))
    return (
        np.broadcast_to(M, shape[:-1] + (n, n)),
        np.broadcast_to(G, shape),
        np.broadcast_to(Cv, shape),
    )


def _params_type(p: DataclassInstance) -> type[DataclassInstance]:
    """The class of what parameters() returned (a key of the derivation caches)."""
    return type(p)

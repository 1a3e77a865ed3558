"""The structure every Lagrangian derivation has, checked on the person's own functions alone.

Whatever the chain, equations of motion derived by Lagrange's method have (q the coordinates, v the rates,
C v = bias(q, v) - bias(q, 0) the velocity terms, G = bias(q, 0) the gravity terms):

    symmetric            M(q) = M(q)^T
    positive definite    v.M(q) v > 0 for every v != 0
    quadratic            C v is homogeneous of degree 2 in v: C(q, 2 v) 2 v = 4 C(q, v) v
    christoffel          (C v)_i = sum_jk (dM_ij/dq_k - dM_jk/dq_i / 2) v_j v_k, of the person's own M
    gradient             G is a gradient: dG_i/dq_j = dG_j/dq_i
    potential            G = dV/dq, where the module gives V
    kinetic              T = v.M v / 2, where the module gives T

So a wrong Coriolis sign is found where no single slip of the model's expected equations reproduces it
(verdict/explain.py): the person's velocity terms are not those of their own M. Each property is checked at
the first `STATES` states of the verdict's sample; a derivative of M, G or V is a fourth-order central
difference, judged against ten times its own error bound as well (core/tolerances.py STRUCTURE). A broken
property is a finding naming the first entry that breaks it and, where the person's code traces with sympy
(handwritten/tracing.py), the entry's difference in the person's own symbols (their Params fields, the
coordinates, d<coordinate> for the rates), checked against the numbers; otherwise the numbers at the state
where it is worst. Nothing here raises: a function that cannot be called is the term rows' finding.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

import numpy as np

from ..core.tolerances import EPS, STRUCTURE, STRUCTURE_STEP
from ..handwritten import tracing
from ..handwritten.forms import accelerations_only, not_provided_in, written_form
from ..handwritten.values import real_array
from ..results.schema import StructureFinding
from ..sources import SYMBOLIC_MAX_DOF
from ..systems import System
from .pointwise import States, force_scale, physical_scales

if TYPE_CHECKING:
    import sympy as sp
    from _typeshed import DataclassInstance

STATES = 24  # states of the verdict's sample the structure is checked at
MAX_OPERATIONS = 600  # a difference larger than this (as traced) is said in numbers: expanding it is costly
WHAT = {
    "symmetric": "your M is not symmetric",
    "positive definite": "your M is not positive definite",
    "quadratic": "your velocity terms are not quadratic in the rates",
    "christoffel": "your velocity terms are not those of your M",
    "gradient": "your gravity terms are not the gradient of a potential",
    "potential": "your gravity terms are not those of your V",
    "kinetic": "your T is not v.M v / 2 of your M",
}
VERB = {"christoffel": "differs by", "quadratic": "has, of another degree than 2,"}  # else "="


@dataclass(frozen=True)
class Values:
    """The person's functions at K states: M, its derivatives dM[a, k] = dM/dq_k, the forces and energies,
    and each finite difference's error bound per state (`*_err`)."""

    q: np.ndarray
    v: np.ndarray
    M: np.ndarray  # (K, n, n)
    dM: np.ndarray  # (K, n, n, n): [a, k, i, j] = dM_ij/dq_k
    dM_err: np.ndarray  # (K,)
    G: np.ndarray  # (K, n)
    dG: np.ndarray  # (K, n, n): [a, j, i] = dG_i/dq_j
    dG_err: np.ndarray
    Cv: np.ndarray  # (K, n) at v
    Cv2: np.ndarray  # (K, n) at 2 v
    T: np.ndarray | None = None  # (K,)
    V: np.ndarray | None = None
    dV: np.ndarray | None = None  # (K, n)
    dV_err: np.ndarray | None = None


@dataclass(frozen=True)
class Gap:
    """One property, numerically: the difference of its two sides per state and entry, its tolerance."""

    prop: str
    terms: tuple[str, ...]  # the verdict's terms it concerns
    diff: np.ndarray  # (K, E)
    tol: np.ndarray  # (K, 1) or (K, E)
    scale: float
    labels: list[str]  # E entries
    index: Sequence[tuple[int, ...]]  # each entry's index (the symbolic side's)


def derivative(fn: Callable[[np.ndarray], np.ndarray], q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """d fn / d q_k for every k at each state, by the fourth-order central difference (one call of `fn` on
    every shifted state), as (K, n, ...); and a bound on its error per state (K,): the second- minus the
    fourth-order difference (the larger error) plus the rounding, 4 eps max |fn| / h."""
    K, n = q.shape
    h = STRUCTURE_STEP
    eye = np.eye(n)
    shifted = np.concatenate([q + s * h * eye[k] for k in range(n) for s in (-2, -1, 1, 2)])
    f = np.asarray(fn(shifted))
    f = f.reshape(n, 4, K, *f.shape[1:])
    m2, m1, p1, p2 = (f[:, i] for i in range(4))
    d2 = (p1 - m1) / (2 * h)
    d4 = (8 * (p1 - m1) - (p2 - m2)) / (12 * h)
    per_state = np.moveaxis(np.abs(d2 - d4), 1, 0).reshape(K, -1).max(axis=1)
    size = np.moveaxis(np.abs(f), 2, 0).reshape(K, -1).max(axis=1)
    return np.moveaxis(d4, 1, 0), per_state + 4 * EPS * size / h


def values(system: System, states: States) -> Values:
    """The person's M, forces and energies at the first STATES states, with the derivatives the
    properties need (handwritten functions called in batches: a few calls in all)."""
    eq, p = system.derivation, system.params
    q, v = states.q[:STATES], states.v[:STATES]
    K, n = q.shape
    zero = np.zeros_like(q)

    def mass(x: np.ndarray) -> np.ndarray:
        return real_array("mass_matrix()", eq.mass_matrix(p, x), (len(x), n, n))

    def gravity(x: np.ndarray) -> np.ndarray:
        return real_array("bias()", eq.bias(p, x, np.zeros_like(x)), (len(x), n))

    b = real_array("bias()", eq.bias(p, np.concatenate([q, q, q]), np.concatenate([zero, v, 2 * v])), (3 * K, n))
    G, B1, B2 = np.split(b, 3)
    dM, dM_err = derivative(mass, q)
    dG, dG_err = derivative(gravity, q)
    out = Values(q, v, mass(q), dM, dM_err, G, dG, dG_err, B1 - G, B2 - G)
    missing = not_provided_in(eq)
    if "kinetic_energy" not in missing:
        out = dataclasses.replace(out, T=real_array("kinetic_energy()", eq.kinetic_energy(p, q, v), (K,)))
    if "potential_energy" not in missing:

        def potential(x: np.ndarray) -> np.ndarray:
            return real_array("potential_energy()", eq.potential_energy(p, x), (len(x),))

        dV, dV_err = derivative(potential, q)
        out = dataclasses.replace(out, V=potential(q), dV=dV, dV_err=dV_err)
    return out


def _pairs(n: int) -> list[tuple[int, int]]:
    return [(i, j) for i in range(n) for j in range(i + 1, n)]


def gaps(at: Values, coordinates: Sequence[str], floors: dict[str, float]) -> list[Gap]:
    """Every property but positive definiteness (`indefinite`), as the differences of its two sides."""
    n, c, rtol = len(coordinates), list(coordinates), STRUCTURE.rtol
    ones = np.ones((len(at.q), 1))
    pairs = _pairs(n)
    out = []
    m_scale = max(float(np.abs(at.M).max(initial=0.0)), floors["mass matrix"], 1e-300)
    asym = np.stack([at.M[:, i, j] - at.M[:, j, i] for i, j in pairs], -1) if pairs else np.zeros((len(at.q), 0))
    sym_labels = [f"M[{c[i]}, {c[j]}] - M[{c[j]}, {c[i]}]" for i, j in pairs]
    out.append(Gap("symmetric", ("mass matrix",), asym, rtol * m_scale * ones, m_scale, sym_labels, pairs))
    cv_labels, single = [f"(C v)[{x}]" for x in c], [(i,) for i in range(n)]
    f_scale = max(float(np.abs(at.Cv2).max()), 4 * floors["velocity"], float(np.abs(at.G).max()), 1e-300)
    quad = at.Cv2 - 4 * at.Cv
    out.append(Gap("quadratic", ("velocity",), quad, rtol * f_scale * ones, f_scale, cv_labels, single))
    out.append(_christoffel(at, cv_labels, floors["velocity"]))
    out.append(_gradient(at, c, floors["gravity"]))
    if at.dV is not None and at.dV_err is not None:
        g_scale = max(float(np.abs(at.G).max()), float(np.abs(at.dV).max()), floors["gravity"], 1e-300)
        tol = np.maximum(rtol * g_scale, 10 * at.dV_err)[:, None]
        labels = [f"G[{x}] - dV/d{x}" for x in c]
        out.append(Gap("potential", ("gravity", "potential energy"), at.G - at.dV, tol, g_scale, labels, single))
    if at.T is not None:
        half = 0.5 * np.einsum("ai,aij,aj->a", at.v, at.M, at.v)
        t_scale = max(float(np.abs(at.T).max()), float(np.abs(half).max()), floors["kinetic energy"], 1e-300)
        terms = ("kinetic energy", "mass matrix")
        out.append(
            Gap("kinetic", terms, (at.T - half)[:, None], rtol * t_scale * ones, t_scale, ["T - v.M v / 2"], [()])
        )
    return out


def _christoffel(at: Values, labels: list[str], floor: float) -> Gap:
    """(C v)_i against sum_jk (dM_ij/dq_k - dM_jk/dq_i / 2) v_j v_k, with the difference's error carried."""
    first = np.einsum("akij,aj,ak->ai", at.dM, at.v, at.v)
    second = np.einsum("aijk,aj,ak->ai", at.dM, at.v, at.v)
    form = first - 0.5 * second
    scale = max(float(np.abs(at.Cv).max()), float(np.abs(form).max()), force_scale(at.M, at.v), floor, 1e-300)
    carried = 1.5 * at.dM_err * np.abs(at.v).sum(axis=1) ** 2
    tol = np.maximum(STRUCTURE.rtol * scale, 10 * carried)[:, None]
    terms = ("velocity", "mass matrix")
    return Gap("christoffel", terms, at.Cv - form, tol, scale, labels, [(i,) for i in range(len(labels))])


def _gradient(at: Values, c: list[str], floor: float) -> Gap:
    """dG_i/dq_j against dG_j/dq_i for i < j (at.dG[a, j, i] = dG_i/dq_j)."""
    pairs = _pairs(len(c))
    J = np.swapaxes(at.dG, 1, 2)  # [a, i, j] = dG_i/dq_j
    asym = np.stack([J[:, i, j] - J[:, j, i] for i, j in pairs], -1) if pairs else np.zeros((len(at.q), 0))
    scale = max(float(np.abs(J).max(initial=0.0)), floor, 1e-300)
    tol = np.maximum(STRUCTURE.rtol * scale, 10 * 2 * at.dG_err)[:, None]
    labels = [f"dG[{c[i]}]/d{c[j]} - dG[{c[j]}]/d{c[i]}" for i, j in pairs]
    return Gap("gradient", ("gravity",), asym, tol, scale, labels, pairs)


def _state(at: Values, a: int) -> str:
    return f"q = {np.round(at.q[a], 4).tolist()}, v = {np.round(at.v[a], 4).tolist()}"


def numeric_finding(gap: Gap, at: Values) -> StructureFinding | None:
    """The property broken where a difference passes its tolerance, named by its first entry (in the
    coordinates' order) at the state where that entry is worst; None where it holds."""
    over = np.abs(gap.diff) > gap.tol
    if not over.any():
        return None
    bad = [e for e in range(gap.diff.shape[1]) if over[:, e].any()]
    e = bad[0]
    a = int(np.argmax(np.abs(gap.diff[:, e]) / np.broadcast_to(gap.tol, gap.diff.shape)[:, e]))
    value = float(gap.diff[a, e])
    return {
        "property": gap.prop,
        "terms": list(gap.terms),
        "entry": gap.labels[e],
        "entries": [gap.labels[k] for k in bad],
        "difference": "",
        "value": value,
        "scaled": float(np.abs(gap.diff).max() / gap.scale),
        "tolerance": float(np.broadcast_to(gap.tol, gap.diff.shape)[a, e] / gap.scale),
        "q": at.q[a].tolist(),
        "v": at.v[a].tolist(),
        "statement": sentence(
            gap.prop, gap.labels[e], f"{value:.4g} at {_state(at, a)}", [gap.labels[k] for k in bad[1:]]
        ),
    }


def indefinite(at: Values) -> StructureFinding | None:
    """Where the symmetric part of M has an eigenvalue at or below zero (relative to |M|): the worst state."""
    sym = 0.5 * (at.M + np.swapaxes(at.M, -1, -2))
    low = np.linalg.eigvalsh(sym)[:, 0]
    top = np.maximum(np.abs(at.M).max(axis=(-1, -2)), 1e-300)
    bad = low <= 1e-12 * top
    if not bad.any():
        return None
    a = int(np.argmin(low / top))
    said = f"its smallest eigenvalue is {low[a]:.4g} at q = {np.round(at.q[a], 4).tolist()}"
    return {
        "property": "positive definite",
        "terms": ["mass matrix"],
        "entry": "M",
        "entries": ["M"],
        "difference": "",
        "value": float(low[a]),
        "scaled": float(-low[a] / top[a]),
        "tolerance": 1e-12,
        "q": at.q[a].tolist(),
        "v": at.v[a].tolist(),
        "statement": f"{WHAT['positive definite']}: {said} ({int(bad.sum())} of {len(bad)} states)",
    }


def sentence(prop: str, entry: str, said: str, others: Sequence[str] = ()) -> str:
    """ "your velocity terms are not those of your M: (C v)[theta] differs by <said> (also (C v)[phi])"."""
    verb = VERB.get(prop, "=")
    also = f" (also {', '.join(others[:3])}{' and more' if len(others) > 3 else ''})" if others else ""
    return f"{WHAT[prop]}: {entry} {verb} {said}{also}"


def findings(system: System, states: States) -> list[StructureFinding]:
    """Every property of a Lagrangian derivation the person's functions break at the verdict's states, in
    the order of the module docstring, each in the person's own symbols where their code traces; [] where
    the functions cannot be called (the term rows say why) or the derivation is judged in accelerations."""
    if system.equations is None or accelerations_only(system.equations) or not system.nv or not len(states):
        return []
    import warnings

    try:
        with np.errstate(all="ignore"), warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            at = values(system, states)
    except Exception:  # noqa: BLE001 - the person's code: a call that fails is the term rows' finding
        return []
    if said:  # complex or otherwise not real numbers (cast with a warning): the term rows name them
        return []
    if not all(np.all(np.isfinite(x)) for x in (at.M, at.dM, at.G, at.dG, at.Cv, at.Cv2)):
        return []
    scales = physical_scales(system, states)
    floors = {t: scales.floor(t) for t in ("mass matrix", "velocity", "gravity", "kinetic energy")}
    pairs = [(g, f) for g in gaps(at, system.coordinates, floors) if (f := numeric_finding(g, at)) is not None]
    found_gaps, out = [g for g, _ in pairs], [f for _, f in pairs]
    pd = indefinite(at)
    if pd is not None:
        out.insert(1 if out and out[0]["property"] == "symmetric" else 0, pd)
    if found_gaps and system.nv <= SYMBOLIC_MAX_DOF:
        named(system, found_gaps, out)
    return out


def sp_ops(expr: sp.Expr) -> int:
    """The operations of a traced expression (sympy's count_ops, unevaluated)."""
    import sympy as sp

    return int(sp.count_ops(expr, visual=False))


def lead(found: Sequence[StructureFinding], failing_terms: Sequence[str]) -> str:
    """The statement of the finding a verdict leads with: the first whose terms include the first failing
    term (then the next failing term); "" where none concerns a failing term."""
    for term in failing_terms:
        for f in found:
            if term in f.get("terms", []):
                return str(f["statement"])
    return ""


def named(system: System, found_gaps: list[Gap], out: list[StructureFinding]) -> None:
    """Each finding's entry as a difference in the person's own symbols, where their code traces with sympy
    and the difference gives the numbers found (kept in `out` in place; the numbers stay otherwise)."""
    if written_form(system.equations) == "c":  # M and the forces through an inversion: not the person's terms
        return
    try:
        traced = Traced.of(system)
    except Exception:  # noqa: BLE001 - the person's code may not trace (a branch on a value, a numpy call)
        return
    by_prop = {g.prop: g for g in found_gaps}
    for f in out:
        gap = by_prop.get(str(f["property"]))
        if gap is None:
            continue
        try:
            expr = traced.difference(gap.prop, gap.index[gap.labels.index(str(f["entry"]))])
        except Exception:  # noqa: BLE001 - sympy could not take it (a Piecewise, a polynomial test)
            continue
        if sp_ops(expr) > MAX_OPERATIONS:  # expanding it could take minutes: the numbers say it
            continue
        if traced.gives(expr, f, gap):
            f["difference"] = traced.text(expr)
            f["statement"] = sentence(gap.prop, str(f["entry"]), f["difference"], f["entries"][1:])


@dataclass(frozen=True)
class Traced:
    """The person's M, bias, T and V traced with sympy: their Params fields as symbols, the coordinates
    by name and d<coordinate> for the rates."""

    q: list[sp.Symbol]
    v: list[sp.Symbol]
    params: list[sp.Symbol]
    numbers: list[float]
    M: list[list[sp.Expr]]
    G: list[sp.Expr]
    Cv: list[sp.Expr]
    T: sp.Expr | None
    V: sp.Expr | None

    @classmethod
    def of(cls, system: System) -> Traced:
        import sympy as sp

        backend = tracing.sympy_backend()
        names, psyms, p = tracing.sympy_params(
            cast("type[DataclassInstance]", type(system.params)), None
        )  # parameters() returns a dataclass
        qs = [sp.Symbol(c, real=True) for c in system.coordinates]
        vs = [sp.Symbol(f"d{c}", real=True) for c in system.coordinates]
        M, bias, _ = tracing.dynamics(tracing.SystemParts(system.nv, system.derivation, p), qs, vs, backend)
        G = [sp.sympify(b).subs({x: 0 for x in vs}) for b in bias]
        eq, missing = system.derivation, not_provided_in(system.derivation)
        q, v = tracing.wrap(qs, backend), tracing.wrap(vs, backend)
        T = V = None
        if "kinetic_energy" not in missing:
            T = tracing.vector(tracing.traced_call(backend, "kinetic_energy", eq.kinetic_energy, p, q, v), 1, backend)[
                0
            ]
        if "potential_energy" not in missing:
            V = tracing.vector(tracing.traced_call(backend, "potential_energy", eq.potential_energy, p, q), 1, backend)[
                0
            ]
        numbers = [float(getattr(system.params, k)) for k in names]
        return cls(qs, vs, psyms, numbers, M, G, [b - g for b, g in zip(bias, G, strict=True)], T, V)

    def difference(self, prop: str, index: tuple[int, ...]) -> sp.Expr:
        """The entry's difference of the property's two sides, as the numbers have it (Gap.diff)."""
        import sympy as sp

        q, v, M, n = self.q, self.v, self.M, len(self.q)
        if prop == "symmetric":
            return M[index[0]][index[1]] - M[index[1]][index[0]]
        if prop == "quadratic":
            poly = sp.Poly(sp.expand(self.Cv[index[0]]), *v)
            return sum(
                (c * sp.prod([x**e for x, e in zip(v, m, strict=True)]) for m, c in poly.terms() if sum(m) != 2), 0
            )
        if prop == "christoffel":
            i = index[0]
            form = sum(
                (sp.diff(M[i][j], q[k]) - sp.diff(M[j][k], q[i]) / 2) * v[j] * v[k] for j in range(n) for k in range(n)
            )
            return self.Cv[i] - form
        if prop == "gradient":
            i, j = index
            return sp.diff(self.G[i], q[j]) - sp.diff(self.G[j], q[i])
        if prop == "potential" and self.V is not None:
            return self.G[index[0]] - sp.diff(self.V, q[index[0]])
        if prop == "kinetic" and self.T is not None:
            return self.T - sum(M[i][j] * v[i] * v[j] for i in range(n) for j in range(n)) / 2
        raise ValueError(f"no symbolic side for {prop}")

    def gives(self, expr: sp.Expr, f: StructureFinding, gap: Gap) -> bool:
        """Whether `expr`, at the finding's state and the model's parameters, is the difference found."""
        import sympy as sp

        if gap.prop == "quadratic":  # the part of another degree P: the numbers have P(2 v) - 4 P(v)
            expr = expr.subs({x: 2 * x for x in self.v}, simultaneous=True) - 4 * expr
        fn = sp.lambdify([*self.q, *self.v, *self.params], expr, modules="numpy")
        got = float(fn(*f["q"], *f["v"], *self.numbers))
        allowed = 2 * float(f["tolerance"]) * gap.scale + 1e-6 * abs(float(f["value"]))
        return bool(np.isfinite(got)) and abs(got - float(f["value"])) <= allowed and got != 0.0

    @staticmethod
    def text(expr: sp.Expr) -> str:
        """The difference as a person reads it: simple numbers as fractions, trigonometry expanded, then
        simplified and factored where it is small enough to simplify quickly."""
        import sympy as sp

        simple = {}
        for x in sp.sympify(expr).atoms(sp.Float):
            r = sp.Rational(float(x)).limit_denominator(24)
            simple[x] = r if abs(float(r) - float(x)) <= 1e-12 * max(abs(float(x)), 1.0) else sp.Float(float(x), 6)
        out = sp.expand(sp.sympify(expr).xreplace(simple), trig=True)
        if sp.count_ops(out) <= 400:
            out = sp.factor(sp.trigsimp(out))
        return str(sp.sstr(out))

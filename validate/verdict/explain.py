"""What a wrong expression lacks: a failing term of a derivation written as a symbolic difference from
the model's own equations (symbolic/derivation.py).

For each entry of a disagreeing term (M[i, j], G[i], (C v)[i], passive[i], T, V), the user's numbers
are taken at random states of the model and of the probe models (where every parameter moves by its
own factor, so that no two parameters are confused), and the difference D = yours - expected is
fitted onto the mistakes one slip typically makes in the expected expression E = sum_k t_k:

    a term lost, doubled, with its sign flipped or a wrong number in front     D = c t_k  (c simple)
    a parameter swapped for another of its kind (a mass, a length, an inertia) D = t_k' - t_k
    a factor lost or an extra one                                              D = t_k / p - t_k, t_k p - t_k
    sin for cos (or back), one coordinate for another in a trigonometric term  D = t_k' - t_k
    two terms wrong at once                                                    D = c1 t_k + c2 t_l

A fit is kept only if it reproduces the user's numbers to near round-off at states held back from the
fit (another half of the samples); it is then stated symbolically, in the model's parameter names:
"M[theta, theta]: yours = expected - 2*c_link2*l_link2*m_link2*cos(phi)". Where no simple form
reproduces the numbers, the statement says so rather than guess.

Simplifying and fitting cost seconds per entry (2.2 s per printed form of the double pendulum, most
of a warm `run`); each entry's record is kept in the cache it is given (kind "explain") under a hash of everything
it is computed from: the harness's code, the expected expression and its arguments, the sample states
and parameter values, and the user's numbers at those states (what the printed form computes, not
where it came from: an equations module changed in memory never shares an entry).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import re
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias, TypedDict, cast

import numpy as np

from ..core import cache
from ..core.cachedir import Cache
from ..handwritten.forms import written_form
from ..handwritten.values import real_array
from ..results.schema import Explanation
from ..sources.symbolic import derivation_of
from ..symbolic.derivation import Derivation, axis_rotation, parameter_values
from ..symbolic.readable import in_coordinates, tidy, transformed
from ..systems import System
from .explain_inputs import User, actuation_explanations, force_part, mass_identifiable
from .pointwise import random_states

if TYPE_CHECKING:  # sympy is imported when first used
    import sympy as sp

# One entry to explain: the term, the entry's label, the model's expression of it (in the system's
# coordinates), and user(system, q, v): the person's value of it, one per state.
Item: TypeAlias = "tuple[str, str, sp.Expr, User]"

PARTS = {
    "mass matrix": "M",
    "gravity": "G",
    "velocity": "Cv",
    "friction": "passive",
    "kinetic energy": "T",
    "potential energy": "V",
}
FORCES = ("M", "G", "Cv", "passive")  # the parts an explicit u form gives as accelerations (explain_inputs.py)
STATES_PER_MODEL = 16  # per model (the system's and each probe's): half fit, half held back
FIT_RTOL = 1e-8  # a fit's residual at the held-back states, relative to the entry's scale
MAX_CANDIDATES = 800
PAIR_POOL = 24  # two-slip fits are tried among the candidates most aligned with the difference
SIMPLE = sorted(
    {Fraction(s * a, b) for a in (1, 2, 3, 4) for b in (1, 2, 3, 4) for s in (1, -1)}, key=lambda f: (abs(f), f)
)


@dataclass(frozen=True)
class Candidate:
    basis: sp.Expr  # D = c * basis
    kind: str  # "term", "swap", "drop", "extra", "trig", "argument"
    text: str  # what the mistake is, when c is the one expected of it
    fixed: Fraction | None  # the coefficient this mistake must have (None: any simple one)


def _kind(symbol: sp.Symbol) -> str:
    name = str(symbol)
    if name.startswith("I_"):
        return "inertia"
    if name[:2] in ("l_", "c_", "a_"):
        return "length"
    return name.split("_")[0]


def _parameter_slips(t: sp.Expr, params: list[sp.Symbol]) -> list[Candidate]:
    """The slips of one parameter in the term `t`: swapped for another of its kind, lost or extra."""
    import sympy as sp

    one = Fraction(1)
    out: list[Candidate] = []
    for p in [p for p in params if t.has(p)]:
        power = sp.degree(t, p) if t.is_polynomial(p) else 1
        for r in params:
            if r == p or _kind(r) != _kind(p):
                continue
            if not t.has(r):
                out.append(Candidate(t.xreplace({p: r}) - t, "swap", f"has {r} where expected has {p} in {t}", one))
            if power >= 2:  # one factor of p^2 for another length: l1 l2 for l2^2
                out.append(Candidate(t * r / p - t, "swap", f"has {p}*{r} where expected has {p}**{power} in {t}", one))
        out.append(Candidate(t / p - t, "drop", f"lacks the factor {p} in {t}", one))
        out.append(Candidate(t * p - t, "extra", f"has an extra factor {p} in {t}", one))
    return out


def _trig_slips(t: sp.Expr, q: list[sp.Symbol]) -> list[Candidate]:
    """The slips of a trigonometric factor in the term `t`: sin for cos (or back), another coordinate."""
    import sympy as sp

    one = Fraction(1)
    out: list[Candidate] = []
    for f in t.atoms(sp.sin, sp.cos):
        other = (sp.cos if isinstance(f, sp.sin) else sp.sin)(f.args[0])
        out.append(Candidate(t.xreplace({f: other}) - t, "trig", f"has {other} where expected has {f} in {t}", one))
        for x in q:
            if f.args[0] != x:
                g = f.func(x)
                out.append(Candidate(t.xreplace({f: g}) - t, "argument", f"has {g} where expected has {f} in {t}", one))
    return out


def _rate_slips(t: sp.Expr, rates: tuple[sp.Symbol, ...]) -> list[Candidate]:
    """One rate for another in the term `t`: (theta' + theta') for (theta' + phi')."""
    one = Fraction(1)
    return [
        Candidate(t.xreplace({x: y}) - t, "argument", f"has {y} where expected has {x} in {t}", one)
        for x in rates
        if t.has(x)
        for y in rates
        if y != x
    ]


def _entry_slips(expanded: sp.Expr, terms: list[sp.Expr], params: list[sp.Symbol]) -> list[Candidate]:
    """The slips across the whole entry: a group of terms scaled, two parameters exchanged, a factor
    lost everywhere, sin for cos everywhere."""
    import sympy as sp

    one = Fraction(1)
    out: list[Candidate] = []
    present = [p for p in params if expanded.has(p)]
    for p in present:  # every term in p by the same wrong number: a 1/2 misplaced in front of a group
        members = [t for t in terms if t.has(p)]
        group = sp.Add(*members)
        if len(members) > 1 and group != expanded:
            out.append(Candidate(group, "group", f"the terms in {p}: {group}", None))
    for p, r in itertools.permutations(present, 2):
        if _kind(p) == _kind(r) and str(p) < str(r):
            out.append(
                Candidate(expanded.xreplace({p: r, r: p}) - expanded, "exchange", f"has {p} and {r} exchanged", one)
            )
    for p in present:
        out.append(Candidate(expanded.xreplace({p: 1}) - expanded, "drop", f"lacks the factor {p} everywhere", one))
    for f in expanded.atoms(sp.sin, sp.cos):
        other = (sp.cos if isinstance(f, sp.sin) else sp.sin)(f.args[0])
        out.append(Candidate(expanded.xreplace({f: other}) - expanded, "trig", f"has {other} for {f} everywhere", one))
    return out


def literal_slips(expected: sp.Expr, params: list[sp.Symbol], values: list[dict[sp.Symbol, float]]) -> list[Candidate]:
    """A parameter typed in as a number: the entry with one parameter replaced by its model value (a
    literal equal to it hides the slip at the model's values; a probe shows it) or by a number typed
    into parameters() (`values[1]`: any of them, for any parameter of the entry)."""
    import sympy as sp

    expanded = sp.expand(expected)
    present = [p for p in params if expanded.has(p)]
    numbers = [(p, float(values[0][p])) for p in present if p in values[0]]
    numbers += [(p, float(x)) for p in present for x in dict.fromkeys(values[1].values()) if x != values[0].get(p)]
    return [
        Candidate(
            expanded.xreplace({p: sp.Float(x)}) - expanded,
            "literal",
            f"uses {x:.6g} where the model's {p} belongs",
            Fraction(1),
        )
        for p, x in numbers
    ]


def _typed_values(system: System) -> dict[str, float]:
    """The numbers typed into the system's parameters() (verdict/words.py), {} where none or unknown."""
    from .words import typed_numbers

    try:
        return typed_numbers(system) if system.equations is not None else {}
    except Exception:  # noqa: BLE001 - a candidate source, never a failure
        return {}


def candidates(
    expected: sp.Expr, q: list[sp.Symbol], params: list[sp.Symbol], rates: tuple[sp.Symbol, ...] = ()
) -> list[Candidate]:
    """The single-slip differences from `expected`, most specific first: slips in one term, then
    slips across the whole entry, then each term on its own (lost, doubled, sign, wrong number)."""
    import sympy as sp

    expanded = sp.expand(expected)
    terms = [t for t in sp.Add.make_args(expanded) if t != 0] if expanded != 0 else []
    out: list[Candidate] = []
    for t in terms:
        out += [*_parameter_slips(t, params), *_trig_slips(t, q), *_rate_slips(t, rates)]
    out += _entry_slips(expanded, terms, params)
    out += [Candidate(t, "term", str(t), None) for t in terms]
    out.append(Candidate(expanded, "scale", "expected", None))
    return out[:MAX_CANDIDATES]


def _simple(c: float) -> Fraction | None:
    for f in SIMPLE:
        if abs(c - float(f)) <= 1e-6 * max(1.0, abs(c)):
            return f
    return None


def _plus(expr: sp.Expr) -> str:
    """ "+ x" or "- x" for a sympy term."""
    import sympy as sp

    text = sp.sstr(expr)
    return f"- {text[1:]}" if text.startswith("-") else f"+ {text}"


def _coefficient_text(c: Fraction, basis: sp.Expr) -> str:
    import sympy as sp

    return _plus(sp.Rational(c.numerator, c.denominator) * basis)


def _describe(cand: Candidate, c: Fraction) -> str:
    if cand.kind == "scale":
        return "yours = -expected (the whole entry's sign)" if c == -2 else f"yours = {1 + c} * expected"
    if cand.kind == "group":
        times = "lacks" if c == -1 else f"has {1 + c} times"
        return f"yours {times} {cand.text} (yours = expected {_coefficient_text(c, cand.basis)})"
    if cand.kind != "term":
        return f"yours {cand.text}"
    diff = f"yours = expected {_coefficient_text(c, cand.basis)}"
    what = {
        Fraction(-1): f"lacks the term {cand.text}",
        Fraction(1): f"has the term {cand.text} twice",
        Fraction(-2): f"has the term {cand.text} with the wrong sign",
    }.get(c)
    return diff if what is None else f"yours {what} ({diff})"


class _Samples:
    """The entry's arguments at the fit and the held-back states: q, v and parameter values."""

    def __init__(
        self, systems: list[System], derivation: Derivation, symbols: dict[str, list[sp.Symbol]], seed: int
    ) -> None:
        qs, vs, ps, self.states = [], [], [], []
        for k, s in enumerate(systems):
            st = random_states(s, n=STATES_PER_MODEL, seed=seed + 1000 + k)
            values = parameter_values(derivation, s.view)
            qs.append(st.q)
            vs.append(st.v)
            ps.append(np.array([[values[p] for p in derivation.source]] * len(st.q)))
            self.states.append((s, st))
        self.q, self.v, self.p = np.concatenate(qs), np.concatenate(vs), np.concatenate(ps)
        self.typed = _typed_values(systems[0])
        self.args = [*symbols["q"], *symbols["v"], *derivation.source]
        half = np.zeros(len(self.q), dtype=bool)
        half[::2] = True
        self.fit, self.held = half, ~half

    def evaluate(self, exprs: list[sp.Expr]) -> np.ndarray:
        import sympy as sp

        fn = sp.lambdify(self.args, exprs, modules="numpy", cse=True)
        raw = fn(*self.q.T, *self.v.T, *self.p.T)
        return np.stack([np.broadcast_to(np.asarray(x, dtype=float), (len(self.q),)) for x in raw], axis=-1)


def _entries(part: str, n: int, coordinates: tuple[str, ...]) -> list[tuple[tuple[int, ...], str]]:
    if part == "M":
        return [((i, j), f"M[{coordinates[i]}, {coordinates[j]}]") for i in range(n) for j in range(i, n)]
    if part in ("T", "V"):
        return [((), part)]
    label = {"G": "G", "Cv": "(C v)", "passive": "passive"}[part]
    return [((i,), f"{label}[{c}]") for i, c in enumerate(coordinates)]


def _symbols(coordinates: tuple[str, ...]) -> dict[str, list[sp.Symbol]]:
    import sympy as sp

    return {
        "q": [sp.Symbol(c, real=True) for c in coordinates],
        "v": [sp.Symbol(f"d{c}", real=True) for c in coordinates],
    }


def explain_entries(
    system: System,
    probe_systems: list[System],
    items: list[Item],
    *,
    seed: int = 0,
    cache: Cache | None = None,
) -> list[Explanation]:
    """One record per disagreeing item (term, entry label, expected sympy expression in the named
    coordinates, user(system, q, v) -> one value per state): the expected expression and the symbolic
    difference the user's numbers fit (verified at held-back states), or that none fits; each record
    read from `cache` (None: no cache) where it was computed before."""
    where = None if cache is None else cache.folder("explain")
    d = derivation_of(system)
    symbols = _symbols(tuple(system.coordinates))
    samples = _Samples([system, *probe_systems], d, symbols, seed)
    out: list[Explanation] = []
    for term, label, entry, user in items:
        try:
            with np.errstate(all="ignore"):
                mine = np.concatenate([np.asarray(user(s, st.q, st.v), dtype=float) for s, st in samples.states])
        except Exception:  # noqa: BLE001 - the user's code; an entry it cannot give is not explained
            continue
        key = _entry_key(d, samples, term, label, entry, mine)
        found = _cached(key, where)
        record = found["record"] if found is not None else _explain_entry(d, samples, symbols, term, label, entry, mine)
        if found is None:
            _keep(key, record, where)
        if record is not None:
            out.append(record)
    return out


def _explain_entry(
    d: Derivation,
    samples: _Samples,
    symbols: dict[str, list[sp.Symbol]],
    term: str,
    label: str,
    entry: sp.Expr,
    mine: np.ndarray,
) -> Explanation | None:
    """One entry's record, or None where the user's numbers equal the expected entry's."""
    import sympy as sp

    expected = tidy(entry, symbols["q"])
    exp_num = samples.evaluate([expected])[:, 0]
    scale = max(float(np.abs(exp_num).max()), float(np.abs(mine).max()), 1e-300)
    D = mine - exp_num
    if not np.all(np.isfinite(D)) or float(np.abs(D).max()) <= 1e-9 * scale:
        return None
    at_model = D[: len(samples.states[0][1].q)]  # the first model's states are the system's own
    record: Explanation = {
        "term": term,
        "entry": label,
        "expected": sp.sstr(expected),
        "at_model": bool(float(np.abs(at_model).max()) > 1e-9 * scale),
        **_fit(expected, exp_num, D, scale, samples, symbols),
    }
    named = {str(x) for x in sp.sympify(expected).free_symbols} | set(re.findall(r"\w+", record["statement"]))
    record["symbols"] = {str(k): v for k, v in d.parameters.items() if str(k) in named}
    return record


def _entry_key(d: Derivation, samples: _Samples, term: str, label: str, entry: sp.Expr, mine: np.ndarray) -> str:
    """A hash of everything an entry's record is computed from (module docstring)."""
    import sympy as sp

    h = hashlib.sha256((cache.harness_hash() + "\0").encode())
    text = [term, label, sp.srepr(entry), [str(a) for a in samples.args], sorted(map(str, d.parameters.items()))]
    h.update(json.dumps(text).encode() + b"\0")
    for a in (samples.q, samples.v, samples.p, mine):
        x = np.ascontiguousarray(a, dtype=float)
        h.update(f"{x.shape}".encode() + x.tobytes())
    return h.hexdigest()


def _cached(key: str, where: Path | None) -> Kept | None:
    """{"record": ...} as kept for `key` in the folder `where`, or None (not kept, or no cache)."""
    found = None if where is None else cache.load(where / f"{key[:32]}.npz", key)
    return cast(Kept, found[1]) if found is not None and "record" in found[1] else None  # as `_keep` wrote it


class Kept(TypedDict):
    """An entry's record as the cache keeps it (None: the user's numbers equal the expected entry's)."""

    record: Explanation | None


def _keep(key: str, record: Explanation | None, where: Path | None) -> None:
    if where is not None:
        cache.store(where / f"{key[:32]}.npz", key, {}, {"record": record})


_FUNCTION_OF_PART = {
    "M": "mass_matrix",
    "G": "bias",
    "Cv": "bias",
    "passive": "passive",
    "T": "kinetic_energy",
    "V": "potential_energy",
}


def _user_part(part: str, index: tuple[int, ...]) -> User:
    """user(system, q, v) for one entry of one part of a derivation (mass_matrix, bias, ...)."""

    def user(system: System, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        eq, p = system.derivation, system.params
        zero = np.zeros_like(q)
        if part == "M":
            x = eq.mass_matrix(p, q)
        elif part == "G":
            x = eq.bias(p, q, zero)
        elif part == "Cv":
            x = real_array("bias()", eq.bias(p, q, v)) - real_array("bias()", eq.bias(p, q, zero))
        elif part == "passive":
            x = eq.passive(p, q, v)
        elif part == "T":
            x = eq.kinetic_energy(p, q, v)
        else:
            x = eq.potential_energy(p, q)
        arr = real_array(f"{_FUNCTION_OF_PART[part]}()", x, (len(q), *(len(q[0]),) * len(index)))
        where: tuple[slice | int, ...] = (slice(None), *index)
        return np.asarray(arr[where])

    return user


def step_expression(system: System, quantity: tuple[Any, ...], angle_index: int = 0) -> sp.Expr | sp.Matrix:
    """The model's own expression of a derivation step's quantity (terms.engine_quantity's list), in
    the system's coordinates: a scalar, a 3-vector or a 3x3 matrix."""
    import sympy as sp

    d = derivation_of(system)
    kind, which = quantity[0], quantity[1] if len(quantity) > 1 else None
    v = sp.Matrix(d.v)
    if kind == "axis_rotation":
        expr = axis_rotation(sp.Matrix([sp.nsimplify(x) for x in (which or ())]), d.q[angle_index])
    elif which is None:
        expr = {"kinetic_energy": d.T, "potential_energy": d.V, "lagrangian": d.T - d.V}[kind]
    else:
        b = which
        mass = sp.Symbol(f"m_{b}", positive=True) if any(str(x) == f"m_{b}" for x in d.source) else 0
        trans = mass * (d.J_com[b] * v).dot(d.J_com[b] * v) / 2
        table = {
            "com_position": lambda: d.com[b],
            "com_velocity": lambda: d.J_com[b] * v,
            "origin_position": lambda: d.origin[b],
            "origin_velocity": lambda: d.J_origin[b] * v,
            "rotation": lambda: d.rotation[b],
            "angular_velocity": lambda: d.J_omega[b] * v,
            "kinetic_energy": lambda: d.T_body[b],
            "potential_energy": lambda: d.V_body[b],
            "translational_kinetic_energy": lambda: trans,
            "rotational_kinetic_energy": lambda: d.T_body[b] - trans,
            "com_speed_squared": lambda: (d.J_com[b] * v).dot(d.J_com[b] * v),
            "angular_velocity_body": lambda: d.rotation[b].T * d.J_omega[b] * v,
        }
        expr = table[kind]()
    return in_coordinates(d, tuple(system.coordinates), system.joint_map, expr)[0]


def explain(
    system: System, probe_systems: list[System], terms: list[str], *, seed: int = 0, cache: Cache | None = None
) -> list[Explanation]:
    """The disagreeing entries of a derivation's `terms` (mass matrix, gravity, ...), explained
    (`cache`: where records are kept, None for nowhere)."""
    d = derivation_of(system)
    coordinates = tuple(system.coordinates)
    u_form = system.inputs == "u" and written_form(system.equations) == "c"  # M^-1 times each force
    if u_form and terms and mass_identifiable(system):
        terms = ["mass matrix", *terms]  # not judged apart, but read back from B (d qacc / d u)^-1
    items: list[Item] = []
    for term in dict.fromkeys(terms):
        part = PARTS.get(term)
        if part is None or (u_form and part == "M" and not mass_identifiable(system)):
            continue
        expr = transformed(d, coordinates, system.joint_map, part)
        for index, label in _entries(part, system.nv, coordinates):
            entry = expr[index] if len(index) == 2 else expr[index[0]] if index else expr
            user = force_part(part, index) if u_form and part in FORCES else _user_part(part, index)
            items.append((term, label, entry, user))
    out = explain_entries(system, probe_systems, items, seed=seed, cache=cache)
    if system.inputs == "u" and written_form(system.equations) in ("b", "c") and "actuation" in terms:
        out += actuation_explanations(system, probe_systems, seed=seed)
    return out


def _fit(
    expected: sp.Expr,
    exp_num: np.ndarray,
    D: np.ndarray,
    scale: float,
    samples: _Samples,
    symbols: dict[str, list[sp.Symbol]],
) -> Explanation:
    """The simplest candidate difference that reproduces D, or why none does."""
    params = list(samples.args[2 * len(symbols["q"]) :])
    found = candidates(expected, symbols["q"], params, tuple(symbols["v"]))
    found += literal_slips(expected, params, [dict(zip(params, samples.p[0], strict=True)), samples.typed])
    if not found:
        return {"explained": False, "statement": "expected 0: yours has terms where the model has none"}
    B = samples.evaluate([c.basis for c in found])
    fit, held = samples.fit, samples.held
    tol = FIT_RTOL * scale

    def check(cols: list[int], coeffs: list[Fraction]) -> float | None:
        model = sum(float(c) * B[:, k] for k, c in zip(cols, coeffs, strict=True))
        resid = np.abs(D - model)
        return float(resid[held].max()) if resid[fit].max() <= tol and resid[held].max() <= tol else None

    usable, fitted = [], []
    for k, cand in enumerate(found):  # one slip
        b = B[fit, k]
        norm = float(b @ b)
        if norm <= (1e-12 * scale) ** 2 * len(b) or not np.isfinite(norm):
            continue
        raw = float(b @ D[fit]) / norm
        usable.append(k)
        fitted.append(abs(raw) * np.sqrt(norm) / max(float(np.linalg.norm(D[fit])), 1e-300))  # |cos| of the angle
        c = _simple(raw)
        if c is None or (cand.fixed is not None and c != cand.fixed):
            continue
        r = check([k], [c])
        if r is not None:
            return {
                "explained": True,
                "statement": _describe(cand, c),
                "difference": sp_str(c, cand.basis),
                "residual": r / scale,
            }
    best = [usable[i] for i in np.argsort(fitted)[::-1][:PAIR_POOL]]
    for i, j in itertools.combinations(sorted(best), 2):  # two slips at once
        A = B[fit][:, [i, j]]
        coef, *_ = np.linalg.lstsq(A, D[fit], rcond=None)
        simple = [_simple(float(x)) for x in coef]
        if any(x is None or x == 0 for x in simple):
            continue
        if any(found[k].fixed is not None and x != found[k].fixed for k, x in zip((i, j), simple, strict=True)):
            continue
        r = check([i, j], simple)  # type: ignore[arg-type]
        if r is not None:
            statement = "; ".join(_describe(found[k], x) for k, x in zip((i, j), simple, strict=True))  # type: ignore[arg-type]
            return {"explained": True, "statement": statement, "residual": r / scale}
    if float(np.abs(D + exp_num).max()) <= FIT_RTOL * scale:
        return {"explained": True, "statement": "yours is 0 where the model has this entry", "residual": 0.0}
    return {
        "explained": False,
        "statement": f"no simple form reproduces your numbers ({len(found)} single slips and pairs of them tried)",
    }


def sp_str(c: Fraction, basis: sp.Expr) -> str:
    import sympy as sp

    return str(sp.sstr(sp.Rational(c.numerator, c.denominator) * basis))


CHANGED_BY = {"kinetic energy": "mass matrix", "potential energy": "gravity"}  # the entries an energy's slip moves


def statement_tail(explanations: list[Explanation], *, at_model: bool) -> str:
    """ "; <entry>: <what it lacks>" that a verdict's statement ends with: the first explained entry,
    one that differs at the model's own values first (where the derivation is wrong there); a slip in
    an energy (T or V) first of all, since that is where the person made it, with the entries of M (or
    G) it changes after it. "" where nothing is explained."""
    explained = [e for e in explanations if e.get("explained")]
    seen = [e for e in explained if e.get("at_model", True) or not at_model] or explained
    energy = [e for e in seen if e.get("term") in CHANGED_BY]
    if not (energy or seen):
        return ""
    first = (energy or seen)[0]
    tail = f"; {first['entry']}: {first['statement']}"
    changed = [e["entry"] for e in explanations if energy and e.get("term") == CHANGED_BY[str(first["term"])]]
    return tail + (f"; it changes {', '.join(changed)}" if changed else "")

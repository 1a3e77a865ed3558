"""The derived equations as a person would write them: simplified, in the user's coordinates, grouped
by accelerations, velocity products and gravity, printed as text, LaTeX or Python.

Simplification without `sympy.simplify` on whole entries (minutes on a 3-joint arm): each entry is
expanded, its terms grouped by their parameter-and-velocity factor, and only the trigonometric sum
beside each factor is simplified (`trigsimp` on a few terms at a time), once per distinct sum (up to a
numeric factor), and a sum that is a constant found by sin^2 = 1 - cos^2 without `trigsimp`: 10 s for
all of the spatial arm's equations (examples/spatial_arm.xml; 64 s with `trigsimp` on every sum).
"""

from __future__ import annotations

import functools
from collections import defaultdict
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..core.arrays import Floats, JsonObject
from ..systems.scaffold import field_of
from .derivation import Derivation, Entry

if TYPE_CHECKING:  # sympy is imported when first used
    import sympy as sp


@dataclass(frozen=True)
class Equations:
    """The simplified equations of motion in named coordinates: M(q) q'' + C(q, q') q' + G(q) = tau + passive."""

    coordinates: tuple[str, ...]
    q: tuple[sp.Symbol, ...]
    v: tuple[sp.Symbol, ...]
    a: tuple[sp.Symbol, ...]
    tau: tuple[sp.Symbol, ...]
    T: sp.Expr
    V: sp.Expr
    M: sp.Matrix
    Cv: sp.Matrix
    G: sp.Matrix
    passive: sp.Matrix
    parameters: dict[str, str]  # symbol name -> model key and unit
    reads: dict[str, tuple[str, Entry, int]] = field(default_factory=dict)  # symbol name -> (key, entry, sign)
    simplified: bool = True  # False: exact as derived (printed with common subexpressions), not simplified
    rounded: int = 0  # rotation entries rounded to 0 or +-1 (symbolic/derivation.py ROTATION_ROUND)


def tidy(expr: sp.Expr, q: list[sp.Symbol]) -> sp.Expr:
    """`expr` expanded, with the trigonometric sum beside each parameter-and-velocity factor simplified."""
    import sympy as sp

    expr = sp.expand(expr)
    trig_of: dict[sp.Expr, sp.Expr] = defaultdict(lambda: sp.Integer(0))
    for term in sp.Add.make_args(expr):
        coeff, trig = term.as_independent(*q, as_Add=False)
        trig_of[trig] += coeff
    by_factor: dict[sp.Expr, sp.Expr] = defaultdict(lambda: sp.Integer(0))
    for trig, coeff in trig_of.items():
        for c in sp.Add.make_args(sp.expand(coeff)):
            number, factor = c.as_coeff_Mul()
            by_factor[factor] += number * trig
    return sp.Add(*(factor * _trigsimp(trig) for factor, trig in by_factor.items()))


def _trigsimp(trig: sp.Expr) -> sp.Expr:
    """`trigsimp(trig)`, computed once per trigonometric sum up to a numeric factor: in a spatial arm's
    equations the same sum stands beside many parameter factors (its M, C v and T: 370 sums, most
    repeated, each 0.2-0.8 s)."""
    content, primitive = trig.primitive() if trig.is_Add else (1, trig)
    if primitive.is_Add and primitive.could_extract_minus_sign():
        content, primitive = -content, -primitive
    return content * _trigsimp_primitive(primitive)


@functools.lru_cache(maxsize=4096)
def _trigsimp_primitive(trig: sp.Expr) -> sp.Expr:
    import sympy as sp

    # sin^2 = 1 - cos^2 turns a sum that is a constant into that constant at once (trigsimp: 0.5 s each);
    # any other sum is simplified as it stands (the reduced one simplifies to less readable forms)
    squares = {sp.sin(a) ** 2: 1 - sp.cos(a) ** 2 for a in {f.args[0] for f in trig.atoms(sp.sin)}}
    reduced = sp.expand(trig.xreplace(squares)) if squares else trig
    return reduced if reduced.is_number else sp.trigsimp(trig)


def in_coordinates(
    d: Derivation, coordinates: tuple[str, ...], joint_map: Floats | None, expr: sp.Expr | sp.Matrix
) -> tuple[sp.Expr | sp.Matrix, sp.Matrix]:
    """`expr` (in the derivation's joint coordinates and rates) in the named coordinates, where
    q = joint_map @ (joint coordinates); returns (expr, A^-1 as a sympy Matrix)."""
    import sympy as sp

    q = [sp.Symbol(n, real=True) for n in coordinates]
    v = [sp.Symbol(f"d{n}", real=True) for n in coordinates]
    if joint_map is None:
        Ainv = sp.eye(len(coordinates))
    else:
        inverse = np.linalg.inv(np.asarray(joint_map, dtype=float))
        Ainv = sp.Matrix([[sp.nsimplify(x, rational=True) for x in row] for row in inverse])
    qj, vj = Ainv * sp.Matrix(q), Ainv * sp.Matrix(v)
    subs = {**dict(zip(d.q, qj, strict=True)), **dict(zip(d.v, vj, strict=True))}
    return sp.sympify(expr).xreplace(subs), Ainv


def transformed(
    d: Derivation, coordinates: tuple[str, ...], joint_map: Floats | None, part: str
) -> sp.Expr | sp.Matrix:
    """One part of the derivation ("M", "Cv", "G", "passive", "T", "V") in the named coordinates,
    q = joint_map @ (joint coordinates), not simplified: forces map by A^-T, M by A^-T M A^-1."""
    expr, Ainv = in_coordinates(d, coordinates, joint_map, getattr(d, part))
    if part == "M":
        return Ainv.T * expr * Ainv
    if part in ("Cv", "G", "passive"):
        return Ainv.T * expr
    return expr


def equations(
    d: Derivation, coordinates: tuple[str, ...] | None = None, joint_map: Floats | None = None, *, simplify: bool = True
) -> Equations:
    """The derivation in the coordinates `coordinates` (default: the joints' names), where
    q = joint_map @ (joint coordinates) if a map is given; simplified unless `simplify` is False (exact
    as derived: simplifying a 6-joint arm's entries takes far longer than deriving them; stages/derived.py
    keeps the result in the cache)."""
    import sympy as sp

    names = tuple(coordinates or d.joints)
    A = None if joint_map is None else np.asarray(joint_map, dtype=float)
    q = [sp.Symbol(n, real=True) for n in names]

    def part(name: str) -> sp.Expr | sp.Matrix:
        expr = transformed(d, names, A, name)
        if not simplify:
            return expr
        return expr.applyfunc(lambda e: tidy(e, q)) if hasattr(expr, "applyfunc") else tidy(expr, q)

    out = Equations(
        coordinates=names,
        q=tuple(q),
        v=tuple(sp.Symbol(f"d{n}", real=True) for n in names),
        a=tuple(sp.Symbol(f"dd{n}", real=True) for n in names),
        tau=tuple(sp.Symbol(f"tau_{n}", real=True) for n in names),
        T=part("T"),
        V=part("V"),
        M=part("M"),
        Cv=part("Cv"),
        G=part("G"),
        passive=part("passive"),
        parameters={str(s): meaning for s, meaning in d.parameters.items()},
        reads={str(s): (key, entry, d.signs.get(s, 1)) for s, (key, entry) in d.source.items()},
        simplified=simplify,
        rounded=getattr(d, "rounded", 0),
    )
    return out


def rounding_note(e: Equations) -> list[str]:
    """The header line saying which rotation entries were rounded (none: no line)."""
    from .derivation import ROTATION_ROUND

    if not e.rounded:
        return []
    return [
        f"rotation entries within {ROTATION_ROUND:g} of 0 or +-1 rounded to them ({e.rounded}): the float noise "
        "of the model's rpy angles"
    ]


def _rows(e: Equations) -> list[sp.Eq]:
    """Lagrange's equations, one per coordinate: sum_j M_ij q''_j + (C q')_i + G_i - passive_i = tau_i."""
    import sympy as sp

    n = len(e.q)
    return [
        sp.Eq(sum((e.M[i, j] * e.a[j] for j in range(n)), sp.Integer(0)) + e.Cv[i] + e.G[i] - e.passive[i], e.tau[i])
        for i in range(n)
    ]


def _dots(e: Equations) -> dict[sp.Symbol, str]:
    """LaTeX names of the rates and accelerations: \\dot{theta}, \\ddot{theta}."""
    import sympy as sp

    return {
        **{v: rf"\dot{{{sp.latex(q)}}}" for q, v in zip(e.q, e.v, strict=True)},
        **{a: rf"\ddot{{{sp.latex(q)}}}" for q, a in zip(e.q, e.a, strict=True)},
    }


def as_text(e: Equations, fmt: str = "text") -> str:
    """The equations as plain text (sympy's notation), LaTeX, or Python (numpy) code."""
    import sympy as sp

    n = len(e.q)
    lines: list[str] = []
    if fmt == "python":
        return as_python(e)
    if fmt == "latex":
        dots = _dots(e)

        def show(x: sp.Basic) -> str:
            return str(sp.latex(x, symbol_names=dots))
    else:
        show = sp.sstr
    if not e.simplified and fmt == "text":
        return _exact_text(e)
    lines.append(f"coordinates: {', '.join(e.coordinates)} (velocities d<name>, accelerations dd<name>)")
    lines += rounding_note(e)
    lines.append(f"T = {show(e.T)}")
    lines.append(f"V = {show(e.V)}")
    for i in range(n):
        for j in range(i, n):
            lines.append(f"M[{e.coordinates[i]}, {e.coordinates[j]}] = {show(e.M[i, j])}")
    for i, c in enumerate(e.coordinates):
        lines.append(f"(C v)[{c}] = {show(e.Cv[i])}")
    for i, c in enumerate(e.coordinates):
        lines.append(f"G[{c}] = {show(e.G[i])}")
    if any(x != 0 for x in e.passive):
        for i, c in enumerate(e.coordinates):
            lines.append(f"passive[{c}] = {show(e.passive[i])}")
    lines.append("Lagrange's equations, M q'' + C q' + G - passive = tau:")
    lines.extend(f"  {show(row)}" for row in _rows(e))
    lines.append("parameters: (each symbol is the model's number read as shown; the symbols are positive)")
    lines.extend(f"  {name} = {meaning}" for name, meaning in sorted(e.parameters.items()))
    return "\n".join(lines) + "\n"


def _named_terms(e: Equations) -> list[tuple[str, sp.Expr]]:
    n = len(e.q)
    out = [("T", e.T), ("V", e.V)]
    out += [(f"M[{e.coordinates[i]}, {e.coordinates[j]}]", e.M[i, j]) for i in range(n) for j in range(i, n)]
    out += [(f"(C v)[{c}]", e.Cv[i]) for i, c in enumerate(e.coordinates)]
    out += [(f"G[{c}]", e.G[i]) for i, c in enumerate(e.coordinates)]
    return out + [(f"passive[{c}]", e.passive[i]) for i, c in enumerate(e.coordinates) if e.passive[i] != 0]


def _exact_text(e: Equations) -> str:
    """Unsimplified equations as text: their common subexpressions first (x0, x1, ...), then each term
    in them, so that a 6-joint arm's exact equations stay readable and short."""
    import sympy as sp

    named = _named_terms(e)
    shared, reduced = sp.cse([x for _, x in named], symbols=sp.numbered_symbols("x"))
    lines = [
        f"coordinates: {', '.join(e.coordinates)} (velocities d<name>, accelerations dd<name>)",
        "exact, not simplified: common subexpressions first, then the terms in them",
        *rounding_note(e),
    ]
    lines += [f"{sym} = {sp.sstr(value)}" for sym, value in shared]
    lines += [f"{name} = {sp.sstr(value)}" for (name, _), value in zip(named, reduced, strict=True)]
    lines.append("Lagrange's equations: M q'' + C q' + G - passive = tau")
    lines.append("parameters: (each symbol is the model's number read as shown; the symbols are positive)")
    lines.extend(f"  {name} = {meaning}" for name, meaning in sorted(e.parameters.items()))
    return "\n".join(lines) + "\n"


def as_data(e: Equations) -> JsonObject:
    """The equations as strings for the results: plain text and LaTeX of each term."""
    import sympy as sp

    n = len(e.q)

    dots = _dots(e)

    def both(x: sp.Expr) -> JsonObject:
        return {"text": sp.sstr(x), "latex": sp.latex(x, symbol_names=dots)}

    return {
        "coordinates": list(e.coordinates),
        "T": both(e.T),
        "V": both(e.V),
        "M": [[both(e.M[i, j]) for j in range(n)] for i in range(n)],
        "Cv": [both(e.Cv[i]) for i in range(n)],
        "G": [both(e.G[i]) for i in range(n)],
        "passive": [both(e.passive[i]) for i in range(n)],
        "parameters": dict(sorted(e.parameters.items())),
    }


PYTHON_HEADER = """\
# The model's equations of motion, derived symbolically by `lagrange-xval derive --python`: the
# dynamics (form a) and the energies of the equations module `lagrange-xval new` writes for the same
# model (and the same --lock). Each parameter is a field of that module's Params, p (the derivation's
# symbols are positive: a negative number's sign is written where it is bound); q and v are
# (..., {n}) arrays of the coordinates ({coordinates}) and their rates.
import numpy as np
from lagrange_xval.forms import stack_matrix, stack_vector
"""

# (function, arguments, docstring, the Equations terms it returns, shape after the batch axes)
_FUNCTIONS = (
    ("mass_matrix", "p, q", "M(q), (..., n, n).", ("M",), "(n, n)"),
    ("bias", "p, q, v", "C(q, v) v + G(q), (..., n).", ("Cv", "G"), "(n,)"),
    ("passive", "p, q, v", "The joints' damping and spring forces, (..., n).", ("passive",), "(n,)"),
    ("kinetic_energy", "p, q, v", "T(q, v), (...).", ("T",), "()"),
    ("potential_energy", "p, q", "V(q), (...).", ("V",), "()"),
)


def _local_names(e: Equations) -> dict[sp.Symbol, sp.Symbol]:
    """Python-safe local names for the coordinates and rates: a joint's name may not be an identifier,
    and must not shadow an argument, the imports or a parameter."""
    import re

    import sympy as sp

    taken = {"p", "q", "v", "np", "stack_matrix", "stack_vector", *e.reads}  # and names starting cse_ (below)
    out: dict[sp.Symbol, sp.Symbol] = {}
    for sym in (*e.q, *e.v):
        name = re.sub(r"\W", "_", str(sym))
        name = name if name.isidentifier() and not name.startswith("cse_") else f"_{name}"
        while name in taken:
            name += "_"
        taken.add(name)
        out[sym] = sp.Symbol(name, real=True)
    return out


def _function(
    e: Equations, spec: tuple[str, str, str, tuple[str, ...], str], names: dict[sp.Symbol, sp.Symbol]
) -> list[str]:
    """One function of the generated module: bind what its expression uses, return the expression."""
    import sympy as sp

    fn, args, doc, terms, shape = spec
    n = len(e.q)
    value = getattr(e, terms[0])
    for extra in terms[1:]:
        value = value + getattr(e, extra)
    exprs = [value] if shape == "()" else list(value)
    exprs = [sp.sympify(x).xreplace(names) for x in exprs]
    used = set().union(*(x.free_symbols for x in exprs))
    printer = sp.printing.numpy.NumPyPrinter({"fully_qualified_modules": True})

    def code(x: sp.Expr) -> str:

        return str(printer.doprint(x)).replace("numpy.", "np.")

    out = ["", "", f"def {fn}({args}):", f'    """{doc}"""']
    for i, sym in enumerate(e.q):
        out += [f"    {names[sym]} = q[..., {i}]"] if names[sym] in used else []
    for i, sym in enumerate(e.v):
        out += [f"    {names[sym]} = v[..., {i}]"] if names[sym] in used and "v" in args else []
    for name in sorted(str(s) for s in used if str(s) in e.reads):
        key, entry, sign = e.reads[name]
        out.append(f"    {name} = {'-' if sign < 0 else ''}p.{field_of(key, entry)}")
    # common subexpressions first, each computed once (a 7-joint arm's expanded entries ran to 96 MB)
    shared, exprs = sp.cse(exprs, symbols=sp.numbered_symbols("cse_"), order="none")
    out += [f"    {sym} = {code(value)}" for sym, value in shared]
    if shape == "(n, n)":
        rows = ("[" + ", ".join(code(exprs[i * n + j]) for j in range(n)) + "]" for i in range(n))
        body = "stack_matrix([" + ", ".join(rows) + "])"
    else:
        body = "stack_vector([" + ", ".join(map(code, exprs)) + "])" if shape == "(n,)" else code(exprs[0])
    batch = {"(n, n)": f"q.shape[:-1] + ({n}, {n})", "(n,)": "q.shape", "()": "q.shape[:-1]"}[shape]
    moving = {names[s] for s in (*e.q, *e.v)} & used  # else a constant: given the batch's shape
    return [*out, f"    return {body}" + ("" if moving else f" + np.zeros({batch})")]


def as_python(e: Equations) -> str:
    """The equations as importable Python: form (a) (mass_matrix, bias, passive) and the energies, in
    the Params fields of the module `lagrange-xval new` writes (systems/scaffold.field_of)."""
    n = len(e.q)
    lines = [PYTHON_HEADER.format(n=n, coordinates=", ".join(e.coordinates)).rstrip("\n")]
    lines[1:1] = [f"# {line}" for line in rounding_note(e)]  # after the header's first line
    names = _local_names(e)
    for spec in _FUNCTIONS:
        lines += _function(e, spec, names)
    lines += ["", "", "# parameters (the derivation's symbols, where each is read):"]
    lines += [f"#   {name} = {meaning}" for name, meaning in sorted(e.parameters.items())]
    return "\n".join(lines) + "\n"

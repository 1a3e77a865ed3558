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
from dataclasses import dataclass
from typing import Any

import numpy as np

from .derivation import Derivation


@dataclass(frozen=True)
class Equations:
    """The simplified equations of motion in named coordinates: M(q) q'' + C(q, q') q' + G(q) = tau + passive."""

    coordinates: tuple[str, ...]
    q: tuple[Any, ...]
    v: tuple[Any, ...]
    a: tuple[Any, ...]
    tau: tuple[Any, ...]
    T: Any
    V: Any
    M: Any  # sympy Matrix
    Cv: Any
    G: Any
    passive: Any
    parameters: dict[str, str]  # symbol name -> model key and unit


def tidy(expr: Any, q: list[Any]) -> Any:
    """`expr` expanded, with the trigonometric sum beside each parameter-and-velocity factor simplified."""
    import sympy as sp

    expr = sp.expand(expr)
    trig_of: dict[Any, Any] = defaultdict(lambda: sp.Integer(0))
    for term in sp.Add.make_args(expr):
        coeff, trig = term.as_independent(*q, as_Add=False)
        trig_of[trig] += coeff
    by_factor: dict[Any, Any] = defaultdict(lambda: sp.Integer(0))
    for trig, coeff in trig_of.items():
        for c in sp.Add.make_args(sp.expand(coeff)):
            number, factor = c.as_coeff_Mul()
            by_factor[factor] += number * trig
    return sp.Add(*(factor * _trigsimp(trig) for factor, trig in by_factor.items()))


def _trigsimp(trig: Any) -> Any:
    """`trigsimp(trig)`, computed once per trigonometric sum up to a numeric factor: in a spatial arm's
    equations the same sum stands beside many parameter factors (its M, C v and T: 370 sums, most
    repeated, each 0.2-0.8 s)."""
    content, primitive = trig.primitive() if trig.is_Add else (1, trig)
    if primitive.is_Add and primitive.could_extract_minus_sign():
        content, primitive = -content, -primitive
    return content * _trigsimp_primitive(primitive)


@functools.lru_cache(maxsize=4096)
def _trigsimp_primitive(trig: Any) -> Any:
    import sympy as sp

    # sin^2 = 1 - cos^2 turns a sum that is a constant into that constant at once (trigsimp: 0.5 s each);
    # any other sum is simplified as it stands (the reduced one simplifies to less readable forms)
    squares = {sp.sin(a) ** 2: 1 - sp.cos(a) ** 2 for a in {f.args[0] for f in trig.atoms(sp.sin)}}
    reduced = sp.expand(trig.xreplace(squares)) if squares else trig
    return reduced if reduced.is_number else sp.trigsimp(trig)


def in_coordinates(d: Derivation, coordinates: tuple[str, ...], joint_map: Any, expr: Any) -> Any:
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


def transformed(d: Derivation, coordinates: tuple[str, ...], joint_map: Any, part: str) -> Any:
    """One part of the derivation ("M", "Cv", "G", "passive", "T", "V") in the named coordinates,
    q = joint_map @ (joint coordinates), not simplified: forces map by A^-T, M by A^-T M A^-1."""
    expr, Ainv = in_coordinates(d, coordinates, joint_map, getattr(d, part))
    if part == "M":
        return Ainv.T * expr * Ainv
    if part in ("Cv", "G", "passive"):
        return Ainv.T * expr
    return expr


def equations(d: Derivation, coordinates: tuple[str, ...] | None = None, joint_map: Any = None) -> Equations:
    """The derivation in the coordinates `coordinates` (default: the joints' names), where
    q = joint_map @ (joint coordinates) if a map is given; simplified (checks/derived.py keeps the
    result in the cache)."""
    import sympy as sp

    names = tuple(coordinates or d.joints)
    A = None if joint_map is None else np.asarray(joint_map, dtype=float)
    q = [sp.Symbol(n, real=True) for n in names]

    def part(name: str) -> Any:
        expr = transformed(d, names, A, name)
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
    )
    return out


def _rows(e: Equations) -> list[Any]:
    """Lagrange's equations, one per coordinate: sum_j M_ij q''_j + (C q')_i + G_i - passive_i = tau_i."""
    import sympy as sp

    n = len(e.q)
    return [
        sp.Eq(sum((e.M[i, j] * e.a[j] for j in range(n)), sp.Integer(0)) + e.Cv[i] + e.G[i] - e.passive[i], e.tau[i])
        for i in range(n)
    ]


def _dots(e: Equations) -> dict[Any, str]:
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
        printer = sp.printing.numpy.NumPyPrinter({"fully_qualified_modules": False})
        lines.append(f"# coordinates q = ({', '.join(e.coordinates)}), velocities d<name>; numpy as np")
        lines.append(f"T = {printer.doprint(e.T)}")
        lines.append(f"V = {printer.doprint(e.V)}")
        rows = ", ".join("[" + ", ".join(printer.doprint(e.M[i, j]) for j in range(n)) + "]" for i in range(n))
        lines.append(f"M = np.array([{rows}])")
        for name in ("Cv", "G", "passive"):
            vec = getattr(e, name)
            lines.append(f"{name} = np.array([{', '.join(printer.doprint(vec[i]) for i in range(n))}])")
        return "\n".join(lines) + "\n"
    if fmt == "latex":
        dots = _dots(e)

        def show(x: Any) -> str:
            return str(sp.latex(x, symbol_names=dots))
    else:
        show = sp.sstr
    lines.append(f"coordinates: {', '.join(e.coordinates)} (velocities d<name>, accelerations dd<name>)")
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
    lines.append("parameters:")
    lines.extend(f"  {name}: {meaning}" for name, meaning in sorted(e.parameters.items()))
    return "\n".join(lines) + "\n"


def as_data(e: Equations) -> dict[str, Any]:
    """The equations as strings for the results: plain text and LaTeX of each term."""
    import sympy as sp

    n = len(e.q)

    dots = _dots(e)

    def both(x: Any) -> dict[str, str]:
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

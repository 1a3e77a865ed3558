"""The diagnosis in the person's words, and the model numbers a derivation assumes without saying so.

The model's own equations (symbolic/derivation.py) name each model number by where it is
(`c_pole` for body/pole/com[2], `m_link2`); a person names it as their `parameters()` reads it (`l`
with l = 2 * com[2], `m2`). `person_names` maps the first to the second through the numbers that
`parameters()` reads (validate/handwritten/reads.py), and `in_person_words` rewrites a statement with it,
the model's name beside each.

`unread_numbers` finds what a failing term depends on (the symbols of its part of the model's own
equations) that `parameters()` does not read: a probe
moves only the numbers a derivation reads, so a formula that bakes one in (a uniform rod's
m l^2 / 12) fails at a probe and agrees at the model's own values. That is then said as a possible
unstated assumption, with how to state it.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

import numpy as np

from ..handwritten.reads import knobs, numeric_fields
from ..sources.symbolic import derivation_of
from ..symbolic.derivation import Derivation, parameter_values
from ..systems import System

if TYPE_CHECKING:  # sympy is imported when first used
    import sympy as sp

# The parts of the model's own equations a term of a derivation is made of (explicit accelerations
# carry M^-1 in each term).
TERM_PARTS = {
    "mass matrix": ("M",),
    "gravity": ("G", "M"),
    "velocity": ("Cv", "M"),
    "friction": ("passive", "M"),
    "actuation": ("M",),
    "acceleration": ("M", "G", "Cv", "passive"),
    "kinetic energy": ("T",),
    "potential energy": ("V",),
}


def _label(key: str, entry: int | tuple[int, int] | str | None) -> str:
    if entry is None:
        return key
    if isinstance(entry, tuple):
        i, j = sorted(entry)
        return f"{key}[{i}][{j}]"
    return f"{key}[{entry}]"


def person_names(system: System) -> dict[str, str]:
    """{symbol of the model's equations: the person's expression for it}, e.g. {"c_pole": "l/2"}, for
    every symbol whose number one field of the person's Params follows."""
    knob_list = knobs(system.derivation.parameters, system.view)
    by_label = {k.label: k for k in knob_list if len(k.fields) == 1}
    derivation = derivation_of(system)
    out = {}
    for sym, (key, entry) in derivation.source.items():
        knob = by_label.get(_label(key, entry))
        if knob is None:
            continue
        gain = knob.gains[0]
        sign = "" if np.sign(knob.value) * np.sign(gain) > 0 else "-"
        size = abs(gain)
        out[str(sym)] = sign + knob.fields[0] + ("" if abs(size - 1.0) < 1e-9 else f"/{size:.6g}")
    return out


def in_person_words(text: str, names: dict[str, str], model_names: dict[str, str] | None = None) -> str:
    """`text` with each model symbol replaced by the person's name for it, and the model's names beside
    (" [l/2 = c_pole: body/pole/com[2]]")."""
    used = []

    def swap(match: re.Match[str]) -> str:
        sym = match.group(0)
        if sym not in names:
            return sym
        used.append(sym)
        mine = names[sym]
        return f"({mine})" if not re.fullmatch(r"\w+", mine) else mine

    out = re.sub(r"\b[A-Za-z_]\w*\b", swap, text)
    if not used:
        return text
    where = model_names or {}
    legend = ", ".join(f"{names[s]} = {s}" + (f" ({where[s]})" if s in where else "") for s in dict.fromkeys(used))
    return f"{out} [your names: {legend}]"


def model_symbol_keys(system: System) -> dict[str, str]:
    """{symbol of the model's equations: the model number it stands for, with its sign as `derive` prints
    it}: the symbols are positive, so a negative number's symbol reads "-body/link2/com[1]"."""
    derivation = derivation_of(system)
    signs = derivation.signs
    return {str(s): ("-" if signs.get(s, 1) < 0 else "") + _label(k, e) for s, (k, e) in derivation.source.items()}


def unread_numbers(system: System, term: str) -> list[str]:
    """The model numbers `term` depends on (the free symbols of its part of the model's own equations)
    that parameters() does not read, as labels like body/pole/inertia[1][1]; only those whose doubling
    moves the term by more than MATTERS of its size at random states (a point mass's 1e-14 inertia does
    not)."""
    parts = TERM_PARTS.get(term)
    if parts is None:
        return []
    derivation = derivation_of(system)
    exprs = [x for part in parts for x in _entries(getattr(derivation, part))]
    used: set[sp.Symbol] = set().union(*(x.free_symbols for x in exprs)) if exprs else set()
    read = {k.label for k in knobs(system.derivation.parameters, system.view)}
    unread = [s for s in derivation.source if s in used and _label(*derivation.source[s]) not in read]
    values = parameter_values(derivation, system.view)
    found = [s for s in unread if not _label(*derivation.source[s]).startswith("gravity")]
    return sorted(_label(*derivation.source[s]) for s in found if _matters(derivation, exprs, values, s))


MATTERS = 1e-9  # relative change of a term when one number doubles: below it, the number does not matter


def _entries(x: sp.Expr | sp.Matrix) -> list[sp.Expr]:
    return list(x) if hasattr(x, "shape") else [x]


def _matters(
    derivation: Derivation, exprs: list[sp.Expr], values: dict[sp.Symbol, float], sym: sp.Symbol, n_states: int = 8
) -> bool:
    """Whether doubling the number `sym` stands for moves the expressions by more than MATTERS of their size."""
    import sympy as sp

    syms = list(values)
    f = sp.lambdify([*derivation.q, *derivation.v, *syms], exprs, modules="numpy")
    rng = np.random.default_rng(0)
    x = rng.uniform(-np.pi, np.pi, (len(derivation.q) + len(derivation.v), n_states))
    base = [values[s] for s in syms]
    moved = [2.0 * values[s] if s == sym else values[s] for s in syms]
    a = np.array([np.broadcast_to(e, (n_states,)) for e in f(*x, *base)], dtype=float)
    b = np.array([np.broadcast_to(e, (n_states,)) for e in f(*x, *moved)], dtype=float)
    return bool(np.abs(b - a).max() > MATTERS * max(float(np.abs(a).max()), 1e-300))


def assumption_hint(labels: list[str], term: str) -> str:
    """The sentence that says what may be an unstated assumption and how to state it."""
    if not labels:
        return ""
    shown = ", ".join(labels[:4]) + (f" and {len(labels) - 4} more" if len(labels) > 4 else "")
    key = labels[0].split("[")[0]
    return (
        f"this may be an unstated assumption: parameters() does not read {shown}, which the {term} depends on "
        f"(a probe moves only what parameters() reads); if your formulas assume it (a uniform rod's m l^2/12, "
        f'a centre of mass at l/2), state it in assumptions(p), e.g. {{"{key}": ...}} with NaN for the '
        "entries they do not fix"
    )


def typed_numbers(system: System) -> dict[str, float]:
    """{field: value} of the numbers parameters() returns without reading them from the model (g = 9.81,
    a length typed in): no model number moves them, so no probe can, and nothing checks them against
    the model. Zero fields are left out (an offset of 0 is rarely a number read wrong)."""
    base = numeric_fields(system.params)
    followed = {f for k in knobs(system.derivation.parameters, system.view) for f in k.fields}
    return {f: v for f, v in base.items() if f not in followed and v != 0.0}


def typed_note(typed: dict[str, float]) -> str:
    """The clause a verdict adds, pass or FAIL, for the numbers typed into parameters()."""
    if not typed:
        return ""
    shown = ", ".join(f"{f} = {v:.6g}" for f, v in list(typed.items())[:6]) + (" ..." if len(typed) > 6 else "")
    return (
        f"parameters() does not read {shown} from the model (typed in: no probe moves "
        f"{'it' if len(typed) == 1 else 'them'}, so nothing checks {'it' if len(typed) == 1 else 'them'} "
        "against the model's numbers)"
    )


NOT_LOOKED_FOR = "mistakes the model's own values hide were not looked for"
NOTHING_TO_PROBE = "its numbers are written inside it (it reads none from the model)"
REASON_CHARS = 160  # the first reason a probe could not be built, cut to one readable clause


def unbuilt_probes(built: int, asked: int, problems: list[str]) -> str:
    """What a verdict reached without some of its probes means, or "" (every probe asked for was built,
    or none was asked for and none tried). A verdict at the model's own numbers alone cannot see a
    mistake those numbers hide (l1 l2 for l2^2 at l1 = l2): the line says so, with the first reason."""
    missing = max(asked - built, len(problems) if built == 0 else 0)
    if missing <= 0:
        return ""
    reason = problems[0] if problems else ""
    reason = reason if len(reason) <= REASON_CHARS else reason[: REASON_CHARS - 3].rstrip() + "..."
    why = f" ({reason})" if reason else ""
    if reason == NOTHING_TO_PROBE:
        return f"no probe could be built: {reason}, so {NOT_LOOKED_FOR}"
    if built == 0:
        return f"none of the {max(asked, missing)} probe(s) could be built, so {NOT_LOOKED_FOR}{why}"
    return (
        f"{missing} of {asked} probe(s) could not be built, so {NOT_LOOKED_FOR} at those: they were looked for "
        f"at {built} parameter set(s){why}"
    )

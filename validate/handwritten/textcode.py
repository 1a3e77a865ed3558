"""The text form's energies as the source of a small numpy module, run in a worker like a person's module.

The expressions are read in this process (handwritten/expression.py: bounded, nothing evaluated) and
compiled by sympy's lambdify; its source, with the numpy names it uses imported by name, becomes a
module of `kinetic_energy`, `potential_energy` and (with friction) `passive`. The module is imported and
called in a worker process (validate/handwritten/worker.py) within the system's time limit: evaluating the
person's expressions (numbers or traced values) never runs in the judge's process.
"""

from __future__ import annotations

import inspect
import math
from types import FunctionType

from ..core.errors import HarnessError

HEADER = '"""The energies of a text form, written by lagrange-xval from its expressions."""\n\nimport numpy\n'
ENERGY = """

def {name}(p, {vars}):
    zero = numpy.zeros({shape})
    return _{name}({args})[0] + zero
"""
PASSIVE = """

def passive(p, q, v):
    zero = numpy.zeros(numpy.broadcast_shapes(numpy.shape(q), numpy.shape(v))[:-1])
    rows = _passive({args})
    return numpy.stack([numpy.asarray(r + zero) for r in rows], axis=-1)
"""


def _imports(fn: FunctionType) -> list[str]:
    """The lines that bind every global name lambdify's code of `fn` reads: numpy's names by name, its
    constants (pi) as numbers; anything else is the harness's error, never guessed."""
    import builtins

    import numpy

    code = fn.__code__
    names = set(code.co_names)
    lines = []
    for name in sorted(names):
        if name not in fn.__globals__ or name == "numpy":
            continue
        value = fn.__globals__[name]
        if getattr(numpy, name, None) is value:
            lines.append(f"from numpy import {name}")
        elif isinstance(value, float) and math.isfinite(value):
            lines.append(f"{name} = {value!r}")
        elif not hasattr(builtins, name):
            raise HarnessError(f"the text form's code reads {name!r}, which is not numpy's")
    return lines


def _function(fn: FunctionType, name: str) -> tuple[list[str], str]:
    """(imports, source) of lambdify's `fn` as a function called `name`."""
    text = inspect.getsource(fn)
    head, _, rest = text.partition("(")
    if not head.startswith("def "):
        raise HarnessError("the text form's code is not a function")
    return _imports(fn), f"\n\ndef {name}({rest}"


def columns(fields: list[str], groups: list[tuple[str, int]]) -> str:
    """The call's arguments: every field of p, then each of `groups` (name, count) by column."""
    return ", ".join([*(f"p.{f}" for f in fields), *(f"{g}[..., {i}]" for g, n in groups for i in range(n))])


def module_source(
    fields: list[str],
    n: int,
    kinetic: FunctionType,
    potential: FunctionType,
    friction: FunctionType | None,
) -> str:
    """The module's source: lambdify's functions (`_kinetic_energy`, ...) and the contract's around them."""
    parts = [("_kinetic_energy", kinetic), ("_potential_energy", potential)]
    if friction is not None:
        parts.append(("_passive", friction))
    imports: set[str] = set()
    bodies = []
    for name, fn in parts:
        lines, body = _function(fn, name)
        imports.update(lines)
        bodies.append(body)
    qv = columns(fields, [("q", n), ("v", n)])
    text = HEADER + "".join(f"{x}\n" for x in sorted(imports))
    text += "".join(bodies)
    both = "numpy.broadcast_shapes(numpy.shape(q), numpy.shape(v))[:-1]"
    text += ENERGY.format(name="kinetic_energy", vars="q, v", shape=both, args=qv)
    q = columns(fields, [("q", n)])
    text += ENERGY.format(name="potential_energy", vars="q", shape="numpy.shape(q)[:-1]", args=q)
    if friction is not None:
        text += PASSIVE.format(args=qv)
    return text

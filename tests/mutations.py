"""A catalogue of realistic single mistakes in the hand derivations of equations/<system>.py.

Each `Mutation` is one exact source-text substitution in one equations module, the kind of slip a
person makes deriving the equations by hand (as the lecture notes do): a wrong subscript, a lost
length or factor 2, a sign, sin for cos, a dropped term, a wrong key read from the model. Its
`terms` say which terms of the equations the mistake changes, and `hidden` whether the mistake
is invisible at the repository model's own parameters (m1 = m2, l1 = l2, c1 = c2, I1 = I2, equal
damping, unit lengths). tests/unit/verdict/test_mutation_catalogue.py establishes both, independently of the
harness's verdict code.

Term vocabulary (what `term_values` computes; "parameters" is what parameters() returns):
"mass matrix", "gravity", "velocity", "friction", "actuation", "kinetic energy", "potential energy",
"body positions", "body rotations", "parameters".

Every module computes T = v^T M v / 2 from mass_matrix, so a mass-matrix mistake also changes the
kinetic energy: such mutations list both. gravity (the bias at v = 0) and potential_energy are
written separately in every module, so a mistake in one does not show in the other.

This is a library used by tests, not a test module (pytest collects test_*.py only).
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import itertools
import sys
import types
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

PACKAGE = "lagrange_xval.equations"

TERMS = frozenset(
    {
        "mass matrix",
        "gravity",
        "velocity",
        "friction",
        "actuation",
        "kinetic energy",
        "potential energy",
        "body positions",
        "body rotations",
        "parameters",
    }
)

# The kinds of mistake the catalogue must cover (Mutation.kinds draws from these).
KINDS = frozenset(
    {
        "l1*l2 for l2^2",
        "wrong mass",
        "lost length",
        "c1/c2 swapped",
        "I1/I2 swapped",
        "damping swapped",
        "coriolis sign",
        "lost 2 in M cos term",
        "M singular or indefinite",
        "friction sign",
        "missing term",
        "sin for cos",
        "gravity sign",
        "energy only",
        "body positions only",
        "wrong key hidden by equal values",
    }
)

# The hand-derivation functions of the contract (equations/__init__.py); VARIANTS are the notes' prints.
HAND_FUNCTIONS = frozenset(
    {
        "parameters",
        "mass_matrix",
        "gravity",
        "bias",
        "passive",
        "kinetic_energy",
        "potential_energy",
        "body_positions",
        "body_rotations",
    }
)

MK = frozenset({"mass matrix", "kinetic energy"})


@dataclass(frozen=True)
class Mutation:
    system: str  # stem of equations/<system>.py
    name: str  # short id
    old: str  # exact source text, occurring exactly once in the module
    new: str  # its replacement
    terms: frozenset[str]  # the terms the mistake changes (at generic parameters)
    hidden: bool  # True if invisible at the repository model's own parameters
    kinds: frozenset[str] = field(default=frozenset())  # which KINDS of mistake it is


def _m(system: str, name: str, old: str, new: str, terms: set[str], hidden: bool, *kinds: str) -> Mutation:
    return Mutation(system, name, old, new, frozenset(terms), hidden, frozenset(kinds))


_SIMPLE = (
    _m(
        "simple_pendulum",
        "g sin th without l in G",
        "g = p.m * p.g * p.l * np.sin(q[..., 0])",
        "g = p.m * p.g * np.sin(q[..., 0])",
        {"gravity"},
        True,
        "lost length",
    ),
    _m(
        "simple_pendulum",
        "m l for m l^2 in M",
        "[[p.m * p.l**2 + p.I + np.zeros",
        "[[p.m * p.l + p.I + np.zeros",
        MK,
        True,
        "lost length",
    ),
    _m(
        "simple_pendulum",
        "G = -m g l sin th",
        "g = p.m * p.g * p.l * np.sin(q[..., 0])",
        "g = -p.m * p.g * p.l * np.sin(q[..., 0])",
        {"gravity"},
        False,
        "gravity sign",
    ),
    _m(
        "simple_pendulum",
        "cos for sin in G",
        "g = p.m * p.g * p.l * np.sin(q[..., 0])",
        "g = p.m * p.g * p.l * np.cos(q[..., 0])",
        {"gravity"},
        False,
        "sin for cos",
    ),
    _m(
        "simple_pendulum",
        "V = +m g l cos th",
        "return -p.m * p.g * p.l * np.cos(q[..., 0])",
        "return p.m * p.g * p.l * np.cos(q[..., 0])",
        {"potential energy"},
        False,
        "energy only",
        "gravity sign",
    ),
    _m(
        "simple_pendulum",
        "T without 1/2",
        'return 0.5 * np.einsum("...i,...ij,...j->...", v, mass_matrix(p, q), v)',
        'return np.einsum("...i,...ij,...j->...", v, mass_matrix(p, q), v)',
        {"kinetic energy"},
        False,
        "energy only",
    ),
    _m(
        "simple_pendulum",
        "bob at +l cos th (y down)",
        "stack_vector([p.l * np.sin(th), -p.l * np.cos(th), np.zeros_like(th)])",
        "stack_vector([p.l * np.sin(th), p.l * np.cos(th), np.zeros_like(th)])",
        {"body positions"},
        False,
        "body positions only",
    ),
    _m(
        "simple_pendulum",
        "frame turned by -theta",
        '{"link": rot_z(q[..., 0])}',
        '{"link": rot_z(-q[..., 0])}',
        {"body rotations"},
        False,
    ),
    _m(
        "simple_pendulum",
        "I read as Ixx",
        'I=model["body/link/inertia"][2, 2]',
        'I=model["body/link/inertia"][0, 0]',
        # I is 1e-14: the wrong value changes M and T by ~1e-14 relative, below any tolerance.
        {"parameters"},
        True,
        "wrong key hidden by equal values",
    ),
    _m(
        "simple_pendulum",
        "l read as com y (sign lost)",
        'l=-model["body/link/com"][1]',
        'l=model["body/link/com"][1]',
        # l < 0: M has l^2 and stays right; G, V and the bob's position flip.
        {"parameters", "gravity", "potential energy", "body positions"},
        False,
    ),
)

_POINT = (
    _m(
        "double_pendulum_point",
        "l1*l2 for l2^2 in M12",
        "m12 = p.m2 * (p.l2**2 + p.l1 * p.l2 * c)",
        "m12 = p.m2 * (p.l1 * p.l2 + p.l1 * p.l2 * c)",
        MK,
        True,
        "l1*l2 for l2^2",
    ),
    _m(
        "double_pendulum_point",
        "lost 2 in M11 cos term",
        "p.m2 * (p.l1**2 + p.l2**2 + 2 * p.l1 * p.l2 * c)",
        "p.m2 * (p.l1**2 + p.l2**2 + p.l1 * p.l2 * c)",
        # det M = m2 l2^2 (m1 l1^2 + m2 l1^2 sin^2 ph - m2 l1 l2 cos ph): at m1 l1 = m2 l2 (the
        # repository's model) M is singular at ph = 0; where m2 l2 > m1 l1 it is indefinite there.
        MK,
        False,
        "lost 2 in M cos term",
        "M singular or indefinite",
    ),
    _m(
        "double_pendulum_point",
        "M11 cos term with minus (cosine rule)",
        "p.m2 * (p.l1**2 + p.l2**2 + 2 * p.l1 * p.l2 * c)",
        "p.m2 * (p.l1**2 + p.l2**2 - 2 * p.l1 * p.l2 * c)",
        MK,
        False,
        "M singular or indefinite",
    ),
    _m(
        "double_pendulum_point",
        "m1 for m2 in M22",
        "[m12, p.m2 * p.l2**2 + p.I2]",
        "[m12, p.m1 * p.l2**2 + p.I2]",
        MK,
        True,
        "wrong mass",
    ),
    _m(
        "double_pendulum_point",
        "Coriolis sign in row 1",
        "[-h * (2 * w1 * w2 + w2**2), h * w1**2]",
        "[h * (2 * w1 * w2 + w2**2), h * w1**2]",
        {"velocity"},
        False,
        "coriolis sign",
    ),
    _m(
        "double_pendulum_point",
        "centrifugal phi'^2 dropped in row 1",
        "[-h * (2 * w1 * w2 + w2**2), h * w1**2]",
        "[-h * 2 * w1 * w2, h * w1**2]",
        {"velocity"},
        False,
        "missing term",
    ),
    _m(
        "double_pendulum_point",
        "g sin(th+ph) without l2 in G2",
        "p.m2 * p.g * p.l2 * s12])",
        "p.m2 * p.g * s12])",
        {"gravity"},
        True,
        "lost length",
    ),
    _m(
        "double_pendulum_point",
        "V of bob 2 with cos ph",
        "- p.m2 * p.g * p.l2 * np.cos(th + ph)",
        "- p.m2 * p.g * p.l2 * np.cos(ph)",
        {"potential energy"},
        False,
        "energy only",
    ),
    _m(
        "double_pendulum_point",
        "bob 2 at relative angle ph",
        "stack_vector([p.l2 * np.sin(th + ph), -p.l2 * np.cos(th + ph), zero])",
        "stack_vector([p.l2 * np.sin(ph), -p.l2 * np.cos(ph), zero])",
        {"body positions"},
        False,
        "body positions only",
    ),
    _m(
        "double_pendulum_point",
        "m2 read from link1",
        'm2=model["body/link2/mass"]',
        'm2=model["body/link1/mass"]',
        {"parameters", "mass matrix", "kinetic energy", "gravity", "velocity", "potential energy"},
        True,
        "wrong key hidden by equal values",
        "wrong mass",
    ),
)

_ABSOLUTE = (
    _m(
        "double_pendulum_absolute",
        "l1*l2 for l2^2 in M22",
        "[m12, p.m2 * p.l2**2 + p.I2 + 0 * c]",
        "[m12, p.m2 * p.l1 * p.l2 + p.I2 + 0 * c]",
        MK,
        True,
        "l1*l2 for l2^2",
    ),
    _m(
        "double_pendulum_absolute",
        "m1 for m1 + m2 in M11",
        "[[(p.m1 + p.m2) * p.l1**2 + p.I1",
        "[[p.m1 * p.l1**2 + p.I1",
        # det M = m2 l1^2 l2^2 (m1 - m2 cos^2(th1 - th2)): singular at th1 = th2 when m1 = m2.
        MK,
        False,
        "wrong mass",
        "M singular or indefinite",
    ),
    _m(
        "double_pendulum_absolute",
        "m1 - m2 in M11",
        "[[(p.m1 + p.m2) * p.l1**2 + p.I1",
        "[[(p.m1 - p.m2) * p.l1**2 + p.I1",
        MK,
        False,
        "M singular or indefinite",
    ),
    _m(
        "double_pendulum_absolute",
        "sin for cos in M12",
        "c = np.cos(q[..., 0] - q[..., 1])",
        "c = np.sin(q[..., 0] - q[..., 1])",
        MK,
        False,
        "sin for cos",
    ),
    _m(
        "double_pendulum_absolute",
        "centrifugal sign in row 2",
        "[h * v[..., 1] ** 2, -h * v[..., 0] ** 2]",
        "[h * v[..., 1] ** 2, h * v[..., 0] ** 2]",
        {"velocity"},
        False,
        "coriolis sign",
    ),
    _m(
        "double_pendulum_absolute",
        "gravity sign in G2",
        "p.m2 * p.g * p.l2 * np.sin(q[..., 1])])",
        "-p.m2 * p.g * p.l2 * np.sin(q[..., 1])])",
        {"gravity"},
        False,
        "gravity sign",
    ),
    _m(
        "double_pendulum_absolute",
        "g sin th1 without l1 in G1",
        "(p.m1 + p.m2) * p.g * p.l1 * np.sin(q[..., 0])",
        "(p.m1 + p.m2) * p.g * np.sin(q[..., 0])",
        {"gravity"},
        True,
        "lost length",
    ),
    _m(
        "double_pendulum_absolute",
        "l1 for l2 in V of bob 2",
        "- p.m2 * p.g * p.l2 * np.cos(q[..., 1])",
        "- p.m2 * p.g * p.l1 * np.cos(q[..., 1])",
        {"potential energy"},
        True,
        "energy only",
    ),
    _m(
        "double_pendulum_absolute",
        "link2 frame by th1 + th2",
        '"link2": rot_z(q[..., 1])',
        '"link2": rot_z(q[..., 0] + q[..., 1])',
        {"body rotations"},
        False,
    ),
    _m(
        "double_pendulum_absolute",
        "m1 read from link2",
        'm1=model["body/link1/mass"]',
        'm1=model["body/link2/mass"]',
        # m1 is not in h = m2 l1 l2 sin(th1 - th2): the velocity terms stay right.
        {"parameters", "mass matrix", "kinetic energy", "gravity", "potential energy"},
        True,
        "wrong key hidden by equal values",
        "wrong mass",
    ),
)

_BARS = (
    _m(
        "double_pendulum_bars",
        "c1 and c2 swapped in G",
        "(p.m1 * p.c1 + p.m2 * p.l1) * p.g * s1 + p.m2 * p.c2 * p.g * s12, p.m2 * p.c2 * p.g * s12",
        "(p.m1 * p.c2 + p.m2 * p.l1) * p.g * s1 + p.m2 * p.c1 * p.g * s12, p.m2 * p.c1 * p.g * s12",
        {"gravity"},
        True,
        "c1/c2 swapped",
    ),
    _m(
        "double_pendulum_bars",
        "I1 and I2 swapped in M",
        "m22 = p.m2 * p.c2**2 + p.I2\n    m12 = m22 + p.m2 * p.l1 * p.c2 * c\n    m11 = p.m1 * p.c1**2 + p.I1 +",
        "m22 = p.m2 * p.c2**2 + p.I1\n    m12 = m22 + p.m2 * p.l1 * p.c2 * c\n    m11 = p.m1 * p.c1**2 + p.I2 +",
        MK,
        True,
        "I1/I2 swapped",
    ),
    _m(
        "double_pendulum_bars",
        "l1*c2 for c2^2 in M22",
        "m22 = p.m2 * p.c2**2 + p.I2",
        "m22 = p.m2 * p.l1 * p.c2 + p.I2",
        MK,
        False,
        "l1*l2 for l2^2",
    ),
    _m(
        "double_pendulum_bars",
        "lost 2 in M11 cos term",
        "+ 2 * p.m2 * p.l1 * p.c2 * c + m22",
        "+ p.m2 * p.l1 * p.c2 * c + m22",
        MK,
        False,
        "lost 2 in M cos term",
    ),
    _m(
        "double_pendulum_bars",
        "M11 cos term with minus",
        "+ 2 * p.m2 * p.l1 * p.c2 * c + m22",
        "- 2 * p.m2 * p.l1 * p.c2 * c + m22",
        MK,
        False,
        "M singular or indefinite",
    ),
    _m(
        "double_pendulum_bars",
        "centrifugal theta'^2 dropped in row 2",
        "[-h * (2 * w1 * w2 + w2**2), h * w1**2]",
        "[-h * (2 * w1 * w2 + w2**2), 0 * w1]",
        {"velocity"},
        False,
        "missing term",
    ),
    _m(
        "double_pendulum_bars",
        "m2 for m1 in G1",
        "(p.m1 * p.c1 + p.m2 * p.l1) * p.g * s1",
        "(p.m2 * p.c1 + p.m2 * p.l1) * p.g * s1",
        {"gravity"},
        True,
        "wrong mass",
    ),
    _m(
        "double_pendulum_bars",
        "c1 and c2 swapped in V",
        "-(p.m1 * p.c1 + p.m2 * p.l1) * p.g * np.cos(th) - p.m2 * p.c2 * p.g * np.cos(th + ph)",
        "-(p.m1 * p.c2 + p.m2 * p.l1) * p.g * np.cos(th) - p.m2 * p.c1 * p.g * np.cos(th + ph)",
        {"potential energy"},
        True,
        "c1/c2 swapped",
        "energy only",
    ),
    _m(
        "double_pendulum_bars",
        "bar 2 hung from bar 1's centre",
        '"link2": p.l1 * u1 + p.c2 * u2',
        '"link2": p.c1 * u1 + p.c2 * u2',
        {"body positions"},
        False,
        "body positions only",
    ),
    _m(
        "double_pendulum_bars",
        "c2 read from link1's com",
        'c2=-model["body/link2/com"][1]',
        'c2=-model["body/link1/com"][1]',
        {
            "parameters",
            "mass matrix",
            "kinetic energy",
            "gravity",
            "velocity",
            "potential energy",
            "body positions",
        },
        True,
        "wrong key hidden by equal values",
        "c1/c2 swapped",
    ),
)

_GIMBAL = (
    _m(
        "gimbal",
        "kpsi and ktheta swapped",
        "k = np.array([p.kpsi, p.ktheta])",
        "k = np.array([p.ktheta, p.kpsi])",
        {"friction"},
        True,
        "damping swapped",
    ),
    _m(
        "gimbal",
        "friction +k v",
        "return -k * v + np.zeros",
        "return k * v + np.zeros",
        {"friction"},
        False,
        "friction sign",
    ),
    _m(
        "gimbal",
        "sin and cos swapped in M11",
        "p.I2xx * s**2 + p.I2zz * c**2",
        "p.I2xx * c**2 + p.I2zz * s**2",
        MK,
        False,
        "sin for cos",
    ),
    _m(
        "gimbal",
        "I2xx s^2 subtracted in M11",
        "m11 = p.I1zz + p.I2xx * s**2",
        "m11 = p.I1zz - p.I2xx * s**2",
        MK,
        False,
        "M singular or indefinite",
    ),
    _m(
        "gimbal",
        "lost 2 in the Coriolis term",
        "[2 * d * sc * dth * dpsi, -d * sc * dpsi**2]",
        "[d * sc * dth * dpsi, -d * sc * dpsi**2]",
        {"velocity"},
        False,
    ),
    _m(
        "gimbal",
        "centrifugal sign in row 2",
        "[2 * d * sc * dth * dpsi, -d * sc * dpsi**2]",
        "[2 * d * sc * dth * dpsi, d * sc * dpsi**2]",
        {"velocity"},
        False,
        "coriolis sign",
    ),
    _m(
        "gimbal",
        "I2yy for I2zz in the difference",
        "d = p.I2xx - p.I2zz",
        "d = p.I2xx - p.I2yy",
        {"velocity"},
        False,
    ),
    _m(
        "gimbal",
        "T without 1/2",
        'return 0.5 * np.einsum("...i,...ij,...j->...", v, mass_matrix(p, q), v)',
        'return np.einsum("...i,...ij,...j->...", v, mass_matrix(p, q), v)',
        {"kinetic energy"},
        False,
        "energy only",
    ),
    _m(
        "gimbal",
        "R_2^0 = R_y(theta) R_z(psi)",
        '"inner": r1 @ rot_y(q[..., 1])',
        '"inner": rot_y(q[..., 1]) @ r1',
        {"body rotations"},
        False,
    ),
    _m(
        "gimbal",
        "ktheta read from the psi joint",
        'ktheta=model["joint/theta/damping"]',
        'ktheta=model["joint/psi/damping"]',
        {"parameters", "friction"},
        True,
        "wrong key hidden by equal values",
        "damping swapped",
    ),
)

MUTATIONS: tuple[Mutation, ...] = _SIMPLE + _POINT + _ABSOLUTE + _BARS + _GIMBAL


def original(system: str) -> types.ModuleType:
    """The installed equations module of `system`."""
    return importlib.import_module(f"{PACKAGE}.{system}")


def source(system: str) -> str:
    """The text of equations/<system>.py."""
    return Path(original(system).__file__).read_text()


def mutated_source(m: Mutation) -> str:
    """The module's text with the substitution applied; `old` must occur exactly once."""
    text = source(m.system)
    count = text.count(m.old)
    if count != 1:
        raise ValueError(f"{m.system}: {m.name!r}: `old` occurs {count} times in the source (need exactly 1)")
    return text.replace(m.old, m.new)


_fresh = itertools.count()


def load_mutated(m: Mutation) -> types.ModuleType:
    """The mutated module, executed fresh as lagrange_xval.equations._mutated_<system>_<n>.

    Its relative imports (`from ._forms import ...`) resolve in the installed package. Nothing is
    written to disk.
    """
    n = MUTATIONS.index(m) if m in MUTATIONS else 1000 + next(_fresh)
    name = f"{PACKAGE}._mutated_{m.system}_{n}"
    text = mutated_source(m)
    spec = importlib.util.spec_from_loader(name, loader=None, origin=f"<mutated equations/{m.system}.py>")
    module = importlib.util.module_from_spec(spec)
    module.__package__ = PACKAGE
    module.__file__ = f"<mutated equations/{m.system}.py: {m.name}>"
    # dataclasses look the module up in sys.modules while the class body runs.
    sys.modules[name] = module
    try:
        exec(compile(text, module.__file__, "exec"), module.__dict__)
    except BaseException:
        del sys.modules[name]
        raise
    return module


def _top_level(text: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for node in ast.parse(text).body:
        if isinstance(node, ast.FunctionDef | ast.ClassDef):
            out[node.name] = ast.dump(node)
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for t in targets:
                if isinstance(t, ast.Name):
                    out[t.id] = ast.dump(node)
    return out


def changed_functions(m: Mutation) -> frozenset[str]:
    """Top-level names (functions, classes, assignments) whose code the substitution changes."""
    before, after = _top_level(source(m.system)), _top_level(mutated_source(m))
    return frozenset(k for k in before.keys() | after.keys() if before.get(k) != after.get(k))


def term_values(module: types.ModuleType, p: Any, q: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
    """The terms of `module`'s equations at states (q, v) of shape (N, n), as the harness defines them.

    "actuation" and "parameters" are not functions of the state: the contract fixes the inputs as
    generalized forces (tau enters M a + bias = tau + passive with unit gain), and "parameters" is
    what parameters() returns.
    """
    q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
    positions = module.body_positions(p, q)
    rotations = module.body_rotations(p, q)
    return {
        "mass matrix": np.asarray(module.mass_matrix(p, q), dtype=float),
        "gravity": np.asarray(module.bias(p, q, np.zeros_like(v)), dtype=float),
        "velocity": np.asarray(module.bias(p, q, v) - module.bias(p, q, np.zeros_like(v)), dtype=float),
        "friction": np.asarray(module.passive(p, q, v), dtype=float),
        "kinetic energy": np.asarray(module.kinetic_energy(p, q, v), dtype=float),
        "potential energy": np.asarray(module.potential_energy(p, q), dtype=float),
        "body positions": np.stack([np.asarray(positions[b], dtype=float) for b in module.BODIES], axis=-2),
        "body rotations": np.stack([np.asarray(rotations[b], dtype=float) for b in module.BODIES], axis=-3),
    }

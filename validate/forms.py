"""What an equations module imports: the helpers for writing the dynamics, and the kinds of printed forms.

    from lagrange_xval.forms import body, hinge, not_provided, rot_z, stack_matrix, stack_vector

Every repository module (equations/*.py, examples/*.py) imports them by this name, so a copy of one
works from any folder. All are numpy only and broadcast over leading axes; they keep symbolic
entries (object arrays) as they are, so dynamics written with them can be traced by the harness.

Building arrays from scalar expressions:
    stack_vector([a, b, ...]) -> (..., n)             broadcastable scalars or arrays stacked on a last axis
    stack_matrix([[a, b], [c, d]]) -> (..., r, c)     the same for the rows of a matrix (M, a rotation)
    rot_x(angle), rot_y(angle), rot_z(angle) -> (..., 3, 3)   rotation by `angle` (rad) about x, y or z

What the derivation assumes of the compiled model (the entries of `assumptions(p)`, key -> value):
    body(name, parent=, mass=, com=, inertia=, pos=, quat=)   one body's keys ("body/<name>/mass", ...)
    hinge(name, body=, axis=, pos=, damping=)                 one hinge joint's keys, with no armature,
                                                              friction loss or spring
    planar_inertia(izz) -> (3, 3)                             a body turning about z only: Izz, the
                                                              rest NaN (a component not depended on)
    NAN                                                       float("nan"): "the derivation does not
                                                              depend on this component"

Functions not written yet:
    @not_provided                      decorates a stub (`lagrange-xval new` writes them): it raises if
                                       called, and the harness counts it as absent, never as an answer

The notes' printed forms (VARIANTS, each judged against MuJoCo and Pinocchio):
    Implicit(name, notes_equations, residual, row_scale, ...)   printed implicit equations, one row each
    Explicit(name, notes_equations, acceleration, ...)          printed accelerations a(p, q, v, tau)
                                                                (kind "matlab" for a Matlab function)
    DerivationStep(name, notes_equations, quantity, evaluate)   a printed intermediate result (a centre
                                                                of mass, an energy, a rotation) compared
                                                                with the engines' kinematics or energies
    Variant                                                     any of the three (a type alias)
    NotApplicable                                               raised by a printed form evaluated where
                                                                its stated assumptions do not hold
    common(symbol, **values) -> float                           the notes' one symbol for parameters the
                                                                printed forms assume equal (m for m1 and
                                                                m2); NotApplicable where they differ

The contract itself:
    EquationsModule                                             the Protocol a module meets: `parameters(model)`
                                                                and the dynamics in one of the forms listed in
                                                                equations/__init__.py (the other names optional)
    FormA                                                       what the harness reads of a module once brought
                                                                to form (a): M, bias and passive, every optional
                                                                function (a stub where absent), VARIANTS

    >>> import numpy as np
    >>> from lagrange_xval.forms import rot_z, stack_vector
    >>> stack_vector([np.zeros(4), 1.0]).shape
    (4, 2)
    >>> np.round(rot_z(np.pi / 2) @ [1.0, 0.0, 0.0], 12).tolist()
    [0.0, 1.0, 0.0]

A variant is one printed form of the notes, transcribed as printed. The harness judges each by
comparing it with MuJoCo and Pinocchio; nothing here says which forms are right.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import ParamSpec, Protocol, TypeVar, runtime_checkable

import numpy as np
import numpy.typing as npt

from .core.arrays import Floats

__all__ = [
    "NAN",
    "DerivationStep",
    "EquationsModule",
    "FormA",
    "Explicit",
    "Implicit",
    "NotApplicable",
    "Variant",
    "body",
    "common",
    "hinge",
    "not_provided",
    "planar_inertia",
    "rot_x",
    "rot_y",
    "rot_z",
    "stack_matrix",
    "stack_vector",
]

NAN = float("nan")
Args = ParamSpec("Args")
R = TypeVar("R")


@dataclass(frozen=True)
class Implicit:
    """Printed implicit equations, one residual row per equation.

    `residual(p, q, v, a, tau)` is the printed left-hand side minus the printed right-hand side.
    If the print is right, it equals `row_scale(p)[i] * (M a + bias - passive - tau)[i]`: the
    printed rows may be divided by a constant (the notes say so where they do).
    """

    name: str
    notes_equations: tuple[str, ...]
    residual: Callable[..., np.ndarray]
    row_scale: Callable[[object], np.ndarray]  # (p) -> (n,)
    note: str = ""
    printed_parameters: Mapping[str, float] = field(default_factory=dict)
    kind: str = "implicit"


@dataclass(frozen=True)
class Explicit:
    """Printed explicit equations: `acceleration(p, q, v, tau) -> a` (the state-space form).

    `kind` is "explicit" for printed formulas and "matlab" for a transcribed Matlab function;
    `printed_parameters` lists the literal values such a function hard-codes (parameter names of
    the module's Params), which a test compares with the compiled MJCF.
    """

    name: str
    notes_equations: tuple[str, ...]
    acceleration: Callable[..., np.ndarray]
    note: str = ""
    printed_parameters: Mapping[str, float] = field(default_factory=dict)
    kind: str = "explicit"


@dataclass(frozen=True)
class DerivationStep:
    """A printed intermediate result, compared with the engines' kinematics or energies.

    `quantity` names what the engines compute, one of:
      ("com_position", body), ("com_velocity", body), ("origin_position", body),
      ("origin_velocity", body), ("rotation", body), ("angular_velocity", body),
      ("kinetic_energy", body or None), ("potential_energy", body or None), ("lagrangian", None),
      ("translational_kinetic_energy", body), ("rotational_kinetic_energy", body),
      ("com_speed_squared", body), ("angular_velocity_body", body): angular velocity in the body's frame,
      ("axis_rotation", (x, y, z)): the rotation by q[angle_index] about a fixed axis.
    `evaluate(p, q, v)` returns the printed expression with the same shape.
    """

    name: str
    notes_equations: tuple[str, ...]
    quantity: tuple[str, str | tuple[float, float, float] | None]
    evaluate: Callable[..., np.ndarray]
    note: str = ""
    angle_index: int = 0
    kind: str = "derivation step"


Variant = Implicit | Explicit | DerivationStep


class NotApplicable(ValueError):
    """A printed form evaluated where its stated assumptions do not hold (the harness reports the
    form as "not applicable" there, and catches nothing broader)."""


def common(symbol: str, **values: float) -> float:
    """The notes' single symbol for parameters their printed forms assume equal (m for m1 and m2);
    a printed form evaluated where they differ does not apply, so this raises NotApplicable."""
    first = next(iter(values.values()))
    if any(v != first for v in values.values()):
        given = ", ".join(f"{k} = {v}" for k, v in values.items())
        raise NotApplicable(f"the notes' printed forms assume one {symbol} for {' and '.join(values)} (got {given})")
    return first


def _array(x: npt.ArrayLike) -> np.ndarray:
    # Numbers become floats; anything else (symbolic entries for code generation, and complex values or
    # strings the harness must see to refuse by name: validate/handwritten/values.py) stays as it is.
    arr = np.asarray(x)
    return arr.astype(float) if arr.dtype.kind in "biuf" else arr


def stack_matrix(rows: Sequence[Sequence[npt.ArrayLike]]) -> np.ndarray:
    """Stacks broadcastable scalars or arrays into an array of shape (..., len(rows), len(rows[0]))."""
    b = np.broadcast_arrays(*[_array(x) for row in rows for x in row])
    flat = np.stack(b, axis=-1)
    return flat.reshape(flat.shape[:-1] + (len(rows), len(rows[0])))


def stack_vector(items: Sequence[npt.ArrayLike]) -> np.ndarray:
    """Stacks broadcastable scalars or arrays into an array of shape (..., len(items))."""
    return np.stack(np.broadcast_arrays(*[_array(x) for x in items]), axis=-1)


def rot_x(angle: npt.ArrayLike) -> np.ndarray:
    """Rotation by `angle` about x, (..., 3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return stack_matrix([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_z(angle: npt.ArrayLike) -> np.ndarray:
    """Rotation by `angle` about z, (..., 3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return stack_matrix([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_y(angle: npt.ArrayLike) -> np.ndarray:
    """Rotation by `angle` about y, (..., 3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return stack_matrix([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def body(
    name: str,
    *,
    parent: str,
    mass: float,
    com: Floats,
    inertia: Floats,
    pos: Floats = (0.0, 0.0, 0.0),
    quat: Floats = (1.0, 0.0, 0.0, 0.0),
) -> dict[str, str | float | np.ndarray]:
    """The assumptions a derivation makes about one MJCF body."""
    return {
        f"body/{name}/parent": parent,
        f"body/{name}/mass": mass,
        f"body/{name}/com": np.asarray(com, dtype=float),
        f"body/{name}/inertia": np.asarray(inertia, dtype=float),
        f"body/{name}/pos": np.asarray(pos, dtype=float),
        f"body/{name}/quat": np.asarray(quat, dtype=float),
    }


def hinge(
    name: str, *, body: str, axis: Floats, pos: Floats = (0.0, 0.0, 0.0), damping: float = 0.0
) -> dict[str, str | float | np.ndarray]:
    """The assumptions a derivation makes about one hinge joint (no armature, friction loss or spring)."""
    return {
        f"joint/{name}/type": "hinge",
        f"joint/{name}/body": body,
        f"joint/{name}/axis": np.asarray(axis, dtype=float),
        f"joint/{name}/pos": np.asarray(pos, dtype=float),
        f"joint/{name}/damping": damping,
        f"joint/{name}/armature": 0.0,
        f"joint/{name}/frictionloss": 0.0,
        f"joint/{name}/stiffness": 0.0,
    }


def planar_inertia(izz: float) -> np.ndarray:
    """Inertia of a body turning about z only: just Izz matters, and no product couples z to x or y."""
    return np.array([[NAN, NAN, 0.0], [NAN, NAN, 0.0], [0.0, 0.0, izz]])


def not_provided(fn: Callable[Args, R]) -> Callable[Args, R]:
    """Marks a function a person has not written yet (`lagrange-xval new` writes such stubs): it
    raises when called, and the harness counts it as absent, never as an answer."""

    def stub(*args: Args.args, **kwargs: Args.kwargs) -> R:
        raise NotImplementedError(f"{fn.__name__}() is not provided yet: write it in this module")

    stub.__name__, stub.__doc__ = fn.__name__, fn.__doc__
    stub.not_provided = True  # type: ignore[attr-defined]
    return stub


@runtime_checkable
class EquationsModule(Protocol):
    """What the harness asks of an equations module (a Python module, or a stand-in for one: a text form's,
    a worker's proxy): `parameters(model)`, the numbers the derivation uses read from the compiled model.
    Everything else (COORDINATES, the dynamics in one of five forms, the energies, the printed forms) is
    optional and read by name; equations/__init__.py lists each name and its shape."""

    def parameters(self, model: Mapping[str, object]) -> object: ...


class FormA(Hashable, Protocol):
    """An equations module as the harness reads it after `normalize` (validate/handwritten/forms.py): the
    dynamics in form (a), whatever form was written; every optional function (a `not_provided` stub where
    the module leaves it out); VARIANTS (none by default) and assumptions(p) (empty by default). `p` is what
    the module's own parameters() returned; q, v: (..., n) arrays (floats, or traced object arrays)."""

    __name__: str
    __file__: str | None

    def parameters(self, model: Mapping[str, object]) -> object: ...
    def mass_matrix(self, p: object, q: np.ndarray) -> np.ndarray: ...
    def bias(self, p: object, q: np.ndarray, v: np.ndarray) -> np.ndarray: ...
    def passive(self, p: object, q: np.ndarray, v: np.ndarray) -> np.ndarray: ...
    def kinetic_energy(self, p: object, q: np.ndarray, v: np.ndarray) -> np.ndarray: ...
    def potential_energy(self, p: object, q: np.ndarray) -> np.ndarray: ...
    def body_positions(self, p: object, q: np.ndarray) -> Mapping[str, np.ndarray]: ...
    def body_rotations(self, p: object, q: np.ndarray) -> Mapping[str, np.ndarray]: ...
    def assumptions(self, p: object) -> Mapping[str, object]: ...
    @property
    def VARIANTS(self) -> Sequence[Variant]: ...  # noqa: N802 - the module's own name

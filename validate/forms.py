"""The kinds of printed forms a system module can transcribe, and small helpers (numpy only).

Equations modules import these by their public name, `lagrange_xval.forms` (validate/forms.py
documents each); this file is their implementation, numpy only, imported by the harness itself.

A variant is one printed form of the notes, transcribed as printed. The harness judges each by
comparing it with MuJoCo and Pinocchio; nothing here says which forms are right.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

NAN = float("nan")


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
    row_scale: Callable[[Any], np.ndarray]
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
    quantity: tuple[Any, ...]
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


def _array(x: Any) -> np.ndarray:
    # Numbers become floats; anything else (symbolic entries for code generation, and complex values or
    # strings the harness must see to refuse by name: validate/handwritten/values.py) stays as it is.
    arr = np.asarray(x)
    return arr.astype(float) if arr.dtype.kind in "biuf" else arr


def stack_matrix(rows: list[list[Any]]) -> np.ndarray:
    """Stacks broadcastable scalars or arrays into an array of shape (..., len(rows), len(rows[0]))."""
    b = np.broadcast_arrays(*[_array(x) for row in rows for x in row])
    flat = np.stack(b, axis=-1)
    return flat.reshape(flat.shape[:-1] + (len(rows), len(rows[0])))


def stack_vector(items: list[Any]) -> np.ndarray:
    """Stacks broadcastable scalars or arrays into an array of shape (..., len(items))."""
    return np.stack(np.broadcast_arrays(*[_array(x) for x in items]), axis=-1)


def rot_x(angle: Any) -> np.ndarray:
    """Rotation by `angle` about x, (..., 3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return stack_matrix([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_z(angle: Any) -> np.ndarray:
    """Rotation by `angle` about z, (..., 3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return stack_matrix([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_y(angle: Any) -> np.ndarray:
    """Rotation by `angle` about y, (..., 3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return stack_matrix([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def body(
    name: str,
    *,
    parent: str,
    mass: float,
    com: Any,
    inertia: Any,
    pos: Any = (0.0, 0.0, 0.0),
    quat: Any = (1.0, 0.0, 0.0, 0.0),
) -> dict[str, Any]:
    """The assumptions a derivation makes about one MJCF body."""
    return {
        f"body/{name}/parent": parent,
        f"body/{name}/mass": mass,
        f"body/{name}/com": np.asarray(com, dtype=float),
        f"body/{name}/inertia": np.asarray(inertia, dtype=float),
        f"body/{name}/pos": np.asarray(pos, dtype=float),
        f"body/{name}/quat": np.asarray(quat, dtype=float),
    }


def hinge(name: str, *, body: str, axis: Any, pos: Any = (0.0, 0.0, 0.0), damping: float = 0.0) -> dict[str, Any]:
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


def not_provided(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Marks a function a person has not written yet (`lagrange-xval new` writes such stubs): it
    raises when called, and the harness counts it as absent, never as an answer."""

    def stub(*args: Any, **kwargs: Any) -> Any:
        raise NotImplementedError(f"{fn.__name__}() is not provided yet: write it in this module")

    stub.__name__, stub.__doc__ = fn.__name__, fn.__doc__
    stub.not_provided = True  # type: ignore[attr-defined]
    return stub

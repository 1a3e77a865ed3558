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

The implementation is lagrange_xval/equations/_forms.py (the harness imports it from there); this module
is its public name and adds nothing.
"""

from lagrange_xval.equations._forms import (
    NAN,
    DerivationStep,
    Explicit,
    Implicit,
    NotApplicable,
    Variant,
    body,
    common,
    hinge,
    not_provided,
    planar_inertia,
    rot_x,
    rot_y,
    rot_z,
    stack_matrix,
    stack_vector,
)

__all__ = [
    "NAN",
    "DerivationStep",
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

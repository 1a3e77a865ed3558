"""A rigid body's mass, centre of mass and inertia as one 4x4 pseudo-inertia matrix, and random bodies
drawn through its log-Cholesky factor, so that every draw is a body MuJoCo compiles.

    J = [[Σ + m c cᵀ, m c], [m cᵀ, m]],   Σ = ½ tr(I) 1 - I   (I about the centre of mass, body axes)

J is positive definite exactly when m > 0 and Σ is, that is when I is positive definite and its
principal moments satisfy the triangle inequality strictly (Σ's eigenvalues are (B + C - A) / 2 ...).
Rucker & Wensing (2022, "Smooth parameterization of rigid-body inertia") write J = U Uᵀ with

    U = e^α [[D, t], [0, 1]],   D upper triangular with a positive diagonal,

so m = e^(2α), c = t and Σ = m D Dᵀ: every (α, log diag D, the rest of D, t) is a valid body. A probe
(validate/verdict/probes.py) moves α, t and D, each entry by its own factor, so that masses, centres
and inertias move together and no draw breaks the triangle inequality. What is zero in the model stays
zero (a centre on an axis, a product of inertia of a symmetric link): D's entries that would make one
non-zero are instead solved for to keep it zero, which changes nothing of the guarantee (D's diagonal
stays positive). The factor moved here is that of Σ itself (Rucker & Wensing's D times √m), so the
inertia moves by factors of its own, not with the mass.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..core.arrays import Floats

SINGULAR_RTOL = 1e-12  # Σ's smallest eigenvalue below this, relative to its largest: on the boundary (a rod, a lamina)


def pseudo_inertia(mass: float, com: Floats, inertia: Floats) -> np.ndarray:
    """J, (4, 4), of a body of `mass` with centre `com` and inertia `inertia` about that centre."""
    c = np.asarray(com, dtype=float)
    inertia_ = np.asarray(inertia, dtype=float)
    sigma = 0.5 * np.trace(inertia_) * np.eye(3) - inertia_
    out = np.empty((4, 4))
    out[:3, :3] = sigma + mass * np.outer(c, c)
    out[:3, 3] = out[3, :3] = mass * c
    out[3, 3] = mass
    return out


def from_pseudo_inertia(J: Floats) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, com, inertia about the centre of mass) of a pseudo-inertia matrix."""
    J_ = np.asarray(J, dtype=float)
    mass = float(J_[3, 3])
    com = J_[:3, 3] / mass
    sigma = J_[:3, :3] - mass * np.outer(com, com)
    return mass, com, np.trace(sigma) * np.eye(3) - sigma


def body_defect(mass: float, com: Floats, inertia: Floats) -> str:
    """Why (mass, com, inertia) is not a rigid body, or "": a positive mass, a finite centre, and a
    positive definite pseudo-inertia (so the inertia is positive definite and A + B > C)."""
    I = np.asarray(inertia, dtype=float)
    if not (np.isfinite(mass) and mass > 0):
        return f"mass {mass!r} is not positive"
    if not (np.all(np.isfinite(com)) and np.all(np.isfinite(I))):
        return "centre of mass or inertia not finite"
    if not np.allclose(I, I.T, rtol=0.0, atol=1e-12 * float(np.abs(I).max(initial=0.0))):
        return "inertia not symmetric"
    low = float(np.linalg.eigvalsh(pseudo_inertia(mass, com, 0.5 * (I + I.T)))[0])
    if not low > 0:
        return f"pseudo-inertia not positive definite (smallest eigenvalue {low:.3g})"
    moments = np.linalg.eigvalsh(0.5 * (I + I.T))
    if not (moments[0] > 0 and moments[0] + moments[1] >= moments[2]):
        return f"principal moments {moments.tolist()} break A + B >= C"
    return ""


def _upper_factor(sigma: np.ndarray) -> np.ndarray | None:
    """D, upper triangular with a positive diagonal, with D Dᵀ = Σ; None where Σ is (nearly) singular."""
    flip = np.eye(3)[::-1]
    scale = float(np.abs(sigma).max(initial=0.0))
    if scale == 0.0 or np.linalg.eigvalsh(sigma)[0] <= SINGULAR_RTOL * scale:
        return None
    try:
        lower = np.linalg.cholesky(flip @ sigma @ flip)
    except np.linalg.LinAlgError:
        return None
    return np.asarray(flip @ lower @ flip)


def _moved_factor(D: np.ndarray, zero: np.ndarray, factor: Callable[[], float]) -> np.ndarray:
    """D with each diagonal entry and each off-diagonal entry times the square root of its own factor
    (Σ's entries then move by about the factor), columns from the last to the first so that an entry
    whose product of inertia is zero can be solved for to keep it zero: Σ_ij = D_ij D_jj + Σ_(k>j)
    D_ik D_jk for i < j."""
    out = D.copy()
    for j in (2, 1, 0):
        out[j, j] = D[j, j] * np.sqrt(factor())
    for j in (2, 1):
        for i in range(j):
            if zero[i, j]:
                out[i, j] = -sum(out[i, k] * out[j, k] for k in range(j + 1, 3)) / out[j, j]
            elif D[i, j] != 0.0:
                out[i, j] = D[i, j] * np.sqrt(factor())
    return out


def perturbed_body(
    mass: float, com: Floats, inertia: Floats, factor: Callable[[], float]
) -> tuple[float, np.ndarray, np.ndarray]:
    """A random rigid body near (mass, com, inertia): the mass and each non-zero coordinate of the
    centre times its own `factor()`, the inertia's log-Cholesky factor D moved entry by entry (module
    docstring); a zero product of inertia stays exactly zero. A Σ on the boundary (a rod, a lamina, a
    point mass) has no such factor: it is moved by S Σ S with S diagonal and positive, which keeps it
    positive semidefinite and its zeros zero. A body of mass 0 is given back as it is."""
    c0 = np.asarray(com, dtype=float)
    I0 = np.asarray(inertia, dtype=float)
    if not mass > 0:
        return mass, c0.copy(), I0.copy()
    new_mass = mass * factor()
    new_com = np.array([x * factor() if x != 0.0 else 0.0 for x in c0])
    sigma = 0.5 * np.trace(I0) * np.eye(3) - I0
    sigma = 0.5 * (sigma + sigma.T)
    zero = I0 == 0.0
    D = _upper_factor(sigma)
    if D is None:
        s = np.sqrt([factor() for _ in range(3)])
        new_sigma = sigma * np.outer(s, s)
    else:
        moved = _moved_factor(D, zero, factor)
        new_sigma = moved @ moved.T
    new_sigma = np.where(zero & ~np.eye(3, dtype=bool), 0.0, 0.5 * (new_sigma + new_sigma.T))
    new_inertia = np.trace(new_sigma) * np.eye(3) - new_sigma
    return new_mass, new_com, new_inertia

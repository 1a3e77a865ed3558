"""The hand-derived equations as a source: the equations module, vectorised over states."""

from __future__ import annotations

from typing import Any

import numpy as np


class HandSource:
    name = "hand"

    def __init__(self, system: Any) -> None:
        self.system = system
        self.eq = system.equations
        self.p = system.params

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        return np.asarray(self.eq.mass_matrix(self.p, q), dtype=float)

    def bias(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.asarray(self.eq.bias(self.p, q, v), dtype=float)

    def passive(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.asarray(self.eq.passive(self.p, q, v), dtype=float)

    def forward(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """q'' = M^-1 (tau + passive - bias), one batched solve."""
        rhs = tau + self.passive(q, v) - self.bias(q, v)
        return np.linalg.solve(self.mass_matrix(q), rhs[..., None])[..., 0]

    def inverse(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """tau = M a + bias - passive."""
        return np.einsum("...ij,...j->...i", self.mass_matrix(q), a) + self.bias(q, v) - self.passive(q, v)

    def energies(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return (
            np.asarray(self.eq.kinetic_energy(self.p, q, v), dtype=float),
            np.asarray(self.eq.potential_energy(self.p, q), dtype=float),
        )

    def evaluate(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, a_ref: np.ndarray | None = None
    ) -> dict[str, np.ndarray]:
        """Every pointwise quantity, vectorised over the states (M computed once). Without `a_ref`
        the inverse dynamics is taken at the source's own accelerations."""
        M, bias, passive = self.mass_matrix(q), self.bias(q, v), self.passive(q, v)
        kin, pot = self.energies(q, v)
        qacc = np.linalg.solve(M, (tau + passive - bias)[..., None])[..., 0]
        return {
            "M": M,
            "bias": bias,
            "passive": passive,
            "qacc": qacc,
            "tau_inverse": np.einsum("...ij,...j->...i", M, qacc if a_ref is None else a_ref) + bias - passive,
            "T": kin,
            "V": pot,
            "body_positions": self.body_positions(q),
            "body_rotations": self.body_rotations(q),
        }

    def body_positions(self, q: np.ndarray) -> np.ndarray:
        pos = self.eq.body_positions(self.p, q)
        return np.stack([pos[b] for b in self.system.bodies], axis=-2)

    def body_rotations(self, q: np.ndarray) -> np.ndarray:
        rot = self.eq.body_rotations(self.p, q)
        return np.stack([rot[b] for b in self.system.bodies], axis=-3)

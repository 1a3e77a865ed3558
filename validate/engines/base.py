"""What every source has in common: the per-body kinematics record and the batched interface."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Protocol

import numpy as np

# MuJoCo's integrators by the names the harness uses (defined once; the enums live in engines/mujoco.py).
INTEGRATOR_ENUMS = {
    "Euler": "mjINT_EULER",
    "RK4": "mjINT_RK4",
    "implicit": "mjINT_IMPLICIT",
    "implicitfast": "mjINT_IMPLICITFAST",
}
MUJOCO_INTEGRATORS = tuple(INTEGRATOR_ENUMS)


@dataclass(frozen=True)
class Kinematics:
    """Per-body kinematics at N states; the body axis follows `System.bodies`."""

    com_position: np.ndarray  # (N, nb, 3) m
    com_velocity: np.ndarray  # (N, nb, 3) m/s
    origin_position: np.ndarray  # (N, nb, 3) m, the body frame origin (its joint)
    origin_velocity: np.ndarray  # (N, nb, 3) m/s
    rotation: np.ndarray  # (N, nb, 3, 3) body frame in the world frame
    angular_velocity: np.ndarray  # (N, nb, 3) rad/s, world frame
    kinetic_energy: np.ndarray  # (N, nb) J
    potential_energy: np.ndarray  # (N, nb) J


class Source(Protocol):
    name: str

    def mass_matrix(self, q: np.ndarray) -> np.ndarray: ...
    def bias(self, q: np.ndarray, v: np.ndarray) -> np.ndarray: ...
    def forward(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray: ...
    def inverse(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray: ...
    def energies(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...
    def body_positions(self, q: np.ndarray) -> np.ndarray: ...


# An engine's batch is split over threads only from this many states per thread (a thread's share of
# the batch's set-up is then small); results do not depend on the split (tests/test_batch.py).
THREAD_MIN_STATES = 1024


def batch_threads(n_states: int) -> int:
    """Threads for an engine's batch of `n_states` states (MuJoCo's `mujoco.batch` runs them without
    the GIL): one per core this process may run on, fewer where the batch is small."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(cores, n_states // THREAD_MIN_STATES))

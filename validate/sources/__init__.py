"""The three sources of dynamics behind one interface: the hand equations, MuJoCo, Pinocchio.

Every source works on batches of states in the notes' coordinates: `q`, `v`, `tau`, `a` are
(N, n) arrays, and each method returns arrays with a leading N axis. Engines are imported lazily.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

SOURCE_NAMES = ("hand", "mujoco", "pinocchio")


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


def make_source(system: Any, name: str) -> Any:
    """The source called `name` for `system` ("hand", "mujoco" or "pinocchio")."""
    from ..errors import unknown_name

    if name == "hand":
        from .hand import HandSource

        return HandSource(system)
    if name == "mujoco":
        from .mujoco_source import MujocoSource

        return MujocoSource(system)
    if name == "pinocchio":
        from .pinocchio_source import PinocchioSource

        return PinocchioSource(system)
    raise unknown_name("source", name, SOURCE_NAMES)


def make_sources(system: Any) -> dict[str, Any]:
    return {n: make_source(system, n) for n in SOURCE_NAMES}

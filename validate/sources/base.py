"""What every source has in common: the per-body kinematics record and the batched interface."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, TypeVar, runtime_checkable

import numpy as np

from ..core.errors import HarnessError

if TYPE_CHECKING:
    import mujoco

    from ..systems import System

# MuJoCo's integrators by the names the harness uses (defined once; the enums live in sources/mujoco.py).
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
    """What every source answers (hand, mujoco, pinocchio, symbolic, drake, warp, and a `MappedSource` of
    any of them), batched: `q`, `v`, `tau`, `a` are (N, n) arrays in the notes' coordinates and every
    result has a leading N axis.

    Adding a source (as scipy's `OdeSolver` lists what a new solver must do):
        1. A class in its own module of sources/, whose constructor takes the `System` and raises
           HarnessError (one line: what the engine cannot read, and why) where it cannot build the chain.
        2. Implement every method below in the notes' coordinates (the model's joints in order, or
           `System.joints`): M(q), bias = C(q, v) v + G(q), passive (damping, springs at springref),
           forward and inverse dynamics, T and V (V as the engine counts it: MuJoCo and Drake every
           body with mass, those welded to the world too, Pinocchio the bodies it keeps off the universe;
           V is compared up to a constant, so its zero is the source's own), the bodies' centres of mass
           in the world frame; `evaluate` returns them all at once for a batch.
        3. Answer `PosedSource` too if the engine gives body frames, `OneStateSource` if it has a one-state
           right-hand side for integrators, `SteppedSource` if it steps its own scheme.
        4. Register it in sources/__init__.py `REGISTRY` (module and class), and add it to
           `SOURCE_NAMES` if every system should be compared with it (else it is asked for by name).
        5. Import the engine library only inside the module (tests/test_architecture.py holds that only
           sources/, model/ and systems/ import an engine), and list it in the mypy check at the end of
           sources/__init__.py.
    """

    name: str
    system: System

    def mass_matrix(self, q: np.ndarray) -> np.ndarray: ...
    def bias(self, q: np.ndarray, v: np.ndarray) -> np.ndarray: ...
    def passive(self, q: np.ndarray, v: np.ndarray) -> np.ndarray: ...
    def forward(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray: ...
    def inverse(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray: ...
    def energies(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...
    def body_positions(self, q: np.ndarray) -> np.ndarray: ...
    def evaluate(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, a_ref: np.ndarray | None = None
    ) -> dict[str, np.ndarray]:
        """Every pointwise quantity at once: M, bias, passive, qacc (at `tau`), tau_inverse (at `a_ref`;
        without it, at the source's own accelerations), T, V, body_positions, body_rotations; a
        quantity the source does not provide is left out."""
        ...


@runtime_checkable
class PosedSource(Source, Protocol):
    """A source with every body's frame and velocity: the engine references (MuJoCo, Pinocchio,
    symbolic, Drake); the hand source has rotations only, MuJoCo Warp neither."""

    def body_rotations(self, q: np.ndarray) -> np.ndarray: ...
    def kinematics(self, q: np.ndarray, v: np.ndarray) -> Kinematics: ...


# scipy's right-hand side f(t, y) of one state y = (q, v), for a constant input: (v, a) as an array, or
# as the list of floats the hand equations' generated code returns (sources/fastpath.py)
RightHandSide = Callable[[float, np.ndarray], np.ndarray | Sequence[float]]


@runtime_checkable
class OneStateSource(Source, Protocol):
    """A source with its own one-state right-hand side (hand, Pinocchio, symbolic): free runs call it
    without the batch's overhead."""

    def rhs(self, tau: np.ndarray) -> RightHandSide: ...


@runtime_checkable
class SteppedSource(Source, Protocol):
    """MuJoCo's source: a compiled model and its data, set to a state and stepped by MuJoCo itself
    (sources/mujoco.py's runs). `m` and `d` are mujoco.MjModel and mujoco.MjData (untyped)."""

    m: mujoco.MjModel
    d: mujoco.MjData
    qadr: np.ndarray  # the coordinates' places in MuJoCo's qpos and qvel
    dadr: np.ndarray

    def set_state(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray | None = None) -> None: ...
    def get_state(self) -> tuple[np.ndarray, np.ndarray]: ...


def posed(source: Source) -> PosedSource:
    """`source` with its bodies' frames and velocities (an engine reference); a HarnessError where not."""
    if not isinstance(source, PosedSource):
        raise HarnessError(f"the {source.name} source gives no body frames (kinematics).")
    return source


def one_state(source: Source) -> OneStateSource:
    """`source` with its own one-state right-hand side; a HarnessError where it has none."""
    if not isinstance(source, OneStateSource):
        raise HarnessError(f"the {source.name} source has no one-state right-hand side (rhs).")
    return source


def stepped(source: Source) -> SteppedSource:
    """`source` as MuJoCo's, with a model to step (a MappedSource of it too); a HarnessError where not."""
    if not isinstance(source, SteppedSource):
        raise HarnessError(f"the {source.name} source has no MuJoCo model to step.")
    return source


E = TypeVar("E")


def engine_of(source: Source, kind: type[E]) -> E:
    """The engine of class `kind` behind `source`: itself, or a MappedSource's inner one (whose
    arrays are in the model's joint coordinates); a HarnessError naming the source where it is another."""
    inner = getattr(source, "inner", source)
    if not isinstance(inner, kind):
        raise HarnessError(f"the {source.name} source is not {kind.__name__}.")
    return inner


# An engine's batch is split over threads only from this many states per thread (a thread's share of
# the batch's set-up is then small); results do not depend on the split (tests/unit/sources/test_base.py).
THREAD_MIN_STATES = 1024


def batch_threads(n_states: int) -> int:
    """Threads for an engine's batch of `n_states` states (MuJoCo's `mujoco.batch` runs them without
    the GIL): one per core this process may run on, fewer where the batch is small."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(cores, n_states // THREAD_MIN_STATES))

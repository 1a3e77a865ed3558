"""The sources of dynamics behind one interface: the hand equations, MuJoCo, Pinocchio, the model's own
equations derived symbolically (symbolic/derivation.py, sources/symbolic.py), and Drake (sources/drake.py,
a third independent reader of the model file; left out, with the reason, where pydrake is missing or
its parser refuses the model).

Every source works on batches of states in the notes' coordinates: `q`, `v`, `tau`, `a` are
(N, n) arrays, and each method returns arrays with a leading N axis. Engines are imported lazily.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any, Generic, TypeVar

import numpy as np

from ..core.errors import HarnessError, unknown_name
from ..systems import System
from .base import Kinematics, OneStateSource, PosedSource, RightHandSide, Source, SteppedSource
from .hand import HandSource

__all__ = [
    "SOURCE_NAMES",
    "SYMBOLIC_MAX_DOF",
    "Kinematics",
    "REGISTRY",
    "MappedSource",
    "Source",
    "Sources",
    "make_source",
    "make_sources",
]

SOURCE_NAMES = ("hand", "mujoco", "pinocchio", "symbolic", "drake")


class Sources(dict[str, Source]):
    """The sources of a system by name, and `skipped`: each source left out, with why. Asking for a source
    that was left out raises the HarnessError that says why (a reader that cannot read the file)."""

    skipped: dict[str, str]

    def __missing__(self, name: str) -> Source:
        why = getattr(self, "skipped", {}).get(name)
        if why is None:
            raise KeyError(name)
        raise HarnessError(why)


# The readers of the model file (the hand and symbolic sources read MuJoCo's compiled model, not the file).
FILE_READERS = ("mujoco", "pinocchio", "drake")
# A reader that cannot read the file is left out with its reason; MuJoCo's refusal is the model's.
OPTIONAL_READERS = ("pinocchio", "drake")
READER_WORDS = {"mujoco": "MuJoCo", "pinocchio": "Pinocchio", "drake": "Drake"}


S = TypeVar("S", bound=Source, covariant=True)


class MappedSource(Generic[S]):
    """An engine source seen through a linear coordinate map q_notes = A q_joints.

    Velocities and accelerations map like q; generalized forces map covariantly (the power
    tau_notes . v_notes = tau_joints . v_joints), so tau_joints = A^T tau_notes and
    M_notes = A^-T M_joints A^-1. Energies and body kinematics do not depend on coordinates.
    """

    def __init__(self, inner: S, A: np.ndarray) -> None:
        self.inner, self.A, self.Ainv = inner, A, np.linalg.inv(A)
        self.name = inner.name

    def __getattr__(self, attr: str) -> Any:  # .m, .d, .model, ...
        return getattr(self.inner, attr)

    def _j(self, x: np.ndarray) -> np.ndarray:  # notes -> joints, for q, v, a
        return x @ self.Ainv.T

    def _force(self, f: np.ndarray) -> np.ndarray:  # joint forces -> notes forces
        return f @ self.Ainv

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        return self.Ainv.T @ self.inner.mass_matrix(self._j(q)) @ self.Ainv

    def bias(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._force(self.inner.bias(self._j(q), self._j(v)))

    def passive(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._force(self.inner.passive(self._j(q), self._j(v)))

    def forward(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        return self.inner.forward(self._j(q), self._j(v), tau @ self.A) @ self.A.T

    def inverse(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        return self._force(self.inner.inverse(self._j(q), self._j(v), self._j(a)))

    def energies(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.inner.energies(self._j(q), self._j(v))

    def body_positions(self, q: np.ndarray) -> np.ndarray:
        return self.inner.body_positions(self._j(q))

    def body_rotations(self: MappedSource[PosedSource], q: np.ndarray) -> np.ndarray:
        return self.inner.body_rotations(self._j(q))

    def kinematics(self: MappedSource[PosedSource], q: np.ndarray, v: np.ndarray) -> Kinematics:
        return self.inner.kinematics(self._j(q), self._j(v))

    def rhs(self: MappedSource[OneStateSource], tau: np.ndarray) -> RightHandSide:
        """The inner source's right-hand side, seen in the notes' coordinates."""
        inner = self.inner.rhs(self.A.T @ tau)
        n, A, Ainv = len(tau), self.A, self.Ainv

        def f(t: float, y: np.ndarray) -> np.ndarray:
            dy = inner(t, np.concatenate([Ainv @ y[:n], Ainv @ y[n:]]))
            return np.concatenate([A @ dy[:n], A @ dy[n:]])

        return f

    def evaluate(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, a_ref: np.ndarray | None = None, **options: int | None
    ) -> dict[str, np.ndarray]:
        a = None if a_ref is None else self._j(a_ref)
        out = self.inner.evaluate(self._j(q), self._j(v), tau @ self.A, a, **options)
        out["M"] = self.Ainv.T @ out["M"] @ self.Ainv
        for k in ("bias", "passive", "tau_inverse"):
            out[k] = self._force(out[k])
        out["qacc"] = out["qacc"] @ self.A.T
        return out

    def set_state(
        self: MappedSource[SteppedSource], q: np.ndarray, v: np.ndarray, tau: np.ndarray | None = None
    ) -> None:
        self.inner.set_state(self.Ainv @ q, self.Ainv @ v, None if tau is None else self.A.T @ tau)

    def get_state(self: MappedSource[SteppedSource]) -> tuple[np.ndarray, np.ndarray]:
        q, v = self.inner.get_state()
        return self.A @ q, self.A @ v


# Each source's module and class, imported when first asked for (the engines are heavy). "warp" (MuJoCo
# Warp, float32) is asked for by name only (studies/float32.py), never a default source.
REGISTRY: dict[str, tuple[str, str]] = {
    "hand": ("hand", "HandSource"),
    "mujoco": ("mujoco", "MujocoSource"),
    "pinocchio": ("pinocchio", "PinocchioSource"),
    "symbolic": ("symbolic", "SymbolicSource"),  # sympy: loaded when first asked for
    "drake": ("drake", "DrakeSource"),
    "warp": ("warp", "WarpSource"),
}


def make_source(system: System, name: str) -> Source:
    """The source called `name` for `system` (a key of REGISTRY: "hand", "mujoco", "pinocchio",
    "symbolic", "drake" or "warp").

    Engines read joint coordinates; where the notes' coordinates are a linear map of them
    (`JOINT_MAP` in the equations module), the engine sources are wrapped in that map.
    """
    if name not in REGISTRY:
        raise unknown_name("source", name, SOURCE_NAMES)
    module_name, class_name = REGISTRY[name]
    module = importlib.import_module(f".{module_name}", __package__)
    if why := getattr(module, "unavailable", str)():  # an engine that is not installed says so
        raise HarnessError(f"the {name} source: {why}")
    engine: Source = getattr(module, class_name)(system)
    A = system.joint_map
    return engine if A is None or name == "hand" else MappedSource(engine, A)


# Beyond this many joints the symbolic source is left out: a 6-joint arm took 16 s (UR5, axis-aligned
# frames) to 2 min (Kinova, SO-100: frames at general angles) to derive and generate code for.
SYMBOLIC_MAX_DOF = 4


def make_sources(system: System) -> Sources:
    """Every source for `system`; the symbolic one only for chains of at most SYMBOLIC_MAX_DOF joints;
    Pinocchio and Drake where they are installed and read the model (else in `skipped`, with why: a
    reader that refuses a file is left out and the others judge; `two_readers` refuses the model where
    fewer than two readers are left)."""
    skip = {"symbolic"} if system.nv > SYMBOLIC_MAX_DOF else set()
    if system.equations is None:  # the model alone: no hand derivation
        skip.add("hand")
    out = Sources()
    out.skipped = {}
    for name in (n for n in SOURCE_NAMES if n not in skip):
        try:
            out[name] = make_source(system, name)
        except HarnessError as exc:  # a reader that cannot read the file: its absence is stated, never fatal
            if name not in OPTIONAL_READERS:
                raise
            out.skipped[name] = str(exc)
    return out


def left_out(system: System, sources: Sources) -> dict[str, str]:
    """Each file reader left out of `sources` -> why, without the file's name ("Pinocchio cannot read it;
    likely a height-field geom ..."), as the verdict line words it."""
    prefix = f"{system.mjcf.name}: "
    return {n: why.removeprefix(prefix) for n, why in getattr(sources, "skipped", {}).items() if n in FILE_READERS}


def two_readers(system: System, sources: Sources, misread: dict[str, str] | None = None) -> None:
    """Raise HarnessError where fewer than two readers of the file are left (those that cannot read it,
    and `misread`: those set aside for a misreading, taken away), naming each that could not and why:
    MuJoCo alone has nothing to be held against."""
    gone = {**left_out(system, sources), **(misread or {})}
    readers = [n for n in FILE_READERS if n in sources and n not in gone]
    if len(readers) >= 2:
        return
    left = " and ".join(READER_WORDS[n] for n in readers) or "no reader"
    why = "; ".join(gone[n] for n in FILE_READERS if n in gone)
    raise HarnessError(
        f"{system.mjcf.name}: fewer than two readers can read it ({left} only), so there is nothing to hold "
        f"MuJoCo's reading against: {why}"
    )


if TYPE_CHECKING:  # mypy checks every engine against the protocols it answers (nothing runs here)
    from .drake import DrakeSource
    from .mujoco import MujocoSource
    from .pinocchio import PinocchioSource
    from .symbolic import SymbolicSource
    from .warp import WarpSource

    _SOURCES: tuple[type[Source], ...] = (HandSource, MujocoSource, PinocchioSource, SymbolicSource, DrakeSource)
    _WITH_WARP: tuple[type[Source], ...] = (WarpSource, MappedSource)
    _POSED: tuple[type[PosedSource], ...] = (MujocoSource, PinocchioSource, SymbolicSource, DrakeSource)
    _ONE_STATE: tuple[type[OneStateSource], ...] = (HandSource, PinocchioSource, SymbolicSource)
    _STEPPED: tuple[type[SteppedSource], ...] = (MujocoSource,)

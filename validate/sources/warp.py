"""MuJoCo Warp as a float32 source (a bench and study source, never one of the default sources: its
float32 would fail the float64 tiers). Owns MuJoCo Warp's quirks: one model per source, one Warp
`Data` of `nworld` worlds per batch size (a batch of N states is N worlds, every array float32), the
mass matrix in C MuJoCo's sparse layout (`d.M`, rows `M_rownnz`/`M_rowadr`/`M_colind`), and inputs set
exactly as C MuJoCo's source sets them (ctrl = tau / gear on an actuated coordinate, else
`qfrc_applied`). The coordinate maps (qpos/qvel addresses by joint name, the actuators) are C MuJoCo's
source's, so the two are read the same way.

`mujoco_warp` and `warp` are imported when a source is made (the optional extra `warp`); kernels are
compiled on first use and kept in Warp's kernel cache (`~/.cache/warp`, or `WARP_CACHE_PATH`).
"""

from __future__ import annotations

import time
import types
from collections.abc import Callable
from typing import TYPE_CHECKING, TypedDict

import numpy as np

from ..core.errors import HarnessError
from ..systems import System
from .base import INTEGRATOR_ENUMS, Source, engine_of
from .mujoco import MujocoSource

if TYPE_CHECKING:  # imported when a source is made (the optional extra)
    import mujoco_warp as mjw

OUTPUTS = ("M", "bias", "passive", "qacc", "tau_inverse")
EXTRA_MISSING = (
    "MuJoCo Warp is not installed: pip install 'lagrange-xval[warp]' (mujoco-warp 4.0.0 and warp-lang, a 149 MB wheel)"
)


class WarpRun(TypedDict):
    """`WarpSource.run`'s states: (N, samples, n) q and v, float64 of the float32 states, and the wall
    time per step after the first (s)."""

    q: np.ndarray
    v: np.ndarray
    step_s: float


def warp_modules() -> tuple[types.ModuleType, types.ModuleType]:
    """(warp, mujoco_warp), imported and initialised quietly; a HarnessError saying how to install them."""
    try:
        import mujoco_warp
        import warp
    except ImportError as exc:
        raise HarnessError(f"{EXTRA_MISSING} ({exc}).") from None
    warp.config.log_level = max(warp.config.log_level, warp.LOG_WARNING)  # no line per compiled module
    warp.init()
    return warp, mujoco_warp


def versions() -> dict[str, str]:
    """The installed versions of warp-lang and mujoco-warp."""
    wp, mjw = warp_modules()
    return {"warp-lang": str(wp.__version__), "mujoco-warp": str(mjw.__version__)}


def default_device() -> str:
    """Warp's preferred device: "cpu" where no GPU is present, else "cuda:0"."""
    wp, _ = warp_modules()
    return str(wp.get_preferred_device())


class WarpSource:
    """MuJoCo Warp at N states as N worlds, float32, on `device` (default: Warp's preferred device)."""

    name = "warp"

    def __init__(self, system: System, *, device: str | None = None) -> None:
        self.system = system
        self.wp, self.mjw = warp_modules()
        self.device = device or str(self.wp.get_preferred_device())
        self.c = MujocoSource(system)  # C MuJoCo's model and coordinate maps, shared
        self.m = self.c.m
        with self.wp.ScopedDevice(self.device):
            self.model = self.mjw.put_model(self.m)
        self._data: dict[int, mjw.Data] = {}
        self.first_call_s: dict[str, float] = {}  # first call of each kernel set, s (compiled or loaded from cache)

    @property
    def integrator(self) -> str:
        """The model's integrator by the harness's name ("Euler", "RK4", ...): the one Warp's `step` runs."""
        import mujoco

        enum = mujoco.mjtIntegrator(int(self.m.opt.integrator)).name
        return {v: k for k, v in INTEGRATOR_ENUMS.items()}.get(enum, enum)

    @property
    def timestep(self) -> float:
        return float(self.m.opt.timestep)

    # -- batches -------------------------------------------------------------------------------
    def data(self, n: int) -> mjw.Data:
        """The Warp `Data` with `n` worlds (made once per size)."""
        if n not in self._data:
            with self.wp.ScopedDevice(self.device):
                self._data[n] = self.mjw.make_data(self.m, nworld=n)
        return self._data[n]

    def _load(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray | None) -> mjw.Data:
        """A Data whose world i holds state i: qpos0 where no coordinate says otherwise, tau as inputs."""
        m, c, n = self.m, self.c, len(q)
        qpos = np.tile(m.qpos0, (n, 1))
        qpos[:, c.qadr] = q
        qvel = np.zeros((n, m.nv))
        qvel[:, c.dadr] = v
        ctrl, applied = c._inputs(np.zeros((n, m.nv)) if tau is None else tau)  # the maps C MuJoCo uses
        d = self.data(n)
        with self.wp.ScopedDevice(self.device):  # every world as made (time, activations, warm starts)
            self.mjw.reset_data(self.model, d)
        d.qpos.assign(qpos.astype(np.float32))
        d.qvel.assign(qvel.astype(np.float32))
        if m.nu:
            d.ctrl.assign(ctrl.astype(np.float32))
        d.qfrc_applied.assign(applied.astype(np.float32))
        return d

    def _timed(self, label: str, call: Callable[..., None], *args: object) -> None:
        """`call(*args)` on the device, waited for; its first call's time kept in `first_call_s`."""
        start = time.perf_counter()
        with self.wp.ScopedDevice(self.device):
            call(*args)
            self.wp.synchronize_device(self.device)
        self.first_call_s.setdefault(label, time.perf_counter() - start)

    def _dense_m(self, d: mjw.Data) -> np.ndarray:
        """(N, nv, nv) float64 from Warp's sparse rows (C MuJoCo's layout, as mj_fullM scatters it)."""
        sparse = d.M.numpy().astype(float)
        out = np.zeros((len(sparse), self.m.nv, self.m.nv))
        out[:, self.c.m_rows, self.c.m_cols] = sparse
        out[:, self.c.m_cols, self.c.m_rows] = sparse
        return out

    def evaluate(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, a_ref: np.ndarray | None = None, **_: object
    ) -> dict[str, np.ndarray]:
        """M, bias, passive and qacc at tau by one `forward` over N worlds; with `a_ref`, tau_inverse
        by `inverse` at those accelerations. Float32 values, returned as float64 in the coordinates."""
        d = self._load(q, v, tau)
        self._timed("forward", self.mjw.forward, self.model, d)
        dsel = self.c.dadr
        out = {
            "M": self._dense_m(d)[:, dsel][:, :, dsel],
            "bias": d.qfrc_bias.numpy().astype(float)[:, dsel],
            "passive": d.qfrc_passive.numpy().astype(float)[:, dsel],
            "qacc": d.qacc.numpy().astype(float)[:, dsel],
        }
        if a_ref is not None:
            accel = np.zeros((len(q), self.m.nv))
            accel[:, dsel] = a_ref
            d.qacc.assign(accel.astype(np.float32))
            self._timed("inverse", self.mjw.inverse, self.model, d)
            out["tau_inverse"] = d.qfrc_inverse.numpy().astype(float)[:, dsel]
        return out

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        return self.evaluate(q, np.zeros_like(q), np.zeros_like(q))["M"]

    def bias(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self.evaluate(q, v, np.zeros_like(q))["bias"]

    def passive(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self.evaluate(q, v, np.zeros_like(q))["passive"]

    def forward(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        return self.evaluate(q, v, tau)["qacc"]

    def inverse(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        return self.evaluate(q, v, np.zeros_like(q), a)["tau_inverse"]

    def energies(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        raise HarnessError("the MuJoCo Warp source gives M, bias, passive, qacc and tau_inverse, not energies.")

    def body_positions(self, q: np.ndarray) -> np.ndarray:
        raise HarnessError("the MuJoCo Warp source gives M, bias, passive, qacc and tau_inverse, not body positions.")

    # -- trajectories --------------------------------------------------------------------------
    def run(self, q0: np.ndarray, v0: np.ndarray, tau: np.ndarray, samples: int, steps: int) -> WarpRun:
        """MuJoCo Warp's own `step` (the model's integrator and timestep) from (q0, v0) (each (N, n):
        N runs as N worlds), `samples` states `steps` steps apart, the first the start.

        Returns {"q", "v": (N, samples, n) float64 of the float32 states, "step_s": wall time per
        step after the first (compilation excluded)}."""
        d = self._load(np.atleast_2d(q0), np.atleast_2d(v0), np.atleast_2d(tau))
        n_runs, n = d.nworld, self.c.system.nv
        qs, vs = np.empty((n_runs, samples, n)), np.empty((n_runs, samples, n))
        qs[:, 0], vs[:, 0] = np.atleast_2d(q0), np.atleast_2d(v0)
        self._timed("step", self.mjw.step, self.model, d)  # the first step compiles; it counts as a step
        done, start = 1, time.perf_counter()
        with self.wp.ScopedDevice(self.device):
            for k in range(1, samples):
                for _ in range(steps - done):
                    self.mjw.step(self.model, d)
                done = 0
                qs[:, k] = d.qpos.numpy().astype(float)[:, self.c.qadr]  # numpy() waits for the device
                vs[:, k] = d.qvel.numpy().astype(float)[:, self.c.dadr]
        total = max(1, (samples - 1) * steps - 1)
        return {"q": qs, "v": vs, "step_s": (time.perf_counter() - start) / total}


def run_in_coordinates(
    system: System, source: Source, q0: np.ndarray, v0: np.ndarray, tau: np.ndarray, *, samples: int, steps: int
) -> WarpRun:
    """Warp's own run in the system's coordinates: it steps in the joints' (`WarpSource.run`), so where
    the coordinates map them (JOINT_MAP: q = A q_joints, tau_joints = A^T tau) the start goes in mapped
    and the states come back mapped (`source` may be the mapped adapter around a WarpSource)."""
    engine = engine_of(source, WarpSource)
    A = system.joint_map
    if A is None:
        return {**engine.run(q0, v0, tau, samples, steps)}

    Ainv = np.linalg.inv(A)
    run = engine.run(Ainv @ q0, Ainv @ v0, A.T @ tau, samples, steps)
    return {**run, "q": run["q"] @ A.T, "v": run["v"] @ A.T}

"""MuJoCo as a source. Owns MuJoCo's quirks: qpos/qvel addresses by joint name, the dense mass
matrix from `mj_fullM`, inputs as actuator controls (or `qfrc_applied` where no actuator drives a
coordinate), `d.energy` only with the energy flag, and `qfrc_inverse` already net of passive forces.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path
from typing import TypedDict

import mujoco
import numpy as np

from ..core.arrays import Matrix
from ..core.errors import HarnessError, unknown_name
from ..model.scope import joint_actuators
from ..model.start import Scheme, Start
from ..systems import System
from .base import INTEGRATOR_ENUMS, MUJOCO_INTEGRATORS, Kinematics, SteppedSource, batch_threads

# What a batch sets per state with one mj_setState call (in this order in a state row).
STATE_SPEC = int(
    mujoco.mjtState.mjSTATE_QPOS
    | mujoco.mjtState.mjSTATE_QVEL
    | mujoco.mjtState.mjSTATE_CTRL
    | mujoco.mjtState.mjSTATE_QFRC_APPLIED
)
# From this many states mj_forward runs in MuJoCo's batch (making one costs about 0.5 ms, 400 states' loop).
BATCH_MIN_STATES = 256
OUTPUTS = ("M", "bias", "passive", "qacc", "tau_inverse", "T", "V", "body_positions", "body_rotations")
# Each output's array in MjData, copied whole per state: (mjData field, row shape from the model).
RAW_OF = {
    "M": "M",
    "bias": "qfrc_bias",
    "passive": "qfrc_passive",
    "qacc": "qacc",
    "tau_inverse": "qfrc_inverse",
    "T": "energy",
    "V": "energy",
    "body_positions": "xipos",
    "body_rotations": "xmat",
}
ROW_SHAPES = {
    "M": lambda m: (m.nv, m.nv),
    "qfrc_bias": lambda m: (m.nv,),
    "qfrc_passive": lambda m: (m.nv,),
    "qacc": lambda m: (m.nv,),
    "qfrc_inverse": lambda m: (m.nv,),
    "energy": lambda m: (2,),
    "xipos": lambda m: (m.nbody, 3),
    "xmat": lambda m: (m.nbody, 9),
}


def _rows(
    m: mujoco.MjModel,
    d: mujoco.MjData,
    states: np.ndarray,
    accel: np.ndarray | None,
    out: dict[str, np.ndarray],
    lo: int,
    hi: int,
) -> None:
    """States lo..hi-1 of a batch into `out` (keys of ROW_SHAPES): per state one mj_setState, mj_forward
    (when anything but the inverse dynamics is asked for), mj_fullM, copies of whole MjData arrays, and
    for "qfrc_inverse" qacc = accel and mj_inverse. Nothing else runs in the loop: it is the engine's
    calls plus a copy per output (the bench's pointwise ratio measures what that adds)."""
    set_state, forward, full_m, inverse = mujoco.mj_setState, mujoco.mj_forward, mujoco.mj_fullM, mujoco.mj_inverse
    views = {k: getattr(d, k) for k in out if k not in ("M", "qfrc_inverse")}
    copies = [(out[k], views[k]) for k in views]
    M = out.get("M")
    inv = out.get("qfrc_inverse")
    needs_forward = M is not None or bool(copies)
    qacc, qfrc_inverse = d.qacc, d.qfrc_inverse
    for i in range(lo, hi):
        set_state(m, d, states[i], STATE_SPEC)
        if needs_forward:
            forward(m, d)
            if M is not None:
                full_m(m, d, M[i])
            for dst, src in copies:
                dst[i] = src
        if inv is not None:
            qacc[:] = accel[i]  # type: ignore[index]
            inverse(m, d)  # qfrc_inverse does not depend on ctrl or qfrc_applied
            inv[i] = qfrc_inverse


def _dof_mismatch(system: System, model: mujoco.MjModel) -> str:
    """Why the model and the equations cannot be compared: their counts, the module by its own file, and
    for a URDF with joints the equations leave out, the --lock that makes them fixed."""
    where = getattr(system.equations, "__file__", None)
    module = Path(where).name if where else f"equations/{system.name}.py"
    text = (
        f"{system.mjcf.name} has {model.nv} degrees of freedom; {module} has {system.nv} "
        f"({', '.join(system.coordinates)})"
    )
    joints = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint#{j}" for j in range(model.njnt)]
    extra = [j for j in joints if j not in system.joints]
    urdf = system.mjcf.suffix.lower() == ".urdf"
    if urdf and model.nv > system.nv and extra and set(system.joints) <= set(joints):
        text += f"; to compare the joints your equations move, lock the others: --lock {','.join(extra)}"
    return text + "."


class MujocoSource:
    name = "mujoco"

    def __init__(self, system: System) -> None:
        self.system = system
        self.m = system.mujoco_model()
        self.m.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
        self.d = mujoco.MjData(self.m)
        n = system.nv
        if self.m.nv != n:
            raise HarnessError(_dof_mismatch(system, self.m))
        ids = []
        for j in system.joints:
            jid = mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_JOINT, j)
            if jid < 0:
                raise HarnessError(f"{system.mjcf.name} has no joint '{j}' (equations/{system.name}.py JOINTS).")
            ids.append(jid)
        self.qadr = np.array([self.m.jnt_qposadr[j] for j in ids], dtype=int)
        self.dadr = np.array([self.m.jnt_dofadr[j] for j in ids], dtype=int)
        body_ids: list[int] = []
        for b in system.bodies:
            bid = mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_BODY, b)
            if bid < 0:
                raise HarnessError(f"{system.mjcf.name} has no body '{b}' (equations/{system.name}.py BODIES).")
            body_ids.append(bid)
        self.body_ids = np.array(body_ids, dtype=int)
        # Inputs: a coordinate driven by a joint actuator takes tau through ctrl = tau / gear.
        self.ctrl_of_coord = np.full(n, -1)
        self.gear = np.ones(n)
        actuation_on = not (self.m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_ACTUATION))
        for a in joint_actuators(self.m) if actuation_on else []:
            dof = self.m.jnt_dofadr[self.m.actuator_trnid[a, 0]]
            (k,) = np.nonzero(self.dadr == dof)[0][:1] if np.any(self.dadr == dof) else (None,)
            if k is not None:
                self.ctrl_of_coord[k] = a
                self.gear[k] = self.m.actuator_gear[a, 0]
        self.gravity = np.array(system.view["gravity"])
        # The common case: the coordinates are the model's only joints, in order.
        self.identity = (
            self.m.nq == n
            and self.m.nv == n
            and np.array_equal(self.qadr, np.arange(n))
            and np.array_equal(self.dadr, np.arange(n))
        )
        bids = self.body_ids
        consecutive = len(bids) > 0 and np.array_equal(bids, np.arange(bids[0], bids[0] + len(bids)))
        self.body_slice: slice | np.ndarray = slice(int(bids[0]), int(bids[0]) + len(bids)) if consecutive else bids
        # Batches: one state row (qpos, qvel, ctrl, qfrc_applied) per state, set by one mj_setState call.
        self.state_size = mujoco.mj_stateSize(self.m, STATE_SPEC)
        self.state0 = np.zeros(self.state_size)
        self.state0[: self.m.nq] = self.m.qpos0
        # MuJoCo's sparse M: row i holds columns M_colind[M_rowadr[i] : M_rowadr[i] + M_rownnz[i]] (j <= i).
        self.m_rows = np.repeat(np.arange(self.m.nv), self.m.M_rownnz)
        self.m_cols = np.array(self.m.M_colind)

    # -- state setting ------------------------------------------------------------------------
    def _set(self, q: np.ndarray, v: np.ndarray | None = None, tau: np.ndarray | None = None) -> None:
        d = self.d
        d.qpos[self.qadr] = q
        d.qvel[self.dadr] = 0.0 if v is None else v
        d.ctrl[:] = 0.0
        d.qfrc_applied[:] = 0.0
        if tau is not None:
            driven = self.ctrl_of_coord >= 0
            d.ctrl[self.ctrl_of_coord[driven]] = tau[driven] / self.gear[driven]
            d.qfrc_applied[self.dadr[~driven]] = tau[~driven]

    def set_state(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray | None = None) -> None:
        """Puts one state (and input) into `self.d` in the notes' coordinates."""
        self._set(q, v, tau)

    def get_state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.d.qpos[self.qadr].copy(), self.d.qvel[self.dadr].copy()

    # -- dynamics -----------------------------------------------------------------------------
    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        return self._batch(q, np.zeros_like(q), None, None, ("M",))["M"]

    def bias(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._batch(q, v, None, None, ("bias",))["bias"]

    def passive(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._batch(q, v, None, None, ("passive",))["passive"]

    def forward(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        return self._batch(q, v, tau, None, ("qacc",))["qacc"]

    def inverse(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        return self._batch(q, v, None, a, ("tau_inverse",))["tau_inverse"]

    def energies(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        out = self._batch(q, v, None, None, ("T", "V"))
        return out["T"], out["V"]

    def evaluate(
        self,
        q: np.ndarray,
        v: np.ndarray,
        tau: np.ndarray,
        a_ref: np.ndarray | None = None,
        *,
        threads: int | None = None,
    ) -> dict[str, np.ndarray]:
        """Every pointwise quantity in one pass: one mj_forward and one mj_inverse per state.

        `qacc` is the forward dynamics at tau; `tau_inverse` the inverse dynamics at `a_ref`. From
        BATCH_MIN_STATES states mj_forward runs in MuJoCo's batch on `threads` threads (default
        `batch_threads`); the inverse dynamics one call per state. Without `a_ref`, at its own `qacc`."""
        if a_ref is None:
            a_ref = self.forward(q, v, tau)
        return self._batch(q, v, tau, a_ref, OUTPUTS, threads=threads)

    def _batch(
        self,
        q: np.ndarray,
        v: np.ndarray,
        tau: np.ndarray | None,
        a: np.ndarray | None,
        want: tuple[str, ...],
        *,
        threads: int | None = None,
    ) -> dict[str, np.ndarray]:
        """The quantities `want` (of OUTPUTS) at N states: inputs mapped to MuJoCo's state rows for all
        states at once; mj_forward's outputs by MuJoCo's batch (`_forward_batch`) or, for fewer than
        BATCH_MIN_STATES states, the per-state loop `_rows` (the reference path: the two are equal bit
        for bit, tests/unit/sources/test_base.py); the coordinates' columns and the bodies selected after."""
        m = self.m
        n = len(q)
        states = np.empty((n, self.state_size))
        states[:] = self.state0
        states[:, self.qadr] = q
        states[:, m.nq + self.dadr] = v
        if tau is not None:
            ctrl, applied = self._inputs(tau)
            states[:, m.nq + m.nv : m.nq + m.nv + m.nu] = ctrl
            states[:, m.nq + m.nv + m.nu :] = applied
        accel = None
        if a is not None:
            accel = np.zeros((n, m.nv))
            accel[:, self.dadr] = a
        fields = {RAW_OF[w] for w in want}
        raw: dict[str, np.ndarray] = {}
        ahead = fields - {"qfrc_inverse"}  # what mj_forward computes
        if ahead and n >= BATCH_MIN_STATES:
            raw.update(self._forward_batch(states, ahead, threads))
        elif ahead:
            raw.update({k: np.empty((n, *ROW_SHAPES[k](m))) for k in ahead})
            _rows(m, self.d, states, None, raw, 0, n)
        if "qfrc_inverse" in fields:  # mujoco.batch has no mj_inverse: one call per state
            inverse = {"qfrc_inverse": np.empty((n, m.nv))}
            _rows(m, self.d, states, accel, inverse, 0, n)
            raw.update(inverse)
        out: dict[str, np.ndarray] = {}
        dsel = slice(None) if self.identity else self.dadr
        for w in want:
            x = raw[RAW_OF[w]]
            if w == "M":
                out[w] = x if self.identity else x[:, self.dadr][:, :, self.dadr]
            elif w in ("T", "V"):
                out[w] = x[:, 1] if w == "T" else x[:, 0]
            elif w == "body_positions":
                out[w] = x[:, self.body_slice]
            elif w == "body_rotations":
                out[w] = x[:, self.body_slice].reshape(n, -1, 3, 3)
            else:
                out[w] = x[:, dsel]
        return out

    def _forward_batch(self, states: np.ndarray, fields: set[str], threads: int | None) -> dict[str, np.ndarray]:
        """mj_forward at every state row by MuJoCo's own batch (`mujoco.batch`: C loops on a thread pool,
        bit-identical to a loop over one MjData at any thread count), the fields of ROW_SHAPES copied
        out by it; the dense M scattered from MuJoCo's sparse rows as mj_fullM does."""
        from mujoco import batch  # MuJoCo 4's batched simulations

        m, n = self.m, len(states)
        runner = batch.Batch(m, nsim=n, nthread=threads or batch_threads(n))
        bound = {k: runner.bind(k) for k in fields}
        runner.qpos[:] = states[:, : m.nq]
        runner.qvel[:] = states[:, m.nq : m.nq + m.nv]
        if m.nu:
            runner.ctrl[:] = states[:, m.nq + m.nv : m.nq + m.nv + m.nu]
        runner.qfrc_applied[:] = states[:, m.nq + m.nv + m.nu :]
        runner.forward()
        out = {k: np.array(x) for k, x in bound.items() if k != "M"}
        if "M" in fields:
            out["M"] = np.zeros((n, m.nv, m.nv))
            out["M"][:, self.m_rows, self.m_cols] = bound["M"]
            out["M"][:, self.m_cols, self.m_rows] = bound["M"]
        for k in ("xipos", "xmat"):
            if k in out:
                out[k] = out[k].reshape(n, *ROW_SHAPES[k](m))
        return out

    def _inputs(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(ctrl (N, nu), qfrc_applied (N, nv)) carrying tau: actuated coordinates through ctrl = tau / gear."""
        ctrl, applied = np.zeros((len(tau), self.m.nu)), np.zeros((len(tau), self.m.nv))
        driven = self.ctrl_of_coord >= 0
        ctrl[:, self.ctrl_of_coord[driven]] = tau[:, driven] / self.gear[driven]
        applied[:, self.dadr[~driven]] = tau[:, ~driven]
        return ctrl, applied

    def body_positions(self, q: np.ndarray) -> np.ndarray:
        return self.kinematics(q, np.zeros_like(q)).com_position

    def body_rotations(self, q: np.ndarray) -> np.ndarray:
        return self.kinematics(q, np.zeros_like(q)).rotation

    def kinematics(self, q: np.ndarray, v: np.ndarray) -> Kinematics:
        n, nb = len(q), len(self.body_ids)
        out = {k: np.empty((n, nb, 3)) for k in ("cp", "cv", "op", "ov", "w")}
        rot, ke, pe = np.empty((n, nb, 3, 3)), np.empty((n, nb)), np.empty((n, nb))
        res = np.zeros(6)
        m, d = self.m, self.d
        for i in range(n):
            self._set(q[i], v[i])
            mujoco.mj_forward(m, d)
            for k, b in enumerate(self.body_ids):
                out["cp"][i, k] = d.xipos[b]
                out["op"][i, k] = d.xpos[b]
                rot[i, k] = d.xmat[b].reshape(3, 3)
                mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, b, res, 0)
                out["w"][i, k], out["cv"][i, k] = res[:3], res[3:]
                mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_XBODY, b, res, 0)
                out["ov"][i, k] = res[3:]
                ri = d.ximat[b].reshape(3, 3)
                inertia_world = ri @ np.diag(m.body_inertia[b]) @ ri.T
                w = out["w"][i, k]
                ke[i, k] = 0.5 * m.body_mass[b] * out["cv"][i, k] @ out["cv"][i, k] + 0.5 * w @ inertia_world @ w
                pe[i, k] = -m.body_mass[b] * self.gravity @ d.xipos[b]
        return Kinematics(out["cp"], out["cv"], out["op"], out["ov"], rot, out["w"], ke, pe)


# ----------------------------------------------------------------------------------------------
# Stepping: the one place that calls mj_step, with the model's integrator and timestep swapped in
# for the call and restored after, and MuJoCo's warnings read (it resets the state after one).


def model_digest(m: mujoco.MjModel) -> str:
    """SHA-256 of a compiled model's binary (MJB) form: every number, option and flag it holds."""
    import hashlib

    buf = np.zeros(mujoco.mj_sizeModel(m), dtype=np.uint8)
    mujoco.mj_saveModel(m, None, buf)
    return hashlib.sha256(buf.tobytes()).hexdigest()


def integrator_enum(name: str) -> mujoco.mjtIntegrator:
    """MuJoCo's enum value for an integrator name; an unknown name lists the valid ones."""
    if name not in MUJOCO_INTEGRATORS:
        raise unknown_name("MuJoCo integrator", name, MUJOCO_INTEGRATORS)
    return getattr(mujoco.mjtIntegrator, INTEGRATOR_ENUMS[name])


def eulerdamp_active(model: mujoco.MjModel) -> bool:
    """Whether MuJoCo's Euler treats joint damping implicitly for this model (flags and damping)."""
    off = int(mujoco.mjtDisableBit.mjDSBL_EULERDAMP) | int(mujoco.mjtDisableBit.mjDSBL_DAMPER)
    return not (model.opt.disableflags & off) and bool(np.any(model.dof_damping > 0))


def warnings_raised(d: mujoco.MjData) -> list[tuple[str, int]]:
    """(name, last DOF) of every warning MuJoCo counted in `d` (after one it resets the state)."""
    return [(mujoco.mjtWarning(w).name, int(stat.lastinfo)) for w, stat in enumerate(d.warning) if stat.number]


@contextlib.contextmanager
def scheme(m: mujoco.MjModel, stepping: Scheme) -> Iterator[None]:
    """The model steps with `stepping` (its integrator at its timestep) inside the block; its own options after."""
    saved = (m.opt.integrator, m.opt.timestep)
    m.opt.integrator, m.opt.timestep = integrator_enum(stepping.integrator), float(stepping.timestep)
    try:
        yield
    finally:
        m.opt.integrator, m.opt.timestep = saved


def step_states(
    source: SteppedSource,
    q: np.ndarray,
    v: np.ndarray,
    tau: np.ndarray,
    stepping: Scheme,
    *,
    steps: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """`steps` calls of `mj_step` of `stepping` from each of N states, (N, n). A state from which MuJoCo
    warns (and resets) gives NaN rows, never the reset state as data."""
    m, d = source.m, source.d
    tau = np.broadcast_to(np.asarray(tau, dtype=float), np.shape(q))
    q_out, v_out = np.empty(np.shape(q)), np.empty(np.shape(v))
    with scheme(m, stepping):
        for i in range(len(q)):
            mujoco.mj_resetData(m, d)
            source.set_state(q[i], v[i], tau[i])
            mujoco.mj_step(m, d, nstep=steps)
            q_out[i], v_out[i] = source.get_state()
            if d.warning.number.any():  # the array view: a loop over d.warning costs 90 us
                q_out[i], v_out[i] = np.nan, np.nan
    return q_out, v_out


def free_run(
    source: SteppedSource, start: Start, samples: int, steps: int, stepping: Scheme
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[tuple[str, int]]]:
    """One run from `start`: `samples` states (the first is the start) `steps` steps of `stepping` apart.

    Returns q, v (samples, n), MuJoCo's own clock at each sample (a reset after a warning sets it back
    to zero) and the warnings raised; the caller decides which samples are data."""
    m, d = source.m, source.d
    q0, v0, tau = start.q0, start.v0, start.tau
    n = len(np.atleast_1d(q0))
    q, v, clock = np.empty((samples, n)), np.empty((samples, n)), np.empty(samples)
    with scheme(m, stepping):
        mujoco.mj_resetData(m, d)
        source.set_state(q0, v0, tau)
        q[0], v[0], clock[0] = q0, v0, d.time
        for k in range(1, samples):
            mujoco.mj_step(m, d, nstep=steps)
            q[k], v[k] = source.get_state()
            clock[k] = d.time
        raised = warnings_raised(d) if d.warning.number.any() else []
    return q, v, clock, raised


def axis_rotation(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """MuJoCo's rotation by each angle about the unit `axis`, (N, 3, 3)."""
    out = np.empty((len(angles), 3, 3))
    quat, mat = np.zeros(4), np.zeros(9)
    for i, ang in enumerate(angles):
        mujoco.mju_axisAngle2Quat(quat, axis, float(ang))
        mujoco.mju_quat2Mat(mat, quat)
        out[i] = mat.reshape(3, 3)
    return out


@contextlib.contextmanager
def disabled(m: mujoco.MjModel, flags: int) -> Iterator[None]:
    """The model steps with `opt.disableflags = flags` inside the block; its own flags after."""
    saved = m.opt.disableflags
    m.opt.disableflags = int(flags)
    try:
        yield
    finally:
        m.opt.disableflags = saved


def disable_flag_names(flags: int) -> list[str]:
    """The names of the disable bits set in `flags` ("contact", "gravity", ...)."""
    return sorted(
        k.removeprefix("mjDSBL_").lower()
        for k, v in mujoco.mjtDisableBit.__members__.items()
        if k != "mjNDISABLE" and flags & int(v)
    )


def steps_from(source: SteppedSource, start: Start, steps: int) -> None:
    """`steps` calls of `mj_step` from `start` with the model's current options (for timing)."""
    q0, v0, tau = start.q0, start.v0, start.tau
    mujoco.mj_resetData(source.m, source.d)
    source.set_state(np.asarray(q0, dtype=float), np.asarray(v0, dtype=float), np.asarray(tau, dtype=float))
    mujoco.mj_step(source.m, source.d, nstep=steps)


BAD_STATE_WARNINGS = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")


class TimedRun(TypedDict):
    """`timed_run`'s free run: (samples, n) q and v (NaN after a stop), its CPU and wall seconds, the
    sample where the deadline stopped it (None: not stopped), the bad-state warnings and MuJoCo's texts."""

    q: Matrix
    v: Matrix
    cpu_s: float
    wall_s: float
    stopped_at: int | None
    bad: list[str]
    printed: list[str]


class RolloutRun(TypedDict):
    """`rollout_run`'s free run: the first trajectory's (samples, n) q and v, whether the batch's were
    identical, the batch's CPU and wall seconds, the bad-state warnings and the threads used."""

    q: Matrix
    v: Matrix
    identical: bool
    cpu_s: float
    wall_s: float
    bad: list[str]
    threads: int


def timed_run(
    source: SteppedSource,
    start: Start,
    samples: int,
    steps: int,
    stepping: Scheme,
    *,
    deadline: float,
) -> TimedRun:
    """A free run for the benchmark: only the stepping loop is timed (CPU and wall), it stops at
    `deadline` (perf_counter), and MuJoCo's warning texts are collected instead of printed.

    Returns {"q", "v" (samples, n; NaN after a stop), "cpu_s", "wall_s", "stopped_at" (the sample
    index where the deadline hit, or None), "bad" (bad-state warnings raised), "printed" (texts)}."""
    q0, v0, tau = start.q0, start.v0, start.tau
    import time

    m, d = source.m, source.d
    qpos, qvel = np.full((samples, m.nq), np.nan), np.full((samples, m.nv), np.nan)
    printed: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda msg: printed.append(str(msg).strip()))
    stopped_at = None
    try:
        with scheme(m, stepping):
            mujoco.mj_resetData(m, d)
            source.set_state(np.asarray(q0, dtype=float), np.asarray(v0, dtype=float), np.asarray(tau, dtype=float))
            qpos[0], qvel[0] = d.qpos, d.qvel
            step, clock = mujoco.mj_step, time.perf_counter
            c0, w0 = time.process_time(), time.perf_counter()
            for k in range(1, samples):  # a copy of qpos and qvel per sample (~0.3 us each), no indexing
                step(m, d, nstep=steps)
                qpos[k] = d.qpos
                qvel[k] = d.qvel
                if clock() > deadline:
                    stopped_at = k
                    break
            cpu, wall = time.process_time() - c0, time.perf_counter() - w0
            bad = [w for w in BAD_STATE_WARNINGS if d.warning[int(getattr(mujoco.mjtWarning, w))].number > 0]
    finally:
        mujoco.set_mju_user_warning(previous)
    q, v = qpos[:, source.qadr], qvel[:, source.dadr]
    return {"q": q, "v": v, "cpu_s": cpu, "wall_s": wall, "stopped_at": stopped_at, "bad": bad, "printed": printed}


def rollout_run(
    source: SteppedSource,
    start: Start,
    samples: int,
    steps: int,
    stepping: Scheme,
    *,
    batch: int = 1,
    nthread: int | None = None,
) -> RolloutRun:
    """The same free run as `timed_run` through MuJoCo's multithreaded `mujoco.rollout` (C loops, no
    Python per step), for `batch` copies of the start at once; only the rollout call is timed.

    The state of every step is recorded (rollout has no stride), the samples are every `steps`-th.
    Returns {"q", "v" (samples, n) of the first trajectory, "identical" (every trajectory of the batch
    gave the same bits), "cpu_s", "wall_s" (the whole batch), "bad" (bad-state warnings), "threads"}."""
    q0, v0, tau = start.q0, start.v0, start.tau
    import time

    from mujoco import rollout

    m, d = source.m, source.d
    threads = max(1, min(batch, nthread or 1, os.cpu_count() or 1))
    spec = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
    control_spec = int(mujoco.mjtState.mjSTATE_CTRL) | int(mujoco.mjtState.mjSTATE_QFRC_APPLIED)
    with scheme(m, stepping):
        mujoco.mj_resetData(m, d)
        source.set_state(np.asarray(q0, dtype=float), np.asarray(v0, dtype=float), np.asarray(tau, dtype=float))
        x0 = np.empty(mujoco.mj_stateSize(m, spec))
        mujoco.mj_getState(m, d, x0, spec)
        u = np.empty(mujoco.mj_stateSize(m, control_spec))
        mujoco.mj_getState(m, d, u, control_spec)
        nstep = steps * (samples - 1)
        datas = [mujoco.MjData(m) for _ in range(threads)]
        out = np.empty((batch, nstep, len(x0)))
        initial = np.tile(x0, (batch, 1))
        control = np.tile(u, (batch, 1, 1))
        with rollout.Rollout(nthread=threads) as runner:
            c0, w0 = time.process_time(), time.perf_counter()
            runner.rollout(m, datas, initial, control, control_spec=control_spec, nstep=nstep, state=out)
            cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    bad = sorted(
        {w for dd in datas for w in BAD_STATE_WARNINGS if dd.warning[int(getattr(mujoco.mjtWarning, w))].number > 0}
    )
    states = np.concatenate([x0[None], out[0, steps - 1 :: steps]])  # time, qpos, qvel, ...
    qpos, qvel = states[:, 1 : 1 + m.nq], states[:, 1 + m.nq : 1 + m.nq + m.nv]
    return {
        "q": qpos[:, source.qadr],
        "v": qvel[:, source.dadr],
        "identical": bool(batch == 1 or (out == out[:1]).all()),
        "cpu_s": cpu,
        "wall_s": wall,
        "bad": bad,
        "threads": threads,
    }


@contextlib.contextmanager
def collected_warnings() -> Iterator[list[str]]:
    """MuJoCo prints each warning to stderr (and logs it to a file); inside the block the texts are
    collected in the list yielded instead."""
    seen: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda msg: seen.append(str(msg)))
    try:
        yield seen
    finally:
        mujoco.set_mju_user_warning(previous)


def sampled_run(
    source: SteppedSource,
    start: Start,
    chunks: int,
    sample_steps: int,
    stepping: Scheme,
    *,
    eulerdamp: bool = True,
) -> tuple[list[np.ndarray], list[np.ndarray], str | None, int | None]:
    """Up to `chunks` samples `sample_steps` steps apart, stopping at the first whose state MuJoCo
    warned about (it then resets the state) or that is not finite. `eulerdamp=False` disables Euler's
    implicit damping for the run. Returns the samples after the start (q, v lists), the failure (the
    warnings' names or "non-finite state") and the chunk where it happened, or None, None."""
    q0, v0, tau = start.q0, start.v0, start.tau
    m, d = source.m, source.d
    flags = int(m.opt.disableflags) | (0 if eulerdamp else int(mujoco.mjtDisableBit.mjDSBL_EULERDAMP))
    qs: list[np.ndarray] = []
    vs: list[np.ndarray] = []
    with scheme(m, stepping), disabled(m, flags):
        mujoco.mj_resetData(m, d)
        source.set_state(q0, v0, tau)
        for k in range(1, chunks + 1):
            mujoco.mj_step(m, d, nstep=sample_steps)
            q, v = source.get_state()
            warned = [name for name, _ in warnings_raised(d)]
            if warned or not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
                return qs, vs, ", ".join(warned) if warned else "non-finite state", k
            qs.append(q)
            vs.append(v)
    return qs, vs, None, None

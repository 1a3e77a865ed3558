"""The raw engine calls the pointwise check needs, written out by hand: the baseline of the
`pointwise_ratio` benchmark (how much the harness adds over calling the engines directly).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ..systems import System
from .base import Source, engine_of


class StateBatch(Protocol):
    """N states in the notes' coordinates (verdict/pointwise.States): (N, n) each."""

    @property
    def q(self) -> np.ndarray: ...
    @property
    def v(self) -> np.ndarray: ...
    @property
    def tau(self) -> np.ndarray: ...


def joint_coordinates(system: System, states: StateBatch, a: np.ndarray) -> tuple[np.ndarray, ...]:
    """q, v, a, tau in joint coordinates (engines see joints; JOINT_MAP maps them to the notes')."""
    A = system.joint_map
    if A is None:
        return states.q, states.v, a, states.tau
    Ainv = np.linalg.inv(A)
    return states.q @ Ainv.T, states.v @ Ainv.T, a @ Ainv.T, states.tau @ A


def to_notes(system: System, out: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    A = system.joint_map
    if A is None:
        return out
    Ainv = np.linalg.inv(A)
    out["M"] = Ainv.T @ out["M"] @ Ainv
    for k in ("bias", "passive", "tau_inverse"):
        out[k] = out[k] @ Ainv
    out["qacc"] = out["qacc"] @ A.T
    return out


def raw_mujoco(system: System, source: Source, states: StateBatch, a_ref: np.ndarray) -> dict[str, np.ndarray]:
    """Per state: write qpos/qvel/ctrl (or qfrc_applied), mj_forward, mj_fullM; write qacc = a_ref,
    mj_inverse. The same outputs as `MujocoSource.evaluate`, in the notes' coordinates."""
    import mujoco

    from .mujoco import MujocoSource

    qj, vj, aj, tauj = joint_coordinates(system, states, a_ref)
    n_states, n = qj.shape
    mj = engine_of(source, MujocoSource)
    m, d = mj.m, mj.d
    driven = mj.ctrl_of_coord >= 0
    ctrl = np.zeros((n_states, m.nu))
    ctrl[:, mj.ctrl_of_coord[driven]] = tauj[:, driven] / mj.gear[driven]
    applied = np.zeros((n_states, m.nv))
    applied[:, mj.dadr[~driven]] = tauj[:, ~driven]
    ident = np.array_equal(mj.qadr, np.arange(m.nq)) and np.array_equal(mj.dadr, np.arange(m.nv)) and m.nv == n
    qa: slice | np.ndarray = slice(None) if ident else mj.qadr
    da: slice | np.ndarray = slice(None) if ident else mj.dadr
    ix = np.ix_(mj.dadr, mj.dadr)
    bodies = mj.body_ids
    full = np.zeros((m.nv, m.nv))
    M, bias, passive = np.empty((n_states, n, n)), np.empty((n_states, n)), np.empty((n_states, n))
    qacc, tau_inv, energy = np.empty((n_states, n)), np.empty((n_states, n)), np.empty((n_states, 2))
    pos, rot = np.empty((n_states, len(bodies), 3)), np.empty((n_states, len(bodies), 9))
    forward, full_m, inverse = mujoco.mj_forward, mujoco.mj_fullM, mujoco.mj_inverse
    for i in range(n_states):
        d.qpos[qa] = qj[i]
        d.qvel[da] = vj[i]
        d.ctrl[:] = ctrl[i]
        d.qfrc_applied[:] = applied[i]
        forward(m, d)
        full_m(m, d, full)
        M[i] = full if ident else full[ix]
        bias[i], passive[i], qacc[i] = d.qfrc_bias[da], d.qfrc_passive[da], d.qacc[da]
        energy[i] = d.energy
        pos[i], rot[i] = d.xipos[bodies], d.xmat[bodies]
        d.qacc[da] = aj[i]
        d.ctrl[:] = 0.0
        d.qfrc_applied[:] = 0.0
        inverse(m, d)
        tau_inv[i] = d.qfrc_inverse[da]
    out = {
        "M": M,
        "bias": bias,
        "passive": passive,
        "qacc": qacc,
        "tau_inverse": tau_inv,
        "T": energy[:, 1],
        "V": energy[:, 0],
        "body_positions": pos,
        "body_rotations": rot.reshape(n_states, len(bodies), 3, 3),
    }
    return to_notes(system, out)


def raw_pinocchio(system: System, source: Source, states: StateBatch, a_ref: np.ndarray) -> dict[str, np.ndarray]:
    """Per state: crba (and T = 1/2 v^T M v on it, as the source counts T: computeKineticEnergy drops the
    armature of a hinge off the x, y, z axes), rnea at zero acceleration (the bias), aba, rnea,
    computePotentialEnergy (which also places the joints, read for the body poses). The same outputs as
    `PinocchioSource.evaluate`."""
    import pinocchio as pin

    qj, vj, aj, tauj = joint_coordinates(system, states, a_ref)
    n_states, n = qj.shape
    from .pinocchio import PinocchioSource

    pn = engine_of(source, PinocchioSource)
    model, data = pn.model, pn.data
    qfull, vfull, ffull, afull = pin.neutral(model), np.zeros(model.nv), np.zeros(model.nv), np.zeros(model.nv)
    vi, qi = pn.vidx, pn.qidx
    ix = np.ix_(vi, vi)
    passive = -pn.damping * vj
    zero = np.zeros(model.nv)
    local = pin.Convention.LOCAL  # as the harness's ABA (sources/pinocchio.py LOCAL)
    joints = pn.joint_of_body
    levers = [model.inertias[j].lever for j in joints]
    frame_rot = [model.frames[f].placement.rotation for f in pn.frames]
    M, bias, qacc, tau_inv = (
        np.empty((n_states, n, n)),
        np.empty((n_states, n)),
        np.empty((n_states, n)),
        np.empty((n_states, n)),
    )
    kin, pot = np.empty(n_states), np.empty(n_states)
    pos, rot = np.empty((n_states, len(joints), 3)), np.empty((n_states, len(joints), 3, 3))
    crba, aba, rnea = pin.crba, pin.aba, pin.rnea
    potential = pin.computePotentialEnergy
    for i in range(n_states):
        qfull[qi] = qj[i]
        vfull[vi] = vj[i]
        ffull[vi] = tauj[i] + passive[i]
        afull[vi] = aj[i]
        full = crba(model, data, qfull)
        full = np.triu(full) + np.triu(full, 1).T
        M[i] = full[ix]
        kin[i] = 0.5 * vfull @ full @ vfull
        bias[i] = rnea(model, data, qfull, vfull, zero)[vi]  # the non-linear effects: RNEA at a = 0
        qacc[i] = aba(model, data, qfull, vfull, ffull, convention=local)[vi]
        tau_inv[i] = rnea(model, data, qfull, vfull, afull)[vi]
        pot[i] = potential(model, data, qfull)
        for k, (jid, lever) in enumerate(zip(joints, levers, strict=True)):
            oMi = data.oMi[jid]
            pos[i, k] = oMi.act(lever)
            rot[i, k] = oMi.rotation @ frame_rot[k]
    out = {
        "M": M,
        "bias": bias,
        "passive": passive,
        "qacc": qacc,
        "tau_inverse": tau_inv - passive,
        "T": kin,
        "V": pot,
        "body_positions": pos,
        "body_rotations": rot,
    }
    return to_notes(system, out)


def raw_symbolic(system: System, source: Source, states: StateBatch) -> list[list[np.ndarray | float]]:
    """The derived equations' generated numpy code (dynamics and the bodies' kinematics) called once on
    the batch, nothing unpacked or solved: the least the symbolic source can cost."""
    from .symbolic import SymbolicSource

    sym = engine_of(source, SymbolicSource)
    q, v, _, _ = joint_coordinates(system, states, states.q)
    out = []
    for part in ("dynamics", "kinematics"):
        fn, params = sym.generated(part)
        out.append(fn(*q.T, *v.T, *params))
    return out

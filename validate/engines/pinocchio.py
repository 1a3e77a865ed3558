"""Pinocchio as a source: CRBA, RNEA (non-linear effects), ABA on the chain built from the same MJCF
or URDF (read natively by `buildModelFromXML`; validate/systems/urdf.py says what is aligned).

Owns Pinocchio's quirks: `buildModelFromMJCF` ignores `<option gravity>` (the MuJoCo-compiled
gravity is copied in) and joint damping (applied here as a generalized force, for URDF too), and its
configuration vector is indexed by Pinocchio's joint order, mapped here by MJCF joint names.
"""

from __future__ import annotations

import os
import tempfile
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import HarnessError
from ..systems.urdf import for_pinocchio
from .base import Kinematics


def build_model(system: Any) -> Any:
    """Pinocchio's model of the system's MJCF (with any overrides) or URDF, gravity copied from MuJoCo."""
    if system.reads_urdf:
        try:
            model = pin.buildModelFromXML(for_pinocchio(system.urdf_text(), system.mjcf.name))
        except Exception as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise HarnessError(f"{system.mjcf.name}: Pinocchio cannot build the model: {first}") from None
        model.gravity.linear = np.array(system.view["gravity"], dtype=float)
        return model
    xml = system.mjcf_xml()
    fd, path = tempfile.mkstemp(suffix=".xml", prefix=f"{system.name}_")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(xml)
        model = pin.buildModelFromMJCF(path)
    except Exception as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise HarnessError(f"{system.mjcf.name}: Pinocchio cannot build the model: {first}") from None
    finally:
        os.unlink(path)
    model.gravity.linear = np.array(system.view["gravity"], dtype=float)
    return model


class PinocchioSource:
    name = "pinocchio"

    def __init__(self, system: Any) -> None:
        self.system = system
        self.model = build_model(system)
        self.data = self.model.createData()
        n = system.nv
        if self.model.nv != n:
            raise HarnessError(
                f"Pinocchio sees {self.model.nv} degrees of freedom in {system.mjcf.name}; the equations have {n}."
            )
        qidx: list[int] = []
        vidx: list[int] = []
        for j in system.joints:
            if not self.model.existJointName(j):
                raise HarnessError(f"Pinocchio's model of {system.mjcf.name} has no joint '{j}'.")
            joint = self.model.joints[self.model.getJointId(j)]
            if joint.nq != 1 or joint.nv != 1:
                raise HarnessError(f"joint '{j}': only one-degree-of-freedom joints are supported.")
            qidx.append(joint.idx_q)
            vidx.append(joint.idx_v)
        self.qidx, self.vidx = np.array(qidx), np.array(vidx)
        self.damping = np.array([system.view[f"joint/{j}/damping"] for j in system.joints])
        self.frames, self.joint_of_body = [], []
        for b in system.bodies:
            if not self.model.existBodyName(b):
                raise HarnessError(
                    f"Pinocchio's model of {system.mjcf.name} has no body '{b}' (named bodies are required)."
                )
            fid = self.model.getBodyId(b)
            self.frames.append(fid)
            self.joint_of_body.append(self.model.frames[fid].parentJoint)
        self.gravity = np.array(system.view["gravity"], dtype=float)

    def _q(self, q: np.ndarray) -> np.ndarray:
        full = pin.neutral(self.model)
        full[self.qidx] = q
        return full

    def _v(self, v: np.ndarray) -> np.ndarray:
        full = np.zeros(self.model.nv)
        full[self.vidx] = v
        return full

    def joint_frames(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Pinocchio's reading of each compared joint at q = 0: its anchor in world coordinates and
        its motion (linear, angular) per unit velocity, world-aligned: a hinge's axis sits in the
        angular half, a slide's in the linear half."""
        q = self._q(np.zeros(len(self.qidx)))
        pin.computeJointJacobians(self.model, self.data, q)
        out = {}
        for j, v in zip(self.system.joints, self.vidx, strict=True):
            jid = self.model.getJointId(j)
            J = np.reshape(
                pin.getJointJacobian(self.model, self.data, jid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED), (6, -1)
            )
            out[j] = (np.array(self.data.oMi[jid].translation, dtype=float), np.array(J[:, v], dtype=float))
        return out

    def read_damping(self) -> np.ndarray:
        """The joint damping Pinocchio read from the file (its algorithms ignore it: see `passive`)."""
        return np.array(self.model.damping[self.vidx], dtype=float)

    def passive(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Joint damping, which Pinocchio's algorithms ignore, as a generalized force."""
        return -self.damping * v

    def rhs(self, tau: np.ndarray):
        """scipy's right-hand side on ABA, with no per-call work beyond the call and the damping."""
        n, model, data = len(tau), self.model, self.data
        qfull, vfull, tfull = pin.neutral(model), np.zeros(model.nv), np.zeros(model.nv)
        qidx, vidx, damping = self.qidx, self.vidx, self.damping

        def f(t: float, y: np.ndarray) -> np.ndarray:
            qfull[qidx] = y[:n]
            vfull[vidx] = y[n:]
            tfull[vidx] = tau - damping * y[n:]
            out = np.empty(2 * n)
            out[:n] = y[n:]
            out[n:] = pin.aba(model, data, qfull, vfull, tfull)[vidx]
            return out

        return f

    def damped_rhs(self, tau: np.ndarray, h: float):
        """The right-hand side of MuJoCo's Euler step with implicit joint damping on CRBA and RNEA:
        a = (M + h D)^-1 (tau - D v - nle(q, v)), one state per call (see validate/mirror.py)."""
        n, model, data = len(tau), self.model, self.data
        qfull, vfull = pin.neutral(model), np.zeros(model.nv)
        qidx, vidx, damping = self.qidx, self.vidx, self.damping
        ix, hd = np.ix_(vidx, vidx), np.diag(h * damping)

        def f(t: float, y: np.ndarray) -> np.ndarray:
            qfull[qidx] = y[:n]
            vfull[vidx] = y[n:]
            full = pin.crba(model, data, qfull)
            m = (np.triu(full) + np.triu(full, 1).T)[ix]
            rhs = tau - damping * y[n:] - pin.nonLinearEffects(model, data, qfull, vfull)[vidx]
            out = np.empty(2 * n)
            out[:n] = y[n:]
            out[n:] = np.linalg.solve(m + hd, rhs)
            return out

        return f

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        out = np.empty(q.shape + (q.shape[-1],))
        for i in range(len(q)):
            full = pin.crba(self.model, self.data, self._q(q[i]))
            full = np.triu(full) + np.triu(full, 1).T  # CRBA fills the upper triangle
            out[i] = full[np.ix_(self.vidx, self.vidx)]
        return out

    def bias(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        out = np.empty_like(q)
        for i in range(len(q)):
            out[i] = pin.nonLinearEffects(self.model, self.data, self._q(q[i]), self._v(v[i]))[self.vidx]
        return out

    def forward(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        out = np.empty_like(q)
        total = tau + self.passive(q, v)
        for i in range(len(q)):
            out[i] = pin.aba(self.model, self.data, self._q(q[i]), self._v(v[i]), self._v(total[i]))[self.vidx]
        return out

    def inverse(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        out = np.empty_like(q)
        for i in range(len(q)):
            out[i] = pin.rnea(self.model, self.data, self._q(q[i]), self._v(v[i]), self._v(a[i]))[self.vidx]
        return out - self.passive(q, v)

    def energies(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        kin, pot = np.empty(len(q)), np.empty(len(q))
        for i in range(len(q)):
            qi, vi = self._q(q[i]), self._v(v[i])
            kin[i] = pin.computeKineticEnergy(self.model, self.data, qi, vi)
            pot[i] = pin.computePotentialEnergy(self.model, self.data, qi)
        return kin, pot

    def evaluate(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, a_ref: np.ndarray) -> dict[str, np.ndarray]:
        """Every pointwise quantity in one pass: CRBA, NLE, ABA, RNEA and the energies per state."""
        model, data = self.model, self.data
        n, nb = q.shape
        M, bias, qacc, tau_inv = np.empty((n, nb, nb)), np.empty((n, nb)), np.empty((n, nb)), np.empty((n, nb))
        kin, pot = np.empty(n), np.empty(n)
        pos, rot = np.empty((n, len(self.frames), 3)), np.empty((n, len(self.frames), 3, 3))
        passive = -self.damping * v
        ix, vidx = np.ix_(self.vidx, self.vidx), self.vidx
        levers = [model.inertias[j].lever for j in self.joint_of_body]
        for i in range(n):
            qi, vi = self._q(q[i]), self._v(v[i])
            full = pin.crba(model, data, qi)
            M[i] = (np.triu(full) + np.triu(full, 1).T)[ix]
            bias[i] = pin.nonLinearEffects(model, data, qi, vi)[vidx]
            qacc[i] = pin.aba(model, data, qi, vi, self._v(tau[i] + passive[i]))[vidx]
            tau_inv[i] = pin.rnea(model, data, qi, vi, self._v(a_ref[i]))[vidx] - passive[i]
            kin[i] = pin.computeKineticEnergy(model, data, qi, vi)
            pot[i] = pin.computePotentialEnergy(model, data, qi)  # also places every joint (data.oMi)
            for k, (jid, lever) in enumerate(zip(self.joint_of_body, levers, strict=True)):
                oMi = data.oMi[jid]
                pos[i, k] = oMi.act(lever)
                rot[i, k] = oMi.rotation @ model.frames[self.frames[k]].placement.rotation
        return {
            "M": M,
            "bias": bias,
            "passive": passive,
            "qacc": qacc,
            "tau_inverse": tau_inv,
            "T": kin,
            "V": pot,
            "body_positions": pos,
            "body_rotations": rot,
        }

    def body_positions(self, q: np.ndarray) -> np.ndarray:
        return self.kinematics(q, np.zeros_like(q)).com_position

    def body_rotations(self, q: np.ndarray) -> np.ndarray:
        return self.kinematics(q, np.zeros_like(q)).rotation

    def kinematics(self, q: np.ndarray, v: np.ndarray) -> Kinematics:
        n, nb = len(q), len(self.frames)
        cp, cv, op, ov, w = (np.empty((n, nb, 3)) for _ in range(5))
        rot, ke, pe = np.empty((n, nb, 3, 3)), np.empty((n, nb)), np.empty((n, nb))
        model, data = self.model, self.data
        for i in range(n):
            pin.forwardKinematics(model, data, self._q(q[i]), self._v(v[i]))
            pin.updateFramePlacements(model, data)
            for k, (fid, jid) in enumerate(zip(self.frames, self.joint_of_body, strict=True)):
                inertia, oMi, vj = model.inertias[jid], data.oMi[jid], data.v[jid]
                frame = data.oMf[fid]
                fv = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
                op[i, k], rot[i, k], ov[i, k] = frame.translation, frame.rotation, fv.linear
                cp[i, k] = oMi.act(inertia.lever)
                w[i, k] = oMi.rotation @ vj.angular
                cv[i, k] = oMi.rotation @ (vj.linear + np.cross(vj.angular, inertia.lever))
                ke[i, k] = 0.5 * inertia.vtiv(vj)
                pe[i, k] = -inertia.mass * self.gravity @ cp[i, k]
        return Kinematics(cp, cv, op, ov, rot, w, ke, pe)


def axis_rotation(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Pinocchio's rotation by each angle about the unit `axis` (exp3), (N, 3, 3)."""
    out = np.empty((len(angles), 3, 3))
    for i, ang in enumerate(angles):
        out[i] = pin.exp3(axis * float(ang))
    return out

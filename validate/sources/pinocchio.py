"""Pinocchio as a source: CRBA, RNEA (non-linear effects), ABA on the chain built from the same MJCF
or URDF (read natively by `buildModelFromXML`; validate/model/urdf.py says what is aligned).

V is `computePotentialEnergy`: the bodies welded to the world are merged into the universe, whose
inertia it does not count (MuJoCo and Drake do): a constant, and V is compared up to a constant
(results.schema.SCALED_DEFINITION). T is 1/2 v^T M v on CRBA's M, the armature in it once
(`computeKineticEnergy` drops the armature of a hinge off the x, y, z axes: see `_per_state`).

Owns Pinocchio's quirks: `buildModelFromMJCF` ignores `<option gravity>` (the MuJoCo-compiled
gravity is copied in) and joint damping (applied here as a generalized force, for URDF too), and its
configuration vector is indexed by Pinocchio's joint order, mapped here by MJCF joint names.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from ..core.errors import HarnessError
from ..model.modelview import names, welded
from ..model.urdf import for_pinocchio
from ..systems import System
from .base import Kinematics
from .readers import failure

# ABA in Pinocchio's local convention, per state. Its C++ batch (`abaInParallel`) runs the world
# convention only, whose spatial inertias about the world origin lose accuracy with the lever arms:
# on double_pendulum_point with m2/50 and l2 = l1/20 (cond(M) 2e4) qacc differs from the symbolic
# equations by 1.3e-13 of its scale in the world convention against 1.4e-15 in the local one
# (tests/unit/verdict/test_no_false_alarm.py), so the batch's ~1 ms per 1,000 states does not pay.
LOCAL = pin.Convention.LOCAL


def build_model(system: System) -> pin.Model:
    """Pinocchio's model of the system's MJCF (with any overrides) or URDF, gravity copied from MuJoCo."""
    if system.reads_urdf:
        try:
            model = pin.buildModelFromXML(for_pinocchio(system.urdf_text(), system.mjcf.name))
        except Exception as exc:  # the library's own error, named with its likely cause (sources/readers.py)
            raise failure("pinocchio", system.mjcf.name, exc) from None
        model.gravity.linear = np.array(system.view["gravity"], dtype=float)
        return model
    xml = one_tree(system.mjcf_xml())
    fd, path = tempfile.mkstemp(suffix=".xml", prefix=f"{system.name}_")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(xml)
        model = pin.buildModelFromMJCF(path)
    except Exception as exc:  # the library's own error, named with its likely cause (sources/readers.py)
        raise failure("pinocchio", system.mjcf.name, exc, xml) from None
    finally:
        os.unlink(path)
    model.gravity.linear = np.array(system.view["gravity"], dtype=float)
    return model


WRAPPER = "pinocchio#world_bodies"  # the fixed body that gathers the world's bodies for Pinocchio's parser
TREES = ("body", "frame", "replicate")  # elements under <worldbody> that carry bodies


def one_tree(xml: str) -> str:
    """The MJCF with every body under <worldbody> gathered in one fixed body at the world's origin
    (WRAPPER): Pinocchio's MJCF parser reads the first body tree only (the others, and their joints, are
    dropped); a body without joints is welded to its parent, so the dynamics are unchanged. Unchanged
    where the world has one tree."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(xml)
    for world in root.iter("worldbody"):
        trees = [c for c in world if c.tag in TREES]
        if len(trees) > 1:
            wrapper = ET.Element("body", {"name": WRAPPER})
            world.insert(list(world).index(trees[0]), wrapper)
            for tree in trees:
                world.remove(tree)
                wrapper.append(tree)
            return ET.tostring(root, encoding="unicode")
    return xml


COMPOSITE = (
    "Composite_"  # Pinocchio's MJCF parser: the joints of one body as one composite joint, named after the first
)


def joint_indices(model: pin.Model, system: System) -> dict[str, tuple[int, int, int]]:
    """Each one-coordinate joint of Pinocchio's model by its MJCF name: (Pinocchio joint id, q index, v
    index). Several joints in one body (a planar root: slide x, slide z, hinge y) are one composite joint
    in Pinocchio, named after the first; its parts are the body's joints in MuJoCo's order."""
    out: dict[str, tuple[int, int, int]] = {}
    for jid in range(1, model.njoints):
        name, joint = model.names[jid], model.joints[jid]
        if name.startswith(COMPOSITE) and f"joint/{name[len(COMPOSITE) :]}/body" in system.view:
            body = system.view[f"joint/{name[len(COMPOSITE) :]}/body"]
            parts = [j for j in system.model_joints if system.view[f"joint/{j}/body"] == body]
            for k, part in enumerate(parts[: joint.nq] if joint.nq == joint.nv else []):
                out[part] = (jid, joint.idx_q + k, joint.idx_v + k)
        elif joint.nq == 1 and joint.nv == 1:
            out[name] = (jid, joint.idx_q, joint.idx_v)
    return out


class PinocchioSource:
    name = "pinocchio"

    def __init__(self, system: System) -> None:
        self.system = system
        self.model = build_model(system)
        self.data = self.model.createData()
        n = system.nv
        if self.model.nv != n:
            raise HarnessError(
                f"Pinocchio sees {self.model.nv} degrees of freedom in {system.mjcf.name}; the equations have {n}."
            )
        self.joint_ids = joint_indices(self.model, system)
        missing = [j for j in system.joints if j not in self.joint_ids]
        if missing:
            raise HarnessError(f"Pinocchio's model of {system.mjcf.name} has no joint '{missing[0]}'.")
        self.qidx = np.array([self.joint_ids[j][1] for j in system.joints], dtype=int)
        self.vidx = np.array([self.joint_ids[j][2] for j in system.joints], dtype=int)
        self.damping = np.array([system.view[f"joint/{j}/damping"] for j in system.joints])
        # Joint springs, which Pinocchio's algorithms ignore: a passive force and a potential energy here.
        self.stiffness = np.array([system.view[f"joint/{j}/stiffness"] for j in system.joints])
        refs = [f"joint/{j}/springref" for j in system.joints]
        self.springref = np.array([system.view[k] if k in system.view else 0.0 for k in refs])
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
        self.centres = self._centres()
        self.q_neutral = pin.neutral(self.model)
        self._pool: pin.ModelPool | None = None  # for the batched algorithms, made when first used

    def _q(self, q: np.ndarray) -> np.ndarray:
        full = pin.neutral(self.model)
        full[self.qidx] = q
        return full

    def _v(self, v: np.ndarray) -> np.ndarray:
        full = np.zeros(self.model.nv)
        full[self.vidx] = v
        return full

    def _columns(self, x: np.ndarray, idx: np.ndarray, base: np.ndarray) -> np.ndarray:
        """N states (N, n) as Pinocchio's full vectors in columns, (size, N) column-major (no copy
        when handed to the batched algorithms)."""
        rows = np.empty((len(x), len(base)))
        rows[:] = base
        rows[:, idx] = x
        return rows.T

    def _qs(self, q: np.ndarray) -> np.ndarray:
        return self._columns(q, self.qidx, self.q_neutral)

    def _vs(self, v: np.ndarray) -> np.ndarray:
        return self._columns(v, self.vidx, np.zeros(self.model.nv))

    def _in_c(self, algorithm: Callable[..., None], qs: np.ndarray, vs: np.ndarray, x: np.ndarray) -> np.ndarray:
        """RNEA at N states in one call: Pinocchio's C++ loop over the columns (`rneaInParallel` on one
        thread, so no OpenMP thread outlives the call; equal bit for bit to `rnea` called per state,
        tests/unit/sources/test_base.py). `qs`, `vs`: the states as `_qs`, `_vs` give them (built once per batch);
        x (N, n). Returns (N, n)."""
        if self._pool is None:
            self._pool = pin.ModelPool(self.model, 1)
        out = np.empty((qs.shape[1], self.model.nv))
        algorithm(1, self._pool, qs, vs, self._vs(x), out.T)
        return out[:, self.vidx]

    def _aba(self, qs: np.ndarray, vs: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """ABA at N states, one call per state in the local convention (see LOCAL). Returns (N, n)."""
        model, data, aba = self.model, self.data, pin.aba
        out = np.empty((qs.shape[1], model.nv))
        for i, (qi, vi, ti) in enumerate(zip(qs.T, vs.T, self._vs(tau).T, strict=True)):
            out[i] = aba(model, data, qi, vi, ti, convention=LOCAL)
        return out[:, self.vidx]

    def _centres(self) -> np.ndarray:
        """Each compared body's centre of mass in its joint's frame: Pinocchio's joint inertia's lever,
        except where bodies without a joint are welded to the body (Pinocchio adds them to the joint's
        inertia and keeps no inertia per body): there the body's own centre, as compiled, in its frame."""
        view = self.system.view
        carrying = welded(view)
        alone = {str(view[f"joint/{j}/body"]) for j in names(view, "joint", "body")} - set(carrying)
        out = []
        for b, jid, fid in zip(self.system.bodies, self.joint_of_body, self.frames, strict=True):
            # a body welded to its parent (no joint of its own) has no inertia in Pinocchio either: its
            # joint's is the rigid group's
            if b not in alone:
                out.append(self.model.frames[fid].placement.act(np.asarray(view[f"body/{b}/com"], dtype=float)))
            else:
                out.append(np.array(self.model.inertias[jid].lever, dtype=float))
        return np.array(out, dtype=float).reshape(-1, 3)

    def joint_frames(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Pinocchio's reading of each compared joint at q = 0: its anchor in world coordinates and
        its motion (linear, angular) per unit velocity, world-aligned: a hinge's axis sits in the
        angular half, a slide's in the linear half."""
        q = self._q(np.zeros(len(self.qidx)))
        pin.computeJointJacobians(self.model, self.data, q)
        out = {}
        for j, v in zip(self.system.joints, self.vidx, strict=True):
            jid = self.joint_ids[j][0]
            J = np.reshape(
                pin.getJointJacobian(self.model, self.data, jid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED), (6, -1)
            )
            out[j] = (np.array(self.data.oMi[jid].translation, dtype=float), np.array(J[:, v], dtype=float))
        return out

    def read_damping(self) -> np.ndarray:
        """The joint damping Pinocchio read from the file (its algorithms ignore it: see `passive`)."""
        return np.array(self.model.damping[self.vidx], dtype=float)

    def passive(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Joint damping and springs, which Pinocchio's algorithms ignore, as a generalized force."""
        return -self.damping * v - self.stiffness * (q - self.springref)

    def rhs(self, tau: np.ndarray):
        """scipy's right-hand side on ABA, with no per-call work beyond the call and the damping; ABA in
        the local convention, as `forward` runs it, so a run and its windows round alike."""
        n, model, data = len(tau), self.model, self.data
        qfull, vfull, tfull = pin.neutral(model), np.zeros(model.nv), np.zeros(model.nv)
        qidx, vidx, damping = self.qidx, self.vidx, self.damping

        def f(t: float, y: np.ndarray) -> np.ndarray:
            qfull[qidx] = y[:n]
            vfull[vidx] = y[n:]
            tfull[vidx] = tau - damping * y[n:]
            out = np.empty(2 * n)
            out[:n] = y[n:]
            out[n:] = pin.aba(model, data, qfull, vfull, tfull, convention=LOCAL)[vidx]
            return out

        return f

    def damped_rhs(self, tau: np.ndarray, h: float):
        """The right-hand side of MuJoCo's Euler step with implicit joint damping on CRBA and RNEA:
        a = (M + h D)^-1 (tau - D v - nle(q, v)), one state per call (see validate/dynamics/mirror.py)."""
        n, model, data = len(tau), self.model, self.data
        qfull, vfull, zero = pin.neutral(model), np.zeros(model.nv), np.zeros(model.nv)
        qidx, vidx, damping = self.qidx, self.vidx, self.damping
        ix, hd = np.ix_(vidx, vidx), np.diag(h * damping)
        lower = np.tril_indices(model.nv, -1)

        def f(t: float, y: np.ndarray) -> np.ndarray:
            qfull[qidx] = y[:n]
            vfull[vidx] = y[n:]
            full = np.array(pin.crba(model, data, qfull))
            full[lower] = full.T[lower]  # CRBA fills the upper triangle: mirrored, as `_symmetric` does
            m = full[ix]
            rhs = tau - damping * y[n:] - pin.rnea(model, data, qfull, vfull, zero)[vidx]  # as `bias`
            out = np.empty(2 * n)
            out[:n] = y[n:]
            out[n:] = np.linalg.solve(m + hd, rhs)
            return out

        return f

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """CRBA per state (it has no batched form), the stack symmetrised and selected at once."""
        model, data, crba = self.model, self.data, pin.crba
        full = np.empty((len(q), model.nv, model.nv))
        for i, qi in enumerate(self._qs(q).T):
            full[i] = crba(model, data, qi)
        return self._symmetric(full)

    def _symmetric(self, full: np.ndarray) -> np.ndarray:
        upper = np.triu(full)  # CRBA fills the upper triangle
        return (upper + np.swapaxes(np.triu(full, 1), -1, -2))[:, self.vidx][:, :, self.vidx]

    def bias(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """C(q, v) v + G(q): RNEA at zero acceleration, in Pinocchio's C++ loop over the states."""
        return self._in_c(pin.rneaInParallel, self._qs(q), self._vs(v), np.zeros_like(v))

    def forward(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        return self._aba(self._qs(q), self._vs(v), tau + self.passive(q, v))

    def inverse(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        return self._in_c(pin.rneaInParallel, self._qs(q), self._vs(v), a) - self.passive(q, v)

    def energies(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        out = self._per_state(self._qs(q), self._vs(v), poses=False)
        return out["T"], out["V"]

    def _per_state(self, qs: np.ndarray, vs: np.ndarray, *, poses: bool) -> dict[str, np.ndarray]:
        """What has no batched form in Pinocchio, one state at a time with nothing else in the loop:
        CRBA, forward kinematics, the potential energy from it and the joints' placements (`poses`: the
        bodies' positions and rotations composed after the loop, at once); T from CRBA's M."""
        model, data = self.model, self.data
        n, nb = qs.shape[1], len(self.frames)
        pot = np.empty(n)
        full = np.empty((n, model.nv, model.nv))
        R, p = np.empty((n, nb, 3, 3)), np.empty((n, nb, 3))
        fk, crba, potential = pin.forwardKinematics, pin.crba, pin.computePotentialEnergy
        placements, joints = data.oMi, self.joint_of_body if poses else []
        kin = np.empty(n)
        for i, (qi, vi) in enumerate(zip(qs.T, vs.T, strict=True)):
            upper = crba(model, data, qi)  # its upper triangle mirrored, as `_symmetric` does
            full[i] = np.triu(upper) + np.triu(upper, 1).T
            kin[i] = 0.5 * vi @ full[i] @ vi
            fk(model, data, qi, vi)
            pot[i] = potential(model, data)
            for k, jid in enumerate(joints):
                oMi = placements[jid]
                R[i, k] = oMi.rotation
                p[i, k] = oMi.translation
        # T = 1/2 v^T M v on CRBA's M, which holds each joint's armature (model.armature) once, as MuJoCo
        # counts T. Not computeKineticEnergy: in Pinocchio 4.1 it adds the armature of axis-aligned joints
        # (RX, RY, RZ) and drops that of a hinge on any other axis (RevoluteUnaligned: dm_control's ant,
        # 44% of T), so it is right on neither kind of model (tests/unit/sources/test_pinocchio_energy.py).
        springs = 0.5 * self.stiffness @ (qs[self.qidx] - self.springref[:, None]) ** 2
        out = {"T": kin, "V": pot + springs, "M": full[:, self.vidx][:, :, self.vidx]}
        if poses:
            levers = self.centres.reshape(nb, 3)
            frame_rot = np.array([model.frames[f].placement.rotation for f in self.frames]).reshape(nb, 3, 3)
            out["body_positions"] = np.einsum("nkij,kj->nki", R, levers) + p
            out["body_rotations"] = R @ frame_rot
        return out

    def evaluate(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, a_ref: np.ndarray | None = None
    ) -> dict[str, np.ndarray]:
        """Every pointwise quantity: RNEA (bias: at zero acceleration) in Pinocchio's C++ loop over the
        states; ABA (`_aba`), CRBA, forward kinematics and the energies per state (`_per_state`). The
        inverse dynamics at `a_ref`, or without it at its own `qacc`."""
        passive = self.passive(q, v)
        qs, vs = self._qs(q), self._vs(v)  # the states as Pinocchio's full vectors, once for every call
        out = self._per_state(qs, vs, poses=True)
        qacc = self._aba(qs, vs, tau + passive)
        return {
            "M": out["M"],
            "bias": self._in_c(pin.rneaInParallel, qs, vs, np.zeros_like(v)),
            "passive": passive,
            "qacc": qacc,
            "tau_inverse": self._in_c(pin.rneaInParallel, qs, vs, qacc if a_ref is None else a_ref) - passive,
            "T": out["T"],
            "V": out["V"],
            "body_positions": out["body_positions"],
            "body_rotations": out["body_rotations"],
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
                centre = self.centres[k]  # the body's own, where its joint carries welded bodies (`_centres`)
                cp[i, k] = oMi.act(centre)
                w[i, k] = oMi.rotation @ vj.angular
                cv[i, k] = oMi.rotation @ (vj.linear + np.cross(vj.angular, centre))
                ke[i, k] = 0.5 * inertia.vtiv(vj)
                pe[i, k] = -inertia.mass * self.gravity @ cp[i, k]
        return Kinematics(cp, cv, op, ov, rot, w, ke, pe)

    def regressor(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """Pinocchio's joint-torque regressor at N states in the harness's coordinates, (N, n, 10 k) for
        k moving joints: inverse dynamics = Y theta + armature a (`dynamic_parameters`, `armature`;
        joint damping and springs are `passive`, outside Y)."""
        model, data, regress = self.model, self.data, pin.computeJointTorqueRegressor
        qs, vs, acc = self._qs(q), self._vs(v), self._vs(a)
        out = np.empty((len(q), len(self.vidx), 10 * (model.njoints - 1)))
        for i in range(len(q)):
            # one joint: Pinocchio returns Y as a vector, its one row
            out[i] = np.reshape(regress(model, data, qs[:, i], vs[:, i], acc[:, i]), (model.nv, -1))[self.vidx]
        return out

    def dynamic_parameters(self) -> np.ndarray:
        """Each moving joint's 10 inertial parameters in its frame, (k, 10): m, m c (x, y, z) and the
        inertia about the joint's origin (xx, xy, yy, xz, yz, zz), Pinocchio's `toDynamicParameters`."""
        return np.array([self.model.inertias[j].toDynamicParameters() for j in range(1, self.model.njoints)])

    def armature(self) -> np.ndarray:
        """The joints' armature in the harness's order (in CRBA's M and RNEA, not in the regressor)."""
        return np.array(self.model.armature[self.vidx], dtype=float)

    def joint_bodies(self) -> list[tuple[str, ...]]:
        """The bodies (file names) each moving joint carries: its own and those welded to it."""
        frames = [f for f in self.model.frames if f.type == pin.FrameType.BODY and f.name != WRAPPER]
        return [tuple(f.name for f in frames if f.parentJoint == j) for j in range(1, self.model.njoints)]

    def joint_axes(self) -> list[np.ndarray | None]:
        """Each moving joint's rotation axis in its own frame, or None where it is not one hinge."""
        model, data = self.model, self.data
        pin.forwardKinematics(model, data, self.q_neutral)
        out: list[np.ndarray | None] = []
        for j in range(1, model.njoints):
            S = np.asarray(data.joints[j].S, dtype=float).reshape(6, -1)
            hinge = S.shape[1] == 1 and not S[:3].any() and S[3:].any()
            out.append(S[3:, 0] / np.linalg.norm(S[3:, 0]) if hinge else None)
        return out


def axis_rotation(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Pinocchio's rotation by each angle about the unit `axis` (exp3), (N, 3, 3)."""
    out = np.empty((len(angles), 3, 3))
    for i, ang in enumerate(angles):
        out[i] = pin.exp3(axis * float(ang))
    return out

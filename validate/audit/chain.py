"""The dynamics of a model's reading, in numpy alone (issue 33's two-file audit).

A `Reading` (validate/model/meaning.py) holds, at the reference configuration and in world
coordinates, each joint's screw (axis, anchor) and the rigid group it moves (mass, centre of mass,
inertia). That is all the product-of-exponentials form needs (Lynch and Park, Modern Robotics, 4.1 and
8.1): at a configuration q the group of joint k is moved by exp([S_1] q_1) ... exp([S_k] q_k), the
joints taken from the root down. From it: the joints' anchors and axes and the groups' centres of
mass at q (forward kinematics), the space Jacobian, M(q) = sum_k J_k^T diag(m_k, I_k) J_k + armature, the
gravity torques G(q) = -sum_k m_k J_vk^T g and the bias C(q, v) v + G(q) from the Jacobian's time
derivative (dS_i/dt = ad_{V_parent(i)} S_i). So two files are compared by what each means, with no
engine between the file and the numbers; tests/unit/audit/test_audit.py checks these against MuJoCo's own M and
bias on MuJoCo's reading of a chain.

Shapes: q, v (N, n) in `order(reading)`'s joint order; M (N, n, n); G, bias (N, n).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.meaning import Reading


def order(reading: Reading) -> list[str]:
    """The joints, each after the joint above it."""
    out: list[str] = []
    seen: set[str] = set()

    def visit(j: str) -> None:
        if j in seen or j not in reading.joints:
            return
        seen.add(j)
        visit(reading.joints[j].parent)
        out.append(j)

    for j in reading.joints:
        visit(j)
    return out


def _skew(w: np.ndarray) -> np.ndarray:
    """(N, 3) -> (N, 3, 3)."""
    z = np.zeros(len(w))
    return np.stack(
        [
            np.stack([z, -w[:, 2], w[:, 1]], -1),
            np.stack([w[:, 2], z, -w[:, 0]], -1),
            np.stack([-w[:, 1], w[:, 0], z], -1),
        ],
        1,
    )


def _exp(w: np.ndarray, v: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """exp([S] theta) for the unit screw S = (w, v) (a hinge: |w| = 1; a slide: w = 0), N angles."""
    n = len(theta)
    if not np.any(w):
        return np.broadcast_to(np.eye(3), (n, 3, 3)).copy(), np.outer(theta, v)
    W = _skew(np.broadcast_to(w, (n, 3)))
    s, c = np.sin(theta)[:, None, None], np.cos(theta)[:, None, None]
    R = np.eye(3) + s * W + (1 - c) * (W @ W)
    p = np.einsum("nij,j->ni", np.eye(3) - R, np.cross(w, v)) + np.outer(theta, w * (w @ v))
    return R, p


@dataclass(frozen=True)
class Chain:
    """The reading's joints in order, their screws at the reference, each joint's parent index."""

    joints: list[str]
    w: np.ndarray  # (n, 3) rotation axis (0 for a slide)
    v: np.ndarray  # (n, 3) linear part of the space screw
    parent: list[int]  # index of the joint above (-1: the world)
    anchor: np.ndarray  # (n, 3)
    axis: np.ndarray  # (n, 3)
    mass: np.ndarray  # (n,)
    com: np.ndarray  # (n, 3)
    inertia: np.ndarray  # (n, 3, 3)
    gravity: np.ndarray  # (3,)
    armature: np.ndarray  # (n,) kg m^2 or kg, on M's diagonal


def chain(reading: Reading) -> Chain:
    joints = order(reading)
    index = {j: i for i, j in enumerate(joints)}
    r = [reading.joints[j] for j in joints]
    hinge = np.array([x.kind == "hinge" for x in r])
    axis = np.array([x.axis / np.linalg.norm(x.axis) for x in r]).reshape(-1, 3)
    anchor = np.array([x.anchor for x in r]).reshape(-1, 3)
    w = axis * hinge[:, None]
    v = np.where(hinge[:, None], np.cross(anchor, axis), axis)  # a hinge: -w x anchor; a slide: its direction
    g = [reading.groups[j] for j in joints]
    return Chain(
        joints=joints,
        w=w,
        v=v,
        parent=[index.get(x.parent, -1) for x in r],
        anchor=anchor,
        axis=axis,
        mass=np.array([x.mass for x in g]),
        com=np.array([x.com for x in g]).reshape(-1, 3),
        inertia=np.array([x.inertia for x in g]).reshape(-1, 3, 3),
        gravity=np.asarray(reading.gravity, dtype=float),
        armature=np.array([x.armature for x in r]),
    )


@dataclass(frozen=True)
class State:
    """At N configurations: each joint's frame product (R, p) of the exponentials up to its parent
    (`Rp`, `pp`) and up to itself (`R`, `p`), and the space screws S'_i = Ad(parent) S_i (w, v)."""

    Rp: np.ndarray
    pp: np.ndarray
    R: np.ndarray
    p: np.ndarray
    w: np.ndarray  # (N, n, 3)
    v: np.ndarray  # (N, n, 3)


def state(c: Chain, q: np.ndarray) -> State:
    N, n = q.shape
    Rp, pp = np.empty((N, n, 3, 3)), np.empty((N, n, 3))
    R, p = np.empty((N, n, 3, 3)), np.empty((N, n, 3))
    for i in range(n):
        k = c.parent[i]
        Rp[:, i] = np.eye(3) if k < 0 else R[:, k]
        pp[:, i] = 0.0 if k < 0 else p[:, k]
        Re, pe = _exp(c.w[i], c.v[i], q[:, i])
        R[:, i] = Rp[:, i] @ Re
        p[:, i] = np.einsum("nij,nj->ni", Rp[:, i], pe) + pp[:, i]
    w = np.einsum("nkij,kj->nki", Rp, c.w)
    v = np.einsum("nkij,kj->nki", Rp, c.v) + np.cross(pp, w)
    return State(Rp, pp, R, p, w, v)


def kinematics(c: Chain, q: np.ndarray) -> dict[str, np.ndarray]:
    """Each joint's anchor and axis and each group's centre of mass in the world at q, (N, n, 3)."""
    s = state(c, q)
    return {
        "anchor": np.einsum("nkij,kj->nki", s.Rp, c.anchor) + s.pp,
        "axis": np.einsum("nkij,kj->nki", s.Rp, c.axis),
        "com": np.einsum("nkij,kj->nki", s.R, c.com) + s.p,
    }


def _moves(c: Chain) -> np.ndarray:
    """(n, n) boolean: joint i moves group k (i is k or above it)."""
    n = len(c.joints)
    out = np.eye(n, dtype=bool)
    for k in range(n):
        i = c.parent[k]
        while i >= 0:
            out[i, k] = True
            i = c.parent[i]
    return out


def _jacobians(c: Chain, s: State, com: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Linear (at each group's centre of mass) and angular Jacobians, (N, n_groups, 3, n_joints)."""
    moves = _moves(c)
    Jv = np.cross(s.w[:, None, :, :], com[:, :, None, :]) + s.v[:, None, :, :]  # (N, k, i, 3)
    Jv = Jv * moves.T[None, :, :, None]
    Jw = np.broadcast_to(s.w[:, None, :, :], Jv.shape) * moves.T[None, :, :, None]
    return np.swapaxes(Jv, -1, -2), np.swapaxes(Jw, -1, -2)


def dynamics(c: Chain, q: np.ndarray, v: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """M (N, n, n), G (N, n) and, with velocities v, the bias C(q, v) v + G (N, n)."""
    s = state(c, q)
    com = np.einsum("nkij,kj->nki", s.R, c.com) + s.p
    inertia = s.R @ c.inertia @ np.swapaxes(s.R, -1, -2)
    Jv, Jw = _jacobians(c, s, com)
    M = np.einsum("k,nkai,nkaj->nij", c.mass, Jv, Jv) + np.einsum("nkai,nkab,nkbj->nij", Jw, inertia, Jw)
    M += np.diag(c.armature)
    G = -np.einsum("k,nkai,a->ni", c.mass, Jv, c.gravity)
    out = {"M": M, "G": G}
    if v is not None:
        out["bias"] = _bias(c, s, v, com, inertia, Jv, Jw) + G
    return out


def _bias(
    c: Chain, s: State, qd: np.ndarray, com: np.ndarray, inertia: np.ndarray, Jv: np.ndarray, Jw: np.ndarray
) -> np.ndarray:
    """C(q, v) v: each group's velocity-product accelerations (from dS'_i/dt = ad_{V_parent} S'_i)
    mapped back through the Jacobians."""
    N, n = qd.shape
    Vw, Vv = np.zeros((N, n, 3)), np.zeros((N, n, 3))  # each group's spatial velocity
    Aw, Av = np.zeros((N, n, 3)), np.zeros((N, n, 3))  # each group's J-dot v
    for i in range(n):
        k = c.parent[i]
        pw, pv = (Vw[:, k], Vv[:, k]) if k >= 0 else (np.zeros((N, 3)), np.zeros((N, 3)))
        aw, av = (Aw[:, k], Av[:, k]) if k >= 0 else (np.zeros((N, 3)), np.zeros((N, 3)))
        wi, vi, qi = s.w[:, i], s.v[:, i], qd[:, i : i + 1]
        Vw[:, i], Vv[:, i] = pw + wi * qi, pv + vi * qi
        Aw[:, i] = aw + np.cross(pw, wi) * qi
        Av[:, i] = av + (np.cross(pw, vi) + np.cross(pv, wi)) * qi
    ccom = np.cross(Vw, com) + Vv  # the centres' velocities
    acc = np.cross(Aw, com) + Av + np.cross(Vw, ccom)
    spin = np.einsum("nkab,nkb->nka", inertia, Aw) + np.cross(Vw, np.einsum("nkab,nkb->nka", inertia, Vw))
    return np.einsum("k,nkai,nka->ni", c.mass, Jv, acc) + np.einsum("nkai,nka->ni", Jw, spin)

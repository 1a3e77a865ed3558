"""Triple pendulum of rigid bars, relative angles theta, phi, psi (a student's derivation, issue 44).

Written in the absolute angles a = (theta, theta + phi, theta + phi + psi) with rates w = S v, S the
lower-triangular matrix of ones: M_abs[i, j] = K_ij cos(a_i - a_j), the velocity terms
c_i = sum_j K_ij sin(a_i - a_j) w_j^2 (so K23 sin(psi) w3^2 enters c2 with a minus) and gravity
g h_i sin(a_i); then M = S^T M_abs S and bias = S^T (c + G_abs) in the relative angles.
"""

from dataclasses import dataclass

import numpy as np
from lagrange_xval.forms import stack_matrix, stack_vector


@dataclass(frozen=True)
class Params:
    m1: float
    m2: float
    m3: float
    l1: float
    l2: float
    c1: float
    c2: float
    c3: float
    I1: float
    I2: float
    I3: float
    d1: float
    d2: float
    d3: float
    g: float


def parameters(model):
    return Params(
        m1=model["body/bar1/mass"],
        m2=model["body/bar2/mass"],
        m3=model["body/bar3/mass"],
        l1=-model["body/bar2/pos"][1],
        l2=-model["body/bar3/pos"][1],
        c1=-model["body/bar1/com"][1],
        c2=-model["body/bar2/com"][1],
        c3=-model["body/bar3/com"][1],
        I1=model["body/bar1/inertia"][2, 2],
        I2=model["body/bar2/inertia"][2, 2],
        I3=model["body/bar3/inertia"][2, 2],
        d1=model["joint/theta/damping"],
        d2=model["joint/phi/damping"],
        d3=model["joint/psi/damping"],
        g=-model["gravity"][1],
    )


def _k(p):
    K11 = p.m1 * p.c1**2 + p.I1 + (p.m2 + p.m3) * p.l1**2
    K22 = p.m2 * p.c2**2 + p.I2 + p.m3 * p.l2**2
    K33 = p.m3 * p.c3**2 + p.I3
    K12 = (p.m2 * p.c2 + p.m3 * p.l2) * p.l1
    K13 = p.m3 * p.c3 * p.l1
    K23 = p.m3 * p.c3 * p.l2
    return K11, K22, K33, K12, K13, K23


def _relative(rows):
    """S^T x for the three absolute rows x: the forces on theta, phi and psi."""
    r1, r2, r3 = rows
    return [r1 + r2 + r3, r2 + r3, r3]


def mass_matrix(p, q):
    K11, K22, K33, K12, K13, K23 = _k(p)
    phi, psi = q[..., 1], q[..., 2]
    one = np.ones(np.shape(q)[:-1])
    a = [
        [K11 * one, K12 * np.cos(phi), K13 * np.cos(phi + psi)],
        [K12 * np.cos(phi), K22 * one, K23 * np.cos(psi)],
        [K13 * np.cos(phi + psi), K23 * np.cos(psi), K33 * one],
    ]
    cols = [_relative([a[0][j], a[1][j], a[2][j]]) for j in range(3)]  # S^T A, column by column
    sta = [[cols[j][i] for j in range(3)] for i in range(3)]
    m = [[sta[i][0] + sta[i][1] + sta[i][2], sta[i][1] + sta[i][2], sta[i][2]] for i in range(3)]  # (S^T A) S
    return stack_matrix(m)


def bias(p, q, v):
    K11, K22, K33, K12, K13, K23 = _k(p)
    th, phi, psi = q[..., 0], q[..., 1], q[..., 2]
    w1, w2, w3 = v[..., 0], v[..., 0] + v[..., 1], v[..., 0] + v[..., 1] + v[..., 2]
    a1, a2, a3 = th, th + phi, th + phi + psi
    c1 = -K12 * np.sin(phi) * w2**2 - K13 * np.sin(phi + psi) * w3**2
    c2 = K12 * np.sin(phi) * w1**2 - K23 * np.sin(psi) * w3**2
    c3 = K13 * np.sin(phi + psi) * w1**2 + K23 * np.sin(psi) * w2**2
    h1 = p.m1 * p.c1 + (p.m2 + p.m3) * p.l1
    h2 = p.m2 * p.c2 + p.m3 * p.l2
    h3 = p.m3 * p.c3
    g1, g2, g3 = p.g * h1 * np.sin(a1), p.g * h2 * np.sin(a2), p.g * h3 * np.sin(a3)
    return stack_vector(_relative([c1 + g1, c2 + g2, c3 + g3]))


def passive(p, q, v):
    return stack_vector([-p.d1 * v[..., 0], -p.d2 * v[..., 1], -p.d3 * v[..., 2]])

"""Probe bodies drawn through the pseudo-inertia's log-Cholesky factor (validate/model/pseudo_inertia.py):
every draw is a rigid body (positive mass, pseudo-inertia positive definite, triangle inequality) that
MuJoCo compiles and gives back, whatever the model's body, and what is zero in the model stays zero."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.model.pseudo_inertia import body_defect, from_pseudo_inertia, perturbed_body, pseudo_inertia
from lagrange_xval.model.set_values import compiled_view, set_values
from lagrange_xval.verdict.probes import _factor

ONE_BODY = """<mujoco><worldbody><body name="b" pos="0 0 1"><joint name="j" type="hinge" axis="0 1 0"/>
<inertial mass="1" pos="0 0 0.1" diaginertia="0.01 0.01 0.01"/></body></worldbody></mujoco>"""

# Independent factors on a real link's six entries (the Z1's link02: moments 1.0e-3, 2.43e-2, 2.47e-2)
Z1_LINK02 = np.array(
    [[0.00102138, 0.00062358, 5.13e-06], [0.00062358, 0.02429457, -2.1e-06], [5.13e-06, -2.1e-06, 0.02466114]]
)


def _rotation(kind: str, angles: tuple[float, float, float]) -> np.ndarray:
    """Body axes: the principal ones (a diagonal tensor), a turn about z (two products zero), or any."""

    def about(axis: int, a: float) -> np.ndarray:
        c, s = np.cos(a), np.sin(a)
        i, j = [k for k in range(3) if k != axis]
        R = np.eye(3)
        R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
        return R

    if kind == "principal":
        return np.eye(3)
    if kind == "about z":
        return about(2, angles[0])
    return about(2, angles[0]) @ about(1, angles[1]) @ about(0, angles[2])


@st.composite
def bodies(draw: st.DrawFn) -> tuple[float, np.ndarray, np.ndarray]:
    """A valid body: log-uniform mass and size, principal moments anywhere inside the triangle inequality
    (down to a relative margin of 1e-6: nearly a rod or a lamina), axes principal, turned about z or any,
    centre coordinates zero or from 1e-6 to 1 m either way."""
    mass = 10 ** draw(st.floats(-3, 3))
    size = 10 ** draw(st.floats(-6, 1))
    a, b = (10 ** draw(st.floats(-3, 0)) for _ in range(2))
    t = draw(st.floats(1e-6, 1 - 1e-6))
    c = abs(a - b) + t * (a + b - abs(a - b))
    moments = size * np.array([a, b, c])
    kind = draw(st.sampled_from(["principal", "about z", "any"]))
    R = _rotation(kind, tuple(draw(st.floats(-np.pi, np.pi)) for _ in range(3)))
    inertia = R @ np.diag(moments) @ R.T
    if kind == "about z":  # exact zeros where the turn leaves them
        inertia[0, 2] = inertia[2, 0] = inertia[1, 2] = inertia[2, 1] = 0.0
    signed = st.tuples(st.sampled_from([-1.0, 1.0]), st.floats(-6, 0)).map(lambda x: x[0] * 10 ** x[1])
    com = np.array([draw(st.sampled_from([0.0, draw(signed)])) for _ in range(3)])
    return mass, com, 0.5 * (inertia + inertia.T)


def _factors(seed: int):
    rng = np.random.default_rng(seed)
    return lambda: _factor(rng)


@settings(max_examples=80, deadline=None)
@given(body=bodies(), seed=st.integers(0, 2**32 - 1))
def test_every_draw_is_a_rigid_body_that_mujoco_compiles_and_gives_back(body, seed):
    mass, com, inertia = body
    assert body_defect(mass, com, inertia) == ""  # the strategy's own bodies are valid
    m, c, I = perturbed_body(mass, com, inertia, _factors(seed))
    assert m > 0 and body_defect(m, c, I) == "", body_defect(m, c, I)
    assert np.linalg.eigvalsh(pseudo_inertia(m, c, I))[0] > 0
    p = np.linalg.eigvalsh(I)
    assert p[0] > 0 and p[0] + p[1] >= p[2]
    assert np.all((I == 0.0) == (inertia == 0.0)) and np.all((c == 0.0) == (com == 0.0))  # zeros stay zero
    assert m != mass and np.all(c[com != 0] != com[com != 0])  # the mass and the centre move
    text = set_values(ONE_BODY, {"body/b/mass": m, "body/b/com": c, "body/b/inertia": I})  # verifies the read-back
    view = compiled_view(text)
    assert np.allclose(view["body/b/inertia"], I, rtol=0, atol=1e-13 * np.abs(I).max())


def test_independent_factors_break_a_real_link_at_most_draws_and_the_pseudo_inertia_never():
    """The converse: what the probes drew before (each entry times its own factor) is refused by MuJoCo
    at most draws of the Z1's link02, so the test above can fail; the pseudo-inertia draw never is."""
    rng = np.random.default_rng(0)
    refused = 0
    for _ in range(50):
        moved = np.array([[x * _factor(rng) for x in row] for row in Z1_LINK02])
        moved = np.triu(moved) + np.triu(moved, 1).T
        try:
            set_values(ONE_BODY, {"body/b/inertia": moved})
        except HarnessError:
            refused += 1
    assert refused > 25
    factors = _factors(1)
    for _ in range(50):
        m, c, I = perturbed_body(1.19, np.array([0.1, 0.0, -0.02]), Z1_LINK02, factors)
        set_values(ONE_BODY, {"body/b/mass": m, "body/b/com": c, "body/b/inertia": I})


def test_a_lamina_stays_a_lamina_and_compiles():
    """Σ singular (A + B = C): no Cholesky factor; S Σ S keeps it on the boundary, which MuJoCo accepts."""
    lamina = np.diag([1e-3, 2e-3, 3e-3])
    m, c, I = perturbed_body(0.5, np.zeros(3), lamina, _factors(3))
    p = np.linalg.eigvalsh(I)
    assert p[0] + p[1] == pytest.approx(p[2], rel=1e-12) and not np.allclose(I, lamina)
    set_values(ONE_BODY, {"body/b/mass": m, "body/b/com": c, "body/b/inertia": I})


def test_the_pseudo_inertia_round_trips_and_names_what_is_not_a_body():
    I = np.array([[2.0, 0.1, 0.0], [0.1, 3.0, 0.2], [0.0, 0.2, 4.0]])
    m, c, back = from_pseudo_inertia(pseudo_inertia(2.5, [0.1, -0.2, 0.3], I))
    assert m == pytest.approx(2.5) and np.allclose(c, [0.1, -0.2, 0.3]) and np.allclose(back, I)
    assert "mass" in body_defect(0.0, np.zeros(3), I)
    assert "pseudo-inertia not positive definite" in body_defect(1.0, np.zeros(3), np.diag([1.0, 1.0, 3.0]))
    assert perturbed_body(0.0, np.zeros(3), I, _factors(0))[0] == 0.0  # a massless body is left as it is

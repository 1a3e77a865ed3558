"""Mechanics that hold for every correct source, at random states and parameters (hypothesis).

M symmetric positive definite; v^T (dM/dt - 2C) v = 0 (dM/dt - 2C is skew along the motion);
energy balance dE/dt = v . (tau + passive); inverse dynamics undoes forward dynamics.
"""

from __future__ import annotations

import functools

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from lagrange_xval import systems
from lagrange_xval.sources import make_sources
from lagrange_xval.verdict import pointwise as compare

PROPERTY_SETTINGS = settings(
    max_examples=12, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
# Rescalings that keep the bobs' 1e-14 kg m^2 inertia above MuJoCo's mjMINVAL (1e-15): mass x length^2 >= 0.125.
scales = st.sampled_from([0.5, 0.8, 1.0, 2.0, 4.0])


@functools.lru_cache(maxsize=64)
def _sources(name: str, mass: float, length: float):
    s = systems.load(name, overrides=(("scale/mass", mass), ("scale/length", length)))
    return s, make_sources(s)


def _states(system, seed: int, n: int = 8):
    st_ = compare.random_states(system, n=n, seed=seed)
    rng = np.random.default_rng(seed)
    return st_.q, st_.v, rng.uniform(-1, 1, st_.q.shape)


@PROPERTY_SETTINGS
@given(seed=st.integers(0, 2**31), mass=scales, length=scales)
def test_mass_matrix_symmetric_positive_definite(system, seed, mass, length):
    s, sources = _sources(system.name, mass, length)
    q, _, _ = _states(s, seed)
    for name, src in sources.items():
        M = src.mass_matrix(q)
        assert np.abs(M - np.swapaxes(M, -1, -2)).max() <= 1e-14 * np.abs(M).max(), name
        assert np.linalg.eigvalsh(M).min() > 0, name


@PROPERTY_SETTINGS
@given(seed=st.integers(0, 2**31), mass=scales, length=scales)
def test_mdot_minus_2c_is_skew_along_the_motion(system, seed, mass, length):
    """v^T dM/dt v = 2 v^T C(q, v) v, with dM/dt by a central difference along v."""
    s, sources = _sources(system.name, mass, length)
    q, v, _ = _states(s, seed)
    h = 1e-6
    for name, src in sources.items():
        mdot = (src.mass_matrix(q + h * v) - src.mass_matrix(q - h * v)) / (2 * h)
        cv = src.bias(q, v) - src.bias(q, np.zeros_like(v))
        lhs = np.einsum("ni,nij,nj->n", v, mdot, v)
        rhs = 2 * np.einsum("ni,ni->n", v, cv)
        scale = np.abs(np.einsum("ni,nij,nj->n", v, src.mass_matrix(q), v)).max() * np.abs(v).max()
        assert np.abs(lhs - rhs).max() <= 1e-6 * scale, f"{name}: {np.abs(lhs - rhs).max():.2e} vs {scale:.2e}"


@PROPERTY_SETTINGS
@given(seed=st.integers(0, 2**31), mass=scales, length=scales)
def test_energy_balance(system, seed, mass, length):
    """dE/dt along the motion equals the power of friction and inputs."""
    s, sources = _sources(system.name, mass, length)
    q, v, tau = _states(s, seed)
    h = 1e-6
    for name, src in sources.items():
        a = src.forward(q, v, tau)
        e_plus = sum(src.energies(q + h * v, v + h * a))
        e_minus = sum(src.energies(q - h * v, v - h * a))
        dedt = (e_plus - e_minus) / (2 * h)
        power = np.einsum("ni,ni->n", v, tau + src.passive(q, v))
        scale = np.abs(np.einsum("ni,ni->n", v, src.bias(q, v))).max() + np.abs(power).max()
        assert np.abs(dedt - power).max() <= 1e-6 * scale, f"{name}: {np.abs(dedt - power).max():.2e}"


@PROPERTY_SETTINGS
@given(seed=st.integers(0, 2**31), mass=scales, length=scales)
def test_inverse_dynamics_undoes_forward_dynamics(system, seed, mass, length):
    s, sources = _sources(system.name, mass, length)
    q, v, tau = _states(s, seed)
    for name, src in sources.items():
        back = src.inverse(q, v, src.forward(q, v, tau))
        scale = np.abs(src.bias(q, v)).max() + np.abs(tau).max()
        assert np.abs(back - tau).max() <= 1e-10 * scale, f"{name}: {np.abs(back - tau).max():.2e}"

"""The four forms a derivation can be written in give one verdict (validate/forms.py).

Every repository derivation is rewritten in forms (b) implicit residual, (c) explicit accelerations
and (d) energies only; each must agree with both engines term by term at the model's parameters and
at probes, trace for the fast path to round-off, and a mistake put into the rewritten form must be
found in the term it is in.
"""

from __future__ import annotations

import types

import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.dynamics.reference import rhs_check
from lagrange_xval.handwritten import forms
from lagrange_xval.sources import make_sources
from lagrange_xval.verdict import pointwise as compare
from lagrange_xval.verdict import verdict

SHARED = (
    "DESCRIPTION",
    "COORDINATES",
    "JOINTS",
    "JOINT_MAP",
    "BODIES",
    "Params",
    "parameters",
    "assumptions",
    "kinetic_energy",
    "potential_energy",
    "body_positions",
    "body_rotations",
    "VARIANTS",
    "INITIAL_STATE",
)


def _matvec(M, x):
    return np.einsum("...ij,...j->...i", M, x) if M.dtype != object else forms._matvec(M, x)


def rewrite(name: str, form: str, *, gravity_factor: float = 1.0) -> types.ModuleType:
    """The repository derivation of `name` rewritten in `form`, built from its own functions with
    arithmetic only (so it traces); `gravity_factor` != 1 plants a mistake in the gravity term."""
    orig = systems.load(name).equations
    mod = types.ModuleType(f"lagrange_xval.equations._rewritten_{name}_{form}")
    mod.__package__ = "lagrange_xval.equations"
    for key in SHARED:
        if hasattr(orig, key):
            setattr(mod, key, getattr(orig, key))

    def bias(p, q, v):
        zero = np.zeros_like(np.asarray(q, dtype=float)) if np.asarray(q).dtype != object else 0 * q
        g = orig.bias(p, q, zero)
        return orig.bias(p, q, v) + (gravity_factor - 1.0) * g

    if form == "b":
        mod.residual = lambda p, q, v, a, tau: (
            _matvec(orig.mass_matrix(p, q), a) + bias(p, q, v) - orig.passive(p, q, v) - tau
        )
    elif form == "c":

        def qacc(p, q, v, tau):
            M = np.asarray(orig.mass_matrix(p, q))
            return _matvec(forms.inverse(M), tau + orig.passive(p, q, v) - bias(p, q, v))

        mod.qacc = qacc
    else:  # d: the energies, plus the friction forces
        mod.passive = orig.passive
        if gravity_factor != 1.0:
            mod.potential_energy = lambda p, q: gravity_factor * orig.potential_energy(p, q)
    return mod


CASES = [(n, f) for n in systems.system_names() for f in "bcd"]


@pytest.mark.parametrize(("name", "form"), CASES, ids=[f"{n}-{f}" for n, f in CASES])
def test_every_form_agrees_with_the_engines(name, form):
    """The same derivation in another form: every term agrees at the model's parameters and 2 probes."""
    system = systems.load(name).derive(equations=rewrite(name, form))
    assert system.equations.FORM == form
    sources = make_sources(system)
    states = compare.random_states(system, n=100, seed=0)
    result = verdict.judge_derivation(system, states, sources, n_probes=2, probe_states=50)
    assert result["verdict"] == "agrees", [r for r in result["terms"] if not r["passed"]][:2]


# The mistake below scales gravity, so it is planted only where the scene has gravity.
GRAVITY_CASES = [(n, f) for n, f in CASES if "gravity" in systems.load(n).uses]


@pytest.mark.parametrize(("name", "form"), GRAVITY_CASES, ids=[f"{n}-{f}" for n, f in GRAVITY_CASES])
def test_a_mistake_in_any_form_is_named(name, form):
    """Gravity 10% too strong, written into the form: the gravity term is named."""
    system = systems.load(name).derive(equations=rewrite(name, form, gravity_factor=1.1))
    sources = make_sources(system)
    states = compare.random_states(system, n=100, seed=0)
    result = verdict.judge_derivation(system, states, sources, n_probes=1, probe_states=50)
    assert result["first_disagreeing_term"] == "gravity", result["statement"]


@pytest.mark.parametrize("form", "bd")
def test_derived_forms_trace_for_the_fast_path(form):
    """Forms (b) and (d) trace symbolically (fast path and Taylor reference) to round-off."""
    system = systems.load("double_pendulum_point").derive(equations=rewrite("double_pendulum_point", form))
    assert rhs_check(system) < 1e-12


def test_a_module_without_dynamics_is_one_line():
    mod = types.ModuleType("x")
    mod.COORDINATES = ("q",)
    with pytest.raises(HarnessError, match="the dynamics are not provided .yet.; write one of"):
        forms.normalize(mod)


def test_inverse_matches_numpy():
    """The arithmetic-only inverse used for form (c) equals numpy's on SPD matrices."""
    rng = np.random.default_rng(0)
    A = rng.normal(size=(50, 3, 3))
    M = A @ np.swapaxes(A, -1, -2) + 3 * np.eye(3)
    np.testing.assert_allclose(forms.inverse(M), np.linalg.inv(M), rtol=1e-12, atol=1e-14)

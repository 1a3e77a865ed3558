"""The Taylor reference: two precisions agree, the trace is the module, the cache returns what it stored."""

from __future__ import annotations

import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.dynamics import reference
from lagrange_xval.dynamics.integrate import initial_state, scipy_trajectory, time_grid
from lagrange_xval.model.start import Start
from lagrange_xval.sources.hand import HandSource

SYSTEMS = systems.system_names()
NOTES_START = (np.array([0.0, 3.0]), np.zeros(2))  # the notes' ode45 experiment: theta = 0, phi = 3, at rest


def test_long_double_and_quad_runs_agree_over_10_s(tmp_path):
    """heyoka in long double (tol 1.1e-19) and in quad (tol 1.9e-34) agree to < 1e-12 rad over 10 s from (0, 3)."""
    system = systems.load("double_pendulum_point")
    q0, v0 = NOTES_START
    _, info = reference.reference_trajectory(
        system, Start.of(q0, v0, np.zeros(2)), time_grid(10.0, 0.01), cache_dir=tmp_path
    )
    assert info["precision"] == "long double" and info["check_method"].startswith("heyoka Taylor, quad")
    # measured: 4.0e-17 rad (q), 1.4e-16 rad/s (v)
    assert info["agreement_q"] < 1e-12, f"long double vs quad: {info['agreement_q']:.2e} rad"
    assert info["agreement_v"] < 1e-11, f"long double vs quad: {info['agreement_v']:.2e} rad/s"


def test_cache_hit_returns_identical_arrays(tmp_path):
    """A second call loads the stored arrays bit for bit and says so."""
    system = systems.load("double_pendulum_point")
    q0, v0 = NOTES_START
    t = time_grid(2.0, 0.01)
    first, info1 = reference.reference_trajectory(
        system, Start.of(q0, v0, np.zeros(2)), t, cache_dir=tmp_path, check=None
    )
    second, info2 = reference.reference_trajectory(
        system, Start.of(q0, v0, np.zeros(2)), t, cache_dir=tmp_path, check=None
    )
    assert (info1["cache"], info2["cache"]) == ("miss", "hit")
    assert info1["cache_file"] == info2["cache_file"]
    for name in ("t", "q", "v"):
        assert np.array_equal(getattr(first, name), getattr(second, name)), f"cached {name} differs"
    assert {k: v for k, v in info2.items() if k not in ("cache", "timing")} == {
        k: v for k, v in info1.items() if k not in ("cache", "timing")
    }


def test_cache_key_covers_every_input():
    """Changing the state, the input, the grid or a parameter changes the cache key."""
    system = systems.load("double_pendulum_point")
    q0, v0 = NOTES_START
    t = time_grid(1.0, 0.01)
    base = reference.cache_key(system, q0, v0, np.zeros(2), t, check="quad")
    changed = [
        reference.cache_key(system, q0 + [0, 1e-15], v0, np.zeros(2), t, check="quad"),
        reference.cache_key(system, q0, v0 + [1e-15, 0], np.zeros(2), t, check="quad"),
        reference.cache_key(system, q0, v0, np.array([0.0, 1e-15]), t, check="quad"),
        reference.cache_key(system, q0, v0, np.zeros(2), time_grid(1.0, 0.02), check="quad"),
        reference.cache_key(system, q0, v0, np.zeros(2), t, check=None),
        reference.cache_key(
            systems.load("double_pendulum_point", overrides=(("scale/mass", 1.5),)),
            q0,
            v0,
            np.zeros(2),
            t,
            check="quad",
        ),
    ]
    assert base not in changed and len(set(changed)) == len(changed)


def test_traced_equations_are_the_module(system):
    """The symbolic right-hand side reproduces HandSource.forward to a few ulps at random states."""
    err = reference.rhs_check(system, n_states=200, seed=3)
    assert err < 1e-13, f"{system.name}: traced vs numpy accelerations differ by {err:.1e} of their range"


def test_dop853_agrees_with_the_reference_in_units_of_its_tolerance(system):
    """scipy's DOP853 (the numpy equations, an independent path) is within 20 rtol of the reference over 1 s.

    As scipy's test_ivp: the global error of a well-behaved run over a short span is a few times the
    requested tolerance (measured: 1.5-7.2 at rtol 1e-12 over the discovered systems); chaos has not
    yet amplified it (it does by ~1e2-1e3 at 10 s)."""
    q0, v0 = initial_state(system)
    tau = np.zeros(system.nv)
    t = time_grid(1.0, 0.01)
    ref, _ = reference.reference_trajectory(system, Start.of(q0, v0, tau), t, cache_dir=None, check=None)
    rtol = 1e-12
    run = scipy_trajectory(system, HandSource(system), Start.of(q0, v0, tau), t, rtol=rtol, atol=rtol)
    units = np.abs(run.q - ref.q).max() / rtol
    assert units < 20, f"{system.name}: DOP853 error is {units:.1f} x rtol against the reference"


CONSERVATIVE = [n for n in systems.system_names() if not systems.load(n).uses & {"damping", "actuation"}]


@pytest.mark.parametrize("name", CONSERVATIVE)
def test_reference_conserves_energy(name):
    """Without damping or inputs the reference's energy stays constant to ~1e-14 of its scale over 10 s."""
    system = systems.load(name)
    q0, v0 = initial_state(system)
    ref, _ = reference.reference_trajectory(
        system, Start.of(q0, v0, np.zeros(system.nv)), time_grid(10.0, 0.01), cache_dir=None, check=None
    )
    kin, pot = HandSource(system).energies(ref.q, ref.v)
    e = kin + pot
    scale = np.abs(kin).max() + np.abs(pot).max()
    assert np.ptp(e) < 1e-12 * scale, f"{system.name}: energy varies by {np.ptp(e):.1e} J (scale {scale:.2g} J)"


def test_bad_inputs_name_the_argument():
    system = systems.load("double_pendulum_point")
    with pytest.raises(HarnessError, match="q0 must have shape"):
        reference.reference_trajectory(
            system, Start.of([0.0], [0.0, 0.0], [0.0, 0.0]), time_grid(1.0, 0.1), cache_dir=None
        )
    with pytest.raises(HarnessError, match="non-finite"):
        reference.reference_trajectory(
            system, Start.of([0.0, np.nan], [0.0, 0.0], [0.0, 0.0]), time_grid(1.0, 0.1), cache_dir=None
        )

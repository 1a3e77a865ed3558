"""Where there is no symbolic source (a robot), which engine departs from the reference, from when, and
whether that is expected (validate/dynamics/trust.py; issue 25 item 3)."""

from __future__ import annotations

import numpy as np
import pytest
from lagrange_xval.dynamics import freeruns, trust
from lagrange_xval.sources import make_sources
from lagrange_xval.systems import MODELS_DIR, System

T = np.linspace(0.0, 2.0, 201)


def _run(err: np.ndarray, est: np.ndarray) -> dict:
    return {"error_vs_hand": err, "threshold": np.maximum(1e-6, 10 * est), "error_estimate": est}


def test_a_run_within_its_own_estimate_departs_as_expected():
    """Error and estimate both grow (a chaotic run): it is trusted until its estimate passes TRUST, and its
    departure is its integrator's, not a disagreement."""
    est = 1e-9 * np.exp(8 * T)
    out = trust.run_trust(_run(2 * est, est), T, reference_limit=float(T[-1]))
    assert out["why"].startswith("its own error estimate") and out["expected"] is True
    assert out["trusted_until"] == pytest.approx(np.log(trust.TRUST / 1e-9) / 8, abs=0.02)


def test_a_run_beyond_its_own_estimate_does_not_solve_the_reference_equations():
    """A run 1e-2 rad away while its own estimate stays at 1e-10: trusted until it passes its threshold, and
    its departure is named as a disagreement."""
    err = np.where(T > 0.5, 1e-2, 1e-9)
    out = trust.run_trust(_run(err, np.full_like(T, 1e-10)), T, reference_limit=float(T[-1]))
    assert out["trusted_until"] == pytest.approx(0.51) and out["expected"] is False
    assert "does not solve" in trust.statement("MuJoCo RK4", out, float(T[-1]))


def test_the_reference_horizon_bounds_every_run():
    out = trust.run_trust(_run(np.zeros_like(T), np.zeros_like(T)), T, reference_limit=1.2)
    assert out["trusted_until"] == 1.2 and "reference's own horizon" in out["why"]


def test_a_chain_with_no_symbolic_source_says_per_engine_until_when():
    system = System.model_only(MODELS_DIR / "double_pendulum_point.xml")
    sources = {k: v for k, v in make_sources(system).items() if k != "symbolic"}
    traj = freeruns.divergence_results(system, sources, t_end=2.0, dt_out=0.01, why="test", aba_reference=True)
    found = traj["trust"]
    assert found["reference_until"] == pytest.approx(2.0) and np.isfinite(found["lyapunov_exponent"])
    for run in traj["runs"]:
        assert run["trust_statement"].startswith(run["method"]), run["trust_statement"]
        assert run["trust"]["trusted_until"] == pytest.approx(2.0), run["trust_statement"]

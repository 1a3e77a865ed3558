"""The generated scalar right-hand sides equal the numpy reference path."""

from __future__ import annotations

import numpy as np
from lagrange_xval.forms import Explicit, Implicit
from lagrange_xval.sources import fastpath
from lagrange_xval.sources.hand import HandSource


def _numpy_path(system, variant):
    p = system.params
    if variant is None:
        return HandSource(system).forward
    if isinstance(variant, Explicit):
        return lambda q, v, tau: variant.acceleration(p, q, v, tau)

    def solve(q, v, tau):  # the printed residual is linear in a
        n = q.shape[-1]
        r0 = variant.residual(p, q, v, np.zeros_like(q), tau)
        cols = [variant.residual(p, q, v, np.broadcast_to(np.eye(n)[j], q.shape), tau) - r0 for j in range(n)]
        return np.linalg.solve(np.stack(cols, axis=-1), -r0[..., None])[..., 0]

    return solve


def test_scalar_rhs_equals_the_numpy_path(system):
    rng = np.random.default_rng(5)
    n = system.nv
    q, v, tau = rng.uniform(-3, 3, (100, n)), rng.uniform(-10, 10, (100, n)), rng.uniform(-1, 1, (100, n))
    for variant in [None] + [x for x in system.variants if isinstance(x, (Explicit, Implicit))]:
        ref = np.asarray(_numpy_path(system, variant)(q, v, tau))
        f = fastpath.scalar_rhs(system, variant)
        fast = np.array([f(0.0, np.concatenate([q[i], v[i]]), tau[i]) for i in range(100)])
        assert np.array_equal(fast[:, :n], v)
        err = np.abs(fast[:, n:] - ref).max() / np.abs(ref).max()
        assert err < 1e-12, f"{system.name} {variant.name if variant else 'hand'}: {err:.1e}"

"""The engines' batched pointwise paths against plain per-state loops written here, bit for bit.

MuJoCo: from BATCH_MIN_STATES states mj_forward runs in MuJoCo's own batch (`mujoco.batch`, on a
thread pool); Pinocchio: ABA and RNEA in its C++ loops over the states. Each must give exactly what
the obvious loop over the engine's calls gives, whatever the thread count or the batch's size.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import pytest
from lagrange_xval.sources import make_source
from lagrange_xval.sources import mujoco as mj_engine
from lagrange_xval.sources.base import batch_threads
from lagrange_xval.systems import System
from lagrange_xval.verdict import pointwise as compare

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
N = mj_engine.BATCH_MIN_STATES + 44  # above the batch threshold, not a multiple of the thread count


def _states(system, n=N, seed=3):
    states = compare.random_states(system, n=n, seed=seed)
    a = np.random.default_rng(seed).normal(size=states.q.shape)
    return states, a


def engine(system, name):
    """The engine source in the model's joint coordinates (any random states serve as inputs)."""
    src = make_source(system, name)
    return getattr(src, "inner", src)


def mujoco_loop(inner, q, v, tau, a):
    """The obvious loop: per state set qpos, qvel and the inputs, mj_forward, read, mj_inverse at a."""
    m, d = inner.m, inner.d
    out = {k: [] for k in ("M", "bias", "passive", "qacc", "tau_inverse", "T", "V", "pos", "rot")}
    full = np.zeros((m.nv, m.nv))
    for i in range(len(q)):
        mujoco.mj_resetData(m, d)
        inner.set_state(q[i], v[i], tau[i])
        mujoco.mj_forward(m, d)
        mujoco.mj_fullM(m, d, full)
        out["M"].append(full[np.ix_(inner.dadr, inner.dadr)].copy())
        out["bias"].append(d.qfrc_bias[inner.dadr].copy())
        out["passive"].append(d.qfrc_passive[inner.dadr].copy())
        out["qacc"].append(d.qacc[inner.dadr].copy())
        out["V"].append(d.energy[0])
        out["T"].append(d.energy[1])
        out["pos"].append(d.xipos[inner.body_ids].copy())
        out["rot"].append(d.xmat[inner.body_ids].reshape(-1, 3, 3).copy())
        d.qacc[inner.dadr] = a[i]
        mujoco.mj_inverse(m, d)
        out["tau_inverse"].append(d.qfrc_inverse[inner.dadr].copy())
    return {k: np.array(x) for k, x in out.items()}


def _user_systems():
    return [System.from_files(EXAMPLES / f"{n}.xml", EXAMPLES / f"{n}.py") for n in ("spatial_arm", "cart_pole")]


@pytest.mark.parametrize("threads", [1, 2])
def test_mujoco_batch_is_the_per_state_loop_bit_for_bit(system, threads):
    """Every quantity of MujocoSource.evaluate, batched on 1 or 2 threads, equals the plain loop exactly."""
    src = engine(system, "mujoco")
    states, a = _states(system)
    got = src.evaluate(states.q, states.v, states.tau, a, threads=threads)
    ref = mujoco_loop(src, states.q, states.v, states.tau, a)
    names = {"body_positions": "pos", "body_rotations": "rot"}
    for key, value in got.items():
        expected = ref[names.get(key, key)]
        assert np.array_equal(value, expected), f"{system.name} {key}: max |diff| {np.abs(value - expected).max()}"


@pytest.mark.parametrize("index", [0, 1])
def test_mujoco_batch_on_user_models(index):
    """The same on a 3-joint spatial arm and an actuated cart-pole (inputs through ctrl, a slide joint)."""
    system = _user_systems()[index]
    src = engine(system, "mujoco")
    states, a = _states(system)
    got = src.evaluate(states.q, states.v, states.tau, a, threads=2)
    ref = mujoco_loop(src, states.q, states.v, states.tau, a)
    for key, ref_key in (("M", "M"), ("bias", "bias"), ("qacc", "qacc"), ("tau_inverse", "tau_inverse"), ("T", "T")):
        assert np.array_equal(got[key], ref[ref_key]), f"{system.name} {key}"


def test_mujoco_small_and_large_batches_agree(system):
    """Below BATCH_MIN_STATES the per-state loop runs; split into small batches, the result is the same bits."""
    src = engine(system, "mujoco")
    states, a = _states(system)
    whole = src.evaluate(states.q, states.v, states.tau, a)
    cut = [slice(0, 100), slice(100, 200), slice(200, N)]
    parts = [src.evaluate(states.q[s], states.v[s], states.tau[s], a[s]) for s in cut[:2]]
    parts.append(src.evaluate(states.q[cut[2]], states.v[cut[2]], states.tau[cut[2]], a[cut[2]], threads=1))
    for key in whole:
        assert np.array_equal(whole[key], np.concatenate([p[key] for p in parts])), key
    # the single-quantity methods share the batch
    assert np.array_equal(src.forward(states.q, states.v, states.tau), whole["qacc"])
    assert np.array_equal(src.mass_matrix(states.q), src.evaluate(states.q, 0 * states.v, states.tau, a)["M"])
    assert np.array_equal(src.inverse(states.q, states.v, a), whole["tau_inverse"])


def test_batch_threads_scale_with_the_batch():
    assert batch_threads(1) == 1
    assert batch_threads(10**5) >= 1
    assert batch_threads(10**5) <= len(__import__("os").sched_getaffinity(0))


def test_pinocchio_c_loops_are_the_per_state_calls_bit_for_bit(system):
    """forward, bias and inverse (Pinocchio's C++ loops) equal aba (local convention) and rnea called
    per state; evaluate's M, energies and poses equal crba, the energies and oMi read per state."""
    inner = engine(system, "pinocchio")
    states, a = _states(system)
    q, v, tau = states.q, states.v, states.tau
    model, data = inner.model, inner.data
    got = inner.evaluate(q, v, tau, a)
    qacc, bias, tau_inv, M, T, V, pos = [], [], [], [], [], [], []
    passive = -inner.damping * v
    for i in range(len(q)):
        qi, vi = inner._q(q[i]), inner._v(v[i])
        qacc.append(pin.aba(model, data, qi, vi, inner._v(tau[i] + passive[i]), convention=pin.Convention.LOCAL))
        bias.append(pin.rnea(model, data, qi, vi, np.zeros(model.nv)).copy())
        tau_inv.append(pin.rnea(model, data, qi, vi, inner._v(a[i])).copy() - inner._v(passive[i]))
        full = pin.crba(model, data, qi).copy()
        full = np.triu(full) + np.triu(full, 1).T
        M.append(full[np.ix_(inner.vidx, inner.vidx)])
        T.append(0.5 * vi @ full @ vi)  # 1/2 v^T M v (computeKineticEnergy drops an unaligned hinge's armature)
        V.append(pin.computePotentialEnergy(model, data, qi))
        pos.append([data.oMi[j].act(model.inertias[j].lever) for j in inner.joint_of_body])
    vi = inner.vidx
    assert np.array_equal(got["qacc"], np.array(qacc)[:, vi])
    assert np.array_equal(got["bias"], np.array(bias)[:, vi])
    assert np.array_equal(got["tau_inverse"], np.array(tau_inv)[:, vi])
    assert np.array_equal(got["M"], np.array(M))
    assert np.array_equal(got["T"], np.array(T))
    assert np.array_equal(got["V"], np.array(V))
    assert np.allclose(got["body_positions"], np.array(pos), rtol=0, atol=1e-14)


def test_pinocchio_one_state_rhs_is_the_batch(system):
    """The one-state right-hand side (free runs) and the batched forward (windows) round alike."""
    src = engine(system, "pinocchio")
    states, _ = _states(system, n=20)
    tau = states.tau[0]
    f = src.rhs(tau)
    n = system.nv
    batched = src.forward(states.q, states.v, np.tile(tau, (20, 1)))
    for i in range(20):
        one = f(0.0, np.concatenate([states.q[i], states.v[i]]))[n:]
        assert np.array_equal(one, batched[i]), (system.name, i)

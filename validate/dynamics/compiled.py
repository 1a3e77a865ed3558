"""The hand equations compiled: heyoka's Taylor integrator in double precision, and heyoka's
compiled functions (`cfunc`) as a right-hand side and as whole fixed-step RK4 steps.

Everything starts from the trace the reference uses (reference.symbolic_dynamics: the equations
module's own `mass_matrix`, `bias`, `passive` called on heyoka expressions, a = M^-1 f by symbolic
elimination), so what is compiled here is the hand derivation itself, checked against the numpy
module by `reference.rhs_check`.

  taylor_integrator  heyoka's adaptive Taylor method in double precision at a tolerance (1e-6 ..
                     1e-16; the order follows the tolerance). Not in compact mode: for these small
                     systems the unrolled code runs 1.6-1.8x faster (measured on double_pendulum_point,
                     0.27 vs 0.49 ms over 10 s at tol 1e-12) and compiles in 0.1-0.4 s (not timed).
                     With `source="symbolic"`: the same on the model's own equations derived
                     symbolically (sources/symbolic.py; sympy's expressions turned into heyoka's by
                     `heyoka.from_sympy`), in the joints' coordinates (`JOINT_MAP` applied on the way
                     in and out by `taylor_grid`'s caller).
  compiled_rhs       a = M^-1 f as a `cfunc` called once per state from Python. Measured on
                     double_pendulum_point: 2.5-2.7 us a call against 1.9 us for the generated `math`
                     code (sources/fastpath.py): the call from Python costs more than the arithmetic,
                     so a compiled right-hand side does not speed up scipy's drivers (the bench shows it).
  compiled_rk4       `k` steps of classic RK4 (MuJoCo's tableau, mirror.py) composed into one `cfunc`:
                     one Python call per k steps, the arithmetic compiled. k is the steps per output
                     sample, at most RK4_STEPS_PER_CALL (100 steps compile in ~6 s, 10 in ~0.3 s).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Hashable
from typing import TYPE_CHECKING

import numpy as np

from ..core.arrays import Floats
from ..core.cachedir import heyoka
from ..core.errors import HarnessError
from ..core.memo import Memo
from ..handwritten import tracing
from ..model.start import Start
from ..sources.symbolic import derivation_of
from ..symbolic.derivation import parameter_values
from ..systems import System
from .reference import param_key, symbolic_dynamics

if TYPE_CHECKING:  # heyoka is imported when first used (core/cachedir.heyoka)
    import sympy as sp
    from heyoka import cfunc_dbl, expression, taylor_adaptive_dbl

# MuJoCo's RK4 tableau (`mj_RungeKutta(m, d, 4)`), used by the mirrors (mirror.py) and the compiled steps
RK4_A = ((0.5,), (0.0, 0.5), (0.0, 0.0, 1.0))
RK4_B = (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0)
RK4_STEPS_PER_CALL = 10
# The harness's own runs (fast.py, mirror.py): unrolled Taylor code and RK4_STEPS_PER_CALL steps per
# call up to this many joints; beyond, compact code and 2 steps per call (unrolled code of a 3-joint
# arm's derived equations compiled in 13.7 s on a fresh machine, compact in 1.3 s).
UNROLLED_MAX_DOF = 2  # steps composed into one compiled call (compile time grows with it)
# heyoka's compiled integrators and functions of this process, keyed by `_key` (not per System: a system
# loaded again, as every worker task does, reuses them); bounded, a dropped one is compiled again. A full
# bench compiles about 140 in a worker (5 systems x 22 Taylor tolerances and sources, cfuncs, RK4 steps).
_COMPILED = Memo(maxsize=512)


def _key(system: System, *what: Hashable) -> tuple[Hashable, ...]:
    # the module itself, not its name: a mutated module of the same name gets its own code
    return (system.name, system.overrides, param_key(system), system.equations, *what)


def derived_ode(system: System) -> list[tuple[expression, expression]]:
    """The model's equations derived symbolically (the "symbolic" source) as a heyoka ODE in the
    joints' coordinates: x = (q_joint, v_joint), a = M^-1 (tau - (C v + G - passive)), tau = par[0:n]."""
    hy = heyoka()

    d = derivation_of(system)
    values = parameter_values(d, system.view)
    n = system.nv
    qs = [hy.expression(f"q{i}") for i in range(n)]
    vs = [hy.expression(f"v{i}") for i in range(n)]
    names = {**dict(zip(d.q, qs, strict=True)), **dict(zip(d.v, vs, strict=True))}
    names.update({sym: hy.expression(float(values[sym])) for sym in d.source})

    def conv(e: sp.Expr) -> expression:
        return hy.from_sympy(e, names)

    m = [[conv(d.M[i, j]) for j in range(n)] for i in range(n)]
    forces = d.Cv + d.G - d.passive
    a = tracing.solve_spd(m, [hy.par[i] - conv(forces[i]) for i in range(n)])
    return list(zip(qs + vs, vs + a, strict=True))


def taylor_integrator(
    system: System, tol: float, *, compact: bool = False, source: str = "hand"
) -> taylor_adaptive_dbl:
    """heyoka's adaptive Taylor integrator in double precision at `tol` of the hand equations (or,
    with source="symbolic", of the derived ones in joint coordinates); tau = par[0:n]. Built once per
    process and reused (its state is set by `taylor_grid`)."""
    hy = heyoka()

    if source not in ("hand", "symbolic"):
        raise HarnessError(f"no Taylor integrator of the '{source}' source; valid: hand, symbolic.")
    key = _key(system, "taylor", float(tol), compact, source)

    def make() -> taylor_adaptive_dbl:
        ode = symbolic_dynamics(system).ode if source == "hand" else derived_ode(system)
        n = system.nv
        return hy.taylor_adaptive(ode, np.zeros(2 * n), pars=np.zeros(n), tol=float(tol), compact_mode=compact)

    return _COMPILED.get(key, make)


def taylor_grid(
    ta: taylor_adaptive_dbl, start: Start, t: np.ndarray, *, max_steps: int = 0
) -> tuple[str, np.ndarray, int]:
    """The state (K, 2n) on the grid `t` from `start` at t[0] (its input held): (outcome, states,
    steps). outcome "ok", or heyoka's own word when it stopped early (the rows it did not reach NaN).
    `max_steps` > 0 bounds the Taylor steps (a budget with no per-step callback, which would cost more
    than the step itself)."""
    q0, v0, tau = start.q0, start.v0, start.tau
    ta.time = float(t[0])
    ta.state[:] = np.concatenate([np.asarray(q0, dtype=float), np.asarray(v0, dtype=float)])
    ta.pars[:] = np.asarray(tau, dtype=float)
    outcome, _min_h, _max_h, steps, _cb, states = ta.propagate_grid(np.asarray(t, dtype=float), max_steps=max_steps)
    word = str(outcome).split(".")[-1]
    out = np.full((len(t), ta.dim), np.nan)
    out[: len(states)] = states
    return ("ok" if word == "time_limit" else word), out, int(steps)


def compiled_rhs(system: System) -> Callable[[float, np.ndarray, Floats], np.ndarray]:
    """f(t, y, tau) -> (2n,) [v, a] of the hand equations as one compiled call (a heyoka `cfunc`)."""
    hy = heyoka()

    key = _key(system, "cfunc")

    def make() -> cfunc_dbl:
        dyn = symbolic_dynamics(system)
        return hy.cfunc(list(dyn.rhs), list(dyn.state))

    cf = _COMPILED.get(key, make)

    def rhs(t: float, y: np.ndarray, tau: Floats) -> np.ndarray:
        return cf(y, pars=tau)  # type: ignore[no-any-return]

    return rhs


def _rk4_expressions(system: System, steps: int) -> tuple[list[expression], list[expression]]:
    """`steps` RK4 steps of the hand equations as heyoka expressions of the state; tau = par[0:n],
    the timestep h = par[n]. MuJoCo's `mj_RungeKutta` operation for operation (mirror.py: the stage
    increments accumulated from 0 over the tableau's row, q_i = q + h dq, v_i = v + dv h, the final
    B-weighted sums the same way), so a compiled mirror rounds as the Python one does."""
    hy = heyoka()

    dyn = symbolic_dynamics(system)
    n, state, f = dyn.n, list(dyn.state), list(dyn.rhs)
    h = hy.par[n]
    names = [str(s) for s in state]

    def rate(x: list[expression]) -> list[expression]:
        return [hy.subs(e, dict(zip(names, x, strict=True))) for e in f[n:]]

    def weighted(weights: tuple[float, ...], terms: list[list[expression]], i: int) -> expression:
        total = hy.expression(0.0)
        for w, term in zip(weights, terms, strict=False):
            total = total + term[i] * w
        return total

    x = state
    for _ in range(steps):
        q, v = x[:n], x[n:]
        vs, acc = [v], [rate(x)]
        for row in RK4_A:
            qi = [q[i] + h * weighted(row, vs, i) for i in range(n)]
            vi = [v[i] + weighted(row, acc, i) * h for i in range(n)]
            vs.append(vi)
            acc.append(rate(qi + vi))
        x = [q[i] + h * weighted(RK4_B, vs, i) for i in range(n)] + [
            v[i] + weighted(RK4_B, acc, i) * h for i in range(n)
        ]
    return x, state


def compiled_rk4(system: System, steps: int) -> cfunc_dbl:
    """A heyoka `cfunc` doing `steps` RK4 steps of the hand equations: cf(y, pars=[tau..., h]) -> y'."""
    hy = heyoka()

    if steps < 1:
        raise HarnessError(f"compiled RK4 needs at least one step per call; got {steps}.")
    key = _key(system, "rk4", steps)

    def make() -> cfunc_dbl:
        return hy.cfunc(*_rk4_expressions(system, steps))

    return _COMPILED.get(key, make)


def rk4_plan(dt_out: float, timestep: float, most: int = RK4_STEPS_PER_CALL) -> tuple[int, int]:
    """(steps per compiled call, calls per output sample) for RK4 at `timestep` sampled every `dt_out`,
    at most `most` steps per call."""
    per_sample = round(dt_out / timestep)
    if per_sample < 1 or not np.isclose(per_sample * timestep, dt_out, rtol=1e-9, atol=0.0):
        raise HarnessError(f"the timestep {timestep} must divide the output step {dt_out}.")
    per_call = max(k for k in range(1, min(per_sample, most) + 1) if per_sample % k == 0)
    return per_call, per_sample // per_call


def rk4_grid(
    cf: cfunc_dbl,
    calls: int,
    start: Start,
    t: np.ndarray,
    *,
    timestep: float,
    deadline: float = np.inf,
) -> tuple[str, np.ndarray]:
    """The state (K, 2n) on the grid `t` by `calls` calls of the compiled RK4 steps `cf` per sample:
    ("ok" | "diverged" | "timeout", states; rows not reached are NaN). The deadline (perf_counter)
    and finiteness are checked once per sample."""
    q0, v0, tau = start.q0, start.v0, start.tau
    y = np.concatenate([np.asarray(q0, dtype=float), np.asarray(v0, dtype=float)])
    pars = np.concatenate([np.asarray(tau, dtype=float), [float(timestep)]])
    out = np.full((len(t), len(y)), np.nan)
    out[0] = y
    clock = time.perf_counter
    for k in range(1, len(t)):
        for _ in range(calls):
            y = cf(y, pars=pars)
        out[k] = y
        if not np.isfinite(y).all():
            out[k] = np.nan
            return "diverged", out
        if clock() > deadline:
            return "timeout", out
    return "ok", out

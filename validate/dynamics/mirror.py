"""Mirror integrators: MuJoCo's own time-stepping schemes applied to any source's dynamics.

A MuJoCo trajectory stepped with `mj_step` and a trajectory of the hand equations integrated by
scipy differ by two things at once: the equations and the integrator. A mirror removes the second:
it applies MuJoCo's scheme, operation for operation, to the hand equations (or Pinocchio's ABA),
so a stepped MuJoCo trajectory and its mirror differ only by the rounding of the forward dynamics
(~1e-16 relative per evaluation). Restarted from a shared state (`lockstep`), they agree to the
last bits whatever the chaos; free-running, that rounding is amplified like any other error.

The schemes, as in MuJoCo's src/engine/engine_forward.c (hinge joints: `mj_integratePos` is
`qpos += h * qvel`):

  RK4        `mj_RungeKutta(m, d, 4)`: tableau A = [[.5], [0, .5], [0, 0, 1]], B = [1/6, 1/3, 1/3, 1/6];
             stage i: dX = sum_j A_ij (v_j, a_j) accumulated from 0; q_i = q + h dXq, v_i = v + dXv h;
             final: dX = sum_j B_j (v_j, a_j); v' = v + dXv h, q' = q + h dXq (`mj_advance` with qvel = dXq).
  Euler      `mj_EulerSkip`: semi-implicit, v' = v + a h, q' = q + h v'. With joint damping D > 0 (and
             neither the eulerdamp nor the damper flag disabled) a = (M + h D)^-1 f, f = tau + passive - bias
             at (q, v): the damping is implicit in v'.
  implicit   `mj_implicitSkip`: a = (M - h dF/dv)^-1 f with dF/dv = d(passive - bias)/dv (`mjd_smooth_vel`
             with the RNE derivative; motor actuators have no velocity derivative), then as Euler.
  implicitfast  the same without the bias derivative (dF/dv = d passive / dv, lower triangle mirrored).

The derivative dF/dv is taken by central differences with a step of 1 rad/s: F is a polynomial of
degree at most 2 in v for any Lagrangian system with viscous friction (bias = C(q, v) v + G(q) is
quadratic, passive linear), for which the central difference is exact; only rounding remains
(~1e-15 relative), so the implicit mirrors agree with MuJoCo's analytic derivative to round-off too.

Loops are driven by step counts. All functions work on batches: q, v, tau are (N, n).

A wrong derivation is the normal input: a free run (`mirror_trajectory`) is bounded by the wall time
and the blow-up bound of a `Budget` (its evaluations are steps x stages, fixed in advance) and ends
with `stats["status"]` "diverged" (with "diverged at t = ..." as the reason) or "stopped: budget",
the samples kept up to there and NaN after; an error raised by the equations' arithmetic
(ZeroDivisionError at a singular M, OverflowError) ends it the same way. Batched steps give NaN rows
for states whose M is singular.
"""

from __future__ import annotations

import functools
import itertools
import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, TypeAlias, TypedDict, cast

import numpy as np

from ..core.arrays import Floats
from ..core.errors import HarnessError, unknown_name
from ..model.start import Scheme, Start
from ..sources.base import Source, SteppedSource, stepped
from ..sources.hand import HandSource, solve_or_nan
from ..systems import System
from .compiled import RK4_A, RK4_B, RK4_STEPS_PER_CALL, UNROLLED_MAX_DOF, compiled_rk4, rk4_plan
from .integrate import DEFAULT_BUDGET, EQUATION_ERRORS, MUJOCO_INTEGRATORS, Budget, Trajectory

if TYPE_CHECKING:  # heyoka is imported when first used (core/cachedir.heyoka)
    from heyoka import cfunc_dbl

# a source's one-state right-hand side f(t, y) -> (v, a), called on an array or on the scheme's list of floats
OneStateRhs: TypeAlias = Callable[[float, np.ndarray | list[float]], np.ndarray | Sequence[float]]
# the generated scheme (`_scheme_code`): run(f, q, v, h, steps) -> (q, v) after `steps` steps
SchemeRun: TypeAlias = Callable[[OneStateRhs, list[float], list[float], float, int], tuple[list[float], list[float]]]


class Lockstep(TypedDict):
    """`lockstep`'s windows: the scheme, the steps per window, the states, and per pair of sources
    ("a~b") the largest differences: "q" (rad), "v" (rad/s), "q_ulps", "v_ulps"."""

    integrator: str
    timestep: float
    window_steps: int
    n_states: int
    pairs: dict[str, dict[str, float]]


INTEGRATORS = MUJOCO_INTEGRATORS
DERIVATIVE_STEP = 1.0  # rad/s: central differences are exact for F quadratic in v, so a large step only cuts rounding


def _check_integrator(integrator: str) -> None:
    if integrator not in INTEGRATORS:
        raise unknown_name("MuJoCo integrator", integrator, INTEGRATORS)


def _force(source: Source, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """f = tau + passive - bias, (N, n)."""
    return tau + source.passive(q, v) - source.bias(q, v)


def _mass_and_force(source: Source, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """M (N, n, n) and f = tau + passive - bias (N, n): in one round trip to a person's module's worker
    where the source asks it so (sources/hand.py `passive_bias_mass`)."""
    both = getattr(source, "passive_bias_mass", None)
    if both is None:
        return source.mass_matrix(q), _force(source, q, v, tau)
    passive, bias, m = both(q, v)
    return m, tau + passive - bias


def force_velocity_jacobian(
    source: Source, q: np.ndarray, v: np.ndarray, *, bias: bool = True, step: float = DERIVATIVE_STEP
) -> np.ndarray:
    """d(passive - bias)/dv (bias=True) or d passive/dv (bias=False), (N, n, n), by central differences.

    Exact up to rounding for F of degree <= 2 in v (see the module docstring).
    """
    n = q.shape[-1]
    # every shifted state in one call per function: rows (+e_0, -e_0, +e_1, ...) x N, the same values as
    # one call per shift (the sources compute state by state) at a 20th of the calls' overhead
    shifts = np.zeros((2 * n, n))
    shifts[0::2][np.arange(n), np.arange(n)] = step
    shifts[1::2][np.arange(n), np.arange(n)] = -step
    qs = np.broadcast_to(q, (2 * n, *q.shape)).reshape(-1, n)
    vs = (v[None] + shifts[:, None, :]).reshape(-1, n)
    forces = source.passive(qs, vs)
    if bias:
        forces = forces - source.bias(qs, vs)
    forces = forces.reshape(n, 2, *q.shape)
    return np.moveaxis((forces[:, 0] - forces[:, 1]) / (2 * step), 0, -1)


def eulerdamp_active(system: System) -> bool:
    """Whether MuJoCo's Euler treats joint damping implicitly for this model (flags and damping)."""
    from ..sources import mujoco as engine

    return engine.eulerdamp_active(system.mujoco_model())


class Stepper:
    """One of MuJoCo's schemes on a source's dynamics, batched over N states."""

    def __init__(self, system: System, source: Source, stepping: Scheme) -> None:
        integrator, timestep = stepping.integrator, stepping.timestep
        _check_integrator(integrator)
        if not timestep > 0:
            raise HarnessError(f"timestep must be positive; got {timestep}.")
        self.system, self.source, self.integrator, self.h = system, source, integrator, float(timestep)
        self.eulerdamp = integrator == "Euler" and eulerdamp_active(system)
        self.evaluations = 0  # forward-dynamics evaluations (states), a cost guard for tests
        self._scalars: dict[tuple[tuple[float, ...], float | None], OneStateRhs | None] = {}  # per (tau, damped)

    def _scalar(self, tau: np.ndarray) -> OneStateRhs | None:
        """A one-state right-hand side f(t, y) without batch overhead, or None for MuJoCo's own."""
        damped = self.h if self.eulerdamp else None  # Euler's implicit damping: (M + h D)^-1 f
        key = (tuple(float(x) for x in tau), damped)
        cache = self._scalars
        if key not in cache:
            make = getattr(self.source, "rhs" if damped is None else "damped_rhs", None)
            cache[key] = (
                None if make is None else make(np.array(key[0])) if damped is None else make(np.array(key[0]), damped)
            )
        return cache[key]

    def _accel(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        self.evaluations += len(q)
        if len(q) == 1 and not self.eulerdamp:  # free runs: the generated scalar path (hand) or the engine's rhs
            fast = self._scalar(tau[0])
            if fast is not None:
                n = q.shape[1]
                try:
                    return np.asarray(fast(0.0, np.concatenate([q[0], v[0]]))[n:], dtype=float)[None]
                except EQUATION_ERRORS:  # e.g. ZeroDivisionError where M(q) is singular: no acceleration
                    return np.full((1, n), np.nan)
        return self.source.forward(q, v, tau)

    def step(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        h = self.h
        if self.integrator == "RK4":
            xs, fs = [v], [self._accel(q, v, tau)]
            for row in RK4_A:
                dq = np.zeros_like(q)
                dv = np.zeros_like(v)
                for a_ij, vj, fj in zip(row, xs, fs, strict=True):
                    dq = dq + vj * a_ij  # mju_addToScl(dX, X[j]+nq, A, nv)
                    dv = dv + fj * a_ij
                qi = q + h * dq  # mj_integratePos(m, X[i], dX, h)
                vi = v + dv * h  # mju_addToScl(X[i]+nq, dX+nv, h, nv)
                xs.append(vi)
                fs.append(self._accel(qi, vi, tau))
            dq = np.zeros_like(q)
            dv = np.zeros_like(v)
            for b_j, vj, fj in zip(RK4_B, xs, fs, strict=True):
                dq = dq + vj * b_j
                dv = dv + fj * b_j
            v_next = v + dv * h  # mj_advance: qvel += qacc h, then qpos += h dX (the B-weighted qvel)
            return q + h * dq, v_next
        if self.integrator == "Euler" and not self.eulerdamp:
            a = self._accel(q, v, tau)
        else:
            self.evaluations += len(q)
            m, f = _mass_and_force(self.source, q, v, tau)
            if self.integrator == "Euler":
                d = -np.diagonal(force_velocity_jacobian(self.source, q, v, bias=False), axis1=-2, axis2=-1)
                lhs = m + h * d[..., None] * np.eye(q.shape[-1])
            else:
                jac = force_velocity_jacobian(self.source, q, v, bias=self.integrator == "implicit")
                if self.integrator == "implicitfast":
                    low = np.tril(jac)
                    jac = low + np.swapaxes(np.tril(jac, -1), -1, -2)
                lhs = m - h * jac
            a = solve_or_nan(lhs, f)  # NaN rows where the (wrong) M makes lhs singular
        v_next = v + a * h
        return q + h * v_next, v_next


class _Blowup(Exception):
    """A free run's state left the budget's bound (or is not finite), or its wall time ran out."""


def _check_sample(q: Sequence[float], v: Sequence[float], budget: Budget, deadline: float) -> None:
    """Between samples: raises _Blowup past the blow-up bound (or at a non-finite entry) or the wall time."""
    bound = budget.max_abs_state
    for x in (*q, *v):
        if not abs(x) <= bound:  # NaN fails every comparison
            raise _Blowup("a non-finite state" if not math.isfinite(x) else f"|x| = {abs(float(x)):.3g} > {bound:g}")
    if time.perf_counter() > deadline:
        raise _Blowup(f"wall time {budget.max_wall_s:g} s")


@functools.lru_cache(maxsize=32)  # two schemes x the few coordinate counts of the systems run
def _scheme_code(integrator: str, n: int) -> SchemeRun:
    """`run(f, q, v, h, steps) -> (q, v)`: `steps` steps of `Stepper.step`'s one-state scheme (RK4 or
    semi-implicit Euler) on Python floats, generated as straight-line code for n coordinates with the
    same operations in the same order (the zero tableau entries included), so it rounds as the loop
    over the tableau does; a loop over lists cost twice as much per step."""
    qs, vs = [f"q{i}" for i in range(n)], [f"v{i}" for i in range(n)]
    rng = range(n)
    body: list[str] = []
    if integrator == "RK4":
        xs, fs = [vs], [[f"a0_{i}" for i in rng]]
        body.append(f"_y = f(0.0, [{', '.join(qs + vs)}])")
        body += [f"a0_{i} = _y[{n + i}]" for i in rng]
        for s, row in enumerate(RK4_A, start=1):
            for i in rng:
                dq = "0.0" + "".join(f" + {xs[j][i]} * {a!r}" for j, a in enumerate(row))
                dv = "0.0" + "".join(f" + {fs[j][i]} * {a!r}" for j, a in enumerate(row))
                body.append(f"dq{i} = {_nest(dq)}")
                body.append(f"dv{i} = {_nest(dv)}")
            body += [f"qs{s}_{i} = q{i} + h * dq{i}" for i in rng]
            body += [f"vs{s}_{i} = v{i} + dv{i} * h" for i in rng]
            body.append(f"_y = f(0.0, [{', '.join([f'qs{s}_{i}' for i in rng] + [f'vs{s}_{i}' for i in rng])}])")
            body += [f"a{s}_{i} = _y[{n + i}]" for i in rng]
            xs.append([f"vs{s}_{i}" for i in rng])
            fs.append([f"a{s}_{i}" for i in rng])
        for i in rng:
            body.append(f"dq{i} = {_nest('0.0' + ''.join(f' + {xs[j][i]} * {b!r}' for j, b in enumerate(RK4_B)))}")
            body.append(f"dv{i} = {_nest('0.0' + ''.join(f' + {fs[j][i]} * {b!r}' for j, b in enumerate(RK4_B)))}")
        body += [f"v{i} = v{i} + dv{i} * h" for i in rng]
        body += [f"q{i} = q{i} + h * dq{i}" for i in rng]
    else:  # semi-implicit Euler
        body.append(f"_y = f(0.0, [{', '.join(qs + vs)}])")
        body += [f"v{i} = v{i} + _y[{n + i}] * h" for i in rng]
        body += [f"q{i} = q{i} + h * v{i}" for i in rng]
    lines = [
        "def run(f, q, v, h, steps):",
        f"    {', '.join(qs)}, = q",
        f"    {', '.join(vs)}, = v",
        "    for _ in range(steps):",
        *[f"        {line}" for line in body],
        f"    return [{', '.join(qs)}], [{', '.join(vs)}]",
    ]
    namespace: dict[str, object] = {}
    exec(compile("\n".join(lines) + "\n", f"<mirror {integrator} n={n}>", "exec"), namespace)  # noqa: S102 - ours
    return cast(SchemeRun, namespace["run"])  # the function written above


def _nest(expr: str) -> str:
    """'0.0 + a + b + c' parenthesised left to right, as the loop accumulates: ((0.0 + a) + b) + c."""
    terms = expr.split(" + ")
    out = terms[0]
    for term in terms[1:]:
        out = f"({out} + {term})"
    return out


def _scalar_run(
    f: OneStateRhs,
    integrator: str,
    h: float,
    steps: int,
    qs: np.ndarray,
    vs: np.ndarray,
    stepper: Stepper,
    budget: Budget = DEFAULT_BUDGET,
    deadline: float = float("inf"),
) -> None:
    """`Stepper.step` for one state, operation for operation, on Python floats; fills rows 1.. of qs, vs.

    Raises _Blowup or one of EQUATION_ERRORS at the sample where the run cannot go on (rows before it filled).
    """
    run = _scheme_code(integrator, qs.shape[1])
    per_step = 4 if integrator == "RK4" else 1
    q, v = [float(x) for x in qs[0]], [float(x) for x in vs[0]]
    for k in range(1, len(qs)):
        q, v = run(f, q, v, h, steps)
        stepper.evaluations += per_step * steps
        _check_sample(q, v, budget, deadline)
        qs[k], vs[k] = q, v


def compiled_steps(source: Source, integrator: str, steps: int) -> tuple[cfunc_dbl, int] | None:
    """(cf, calls): MuJoCo's RK4 compiled (compiled.py `compiled_rk4`, cf(y, pars=[tau..., h]) does
    `steps / calls` steps, on one state (2n,) or a batch (2n, N)) for the hand equations of the
    source's system (a HandSource itself: a subclass may compute other dynamics than the module it
    traces); None for any other source or integrator, or where tracing or compiling fails (the Python
    scheme stands in). Measured (fast.py): 11x faster free runs, 35x faster batched windows, within
    1.03 ulp of MuJoCo's windows. Beyond 2 joints 2 steps per call: 10 unrolled steps of the 3-joint
    spatial arm compile in 1.1 s on a fresh machine."""
    if integrator != "RK4" or type(source) is not HandSource:
        return None
    per_call, calls = rk4_plan(float(steps), 1.0, RK4_STEPS_PER_CALL if source.system.nv <= UNROLLED_MAX_DOF else 2)
    try:
        return compiled_rk4(source.system, per_call), calls
    except Exception:  # noqa: BLE001 - equations heyoka cannot trace: the Python scheme, as before
        return None


_BLOCK = 16  # samples of a compiled run between blow-up and wall-time checks (a per-sample check cost 60%)


def _compiled_run(
    cf: cfunc_dbl,
    calls: int,
    h: float,
    tau: np.ndarray,
    qs: np.ndarray,
    vs: np.ndarray,
    budget: Budget,
    deadline: float,
) -> None:
    """The compiled steps sample by sample; fills rows 1.. of qs, vs. Every _BLOCK samples (and at the
    end) the block is checked against the blow-up bound and the deadline: raises _Blowup with the rows
    from the first bad one on made NaN (a fixed-step run spends at most a block more after a blow-up)."""
    n = qs.shape[1]
    y = np.concatenate([qs[0], vs[0]])
    pars = np.concatenate([tau, [h]])
    bound, last = budget.max_abs_state, 1
    for k in range(1, len(qs)):
        for _ in range(calls):
            y = cf(y, pars=pars)
        qs[k], vs[k] = y[:n], y[n:]
        if k % _BLOCK and k != len(qs) - 1:
            continue
        ok = (np.abs(qs[last : k + 1]) <= bound).all(axis=1) & (np.abs(vs[last : k + 1]) <= bound).all(axis=1)
        if not ok.all():
            bad = last + int(np.argmin(ok))
            x = np.concatenate([qs[bad], vs[bad]])
            qs[bad:], vs[bad:] = np.nan, np.nan
            big = float(np.abs(x).max())
            raise _Blowup("a non-finite state" if not np.isfinite(x).all() else f"|x| = {big:.3g} > {bound:g}")
        if time.perf_counter() > deadline:
            qs[k + 1 :], vs[k + 1 :] = np.nan, np.nan
            raise _Blowup(f"wall time {budget.max_wall_s:g} s")
        last = k + 1


def _steps_per_sample(t: np.ndarray, timestep: float) -> int:
    dt_out = float(t[1] - t[0]) if len(t) > 1 else timestep
    steps = round(dt_out / timestep)
    if steps < 1 or not np.isclose(steps * timestep, dt_out, rtol=1e-9, atol=0.0):
        raise HarnessError(f"timestep {timestep} must divide the output step {dt_out}.")
    return steps


def _step_samples(
    stepper: Stepper,
    source: Source,
    integrator: str,
    compiled: tuple[cfunc_dbl, int] | None,
    q: np.ndarray,
    v: np.ndarray,
    tau_b: np.ndarray,
    qs: np.ndarray,
    vs: np.ndarray,
    steps: int,
    budget: Budget,
) -> tuple[str, str]:
    """Fills rows 1.. of qs, vs, `steps` steps apart, until the end or the first failure; its (status,
    reason): ("ok", "") at the end, the raw reason of a blow-up, a spent budget or the equations' error."""
    dt, n = stepper.h, len(qs)
    fast = stepper._scalar(tau_b[0]) if integrator in ("RK4", "Euler") and compiled is None else None
    deadline = time.perf_counter() + budget.max_wall_s
    status, reason = "ok", ""
    with np.errstate(all="ignore"):
        try:
            if compiled is not None:  # MuJoCo's RK4 compiled: the same operations, one call per steps
                _compiled_run(*compiled, dt, tau_b[0], qs, vs, budget, deadline)
                stepper.evaluations += 4 * steps * (n - 1)
            elif fast is not None:  # one state: the same operations in Python floats (IEEE, so the same rounding)
                _scalar_run(fast, integrator, dt, steps, qs, vs, stepper, budget, deadline)
            else:
                for k in range(1, n):
                    for _ in range(steps):
                        q, v = stepper.step(q, v, tau_b)
                    _check_sample(q[0], v[0], budget, deadline)
                    qs[k], vs[k] = q[0], v[0]
        except _Blowup as exc:
            status = "stopped: budget" if str(exc).startswith("wall time") else "diverged"
            reason = str(exc)
        except EQUATION_ERRORS as exc:
            status = "diverged" if isinstance(exc, OverflowError) else "failed"
            reason = f"the {source.name} equations raised {type(exc).__name__}: {exc}"
    return status, reason


def _stopped(t: np.ndarray, qs: np.ndarray, vs: np.ndarray, status: str, reason: str) -> tuple[float, str]:
    """Sets the samples after the last good one to NaN; (stopped_at, the reason said with its time)."""
    good = int(np.argmax(np.isnan(qs[:, 0]))) if np.isnan(qs[:, 0]).any() else len(t)
    qs[good:], vs[good:] = np.nan, np.nan
    stopped_at = float(t[good - 1])
    if status == "diverged":
        reason = f"diverged at t = {float(t[min(good, len(t) - 1)]):.6g} s: {reason}"
    elif status == "stopped: budget":
        reason = f"stopped: budget: {reason} spent by t = {stopped_at:.6g} s"
    elif status == "failed":
        reason = f"{reason} between t = {stopped_at:.6g} s and the next sample"
    return stopped_at, reason


def mirror_trajectory(
    system: System,
    source: Source,
    start: Start,
    t: np.ndarray,
    *,
    integrator: str,
    timestep: float | None = None,
    budget: Budget = DEFAULT_BUDGET,
) -> Trajectory:
    """MuJoCo's `integrator` applied to `source` (hand, Pinocchio, or MuJoCo's own forward dynamics).

    Args:
        start: the (n,) initial state and constant input.
        t: (K,) uniform output grid starting at 0; `timestep` (default: the MJCF's) must divide its step.
        budget: the wall time and blow-up bound of the run (its evaluations are fixed by the steps).

    Returns:
        The trajectory; `stats` holds "steps", "evaluations", "status" ("ok", "diverged", "stopped:
        budget" or "failed"), "stopped_at" (s, the last good sample) and "reason" (one line, empty
        when ok). Samples after "stopped_at" are NaN. Never raises for what the equations compute.
    """
    q0, v0, tau = start.q0, start.v0, start.tau
    dt = float(timestep or system.mujoco_model().opt.timestep)
    steps = _steps_per_sample(t, dt)
    stepper = Stepper(system, source, Scheme(integrator, dt))
    q = np.asarray(q0, dtype=float)[None].copy()
    v = np.asarray(v0, dtype=float)[None].copy()
    tau_b = np.asarray(tau, dtype=float)[None]
    qs, vs = np.full((len(t), system.nv), np.nan), np.full((len(t), system.nv), np.nan)
    qs[0], vs[0] = q[0], v[0]
    compiled = compiled_steps(source, integrator, steps)
    status, reason = _step_samples(stepper, source, integrator, compiled, q, v, tau_b, qs, vs, steps, budget)
    stopped_at, reason = _stopped(t, qs, vs, status, reason)
    return Trajectory(
        source.name,
        f"mirror of MuJoCo {integrator} dt {dt:g}" + (" (compiled)" if compiled is not None else ""),
        np.asarray(t, dtype=float).copy(),
        qs,
        vs,
        {
            "steps": steps * (len(t) - 1),
            "evaluations": stepper.evaluations,
            "status": status,
            "stopped_at": stopped_at,
            "reason": reason,
        },
    )


def mirror_steps(
    system: System,
    source: Source,
    q: np.ndarray,
    v: np.ndarray,
    tau: np.ndarray,
    stepping: Scheme,
    *,
    steps: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """`steps` mirror steps from each of N states at once, (N, n) in and out (compiled in one call
    per group of steps for a source `compiled_steps` accepts: non-finite rows where it blows up)."""
    q, v = np.array(q, dtype=float), np.array(v, dtype=float)
    tau = np.broadcast_to(np.asarray(tau, dtype=float), q.shape)
    compiled = compiled_steps(source, stepping.integrator, steps) if len(q) else None
    if compiled is not None:
        cf, calls = compiled
        n = q.shape[1]
        y = np.ascontiguousarray(np.concatenate([q, v], axis=1).T)
        pars = np.ascontiguousarray(np.concatenate([tau, np.full((len(q), 1), float(stepping.timestep))], axis=1).T)
        for _ in range(calls):
            y = cf(y, pars=pars)
        return np.ascontiguousarray(y[:n].T), np.ascontiguousarray(y[n:].T)
    stepper = Stepper(system, source, stepping)
    with np.errstate(all="ignore"):  # a wrong derivation's overflow is NaN in its rows, not a warning
        for _ in range(steps):
            q, v = stepper.step(q, v, tau)
    return q, v


def mujoco_steps(
    source: SteppedSource,
    q: np.ndarray,
    v: np.ndarray,
    tau: np.ndarray,
    stepping: Scheme,
    *,
    steps: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """`steps` calls of `mj_step` from each of N states (the MuJoCo side of a lockstep), (N, n). A
    state from which MuJoCo warns (and resets) gives NaN rows, never the reset state as data."""
    from ..sources import mujoco as engine

    _check_integrator(stepping.integrator)
    return engine.step_states(source, q, v, tau, stepping, steps=steps)


def lockstep(
    system: System,
    sources: Mapping[str, Source],
    states: np.ndarray | tuple[Floats, Floats],
    *,
    integrator: str,
    timestep: float | None = None,
    window_steps: int = 1,
    tau: Floats | None = None,
) -> Lockstep:
    """Every source advanced `window_steps` steps from the same states; the largest differences per pair.

    The MuJoCo source (name "mujoco") steps with `mj_step`; every other source with its mirror.
    Restarting from a shared state each window keeps chaos from amplifying the differences: what
    remains is each window's own error (round-off, for a mirror of the same scheme).

    Args:
        sources: name -> source.
        states: (N, 2n) array of (q, v) rows, or a pair (q, v) of (N, n) arrays.
        tau: (n,) or (N, n) input; zero by default.

    Returns:
        {"integrator", "timestep", "window_steps", "n_states",
         "pairs": {"a~b": {"q": max |dq| (rad), "v": max |dv| (rad/s),
                           "q_ulps", "v_ulps": the same in units of spacing(max(|x|, 1))}}}
    """
    _check_integrator(integrator)
    n = system.nv
    if isinstance(states, tuple):
        q, v = (np.atleast_2d(np.asarray(x, dtype=float)) for x in states)
    else:
        x = np.atleast_2d(np.asarray(states, dtype=float))
        if x.shape[-1] != 2 * n:
            raise HarnessError(f"states must have {2 * n} columns (q, v) for {system.name}; got {x.shape}.")
        q, v = x[:, :n], x[:, n:]
    if q.shape != v.shape or q.shape[-1] != n:
        raise HarnessError(f"q and v must both be (N, {n}); got {q.shape} and {v.shape}.")
    tau_b = np.broadcast_to(np.zeros(n) if tau is None else np.asarray(tau, dtype=float), q.shape)
    dt = float(timestep or system.mujoco_model().opt.timestep)
    ends = {}
    for name, src in sources.items():
        if name == "mujoco":
            ends[name] = mujoco_steps(stepped(src), q, v, tau_b, Scheme(integrator, dt), steps=window_steps)
        else:
            ends[name] = mirror_steps(system, src, q, v, tau_b, Scheme(integrator, dt), steps=window_steps)
    pairs = {}
    for a, b in itertools.combinations(sorted(ends), 2):
        entry = {}
        for i, c in enumerate("qv"):
            x, y = ends[a][i], ends[b][i]
            d = np.abs(x - y)
            # in units of the spacing of doubles at the value's magnitude, at least that of 1 (rad, rad/s)
            ulp = np.spacing(np.maximum(np.maximum(np.abs(x), np.abs(y)), 1.0))
            entry[c], entry[f"{c}_ulps"] = float(d.max()), float((d / ulp).max())
        pairs[f"{a}~{b}"] = entry
    return {
        "integrator": integrator,
        "timestep": dt,
        "window_steps": int(window_steps),
        "n_states": int(len(q)),
        "pairs": pairs,
    }

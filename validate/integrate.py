"""Trajectories of each source on a common time grid.

scipy integrates the hand equations and Pinocchio's ABA; MuJoCo steps its own integrator. Loops
are driven by step counts, never by accumulated time, so every sample falls on the grid exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import HarnessError

DEFAULT_T_END = 10.0  # s
DEFAULT_DT_OUT = 0.01  # s
# The default scipy integration: the compiled LSODA driver (`odeint`), the fastest scipy driver to
# 1e-9 rad at t = 2 s on the double pendulum (`lagrange-xval bench` measures it against the others).
SCIPY_DEFAULT: dict[str, Any] = {"method": "odeint", "rtol": 1e-11, "atol": 1e-14}


MUJOCO_INTEGRATORS = ("Euler", "RK4", "implicit", "implicitfast")


def mujoco_integrator(name: str) -> Any:
    """MuJoCo's enum value for an integrator name; an unknown name lists the valid ones."""
    import mujoco

    if name not in MUJOCO_INTEGRATORS:
        from .errors import unknown_name

        raise unknown_name("MuJoCo integrator", name, MUJOCO_INTEGRATORS)
    return {
        "Euler": mujoco.mjtIntegrator.mjINT_EULER,
        "RK4": mujoco.mjtIntegrator.mjINT_RK4,
        "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
        "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    }[name]


@dataclass
class Trajectory:
    source: str  # "hand", "mujoco" or "pinocchio"
    method: str  # how it was integrated, for the report
    t: np.ndarray  # (K,) s
    q: np.ndarray  # (K, n) rad
    v: np.ndarray  # (K, n) rad/s
    stats: dict[str, Any] = field(default_factory=dict)  # e.g. right-hand-side evaluations

    @property
    def label(self) -> str:
        return f"{self.source} ({self.method})"


def initial_state(system: Any) -> tuple[np.ndarray, np.ndarray]:
    """The module's INITIAL_STATE (the notes' experiment) or a generic 0.5 rad, at rest."""
    q0, v0 = getattr(system.equations, "INITIAL_STATE", (np.full(system.nv, 0.5), np.zeros(system.nv)))
    return np.asarray(q0, dtype=float), np.asarray(v0, dtype=float)


def time_grid(t_end: float, dt_out: float) -> np.ndarray:
    samples = round(t_end / dt_out)
    if samples < 1 or not np.isclose(samples * dt_out, t_end, rtol=1e-12, atol=0.0):
        raise HarnessError(f"--t-end ({t_end}) must be a positive whole multiple of --dt-out ({dt_out}).")
    return np.arange(samples + 1) * dt_out


def _rhs(source: Any, tau: np.ndarray):
    """scipy's right-hand side. The hand equations use the generated scalar fast path
    (validate/fastpath.py); engines are called once per evaluation."""
    n = len(tau)
    counter = {"nfev": 0}
    if source.name == "hand":
        from .fastpath import scalar_rhs

        fast = scalar_rhs(source.system)
        tau_list = [float(x) for x in tau]

        def f(t: float, y: np.ndarray) -> Any:
            counter["nfev"] += 1
            return fast(t, y, tau_list)

        return f, counter

    if hasattr(source, "rhs"):
        engine = source.rhs(tau)

        def g(t: float, y: np.ndarray) -> np.ndarray:
            counter["nfev"] += 1
            return engine(t, y)

        return g, counter

    def h(t: float, y: np.ndarray) -> np.ndarray:
        counter["nfev"] += 1
        a = source.forward(y[None, :n], y[None, n:], tau[None])[0]
        return np.concatenate([y[n:], a])

    return h, counter


def scipy_trajectory(
    system: Any,
    source: Any,
    q0: np.ndarray,
    v0: np.ndarray,
    tau: np.ndarray,
    t: np.ndarray,
    *,
    method: str = "DOP853",
    rtol: float = 1e-12,
    atol: float = 1e-12,
) -> Trajectory:
    """scipy on a source's forward dynamics (the hand equations or Pinocchio's ABA): a `solve_ivp`
    method, or "odeint" for the compiled LSODA driver."""
    from scipy.integrate import odeint, solve_ivp

    f, counter = _rhs(source, tau)
    n = system.nv
    y0 = np.concatenate([q0, v0])
    if method == "odeint":
        y, info = odeint(f, y0, t, tfirst=True, rtol=rtol, atol=atol, full_output=True, mxstep=100000)
        if info["message"] != "Integration successful.":
            raise HarnessError(f"{system.name}: scipy odeint failed on the {source.name} equations: {info['message']}")
        sol_t, sol_y = np.asarray(t, dtype=float), y.T
    else:
        sol = solve_ivp(f, (t[0], t[-1]), y0, method=method, t_eval=t, rtol=rtol, atol=atol)
        if not sol.success:
            raise HarnessError(f"{system.name}: scipy {method} failed on the {source.name} equations: {sol.message}")
        sol_t, sol_y = sol.t, sol.y
    return Trajectory(
        source.name,
        f"scipy {method} rtol {rtol:g}",
        sol_t,
        sol_y[:n].T.copy(),
        sol_y[n:].T.copy(),
        {"nfev": counter["nfev"]},
    )


def mujoco_trajectory(
    system: Any,
    source: Any,
    q0: np.ndarray,
    v0: np.ndarray,
    tau: np.ndarray,
    t: np.ndarray,
    *,
    integrator: str = "RK4",
    timestep: float | None = None,
) -> Trajectory:
    """MuJoCo stepping its own integrator; samples every round(dt_out / timestep) steps."""
    import mujoco

    m, d = source.m, source.d
    enum = mujoco_integrator(integrator)
    saved = (m.opt.integrator, m.opt.timestep)
    m.opt.integrator = enum
    dt = float(timestep or m.opt.timestep)
    m.opt.timestep = dt
    dt_out = t[1] - t[0] if len(t) > 1 else dt
    steps = round(dt_out / dt)
    if steps < 1 or not np.isclose(steps * dt, dt_out, rtol=1e-9, atol=0.0):
        raise HarnessError(f"MuJoCo timestep {dt} must divide the output step {dt_out}.")
    try:
        mujoco.mj_resetData(m, d)
        source.set_state(q0, v0, tau)
        q, v = np.empty((len(t), system.nv)), np.empty((len(t), system.nv))
        q[0], v[0] = q0, v0
        for k in range(1, len(t)):
            mujoco.mj_step(m, d, nstep=steps)
            q[k], v[k] = source.get_state()
            _check_step(d, system, integrator, dt, t, k, q[k], v[k])
    finally:
        m.opt.integrator, m.opt.timestep = saved
    return Trajectory("mujoco", f"MuJoCo {integrator} dt {dt:g}", t.copy(), q, v, {"steps": steps * (len(t) - 1)})


class Diverged(HarnessError):
    """A run that went unstable: its samples from here on are not data."""


def _check_step(d: Any, system: Any, integrator: str, dt: float, t: np.ndarray, k: int, q: Any, v: Any) -> None:
    """Refuses sample k of a MuJoCo run after a warning (MuJoCo then resets the state to zeros and
    carries on) or with a non-finite value: never data, one line naming the time and the quantity."""
    warned = [w for w, stat in enumerate(d.warning) if stat.number]
    if warned or not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        import mujoco

        names = [mujoco.mjtWarning(w).name for w in warned]
        what = (
            f"MuJoCo warned {', '.join(names)} (bad {'/'.join(n.removeprefix('mjWARN_BAD').lower() for n in names)}"
            f", DOF {d.warning[warned[0]].lastinfo}) and reset the state"
            if warned
            else f"q = {np.asarray(q).tolist()}, v = {np.asarray(v).tolist()} is not finite"
        )
        raise Diverged(
            f"{system.name}: MuJoCo {integrator} at dt {dt:g} diverged between t = {t[k - 1]:g} s and "
            f"t = {t[k]:g} s: {what}; nothing written."
        )


def energy(system: Any, hand: Any, traj: Trajectory) -> np.ndarray:
    """Total energy T + V along a trajectory, by the hand equations (J)."""
    kin, pot = hand.energies(traj.q, traj.v)
    return kin + pot


def error_against(traj: Trajectory, ref: Trajectory) -> np.ndarray:
    """max over coordinates of |q - q_ref| at each sample, rad."""
    return np.abs(traj.q - ref.q).max(axis=1)


def first_exceeding(t: np.ndarray, err: np.ndarray, threshold: float) -> float | None:
    """The first sample time where err > threshold, or None if it never does."""
    above = np.nonzero(err > threshold)[0]
    return float(t[above[0]]) if len(above) else None


def run_trajectories(
    system: Any, sources: dict[str, Any], *, t_end: float = DEFAULT_T_END, dt_out: float = DEFAULT_DT_OUT
) -> list[Trajectory]:
    """The three sources from the system's initial state: scipy on the hand equations and on
    Pinocchio's ABA (same method and tolerances), MuJoCo RK4 at the MJCF's timestep."""
    q0, v0 = initial_state(system)
    tau = np.zeros(system.nv)
    t = time_grid(t_end, dt_out)
    return [
        scipy_trajectory(system, sources["hand"], q0, v0, tau, t, **SCIPY_DEFAULT),
        mujoco_trajectory(system, sources["mujoco"], q0, v0, tau, t, integrator="RK4"),
        scipy_trajectory(system, sources["pinocchio"], q0, v0, tau, t, **SCIPY_DEFAULT),
    ]

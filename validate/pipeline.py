"""The main job, system by system: model checks -> pointwise -> printed forms -> trajectories.

Each step returns plain data; `run` assembles `results.json` and the reports render from it.
"""

from __future__ import annotations

from concurrent.futures import Executor, as_completed
from typing import Any

import numpy as np

from . import chaos, compare, equivalence, experiments, integrate, judge, modelsync
from .sources import make_sources
from .tolerances import TOLERANCES

TRAJECTORY_THRESHOLD = TOLERANCES.trajectory.rtol  # rad
# The integrators `run` cross-validates (mirrors, convergence order, energy, free runs judged inside
# the predictability horizon); implicit and implicitfast are in `chaos.INTEGRATORS` for the benchmark.
RUN_INTEGRATORS = ("RK4", "Euler")


def trajectory_results(system: Any, sources: dict[str, Any], *, t_end: float, dt_out: float) -> dict[str, Any]:
    """The three sources' free runs against the reference solution of the hand equations (heyoka's
    Taylor method in long double, cached), plus the notes' perturbed start for the divergence."""
    from .reference import reference_trajectory

    q0, v0 = integrate.initial_state(system)
    tau = np.zeros(system.nv)
    t = integrate.time_grid(t_end, dt_out)
    ref, ref_info = reference_trajectory(system, q0, v0, tau, t)
    trajs = integrate.run_trajectories(system, sources, t_end=t_end, dt_out=dt_out)
    q0b = q0.copy()
    q0b[-1] += experiments.PERTURBATION
    perturbed = integrate.scipy_trajectory(system, sources["hand"], q0b, v0, tau, t, **integrate.SCIPY_DEFAULT)
    perturbed.stats["label"] = f"{system.coordinates[-1]}0 + {experiments.PERTURBATION:g}"
    runs = []
    for tr in [*trajs, perturbed]:
        err = integrate.error_against(tr, ref)
        e = integrate.energy(system, sources["hand"], tr)
        run = {
            "source": tr.source,
            "method": tr.method,
            "stats": tr.stats,
            "q": tr.q,
            "v": tr.v,
            "energy": e,
            "error_vs_hand": err,
            "max_error_vs_hand": float(err.max()),
            "first_exceeds_threshold": integrate.first_exceeding(tr.t, err, TRAJECTORY_THRESHOLD),
            "energy_drift": float(np.abs(e - e[0]).max()),
        }
        if "label" in tr.stats:
            run["label"] = tr.stats["label"]
        runs.append(run)
    return {
        "q0": q0,
        "v0": v0,
        "tau": tau,
        "t_end": t_end,
        "dt_out": dt_out,
        "t": t,
        "reference": f"hand equations, {ref_info.get('method', 'Taylor')} ({ref_info.get('precision', '')}); "
        f"agrees with a second method to {ref_info.get('agreement_q', float('nan')):.1e} rad",
        "reference_info": {k: v for k, v in ref_info.items() if np.isscalar(v) or isinstance(v, str)},
        "threshold": TRAJECTORY_THRESHOLD,
        "runs": runs,
    }


NEVER_USED = ("contact", "constraint", "limit", "frictionloss", "spring")  # no system of the notes has these
OPTIONAL = {"gravity": "gravity", "damping": "damper", "actuation": "actuation"}  # USES name -> MuJoCo flag


def skipped_work(system: Any) -> list[str]:
    """What the scene does not need, and so neither MuJoCo nor the harness computes."""
    uses = system.uses
    out = [f"MuJoCo: {', '.join(NEVER_USED)} disabled (no contacts, limits, dry friction or springs in the notes)"]
    for use, flag in OPTIONAL.items():
        if use not in uses:
            out.append(
                f"MuJoCo: {flag} disabled; printed forms' {'friction' if use == 'damping' else use} term not checked"
                " (the scene has none)"
            )
    if uses & {"damping", "actuation"}:
        out.append(
            "energy conservation not judged (friction or motors change the energy); energy balance is tested instead"
        )
    return out


def run_system(
    system: Any,
    *,
    n_states: int,
    seed: int,
    t_end: float = integrate.DEFAULT_T_END,
    dt_out: float = integrate.DEFAULT_DT_OUT,
) -> dict[str, Any]:
    """Everything the harness knows about one system, as plain data."""
    sources = make_sources(system)
    model = modelsync.check(system, sources["pinocchio"])
    states = compare.random_states(system, n=n_states, seed=seed)
    values = compare.evaluate(sources, states)  # evaluated once: the judge reuses the engines' values
    point = compare.pointwise_result(values, states, seed=seed)
    variants = judge.judge_system(system, states, sources, values=values)
    traj = trajectory_results(system, sources, t_end=t_end, dt_out=dt_out)
    notes_experiments = experiments.run_experiments(system)
    same = equivalence.check_equivalence(system)
    cross = chaos.crossvalidate(
        system, sources, t_end=t_end, dt_out=dt_out, integrators=RUN_INTEGRATORS, mirror_engines=("hand", "pinocchio")
    )
    passed = model["passed"] and point["passed"] and (same is None or same["passed"]) and cross["passed"]
    return {
        "name": system.name,
        "description": system.description,
        "mjcf": f"models/{system.mjcf.name}",
        "equations": f"equations/{system.name}.py",
        "coordinates": list(system.coordinates),
        "joints": list(system.joints),
        "bodies": list(system.bodies),
        "uses": sorted(system.uses),
        "parameters": {k: float(v) for k, v in vars(system.params).items()},
        "timestep": float(sources["mujoco"].m.opt.timestep),
        "model_checks": model,
        "pointwise": point,
        "variants": variants,
        "trajectories": traj,
        "experiments": notes_experiments,
        "equivalence": same,
        "chaos": cross,
        "skipped": skipped_work(system),
        "passed": passed,
    }


def _run_one(name: str, n_states: int, seed: int) -> dict[str, Any]:
    """One system, by name (picklable, for process pools)."""
    from .systems import load

    return run_system(load(name), n_states=n_states, seed=seed)


def run(
    names: list[str] | None, *, n_states: int, seed: int, progress: Any = None, executor: Executor | None = None
) -> dict[str, Any]:
    """Every system (or those named), each in a worker of `executor` (default: a process pool on
    every core; any `concurrent.futures.Executor` will do, a distributed one included)."""
    from .results import provenance
    from .systems import load_all

    systems = load_all(names)  # unknown names fail here, before any work starts
    out: dict[str, Any] = {"meta": provenance(seed), "tolerances": TOLERANCES.as_dict(), "systems": {}}
    from .parallel import executor_for

    with executor_for(executor, tasks=len(systems)) as pool:
        futures = {pool.submit(_run_one, s.name, n_states, seed): s.name for s in systems}
        for name in futures.values():
            if progress:
                progress(name, "start")
        done: dict[str, Any] = {}
        for future in as_completed(futures):
            name = futures[future]
            done[name] = future.result()
            if progress:
                progress(name, "done", done[name])
    out["systems"] = {name: done[name] for name in sorted(done)}
    out["passed"] = all(s["passed"] for s in out["systems"].values())
    return out

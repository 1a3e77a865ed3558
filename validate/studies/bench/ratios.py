"""The fast-harness ratios: the generated right-hand side against hand-written math, the pointwise
check against the raw engine calls (both baselines in baselines.py), MuJoCo's disable flags, the
default scipy against the fastest, and `lagrange-xval run`'s wall time.
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from ...dynamics.integrate import source_rhs
from ...model.start import Scheme, Start
from ...results.schema import (
    BenchRow,
    DefaultRatio,
    FlagsRow,
    Frontier,
    FrontierEntry,
    PointwiseRatio,
    PointwiseSize,
    RhsRatio,
    RunBrief,
    RunWallTimes,
    ScipyBrief,
)
from ...results.stages import seconds_of
from ...sources import make_source
from ...sources.base import Source, stepped
from ...sources.baselines import raw_mujoco, raw_pinocchio, raw_symbolic
from ...sources.fastpath import scalar_rhs
from ...systems import System
from ...verdict import pointwise as compare
from .baselines import hand_math_rhs, numpy_solve_rhs, raw_hand, raw_pointwise
from .plan import CONTENDER_DRIVERS, GRID_DRIVERS, Plan
from .runners import case_for, resources
from .shapes import Timed, cpu_of


def interleaved_medians(fns: dict[str, Callable[[], object]], reps: int) -> dict[str, Timed]:
    """Each callable timed `reps` times, in rotating order; medians of CPU and wall seconds."""
    names = list(fns)
    cpu: dict[str, list[float]] = {k: [] for k in names}
    wall: dict[str, list[float]] = {k: [] for k in names}
    for rep in range(reps):
        for k in names[rep % len(names) :] + names[: rep % len(names)]:
            c0, w0 = time.process_time(), time.perf_counter()
            fns[k]()
            cpu[k].append(time.process_time() - c0)
            wall[k].append(time.perf_counter() - w0)
    return {
        k: {
            "cpu_s": statistics.median(cpu[k]),
            "wall_s": statistics.median(wall[k]),
            "cpu_s_repeats": cpu[k],
            "wall_s_repeats": wall[k],
        }
        for k in names
    }


def rhs_ratio(plan: Plan, *, reps: int, calls: int = 10_000, n_states: int = 1000, seed: int = 0) -> RhsRatio:
    """Ratio 1 (a worker task): the right-hand side `scipy_trajectory` hands to the integrator for the
    hand equations (`integrate.source_rhs`: the generated fast path behind one call layer; the evaluation
    guard `integrate_rhs` puts around it is not included) against `hand_math_rhs`, per call, both called
    as scipy calls them (f(t, y), y a float64 array) over `n_states` states, on the plan's `rhs_system`."""
    system, _ = resources(plan.rhs_system)
    hand = make_source(system, "hand")
    harness = source_rhs(hand, np.zeros(system.nv))
    fast, tau0 = scalar_rhs(system), [0.0] * system.nv
    math_rhs, np_rhs = hand_math_rhs(system.params), numpy_solve_rhs(system.params)
    rng = np.random.default_rng(seed)
    ys = [rng.uniform(-3, 3, 2 * system.nv) for _ in range(n_states)]
    passes = max(1, calls // n_states)

    def loop(f: Callable[..., object], *extra: list[float]) -> Callable[[], None]:
        def run() -> None:
            for _ in range(passes):
                for y in ys:
                    f(0.0, y, *extra)

        return run

    timed = interleaved_medians(
        {
            "harness": loop(harness),
            "hand_math": loop(math_rhs),
            "fast_path_bare": loop(fast, tau0),
            "numpy_solve": loop(np_rhs),
        },
        reps,
    )
    per_call = {k: v["cpu_s"] / (passes * n_states) * 1e6 for k, v in timed.items()}
    ratio = per_call["harness"] / per_call["hand_math"]
    return {
        "system": plan.rhs_system,
        "value": ratio,
        "target": plan.rhs_target,
        "passed": ratio <= plan.rhs_target,
        "per_call_us": per_call,
        "numpy_vs_hand_math": per_call["numpy_solve"] / per_call["hand_math"],
        "calls_per_measurement": passes * n_states,
        "repeats": reps,
        "how": "CPU time per call (median of interleaved repeats) of the hand source's right-hand side "
        "(integrate.source_rhs: the generated fast path behind one call layer; integrate_rhs's evaluation "
        "guard around it not included) over the hand-written math version; "
        "both f(t, y) with y a float64 array; the loop overhead (~30 ns/call) is in both",
    }


def pointwise_ratio(name: str, plan: Plan, *, reps: int, seed: int = 0) -> PointwiseRatio:
    """Ratio 2 for one system (a worker task), at each batch size of the plan's `pointwise_sizes`:
    `compare.evaluate` through every source against `raw_pointwise` (the minimal loops computing the
    same), interleaved; and each source's own `evaluate` against its raw calls (`raw_hand`; `raw_mujoco`,
    `raw_pinocchio`: the engine's calls state by state with nothing else in the loop; `raw_symbolic`: the
    generated code alone).
    Sources and states are built, and the symbolic code generated, before timing. Value: the worst
    size's whole-evaluate ratio."""
    system, every = resources(name)
    # Drake has no raw counterpart here (its source is already one engine call per state): not in this ratio
    sources = {k: s for k, s in every.items() if k != "drake"}
    per_size = [_pointwise_at(system, sources, n_states, seed=seed, reps=reps) for n_states in plan.pointwise_sizes]
    worst = max(per_size, key=lambda r: r["value"])
    return {
        "system": system.name,
        "value": worst["value"],
        "target": plan.pointwise_target,
        "passed": all(r["value"] <= plan.pointwise_target for r in per_size),
        "per_size": per_size,
        "by_source": worst["by_source"],
        "repeats": reps,
    }


def _pointwise_at(
    system: System, sources: Mapping[str, Source], n_states: int, *, seed: int, reps: int
) -> PointwiseSize:
    """`pointwise_ratio` at one batch size."""
    states = compare.random_states(system, n=n_states, seed=seed)
    q, v, tau = states.q, states.v, states.tau
    a_hand = sources["hand"].forward(q, v, tau)
    compare.evaluate(sources, compare.States(q[:2], v[:2], tau[:2]))  # generates the symbolic code

    fns: dict[str, Callable[[], object]] = {
        "harness": lambda: compare.evaluate(sources, states),
        "raw": lambda: raw_pointwise(system, sources, states),
        "harness hand": lambda: sources["hand"].evaluate(q, v, tau),  # inverse dynamics at its own qacc
        "raw hand": lambda: raw_hand(system, states),
        "harness mujoco": lambda: sources["mujoco"].evaluate(q, v, tau, a_hand),
        "raw mujoco": lambda: raw_mujoco(system, sources["mujoco"], states, a_hand),
        "harness pinocchio": lambda: sources["pinocchio"].evaluate(q, v, tau, a_hand),
        "raw pinocchio": lambda: raw_pinocchio(system, sources["pinocchio"], states, a_hand),
    }
    if "symbolic" in sources:
        fns["harness symbolic"] = lambda: sources["symbolic"].evaluate(q, v, tau, a_hand)
        fns["raw symbolic"] = lambda: raw_symbolic(system, sources["symbolic"], states)
    # a large batch costs seconds per repeat: fewer repeats there (medians of at least 3 still)
    timed = interleaved_medians(fns, reps if n_states <= 10_000 else max(3, reps // 2))
    per_state = {k: t["cpu_s"] / n_states * 1e6 for k, t in timed.items()}
    return {
        "n_states": n_states,
        "value": timed["harness"]["cpu_s"] / timed["raw"]["cpu_s"],
        "harness_us_per_state": per_state["harness"],
        "raw_us_per_state": per_state["raw"],
        "harness_wall_s": timed["harness"]["wall_s"],
        "raw_wall_s": timed["raw"]["wall_s"],
        "by_source": {
            src: {
                "harness_us_per_state": per_state[f"harness {src}"],
                "raw_us_per_state": per_state[f"raw {src}"],
                "ratio": per_state[f"harness {src}"] / per_state[f"raw {src}"],
            }
            for src in sources
        },
    }


def flags_ratio(name: str, plan: Plan, *, reps: int) -> list[FlagsRow]:
    """Per integrator of the plan's `flag_integrators`: CPU time per mj_step (`flag_steps` of them) at the
    MJCF's timestep from the system's start, with the model's disable flags and with `disableflags = 0`,
    interleaved (a worker task)."""
    from ...sources import mujoco as engine  # imports MuJoCo: loaded when first used

    system, sources = resources(name)
    src = stepped(sources["mujoco"])
    case = case_for(system, plan)
    model_flags, timestep = int(src.m.opt.disableflags), float(src.m.opt.timestep)
    steps = plan.flag_steps
    out: list[FlagsRow] = []
    for integ in plan.flag_integrators:

        def stepping(flags: int, integ: str = integ) -> Callable[[], None]:
            def run() -> None:
                with engine.scheme(src.m, Scheme(integ, timestep)), engine.disabled(src.m, flags):
                    engine.steps_from(src, Start.of(case["q0"], case["v0"], case["tau"]), steps)

            return run

        timed = interleaved_medians({"model": stepping(model_flags), "none": stepping(0)}, reps)
        per_model = timed["model"]["cpu_s"] / steps * 1e6
        per_none = timed["none"]["cpu_s"] / steps * 1e6
        out.append(
            {
                "system": system.name,
                "integrator": integ,
                "timestep": timestep,
                "model_flags": engine.disable_flag_names(model_flags),
                "us_per_step_model_flags": per_model,
                "us_per_step_all_enabled": per_none,
                "all_enabled_over_model": per_none / per_model,
                "saving": 1.0 - per_model / per_none,
                "steps": steps,
                "repeats": reps,
            }
        )
    return out


def default_ratio(rows: list[BenchRow], plan: Plan) -> DefaultRatio:
    """From the sweep, on the plan's `rhs_system`: the default's CPU time over that of the fastest scipy run
    on the hand equations reaching `default_epsilon` at t = 2 s (drivers giving the whole 10 ms grid, as
    the default must), and which (method, rtol) runs would meet `default_target`."""
    system, epsilon, target = plan.rhs_system, plan.default_epsilon, plan.default_target
    mine = [r for r in rows if r["system"] == system]
    default = next((r for r in mine if r["driver"] == "default"), None)
    candidates = [
        r
        for r in mine
        if r["engine"] == "hand"
        and r["driver"] in ("solve_ivp", "ode", "odeint")
        and r["status"] == "ok"
        and r["error_2s"] is not None
        and r["error_2s"] <= epsilon
    ]
    out: DefaultRatio = {"system": system, "epsilon": epsilon, "target": target}
    if default is None or not candidates or default.get("cpu_s") is None:
        return {**out, "value": None, "passed": False, "why": "no default run or no scipy run reached epsilon"}
    fastest = min(candidates, key=cpu_of)
    ivp = [r for r in candidates if r["driver"] == "solve_ivp"]
    fastest_ivp = min(ivp, key=cpu_of) if ivp else None
    reached = default["status"] == "ok" and default["error_2s"] is not None and default["error_2s"] <= epsilon
    ratio = cpu_of(default) / cpu_of(fastest)

    def brief(r: BenchRow) -> ScipyBrief:
        return {
            "method": r["method"],
            "rtol": r["value"],
            "atol": r["atol"],
            "cpu_s": r["cpu_s"],
            "error_2s": r["error_2s"],
        }

    return {
        **out,
        "value": ratio,
        "passed": bool(reached and ratio <= target),
        "default": {**brief(default), "reached": reached},
        "fastest": brief(fastest),
        "fastest_solve_ivp": brief(fastest_ivp) if fastest_ivp is not None else None,
        "default_over_fastest_solve_ivp": cpu_of(default) / cpu_of(fastest_ivp) if fastest_ivp else None,
        "would_pass": [brief(r) for r in sorted(candidates, key=cpu_of) if cpu_of(r) <= target * cpu_of(fastest)],
        "how": "median CPU time of each run in the interleaved sweep; the default is integrate.scipy_trajectory "
        "with integrate.SCIPY_DEFAULT on the hand source",
    }


def frontier_ratios(rows: list[BenchRow], epsilons: tuple[float, ...]) -> Frontier:
    """From the sweep, per system and eps: the harness's default trajectory path (its driver, `odeint`
    on the hand equations' generated right-hand side, at the cheapest rtol reaching eps at t = 2 s; the
    default rtol itself as one of them) against the fastest run of any method reaching eps that gives
    the whole 10 ms grid (as the harness's trajectories must). CPU time ratios; nothing is asserted."""
    out: dict[str, list[FrontierEntry]] = {}

    def brief(r: BenchRow | None) -> RunBrief | None:
        if r is None:
            return None
        return {
            "method": r["method"],
            "setting": r["setting"],
            "value": r["value"],
            "cpu_s": r["cpu_s"],
            "wall_s": r["wall_s"],
            "error_2s": r["error_2s"],
            "error_10s": r["error_10s"],
        }

    def reaching(rs: list[BenchRow], eps: float) -> list[BenchRow]:
        return [
            r
            for r in rs
            if r["status"] == "ok" and r.get("cpu_s") is not None and r["error_2s"] is not None and r["error_2s"] <= eps
        ]

    for system in sorted({r["system"] for r in rows}):
        mine = [r for r in rows if r["system"] == system and r["driver"] in GRID_DRIVERS]
        path = [r for r in mine if (r["engine"], r["driver"]) == ("hand", "odeint") or r["driver"] == "default"]
        per_eps: list[FrontierEntry] = []
        for eps in epsilons:
            good, mine_good = reaching(path, eps), reaching(mine, eps)
            default = min(good, key=cpu_of) if good else None
            fastest = min(mine_good, key=cpu_of) if mine_good else None
            contenders = [r for r in mine_good if r["driver"] in CONTENDER_DRIVERS]
            best_contender = min(contenders, key=cpu_of) if contenders else None
            per_eps.append(
                {
                    "epsilon": eps,
                    "default_path": brief(default),
                    "fastest": brief(fastest),
                    "fastest_contender": brief(best_contender),
                    "ratio": cpu_of(default) / cpu_of(fastest) if default and fastest else None,
                    "why": None
                    if default and fastest
                    else ("the default path does not reach eps" if fastest else "no run reaches eps"),
                }
            )
        out[system] = per_eps
    return {
        "target": None,
        "epsilons": list(epsilons),
        "per_system": out,
        "how": "median CPU time of the sweep's runs; default path = odeint (LSODA) on the hand equations' "
        "generated right-hand side, as integrate.scipy_trajectory runs it, at the cheapest rtol of the sweep "
        "whose error at t = 2 s is <= eps (the default rtol included); fastest = the cheapest run of any method "
        "with the whole output grid reaching eps; ratio = default path / fastest",
    }


RUN_CONDITIONS = {
    "fresh machine": "no reference or chaos cache and an empty heyoka JIT cache (XDG_CACHE_HOME in a new folder)",
    "cold cache": "no reference or chaos cache (an empty --cache-dir); heyoka's JIT cache as the first run left it",
    "warm cache": "the reference and chaos cache the second run wrote",
}


def run_wall_times(plan: Plan, *, timeout: float = 900.0) -> RunWallTimes:
    """`python -m lagrange_xval.cli run` (all systems, reports and replays) timed as
    subprocesses one after another, with nothing else of the bench running: per repeat (the plan's
    `run_repeats`), three runs into new folders, one per condition of RUN_CONDITIONS (fresh machine,
    cold cache, warm cache); the warm cache's median against the plan's `run_warm_target_s`."""
    repeats = plan.run_repeats
    walls: dict[str, list[float]] = {c: [] for c in RUN_CONDITIONS}
    cpus: dict[str, list[float]] = {c: [] for c in RUN_CONDITIONS}
    stages: dict[str, list[dict[str, float]]] = {c: [] for c in RUN_CONDITIONS}
    codes: list[int] = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory(prefix="bench-run-") as tmp:
            env = {**os.environ, "XDG_CACHE_HOME": str(Path(tmp) / "xdg")}
            for k, condition in enumerate(RUN_CONDITIONS):
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                w0 = time.perf_counter()
                out, cache = Path(tmp) / f"out{k}", Path(tmp) / ("cache0" if k == 0 else "cache1")
                proc = subprocess.run(
                    [
                        sys.executable,
                        "-m",
                        "lagrange_xval.cli",
                        "run",
                        "--out",
                        str(out),
                        "--cache-dir",
                        str(cache),
                    ],
                    capture_output=True,
                    text=True,
                    timeout=timeout,
                    env=env,
                )
                walls[condition].append(time.perf_counter() - w0)
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpus[condition].append((after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime))
                codes.append(proc.returncode)
                stages[condition].append(stage_seconds(out / "results.json"))
    medians = {c: statistics.median(w) for c, w in walls.items()}
    return {
        "value": medians["warm cache"],
        "target": plan.run_warm_target_s,
        "passed": medians["warm cache"] <= plan.run_warm_target_s,
        "median_s": medians,
        "wall_s_all": walls,
        "cpu_s_all": cpus,
        "stages_s": {c: median_stages(runs) for c, runs in stages.items()},
        "exit_codes": codes,
        "repeats": repeats,
        "conditions": RUN_CONDITIONS,
        "how": "wall time of `python -m lagrange_xval.cli run --out <new folder> --cache-dir <folder>` "
        f"(every system, reports and rerun replays), {repeats} repeats of three runs one after another: "
        + "; ".join(f"{c}: {why}" for c, why in RUN_CONDITIONS.items())
        + "; value = the warm cache's median, judged against the target (fresh and cold are reported); "
        "CPU = user + system of the process tree",
    }


def stage_seconds(results_json: Path) -> dict[str, float]:
    """Each stage's wall seconds in one run's results.json, summed over its systems ({} if it has none)."""
    try:
        systems = json.loads(results_json.read_text()).get("systems", {})
    except (OSError, ValueError):
        return {}
    out: dict[str, float] = {}
    for s in systems.values():
        for stage, record in (s.get("stages") or {}).items():
            if (seconds := seconds_of(record)) is not None:
                out[stage] = out.get(stage, 0.0) + seconds
    return out


def median_stages(runs: list[dict[str, float]]) -> dict[str, float]:
    """Per stage, the median over the runs of its seconds (a run without the stage counts 0)."""
    names = [n for run in runs for n in run]
    return {n: statistics.median(run.get(n, 0.0) for run in runs) for n in dict.fromkeys(names)}

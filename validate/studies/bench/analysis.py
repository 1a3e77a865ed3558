"""The sweep and what is read from it: errors against the reference, rows, Pareto fronts and the
time to reach an error.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Iterable
from concurrent.futures import Executor, Future
from typing import Any, TypeVar

import numpy as np

from ...core.errors import HarnessError
from ...core.parallel import completed
from ...results.schema import BenchRow, FrontPoint, Spec, TimeToEpsilon
from .plan import ERROR_TIMES, Plan
from .runners import execute
from .shapes import CostKey, ErrorKey, Errors, Execution, Prepared

T = TypeVar("T")


def errors_against(
    t: np.ndarray, q: np.ndarray, ref_t: np.ndarray, ref_q: np.ndarray, *, window: float, tolerance: float
) -> Errors:
    """error_2s, error_10s (max over coordinates of |q - q_ref|, rad), error_horizon (max over the
    samples up to `window`; None when the run was sampled at ERROR_TIMES only) and t_exceeds_tolerance
    (the first sample whose error exceeds `tolerance`, rad)."""
    dt = float(ref_t[1] - ref_t[0])
    idx = np.rint(np.asarray(t) / dt).astype(int)
    if np.any(idx >= len(ref_t)) or not np.allclose(ref_t[idx], t, rtol=0.0, atol=1e-9):
        raise HarnessError("run samples are not on the reference grid.")
    err = np.abs(q - ref_q[idx]).max(axis=1)
    at = {tt: float(err[i]) for i, tt in enumerate(np.asarray(t)) if any(abs(tt - e) < 1e-9 for e in ERROR_TIMES)}
    full = len(t) == len(ref_t)
    inside = np.asarray(t) <= window + 1e-9
    above = np.nonzero(err > tolerance)[0]
    return {
        "error_2s": at.get(2.0),
        "error_10s": at.get(10.0),
        "error_horizon": float(err[inside].max()) if full else None,
        "t_exceeds_tolerance": (float(t[above[0]]) if len(above) else None) if full else None,
    }


def row_of(system: str, spec: Spec) -> BenchRow:
    return {
        "system": system,
        "method": spec["method"],
        "engine": spec["engine"],
        "driver": spec["driver"],
        "scheme": spec["scheme"],
        "setting": spec["setting"],
        "value": spec["value"],
        "atol": spec["atol"],
        "status": "skipped",
        "message": "",
        "error_2s": None,
        "error_10s": None,
        "error_horizon": None,
        "t_exceeds_tolerance": None,
        "cpu_s": None,
        "wall_s": None,
        "cpu_s_repeats": [],
        "wall_s_repeats": [],
        "executions": None,
        "nfev": None,
        "steps": None,
        "deterministic": True,
    }


def sort_key(row: BenchRow) -> tuple[str, str, float]:
    return (row["system"], row["method"], -row["value"])


def pareto_front(rows: Iterable[BenchRow], error: ErrorKey, *, cost: CostKey = "cpu_s") -> list[FrontPoint]:
    """The runs no other run beats in both `cost` and `error` (status ok, finite values), cheapest first."""
    ok = [
        (c, e, r)
        for r in rows
        if r["status"] == "ok"
        and (e := r.get(error)) is not None
        and (c := r.get(cost)) is not None
        and math.isfinite(e)
        and math.isfinite(c)
    ]
    ok.sort(key=lambda ce: (ce[0], ce[1]))
    front: list[FrontPoint] = []
    best = math.inf
    for c, e, r in ok:
        if e < best:
            best = e
            point: FrontPoint = {"method": r["method"], "setting": r["setting"], "value": r["value"]}
            point[cost], point[error] = c, e
            front.append(point)
    return front


def time_to_epsilon(
    rows: Iterable[BenchRow],
    epsilons: Iterable[float],
    *,
    error: ErrorKey = "error_2s",
    cost: CostKey = "cpu_s",
) -> list[TimeToEpsilon]:
    """Per system, method and epsilon: the cheapest run of that method with `error` <= epsilon, or
    "not reached". Sorted by system, method, epsilon (largest first)."""
    groups: dict[tuple[str, str], list[BenchRow]] = {}
    for r in rows:
        groups.setdefault((r["system"], r["method"]), []).append(r)
    out: list[TimeToEpsilon] = []
    for (system, method), runs in sorted(groups.items()):
        for eps in sorted(epsilons, reverse=True):
            good = [
                r
                for r in runs
                if r["status"] == "ok" and (e := r.get(error)) is not None and e <= eps and r.get(cost) is not None
            ]
            out.append(
                _reached(system, method, eps, min(good, key=lambda r: (r[cost], -r["value"])) if good else None, error)
            )
    return out


def _reached(system: str, method: str, eps: float, best: BenchRow | None, error: ErrorKey) -> TimeToEpsilon:
    """`time_to_epsilon`'s entry: the cheapest run reaching eps (`best`), or "not reached"."""
    if best is None:
        return {
            "system": system,
            "method": method,
            "epsilon": eps,
            "result": "not reached",
            "setting": None,
            "value": None,
            "cpu_s": None,
            "wall_s": None,
            "error": None,
        }
    return {
        "system": system,
        "method": method,
        "epsilon": eps,
        "result": "reached",
        "setting": best["setting"],
        "value": best["value"],
        "cpu_s": best["cpu_s"],
        "wall_s": best["wall_s"],
        "error": best[error],
    }


def interleave(groups: list[list[T]], rotate: int) -> list[T]:
    """Round-robin: the first item of every group, then the second, ...; the group order rotated."""
    if groups:
        rotate %= len(groups)
        groups = groups[rotate:] + groups[:rotate]
    out = []
    for level in range(max((len(g) for g in groups), default=0)):
        out += [g[level] for g in groups if level < len(g)]
    return out


def looser(a: Spec, b: Spec) -> bool:
    """Whether setting a is looser (cheaper) than b: larger rtol or timestep."""
    return a["value"] > b["value"]


Key = tuple[str, str, float]  # (system, method, setting value): one row
Task = tuple[str, Spec]  # (system, spec): one run
Tasks = dict[str, tuple[Callable[..., object], tuple[object, ...]]]  # {label: (fn, args)}: more worker tasks


def sweep(
    prepared: dict[str, Prepared],
    specs: list[Spec],
    *,
    plan: Plan,
    executor: Executor,
    progress: Callable[[str], None] | None = None,
    extra: Tasks | None = None,
) -> tuple[list[BenchRow], dict[str, object]]:
    """Every spec on every prepared system, `plan.repeats` times, interleaved; rows sorted.

    Args:
        prepared: {system: prepare(system)}.
        specs: the plan's runs (`Plan.specs`), the same for every system.
        plan: the repeats, the per-run budget and what `execute` reads.
        extra: more worker tasks {key: (fn, args)} submitted with the last repeat (the ratio measurements);
            their results are returned in the second value.
    """
    if plan.repeats < 1:
        raise HarnessError(f"repeats must be at least 1; got {plan.repeats}.")
    rows = {(name, s["method"], s["value"]): row_of(name, s) for name in prepared for s in specs}
    groups = method_groups(prepared, specs)
    extras: dict[str, object] = {}
    digests: dict[Key, str | None] = {}
    for rep in range(plan.repeats):
        todo = [
            [(name, s) for s in g if rep == 0 or rows[(name, s["method"], s["value"])]["status"] == "ok"]
            for (name, _), g in groups.items()
        ]
        futures = {
            executor.submit(execute, s, prepared[name]["case"], plan=plan, samples=rep == 0): (name, s)
            for name, s in interleave(todo, rep)
        }
        last = rep == plan.repeats - 1
        extra_futures = (
            {executor.submit(fn, *args): label for label, (fn, args) in (extra or {}).items()} if last else {}
        )
        collect(futures, extra_futures, rows, digests, extras, prepared=prepared, plan=plan, rep=rep, progress=progress)
    for row in rows.values():
        if row["cpu_s_repeats"]:
            row["cpu_s"] = statistics.median(row["cpu_s_repeats"])
            row["wall_s"] = statistics.median(row["wall_s_repeats"])
    return sorted(rows.values(), key=sort_key), extras


def method_groups(prepared: dict[str, Prepared], specs: list[Spec]) -> dict[tuple[str, str], list[Spec]]:
    """The specs of each (system, method), loosest setting first."""
    groups: dict[tuple[str, str], list[Spec]] = {}
    for name in prepared:
        for s in specs:
            groups.setdefault((name, s["method"]), []).append(s)
    for g in groups.values():
        g.sort(key=lambda s: -s["value"])
    return groups


def collect(
    futures: dict[Future[Any], Task],  # Any: one pool runs `execute` and the extra tasks (Future is invariant)
    extra_futures: dict[Future[Any], str],
    rows: dict[Key, BenchRow],
    digests: dict[Key, str | None],
    extras: dict[str, object],
    *,
    prepared: dict[str, Prepared],
    plan: Plan,
    rep: int,
    progress: Callable[[str], None] | None,
) -> None:
    """One repeat's results into their rows (and the ratio measurements into `extras`) as they finish."""
    if progress:
        more = f" and {len(extra_futures)} ratio measurements" if extra_futures else ""
        progress(f"repeat {rep + 1}/{plan.repeats}: timing {len(futures)} runs{more}")
    done = 0
    for fut in completed([*futures, *extra_futures]):
        if fut in extra_futures:
            extras[extra_futures[fut]] = fut.result()
            if progress:
                progress(f"measured {extra_futures[fut]} ({len(extras)}/{len(extra_futures)})")
            continue
        if fut.cancelled():
            continue
        name, s = futures[fut]
        res = fut.result()
        done += 1
        key = (name, s["method"], s["value"])
        if rep == 0:
            digests[key] = res["digest"]
            record_first(rows[key], res, prepared[name], plan)
            if res["status"] == "timeout":  # tighter settings of the same method cost more: not run
                skip_tighter(futures, rows, (name, s), budget=plan.budget)
        else:
            record_repeat(rows[key], res, digests[key], rep)
        if progress and done % max(1, len(futures) // 10) == 0:
            progress(f"repeat {rep + 1}/{plan.repeats}: {done}/{len(futures)} runs")


def record_first(row: BenchRow, res: Execution, ref: Prepared, plan: Plan) -> None:
    """The first repeat of a run: its status, counts, errors against the reference (when ok) and times."""
    row.update(
        {
            "status": res["status"],
            "message": res["message"],
            "nfev": res["nfev"],
            "steps": res["steps"],
            "executions": res["executions"],
            "deterministic": res["deterministic"],
        }
    )
    t, q = res["t"], res["q"]
    if res["status"] == "ok" and t is not None and q is not None:  # the first repeat keeps its samples
        window = ref["horizon_window_s"]
        row.update(errors_against(t, q, ref["t"], ref["q"], window=window, tolerance=plan.horizon_tolerance))
    add_times(row, res)


def record_repeat(row: BenchRow, res: Execution, first_digest: str | None, rep: int) -> None:
    """A later repeat: its times, and the run marked not deterministic where it failed or gave other bits."""
    if res["status"] != "ok" or res["digest"] != first_digest:
        row["deterministic"] = False
        if res["status"] != "ok":
            row["message"] = f"repeat {rep + 1}: {res['status']} {res['message']}".strip()
            return
    add_times(row, res)


def add_times(row: BenchRow, res: Execution) -> None:
    """A timed execution's CPU and wall seconds among the row's repeats (a skipped run has none)."""
    if res["status"] in ("ok", "timeout", "diverged", "failed"):
        row["cpu_s_repeats"].append(res["cpu_s"])
        row["wall_s_repeats"].append(res["wall_s"])


def skip_tighter(
    futures: dict[Future[Any], Task], rows: dict[Key, BenchRow], timed_out: Task, *, budget: float
) -> None:
    """Cancel the settings of the same method tighter than one that timed out, their rows "skipped"."""
    name, s = timed_out
    for other, (oname, os_) in futures.items():
        if oname == name and os_["method"] == s["method"] and looser(s, os_) and other.cancel():
            rows[(oname, os_["method"], os_["value"])].update(
                {
                    "status": "skipped",
                    "message": f"not run: {s['setting']} {s['value']:g} already exceeded the {budget:g} s budget",
                }
            )

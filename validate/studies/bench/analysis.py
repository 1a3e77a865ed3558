"""The sweep and what is read from it: errors against the reference, rows, Pareto fronts and the
time to reach an error.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Iterable
from concurrent.futures import Executor, Future
from typing import Any

import numpy as np

from ...core.errors import HarnessError
from ...core.parallel import completed
from .plan import ERROR_TIMES, Plan
from .runners import execute


def errors_against(
    t: np.ndarray, q: np.ndarray, ref_t: np.ndarray, ref_q: np.ndarray, *, window: float, tolerance: float
) -> dict[str, Any]:
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


def row_of(system: str, spec: dict[str, Any]) -> dict[str, Any]:
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


def sort_key(row: dict[str, Any]) -> tuple[Any, ...]:
    return (row["system"], row["method"], -row["value"])


def pareto_front(rows: Iterable[dict[str, Any]], error: str, *, cost: str = "cpu_s") -> list[dict[str, Any]]:
    """The runs no other run beats in both `cost` and `error` (status ok, finite values), cheapest first."""
    ok = [
        r
        for r in rows
        if r["status"] == "ok"
        and r.get(error) is not None
        and r.get(cost) is not None
        and math.isfinite(r[error])
        and math.isfinite(r[cost])
    ]
    ok.sort(key=lambda r: (r[cost], r[error]))
    front, best = [], math.inf
    for r in ok:
        if r[error] < best:
            best = r[error]
            front.append(
                {"method": r["method"], "setting": r["setting"], "value": r["value"], cost: r[cost], error: r[error]}
            )
    return front


def time_to_epsilon(
    rows: Iterable[dict[str, Any]],
    epsilons: Iterable[float],
    *,
    error: str = "error_2s",
    cost: str = "cpu_s",
) -> list[dict[str, Any]]:
    """Per system, method and epsilon: the cheapest run of that method with `error` <= epsilon, or
    "not reached". Sorted by system, method, epsilon (largest first)."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["system"], r["method"]), []).append(r)
    out = []
    for (system, method), runs in sorted(groups.items()):
        for eps in sorted(epsilons, reverse=True):
            good = [
                r
                for r in runs
                if r["status"] == "ok" and r.get(error) is not None and r[error] <= eps and r.get(cost) is not None
            ]
            entry: dict[str, Any] = {"system": system, "method": method, "epsilon": eps}
            if good:
                best = min(good, key=lambda r: (r[cost], -r["value"]))
                entry.update(
                    result="reached",
                    setting=best["setting"],
                    value=best["value"],
                    cpu_s=best["cpu_s"],
                    wall_s=best["wall_s"],
                    error=best[error],
                )
            else:
                entry.update(result="not reached", setting=None, value=None, cpu_s=None, wall_s=None, error=None)
            out.append(entry)
    return out


def interleave(groups: list[list[Any]], rotate: int) -> list[Any]:
    """Round-robin: the first item of every group, then the second, ...; the group order rotated."""
    if groups:
        rotate %= len(groups)
        groups = groups[rotate:] + groups[:rotate]
    out = []
    for level in range(max((len(g) for g in groups), default=0)):
        out += [g[level] for g in groups if level < len(g)]
    return out


def looser(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Whether setting a is looser (cheaper) than b: larger rtol or timestep."""
    return a["value"] > b["value"]


Key = tuple[str, str, float]  # (system, method, setting value): one row
Task = tuple[str, dict[str, Any]]  # (system, spec): one run


def sweep(
    prepared: dict[str, dict[str, Any]],
    specs: list[dict[str, Any]],
    *,
    plan: Plan,
    executor: Executor,
    progress: Callable[[str], None] | None = None,
    extra: dict[str, tuple[Callable[..., Any], tuple[Any, ...]]] | None = None,
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
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
    extras: dict[str, Any] = {}
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


def method_groups(prepared: dict[str, Any], specs: list[dict[str, Any]]) -> dict[tuple[str, str], list[dict[str, Any]]]:
    """The specs of each (system, method), loosest setting first."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for name in prepared:
        for s in specs:
            groups.setdefault((name, s["method"]), []).append(s)
    for g in groups.values():
        g.sort(key=lambda s: -s["value"])
    return groups


def collect(
    futures: dict[Future[Any], Task],
    extra_futures: dict[Future[Any], str],
    rows: dict[Key, dict[str, Any]],
    digests: dict[Key, str | None],
    extras: dict[str, Any],
    *,
    prepared: dict[str, dict[str, Any]],
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


def record_first(row: dict[str, Any], res: dict[str, Any], ref: dict[str, Any], plan: Plan) -> None:
    """The first repeat of a run: its status, counts, errors against the reference (when ok) and times."""
    row.update(
        status=res["status"],
        message=res["message"],
        nfev=res["nfev"],
        steps=res["steps"],
        executions=res["executions"],
        deterministic=res["deterministic"],
    )
    if res["status"] == "ok":
        window = ref["horizon_window_s"]
        row.update(
            errors_against(res["t"], res["q"], ref["t"], ref["q"], window=window, tolerance=plan.horizon_tolerance)
        )
    add_times(row, res)


def record_repeat(row: dict[str, Any], res: dict[str, Any], first_digest: str | None, rep: int) -> None:
    """A later repeat: its times, and the run marked not deterministic where it failed or gave other bits."""
    if res["status"] != "ok" or res["digest"] != first_digest:
        row["deterministic"] = False
        if res["status"] != "ok":
            row["message"] = f"repeat {rep + 1}: {res['status']} {res['message']}".strip()
            return
    add_times(row, res)


def add_times(row: dict[str, Any], res: dict[str, Any]) -> None:
    """A timed execution's CPU and wall seconds among the row's repeats (a skipped run has none)."""
    if res["status"] in ("ok", "timeout", "diverged", "failed"):
        row["cpu_s_repeats"].append(res["cpu_s"])
        row["wall_s_repeats"].append(res["wall_s"])


def skip_tighter(
    futures: dict[Future[Any], Task], rows: dict[Key, dict[str, Any]], timed_out: Task, *, budget: float
) -> None:
    """Cancel the settings of the same method tighter than one that timed out, their rows "skipped"."""
    name, s = timed_out
    for other, (oname, os_) in futures.items():
        if oname == name and os_["method"] == s["method"] and looser(s, os_) and other.cancel():
            rows[(oname, os_["method"], os_["value"])].update(
                status="skipped",
                message=f"not run: {s['setting']} {s['value']:g} already exceeded the {budget:g} s budget",
            )

"""The sweep and what is read from it: errors against the reference, rows, Pareto fronts and the
time to reach an error.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Iterable
from concurrent.futures import Executor, Future, as_completed
from typing import Any

import numpy as np

from ...errors import HarnessError
from .plan import EPSILONS, ERROR_TIMES, HORIZON_TOLERANCE, MIN_TIMED
from .runners import execute


def errors_against(
    t: np.ndarray, q: np.ndarray, ref_t: np.ndarray, ref_q: np.ndarray, *, window: float
) -> dict[str, Any]:
    """error_2s, error_10s (max over coordinates of |q - q_ref|, rad), error_horizon (max over the
    samples up to `window`; None when the run was sampled at ERROR_TIMES only) and t_exceeds_tolerance."""
    dt = float(ref_t[1] - ref_t[0])
    idx = np.rint(np.asarray(t) / dt).astype(int)
    if np.any(idx >= len(ref_t)) or not np.allclose(ref_t[idx], t, rtol=0.0, atol=1e-9):
        raise HarnessError("run samples are not on the reference grid.")
    err = np.abs(q - ref_q[idx]).max(axis=1)
    at = {tt: float(err[i]) for i, tt in enumerate(np.asarray(t)) if any(abs(tt - e) < 1e-9 for e in ERROR_TIMES)}
    full = len(t) == len(ref_t)
    inside = np.asarray(t) <= window + 1e-9
    above = np.nonzero(err > HORIZON_TOLERANCE)[0]
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
    epsilons: Iterable[float] = EPSILONS,
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


def sweep(
    prepared: dict[str, dict[str, Any]],
    specs: list[dict[str, Any]],
    *,
    repeats: int,
    executor: Executor,
    budget: float,
    min_timed: float = MIN_TIMED,
    progress: Callable[[str], None] | None = None,
    extra: dict[str, tuple[Callable[..., Any], tuple[Any, ...]]] | None = None,
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Every spec on every prepared system, `repeats` times, interleaved; rows sorted.

    Args:
        prepared: {system: prepare(system)}.
        specs: the plan (see `plan`), the same for every system.
        extra: more worker tasks {key: (fn, args)} submitted with the last repeat (the ratio measurements);
            their results are returned in the second value.
    """
    if repeats < 1:
        raise HarnessError(f"repeats must be at least 1; got {repeats}.")
    rows = {(name, s["method"], s["value"]): row_of(name, s) for name in prepared for s in specs}
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for name in prepared:
        for s in specs:
            groups.setdefault((name, s["method"]), []).append(s)
    for g in groups.values():
        g.sort(key=lambda s: -s["value"])
    extras: dict[str, Any] = {}
    digests: dict[tuple[str, str, float], str | None] = {}
    for rep in range(repeats):
        if rep == 0:
            todo = [[(key[0], s) for s in g] for key, g in groups.items()]
        else:
            todo = [
                [(key[0], s) for s in g if rows[(key[0], s["method"], s["value"])]["status"] == "ok"]
                for key, g in groups.items()
            ]
        order = interleave(todo, rep)
        futures: dict[Future[Any], tuple[str, dict[str, Any]]] = {}
        for name, s in order:
            fut = executor.submit(
                execute, s, prepared[name]["case"], budget=budget, min_timed=min_timed, samples=rep == 0
            )
            futures[fut] = (name, s)
        extra_futures: dict[Future[Any], str] = {}
        if rep == repeats - 1:
            for label, (fn, args) in (extra or {}).items():
                extra_futures[executor.submit(fn, *args)] = label
        done = 0
        if progress:
            more = f" and {len(extra_futures)} ratio measurements" if extra_futures else ""
            progress(f"repeat {rep + 1}/{repeats}: timing {len(futures)} runs{more}")
        for fut in as_completed([*futures, *extra_futures]):
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
            row = rows[key]
            if rep == 0:
                row.update(
                    status=res["status"],
                    message=res["message"],
                    nfev=res["nfev"],
                    steps=res["steps"],
                    executions=res["executions"],
                    deterministic=res["deterministic"],
                )
                digests[key] = res["digest"]
                if res["status"] == "ok":
                    ref = prepared[name]
                    row.update(errors_against(res["t"], res["q"], ref["t"], ref["q"], window=ref["horizon_window_s"]))
                elif res["status"] == "timeout":  # tighter settings of the same method cost more: not run
                    for other, (oname, os_) in futures.items():
                        if oname == name and os_["method"] == s["method"] and looser(s, os_) and other.cancel():
                            rows[(oname, os_["method"], os_["value"])].update(
                                status="skipped",
                                message=f"not run: {s['setting']} {s['value']:g} already exceeded the "
                                f"{budget:g} s budget",
                            )
            elif res["status"] != "ok" or res["digest"] != digests[key]:
                row["deterministic"] = False
                if res["status"] != "ok":
                    row["message"] = f"repeat {rep + 1}: {res['status']} {res['message']}".strip()
                    continue
            if res["status"] in ("ok", "timeout", "diverged", "failed"):
                row["cpu_s_repeats"].append(res["cpu_s"])
                row["wall_s_repeats"].append(res["wall_s"])
            if progress and done % max(1, len(futures) // 10) == 0:
                progress(f"repeat {rep + 1}/{repeats}: {done}/{len(futures)} runs")
    out = []
    for row in rows.values():
        if row["cpu_s_repeats"]:
            row["cpu_s"] = statistics.median(row["cpu_s_repeats"])
            row["wall_s"] = statistics.median(row["wall_s_repeats"])
        out.append(row)
    return sorted(out, key=sort_key), extras

"""How every source's cost and accuracy grow with the number of joints (issue 14): generated n-link
chains, planar and spatial, with random but valid inertias (MJCF written here, in a temporary folder
removed afterwards), n from 2 to 30.

For each chain: time per state of M, bias, forward and inverse dynamics for MuJoCo, Pinocchio and the
symbolic source (batches of states; the best of `repeats`); the largest scaled disagreement of each
quantity between the sources and cond(M); the symbolic derivation's time, its generated code's time
and the size of M and C v (sympy operation count), until one chain's derivation exceeds the budget:
the symbolic source stops there, and the results say where. Fitted log-log slopes of time against n
summarise each source's growth. `lagrange-xval bench --chains [--quick]` writes OUT/chains.json.
"""

from __future__ import annotations

import json
import tempfile
import time
from argparse import Namespace
from collections.abc import Callable
from concurrent.futures import Executor
from pathlib import Path
from typing import NotRequired

import numpy as np

from ..results import atomic_write
from ..results.schema import ChainRow, ChainsStudy, ChainStop, SymbolicCost
from ..sources import make_source
from ..sources.base import Source
from ..symbolic.derivation import derive
from ..systems import System
from ..verdict import pointwise

FULL_NS = (2, 3, 4, 5, 6, 8, 10, 12, 15, 20, 25, 30)
QUICK_NS = (2, 3, 4, 6, 10, 20, 30)
SYMBOLIC_BUDGET = {"full": 60.0, "quick": 10.0}  # s for one chain's derivation and code; beyond, it stops
OPS = ("M", "bias", "forward", "inverse")
GROWTH = 6  # measured: planar chains' derivation and code took 0.17, 0.22, 0.68, 6.8 s at n = 2, 3, 4, 6
MEASURED = (6, 6.8)  # (n, s): the largest of those measurements, the base of the prediction
DERIVE_BUDGET = 120.0  # s: `derive` refuses a model predicted to take longer (unless --force)


# A spatial model (joint axes not all parallel, or a body frame rotated) costs more than the planar
# chains measured: the UR5 (6 joints) took 37 s against 6.8 s predicted, the Panda with its fingers
# locked (7) 135 s against 17 s (issue 34), so 8x. `--python` took 441 s on the Panda when it printed the
# expanded entries (96 MB); with each function's common subexpressions (symbolic/readable.py) it took 98 s
# of CPU against 90 s for the derivation alone (492 KB), so 1.2x.
SPATIAL_FACTOR = 8.0
PYTHON_FACTOR = 1.2


Progress = Callable[[str], None] | None


class Symbolic(SymbolicCost):
    """`_symbolic`: the times, and the symbolic source where its code was generated."""

    source: NotRequired[Source]


def predicted_derive_s(n: int, *, spatial: bool = False, python: bool = False) -> float:
    """The predicted time of the symbolic derivation of an n-joint chain and its code (s): the
    measured n = 6, grown as n^GROWTH; times SPATIAL_FACTOR for a spatial model, PYTHON_FACTOR more
    for `derive --python`."""
    n0, seconds = MEASURED
    return seconds * (n / n0) ** GROWTH * (SPATIAL_FACTOR if spatial else 1.0) * (PYTHON_FACTOR if python else 1.0)


def chain_mjcf(n: int, kind: str, seed: int = 0) -> str:
    """An n-link chain: "planar" (hinges about z, links along -y, gravity along -y) or "spatial"
    (hinge axes cycling z, y, x, link offsets and centres of mass off the axes, gravity along -z);
    masses 0.5-2 kg, inertias rotated principal moments that satisfy the triangle inequality."""
    rng = np.random.default_rng(seed + 1000 * n + (0 if kind == "planar" else 1))
    axes = ["0 0 1", "0 1 0", "1 0 0"]
    body = ""
    for i in reversed(range(n)):
        length = rng.uniform(0.2, 0.5)
        mass = rng.uniform(0.5, 2.0)
        a, b = rng.uniform(0.002, 0.02, 2)
        c = rng.uniform(abs(a - b) + 1e-4, a + b)  # A + B >= C for every pair
        if kind == "planar":
            pos, axis, com = f"0 {-length if i else 0} 0", axes[0], f"0 {-length / 2:.17g} 0"
            quat = "1 0 0 0"
        else:
            off = rng.uniform(-0.05, 0.05, 2)
            pos = f"{off[0]:.17g} {off[1]:.17g} {-length if i else 0:.17g}"
            axis = axes[i % 3]
            cx, cy = rng.uniform(-0.03, 0.03, 2)
            com = f"{cx:.17g} {cy:.17g} {-length / 2:.17g}"
            q = rng.normal(size=4)
            quat = " ".join(f"{x:.17g}" for x in q / np.linalg.norm(q))
        body = (
            f'<body name="b{i}" pos="{pos}"><joint name="j{i}" type="hinge" axis="{axis}"/>'
            f'<inertial pos="{com}" quat="{quat}" mass="{mass:.17g}" diaginertia="{a:.17g} {b:.17g} {c:.17g}"/>'
            f"{body}</body>"
        )
    gravity = "0 -9.81 0" if kind == "planar" else "0 0 -9.81"
    return f'<mujoco model="chain{n}"><option gravity="{gravity}"/><worldbody>{body}</worldbody></mujoco>'


def _per_state(fn: Callable[[], object], n_states: int, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best / n_states


def _timings(source: Source, states: pointwise.States, repeats: int) -> dict[str, float]:
    q, v, tau = states.q, states.v, states.tau
    a = np.zeros_like(q)
    calls = {
        "M": lambda: source.mass_matrix(q),
        "bias": lambda: source.bias(q, v),
        "forward": lambda: source.forward(q, v, tau),
        "inverse": lambda: source.inverse(q, v, a),
    }
    return {op: _per_state(fn, len(q), repeats) for op, fn in calls.items()}


def _symbolic(system: System, budget: float) -> Symbolic:
    """Derivation and code generation of one chain, timed; the expression sizes."""
    import sympy as sp

    start = time.perf_counter()
    d = derive(system.view, system.joints)
    derive_s = time.perf_counter() - start
    size = int(sp.count_ops(list(d.M)) + sp.count_ops(list(d.Cv)))
    out: Symbolic = {"derive_s": derive_s, "ops_M_Cv": size}
    if derive_s > budget:
        return out
    start = time.perf_counter()
    source = make_source(system, "symbolic")
    source.mass_matrix(np.zeros((1, system.nv)))  # generates the dynamics code
    out["codegen_s"] = time.perf_counter() - start
    out["source"] = source
    return out


def _times(sym: Symbolic) -> SymbolicCost:
    """What a row keeps of `_symbolic`: its times and sizes, not the source."""
    times: SymbolicCost = {"derive_s": sym["derive_s"], "ops_M_Cv": sym["ops_M_Cv"]}
    if "codegen_s" in sym:
        times["codegen_s"] = sym["codegen_s"]
    return times


def kind_rows(
    kind: str, ns: tuple[int, ...], n_states: int, repeats: int, budget: float, progress: Progress = None
) -> tuple[list[ChainRow], ChainStop | None]:
    """One kind's chains ("planar" or "spatial"), every n in turn: the rows, and where the symbolic
    source stopped (None if it ran at every n). One task of the study: it runs in a worker as it does here."""
    rows: list[ChainRow] = []
    stopped: ChainStop | None = None
    symbolic_on, last = True, None  # last: (n, derivation + code seconds) of the previous chain
    with tempfile.TemporaryDirectory(prefix="lagrange_xval_chains_") as folder:
        for n in ns:
            path = Path(folder) / f"{kind}{n}.xml"
            path.write_text(chain_mjcf(n, kind))
            system = System.model_only(path, name=f"{kind}{n}")
            states = pointwise.random_states(system, n=n_states, seed=n)
            sources = {name: make_source(system, name) for name in ("mujoco", "pinocchio")}
            row: ChainRow = {"kind": kind, "n": n}
            if symbolic_on and last is not None and last[1] * (n / last[0]) ** GROWTH > budget:
                symbolic_on = False  # predicted, not tried: a derivation cannot be interrupted
                predicted = last[1] * (n / last[0]) ** GROWTH
                stopped = {
                    "n": n,
                    "why": f"predicted {predicted:.0f} s (n = {last[0]} took {last[1]:.1f} s; the time grows "
                    f"about as n^{GROWTH}), over the {budget:g} s budget",
                }
            if symbolic_on:
                sym = _symbolic(system, budget)
                row["symbolic"] = _times(sym)
                spent = sym["derive_s"] + sym.get("codegen_s", 0.0)
                last = (n, spent)
                if "source" in sym and spent <= budget:
                    sources["symbolic"] = sym["source"]
                else:
                    symbolic_on = False
                    stopped = {"n": n, "why": f"derivation and code took more than the {budget:g} s budget"}
            row["per_state_s"] = {name: _timings(src, states, repeats) for name, src in sources.items()}
            compared = pointwise.compare(pointwise.evaluate(sources, states), states)
            row["worst_scaled"] = {f"{r['quantity']} {r['pair']}": float(r["scaled"]) for r in compared}
            row["all_within_tiers"] = all(r["passed"] for r in compared)
            row["cond_M_max"] = float(np.max(np.linalg.cond(sources["mujoco"].mass_matrix(states.q))))
            rows.append(row)
            if progress:
                progress(_progress_line(row))
    return rows, stopped


def _progress_line(row: ChainRow) -> str:
    verdict = "agree" if row["all_within_tiers"] else "DISAGREE"
    return f"{row['kind']} n={row['n']}: {verdict}, cond(M) {row['cond_M_max']:.1e}"


def run_chains(
    *,
    quick: bool = False,
    n_states: int = 200,
    repeats: int = 3,
    progress: Progress = None,
    ns: tuple[int, ...] = (),
    executor: Executor | None = None,
) -> ChainsStudy:
    """The scaling study: every chain, every source; see the module docstring (`ns`: other chain lengths).
    With an `executor` (e.g. a dask cluster's), the planar and the spatial chains are two tasks run
    there side by side; without, both run in this process one after the other (each timing alone)."""
    ns = tuple(ns or (QUICK_NS if quick else FULL_NS))
    budget = SYMBOLIC_BUDGET["quick" if quick else "full"]
    kinds = ("planar", "spatial")
    if executor is None:
        done = [kind_rows(kind, ns, n_states, repeats, budget, progress) for kind in kinds]
    else:
        futures = [executor.submit(kind_rows, kind, ns, n_states, repeats, budget) for kind in kinds]
        done = []
        for future in futures:
            done.append(future.result())
            for row in done[-1][0]:
                if progress:
                    progress(_progress_line(row))
    rows = [row for kind_done in done for row in kind_done[0]]
    stopped = {kind: where for kind, (_, where) in zip(kinds, done, strict=True) if where is not None}
    return {
        "ns": list(ns),
        "n_states": n_states,
        "repeats": repeats,
        "symbolic_budget_s": budget,
        "rows": rows,
        "symbolic_stopped_at": stopped,
        "slopes": slopes(rows),
    }


def slopes(rows: list[ChainRow]) -> dict[str, dict[str, float]]:
    """log-log slope of time per state against n, per kind, source and operation (n >= 4)."""
    out: dict[str, dict[str, float]] = {}
    for kind in sorted({r["kind"] for r in rows}):
        for source in ("mujoco", "pinocchio", "symbolic"):
            for op in OPS:
                pts = [
                    (r["n"], r["per_state_s"][source][op])
                    for r in rows
                    if r["kind"] == kind and source in r["per_state_s"] and r["n"] >= 4
                ]
                if len(pts) >= 2:
                    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
                    out.setdefault(f"{kind} {source}", {})[op] = float(np.polyfit(x, y, 1)[0])
    return out


def chains_command(args: Namespace, executor: Executor | None = None) -> int:
    """`lagrange-xval bench --chains [--quick] [--out DIR] [--executor ...]`: writes DIR/chains.json,
    prints the table."""
    import sys

    def progress(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    results = run_chains(quick=bool(getattr(args, "quick", False)), progress=progress, executor=executor)
    out = Path(getattr(args, "out", None) or "reports")
    out.mkdir(parents=True, exist_ok=True)
    path = out / "chains.json"
    atomic_write(path, json.dumps(results, indent=1, sort_keys=True))
    print(f"{'kind':8} {'n':>3} {'MuJoCo M':>10} {'Pin. M':>10} {'Pin. fwd':>10} {'sym. M':>10} {'cond(M)':>9} agree")
    for r in results["rows"]:
        t = r["per_state_s"]
        sym = t.get("symbolic", {}).get("M")
        print(
            f"{r['kind']:8} {r['n']:>3} {t['mujoco']['M'] * 1e6:>8.2f}us {t['pinocchio']['M'] * 1e6:>8.2f}us "
            f"{t['pinocchio']['forward'] * 1e6:>8.2f}us {'' if sym is None else f'{sym * 1e6:8.2f}us':>10} "
            f"{r['cond_M_max']:>9.1e} {'yes' if r['all_within_tiers'] else 'NO'}"
        )
    for kind, where in results["symbolic_stopped_at"].items():
        print(f"symbolic source stops for {kind} chains at n = {where['n']}: {where['why']}")
    for name, ops in results["slopes"].items():
        print(f"slope of time per state against n, {name}: " + ", ".join(f"{k} {v:.2f}" for k, v in ops.items()))
    print(f"wrote {path}")
    return 0 if all(r["all_within_tiers"] for r in results["rows"]) else 1

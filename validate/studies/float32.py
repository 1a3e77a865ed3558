"""MuJoCo Warp's float32 error, measured (issue 29): per term and along a trajectory, beside C MuJoCo's
float64 error and the float32 rounding one would expect.

What is measured, per system (the repository's pendulums, generated spatial n-link chains from
studies/chains.py, UR5 and Panda from example-robot-data when installed):

  pointwise, at `n_states` seeded random states (verdict/pointwise.random_states), batched as that many
  Warp worlds: M, bias, passive, qacc (at tau) and tau_inverse (at the reference's accelerations) from
  MuJoCo Warp (float32), C MuJoCo (float64) and the reference: the hand derivation where the system
  has one, else Pinocchio. Each error is the max absolute difference over states and entries and
  `scaled` = that over the term's scale (the largest magnitude C MuJoCo gives the term over the
  states, and for tau_inverse and passive at least that of bias, as core/tolerances.SCALE_ALSO_BY).
  The expected float32 rounding is eps32 x scale, times max cond(M) for qacc (FLOAT32 below), and
  each Warp error is also given in those units (`eps32_units`).

  along a trajectory, from the system's `initial_state` with tau = 0 over `horizon` seconds, sampled
  every 10 ms: MuJoCo Warp's own `step` (the model's integrator and timestep) against C MuJoCo's
  float64 run with the same integrator and timestep (the float32 effect alone) and against the
  reference solution (heyoka's Taylor integrator on the hand equations, cached; for a model without
  equations scipy DOP853 at rtol 1e-12 on Pinocchio's ABA); C MuJoCo against the same reference
  (its integrator's error), as max over samples and coordinates of |q - q_ref| (rad or m). The
  expected float32 rounding of a run is eps32 x max|q| x the number of steps (one rounding of the
  state per step, accumulated linearly; chaos can amplify it further).

Everything runs in this process (Warp compiles its kernels once per process, then loads them from
its kernel cache); the first call of each Warp function per system is timed and reported as
`first_call_s` (compilation, or loading from the cache), never counted as the error's cost.
`lagrange-xval bench --float32 [--quick]` prints the table and writes it into OUT/bench.json (key
"float32").
"""

from __future__ import annotations

import os
import tempfile
import time
from argparse import Namespace
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TypedDict

import numpy as np

from ..core.guard import DEFAULT_TIME_LIMIT
from ..core.tolerances import SCALE_ALSO_BY
from ..dynamics.integrate import initial_state, time_grid
from ..dynamics.reference import DEFAULT_CACHE_DIR, reference_trajectory
from ..model.start import Scheme, Start
from ..model.urdf import robots_folder
from ..results import atomic_write, dumps, provenance
from ..sources import make_source
from ..sources.base import Source, engine_of, one_state, stepped
from ..systems import System, load_all, system_names
from ..verdict import pointwise
from .chains import chain_mjcf

EPS32 = 2.0**-23  # float32 unit roundoff (x2), 1.19e-7
CacheDir = str | os.PathLike[str] | None  # reference_trajectory's: a folder, None (no cache) or cache.DEFAULT


class Error(TypedDict):
    """max |a - b| over a term, and over its scale."""

    max_abs: float
    scaled: float


class Term(TypedDict):
    """Warp against C MuJoCo and the reference on one term, and the float32 rounding expected of it."""

    term: str
    scale: float
    warp_vs_mujoco: Error
    warp_vs_reference: Error | None
    mujoco_vs_reference: Error | None
    reference: str
    expected_float32: float
    eps32_units: float | None


class PointwiseRow(Term):
    """A pointwise term at the random states (`pointwise_rows`)."""

    cond_max: float
    tolerance: float
    within_tier: bool


class TrajectoryRow(Term):
    """Warp's own run against C MuJoCo's and the reference (`trajectory_row`)."""

    horizon_s: float
    integrator: str
    timestep: float
    steps: int
    mujoco_warnings: list[str]
    warp_us_per_step: float


class NotRun(TypedDict):
    """A trajectory not run, and why."""

    skipped: str


class ReferenceRun(TypedDict):
    """The reference's samples of q and how it was computed."""

    q: np.ndarray
    method: str


class SystemResult(TypedDict):
    """One system's pointwise rows, trajectory row and first-call times (`system_result`)."""

    nv: int
    device: str
    pointwise: list[PointwiseRow]
    trajectory: TrajectoryRow | NotRun | None
    first_call_s: dict[str, float]


class TableRow(TypedDict):
    """One line of the table (COLUMNS)."""

    system: str
    nv: int
    term: str
    warp_max_abs: float
    warp_scaled: float
    eps32_units: float | None
    expected_scaled: float
    warp_vs_reference_scaled: float | None
    float64_scaled: float | None
    reference: str


class Config(TypedDict):
    """How the study was run."""

    device: str
    versions: dict[str, str]
    n_states: int
    horizon_s: float
    dt_out: float
    eps32: float
    tiers: dict[str, dict[str, object]]
    quick: bool


class Float32Results(TypedDict):
    """The float32 study (`run_float32`), bench.json's "float32"."""

    config: Config
    systems: dict[str, SystemResult]
    table: list[TableRow]
    duration_s: float


@dataclass(frozen=True)
class Float32Tier:
    """The float32 rounding one expects of a term: eps32 x its scale (x cond(M) where `cond`); the
    test tolerance is `factor` times that."""

    factor: float
    reason: str
    cond: bool = False

    def expected(self, scale: float, cond: float = 1.0) -> float:
        return EPS32 * scale * (cond if self.cond else 1.0)

    def tolerance(self, scale: float, cond: float = 1.0) -> float:
        return self.factor * self.expected(scale, cond)


@dataclass(frozen=True)
class Float32Tiers:
    term: Float32Tier = Float32Tier(
        32.0,
        "M, bias, passive and tau_inverse are sums of products computed in float32 from float32 states: "
        "measured (200 random states each) at most 7.9 eps32 x scale on the repository's systems, the examples, "
        "UR5, Panda and spatial chains of 2-30 links, but for tau_inverse on the 20-link chain, 15.7 (M a + bias "
        "cancels: its products exceed the scale); 32 leaves 2x margin and is still 1e4 below a missing term.",
    )
    solve: Float32Tier = Float32Tier(
        16.0,
        "qacc passes through a float32 Cholesky solve with M: its rounding grows like cond(M) eps32. "
        "Measured at most 6.4 eps32 x scale x cond(M) (the simple pendulum, cond 1); 16 leaves 2x margin.",
        cond=True,
    )

    def of(self, quantity: str) -> Float32Tier:
        return self.solve if quantity == "qacc" else self.term

    def as_dict(self) -> dict[str, dict[str, object]]:
        return {"term": asdict(self.term), "solve": asdict(self.solve)}


FLOAT32 = Float32Tiers()
QUANTITIES = ("M", "bias", "passive", "qacc", "tau_inverse")
DT_OUT = 0.01  # s between trajectory samples
HORIZON = 1.0  # s
QUICK_HORIZON = 0.2  # s
CHAIN_NS = (2, 5, 10, 20, 30)
QUICK_CHAIN_NS = (2, 30)
QUICK_SYSTEMS = ("simple_pendulum", "double_pendulum_point")
N_STATES = 200
# example-robot-data's arms: (name, file under its robots folder, URDF joints locked)
ROBOTS = (
    ("ur5", "ur_description/urdf/ur5_robot.urdf", ()),
    ("panda", "panda_description/urdf/panda.urdf", ("panda_finger_joint1", "panda_finger_joint2")),
)
# The table's columns: Warp against C MuJoCo (absolute, scaled, in units of the expected rounding),
# the expected rounding scaled, Warp and C MuJoCo (float64) against the reference, and what that is.
COLUMNS = (
    "system",
    "nv",
    "term",
    "warp_max_abs",
    "warp_scaled",
    "eps32_units",
    "expected_scaled",
    "warp_vs_reference_scaled",
    "float64_scaled",
    "reference",
)


# ----------------------------------------------------------------------------------------------
# Pointwise


def _error(a: np.ndarray | None, b: np.ndarray | None, scale: float) -> Error | None:
    if a is None or b is None:
        return None
    return _diff(a, b, scale)


def _diff(a: np.ndarray, b: np.ndarray, scale: float) -> Error:
    diff = float(np.max(np.abs(a - b))) if np.size(a) else 0.0
    return {"max_abs": diff, "scaled": diff / scale}


def pointwise_rows(system: System, warp: Source, *, n_states: int = N_STATES, seed: int = 0) -> list[PointwiseRow]:
    """One row per term: Warp's error against C MuJoCo and the reference, C MuJoCo's against the
    reference, the scale, cond(M) and the expected float32 rounding (see the module docstring)."""
    states = pointwise.random_states(system, n=n_states, seed=seed)
    against = "hand" if system.equations is not None else "pinocchio"
    sources = {against: make_source(system, against), "mujoco": make_source(system, "mujoco"), "warp": warp}
    values = pointwise.evaluate(sources, states)
    cond = float(np.max(np.linalg.cond(values["mujoco"]["M"])))
    rows: list[PointwiseRow] = []
    for term in QUANTITIES:
        c, w, r = (values[k].get(term) for k in ("mujoco", "warp", against))
        if c is None or w is None:
            continue
        also = [float(np.max(np.abs(values["mujoco"][k]))) for k in SCALE_ALSO_BY.get(term, ())]
        scale = max([float(np.max(np.abs(c))), *also, np.finfo(float).tiny])
        tier = FLOAT32.of(term)
        warp_c = _diff(w, c, scale)
        expected = tier.expected(scale, cond)
        rows.append(
            {
                "term": term,
                "scale": scale,
                "cond_max": cond,
                "warp_vs_mujoco": warp_c,
                "warp_vs_reference": _error(w, r, scale),
                "mujoco_vs_reference": _error(c, r, scale),
                "reference": against,
                "expected_float32": expected,
                "eps32_units": warp_c["max_abs"] / expected if warp_c and expected > 0 else None,
                "tolerance": tier.tolerance(scale, cond),
                "within_tier": bool(warp_c is not None and warp_c["max_abs"] <= tier.tolerance(scale, cond)),
            }
        )
    return rows


# ----------------------------------------------------------------------------------------------
# Trajectories


def _reference_run(system: System, q0: np.ndarray, v0: np.ndarray, t: np.ndarray, cache_dir: CacheDir) -> ReferenceRun:
    """The reference solution on the grid `t`: heyoka on the hand equations, or DOP853 on Pinocchio."""
    tau = np.zeros(system.nv)
    if system.equations is not None:
        ref, info = reference_trajectory(system, Start.of(q0, v0, tau), t, cache_dir=cache_dir)
        return {"q": ref.q, "method": str(info.get("method"))}
    from scipy.integrate import solve_ivp

    rhs = one_state(make_source(system, "pinocchio")).rhs(tau)
    sol = solve_ivp(rhs, (t[0], t[-1]), np.concatenate([q0, v0]), method="DOP853", t_eval=t, rtol=1e-12, atol=1e-14)
    return {"q": sol.y[: system.nv].T, "method": "scipy DOP853 rtol 1e-12 on Pinocchio's ABA"}


def trajectory_row(
    system: System, warp: Source, *, horizon: float, cache_dir: CacheDir = DEFAULT_CACHE_DIR
) -> TrajectoryRow | NotRun:
    """Warp's own run against C MuJoCo's (same integrator and timestep) and the reference (module docstring)."""
    from ..sources import mujoco as engine_mujoco
    from ..sources import warp as engine_warp

    q0, v0 = initial_state(system)
    tau = np.zeros(system.nv)
    t = time_grid(horizon, DT_OUT)
    stepping = engine_of(warp, engine_warp.WarpSource)  # its integrator and timestep
    steps = round(DT_OUT / stepping.timestep)
    if steps < 1 or abs(steps * stepping.timestep - DT_OUT) > 1e-12:
        return {"skipped": f"timestep {stepping.timestep:g} s does not divide the {DT_OUT:g} s sampling interval"}
    run = engine_warp.run_in_coordinates(system, warp, q0, v0, tau, samples=len(t), steps=steps)
    q_warp = run["q"][0]
    q_c, _, _, raised = engine_mujoco.free_run(
        stepped(make_source(system, "mujoco")),
        Start(q0, v0, tau),
        len(t),
        steps,
        Scheme(stepping.integrator, stepping.timestep),
    )
    ref = _reference_run(system, q0, v0, t, cache_dir)
    n_steps = steps * (len(t) - 1)
    scale = max(float(np.max(np.abs(q_c))), np.finfo(float).tiny)
    warp_c = _diff(q_warp, q_c, scale)
    expected = EPS32 * scale * n_steps
    return {
        "term": f"q({horizon:g} s)",
        "scale": scale,
        "horizon_s": horizon,
        "integrator": stepping.integrator,
        "timestep": stepping.timestep,
        "steps": n_steps,
        "warp_vs_mujoco": warp_c,
        "warp_vs_reference": _error(q_warp, ref["q"], scale),
        "mujoco_vs_reference": _error(q_c, ref["q"], scale),
        "reference": ref["method"],
        "expected_float32": expected,
        "eps32_units": warp_c["max_abs"] / expected if warp_c else None,
        "mujoco_warnings": [name for name, _ in raised],
        "warp_us_per_step": run["step_s"] * 1e6,
    }


# ----------------------------------------------------------------------------------------------
# The study


@contextmanager
def float32_systems(
    names: list[str] | None, *, chain_ns: tuple[int, ...], robots: bool, own: tuple[System, ...] = ()
) -> Iterator[list[tuple[str, System]]]:
    """(label, system) of the repository systems `names` (default every one, none where `own` systems
    are given), a person's `own` systems, spatial chains of `chain_ns` links (MJCF in a temporary
    folder, removed after) and, with `robots`, UR5 and Panda when example-robot-data is installed."""
    repository = list(names) if names else ([] if own else system_names())
    chosen = [(s.name, s) for s in (load_all(repository) if repository else [])] + [(s.name, s) for s in own]
    folder = robots_folder() if robots else None
    if folder is not None:
        chosen += [(label, System.model_only(folder / path, locked=lock)) for label, path, lock in ROBOTS]
    with tempfile.TemporaryDirectory(prefix="lagrange_xval_float32_") as tmp:
        for n in chain_ns:
            path = Path(tmp) / f"chain{n}.xml"
            path.write_text(chain_mjcf(n, "spatial"))
            chosen.append((f"chain{n}", System.model_only(path, name=f"chain{n}")))
        yield chosen


def system_result(
    system: System, *, n_states: int, horizon: float | None, cache_dir: CacheDir = DEFAULT_CACHE_DIR
) -> SystemResult:
    """One system's pointwise rows, its trajectory row (None without a horizon) and first-call times."""
    from ..sources import warp as warp_engine  # loads Warp

    start = time.perf_counter()
    warp = make_source(system, "warp")
    made = time.perf_counter() - start
    rows = pointwise_rows(system, warp, n_states=n_states)
    trajectory = trajectory_row(system, warp, horizon=horizon, cache_dir=cache_dir) if horizon else None
    return {
        "nv": system.nv,
        "device": engine_of(warp, warp_engine.WarpSource).device,
        "pointwise": rows,
        "trajectory": trajectory,
        "first_call_s": {"put_model": made, **engine_of(warp, warp_engine.WarpSource).first_call_s},
    }


def run_float32(
    names: list[str] | None = None,
    *,
    quick: bool = False,
    chain_ns: tuple[int, ...] | None = None,
    robots: bool = True,
    own: tuple[System, ...] = (),
    n_states: int = N_STATES,
    horizon: float | None = None,
    cache_dir: CacheDir = DEFAULT_CACHE_DIR,
    progress: Callable[[str], None] | None = None,
) -> Float32Results:
    """The float32 study as JSON-able data: {"config", "systems": {label: system_result}, "table"}.

    Args:
        names: repository systems (default: every one; `quick`: QUICK_SYSTEMS).
        quick: QUICK_SYSTEMS, chains of QUICK_CHAIN_NS links, UR5 only, QUICK_HORIZON.
        chain_ns: chain lengths (default CHAIN_NS; quick QUICK_CHAIN_NS; () for none).
        robots: UR5 and Panda where example-robot-data is installed.
        own: a person's systems (`System.from_files`), measured beside (or, without names, instead of)
            the repository's.
        n_states: pointwise states (Warp worlds) per system.
        horizon: trajectory length, s (default HORIZON; quick QUICK_HORIZON; 0 for none).
    """
    from ..sources import warp as engine_warp

    start = time.perf_counter()
    names = list(names) if names else (list(QUICK_SYSTEMS) if quick and not own else None)
    ns = chain_ns if chain_ns is not None else (QUICK_CHAIN_NS if quick else CHAIN_NS)
    horizon = horizon if horizon is not None else (QUICK_HORIZON if quick else HORIZON)
    out: dict[str, SystemResult] = {}
    with float32_systems(names, chain_ns=tuple(ns), robots=robots, own=own) as chosen:
        for label, system in chosen:
            if quick and label == "panda":
                continue
            out[label] = system_result(system, n_states=n_states, horizon=horizon or None, cache_dir=cache_dir)
            if progress:
                progress(_progress_line(label, out[label]))
    return {
        "config": {
            "device": engine_warp.default_device(),
            "versions": engine_warp.versions(),
            "n_states": n_states,
            "horizon_s": horizon,
            "dt_out": DT_OUT,
            "eps32": EPS32,
            "tiers": FLOAT32.as_dict(),
            "quick": quick,
        },
        "systems": out,
        "table": table(out),
        "duration_s": time.perf_counter() - start,
    }


def _progress_line(label: str, result: SystemResult) -> str:
    worst = max((r["eps32_units"] or 0.0 for r in result["pointwise"]), default=0.0)
    first = sum(result["first_call_s"].values())
    return f"{label}: worst term {worst:.1f} eps32 x scale; first calls {first:.1f} s on {result['device']}"


def table(systems: dict[str, SystemResult]) -> list[TableRow]:
    """Long-format rows (COLUMNS), in the systems' order (as run) then QUANTITIES' order, a system's
    trajectory last as its term "q(T s)".

    Scaled errors are max |a - b| over the term's scale; `expected_scaled` is the expected float32
    rounding over the same scale (eps32, x cond(M) for qacc, x steps for a trajectory)."""
    rows: list[TableRow] = []
    for label, result in systems.items():
        trajectory = result["trajectory"]
        terms = result["pointwise"] + ([trajectory] if trajectory and "skipped" not in trajectory else [])
        for r in terms:
            w, wr, f = r["warp_vs_mujoco"], r["warp_vs_reference"], r["mujoco_vs_reference"]
            rows.append(
                {
                    "system": label,
                    "nv": result["nv"],
                    "term": r["term"],
                    "warp_max_abs": w["max_abs"],
                    "warp_scaled": w["scaled"],
                    "eps32_units": r["eps32_units"],
                    "expected_scaled": r["expected_float32"] / r["scale"],
                    "warp_vs_reference_scaled": None if wr is None else wr["scaled"],
                    "float64_scaled": None if f is None else f["scaled"],
                    "reference": r["reference"],
                }
            )
    return rows


# ----------------------------------------------------------------------------------------------
# The command


def _cell(x: float | None) -> str:
    return "-" if x is None else f"{x:.1e}"


def print_table(results: Float32Results) -> None:
    """The table, one line per system and term, under a one-line title saying how it was measured."""
    cfg = results["config"]
    print(
        f"MuJoCo Warp {cfg['versions']['mujoco-warp']} (float32, device {cfg['device']}) against C MuJoCo "
        f"(float64) at {cfg['n_states']} random states per system and along {cfg['horizon_s']:g} s from the "
        "initial state; scaled = max |error| / the term's scale; expected = eps32 x scale (x cond(M) for qacc, "
        "x steps for q)"
    )
    head = ("system", "nv", "term", "Warp~C abs", "Warp~C scaled", "eps32 units", "expected", "Warp~ref", "C~ref")
    print(f"{head[0]:24} {head[1]:>3} {head[2]:12} " + " ".join(f"{h:>13}" for h in head[3:]) + "  reference")
    for r in results["table"]:
        cells = (
            r["warp_max_abs"],
            r["warp_scaled"],
            r["eps32_units"],
            r["expected_scaled"],
            r["warp_vs_reference_scaled"],
            r["float64_scaled"],
        )
        units = f"{r['eps32_units']:.2f}" if r["eps32_units"] is not None else "-"
        line = [_cell(cells[0]), _cell(cells[1]), units, *(_cell(x) for x in cells[3:])]
        print(f"{r['system']:24} {r['nv']:>3} {r['term']:12} " + " ".join(f"{c:>13}" for c in line), r["reference"])
    first = {k: sum(v["first_call_s"].values()) for k, v in results["systems"].items()}
    print(
        "first calls (Warp's kernels compiled or loaded from its cache), s: "
        + ", ".join(f"{k} {v:.1f}" for k, v in first.items())
    )


def write_into_bench(results: Float32Results, out: Path) -> Path:
    """OUT/bench.json with `results` under "float32", the rest of an existing bench.json kept."""
    import json

    path = Path(out) / "bench.json"
    try:
        bench = json.loads(path.read_text()) if path.is_file() else {}
    except (OSError, ValueError):
        bench = {}
    if not isinstance(bench, dict) or not bench:
        bench = {"meta": provenance()}
    bench["float32"] = results
    Path(out).mkdir(parents=True, exist_ok=True)
    atomic_write(path, dumps(bench))
    return path


def float32_command(args: Namespace) -> int:
    """`lagrange-xval bench --float32 [SYSTEM ...] [--model PATH --equations PATH] [--quick] [--out DIR]`:
    prints the table, writes it into DIR/bench.json. Exit status 0 when every Warp term is within its
    float32 tier, 1 otherwise."""
    import sys

    def progress(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    names = list(getattr(args, "systems", None) or [])
    locked = tuple(getattr(args, "locked", None) or ())
    limit = getattr(args, "time_limit", DEFAULT_TIME_LIMIT)
    own = tuple(
        System.from_files(m, e, locked=locked, time_limit=limit) for m, e in (getattr(args, "files", None) or [])
    )
    results = run_float32(
        names or None,
        quick=bool(getattr(args, "quick", False)),
        chain_ns=() if names or own else None,
        robots=not (names or own),
        own=own,
        cache_dir=getattr(args, "reference_cache", DEFAULT_CACHE_DIR),
        progress=progress,
    )
    print_table(results)
    path = write_into_bench(results, Path(getattr(args, "out", None) or "reports"))
    print(f"wrote {path} (key float32)")
    ok = all(r["within_tier"] for s in results["systems"].values() for r in s["pointwise"])
    return 0 if ok else 1

"""`simulate`: one trajectory of one source, written as a file that says what it is.

The file records the request (system, model, source, initial state, input, duration, output step),
how it was computed (method, MuJoCo's timestep), every adjustment the harness made to the request,
the units of every column and the harness's version: a CSV under a commented header (`#` lines), a
JSON object with one row per line. A request whose output would not fit the memory limit is refused
before anything is computed.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable, Iterator, Sequence
from typing import TypedDict

import numpy as np

from ..core.errors import HarnessError
from ..dynamics import integrate
from ..model.start import Start
from ..results import atomic_write, harness_version
from ..sources import make_source
from ..sources.base import stepped
from ..systems import MODELS_DIR, System
from ..verdict.pointwise import validate_states

# What one number of the trajectory costs in memory while `simulate` runs: the integrator's output,
# the trajectory's copies of q and v, and the table written from them (about three float64 arrays:
# 24.5 bytes measured for scipy, 14 for MuJoCo; tests/unit/cli/test_parser.py holds the bound).
MEMORY_BYTES_PER_NUMBER = 32
FILE_BYTES_PER_NUMBER = 25  # a float at full precision ("-1.2345678901234567e-05") and its separator
MAX_SIMULATE_BYTES = 2**30  # 1 GiB: about 6.7 million samples of a two-degree-of-freedom system
ROWS_PER_WRITE = 10_000  # the file is written in pieces of this many rows, never held whole as text


def size(nbytes: float) -> str:
    """A byte count for a person: 1.5 GiB, 120 MiB, 800 B."""
    for unit, scale in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{nbytes:.0f} B"


def refuse_if_too_large(t_end: float, dt_out: float, columns: int) -> None:
    """One line saying how many samples and bytes the request needs and the limit, before any work."""
    samples = t_end / dt_out + 1  # a float: 1e300 / 1e-300 must not become an integer of 600 digits
    need = samples * columns * MEMORY_BYTES_PER_NUMBER
    if need <= MAX_SIMULATE_BYTES:
        return
    fits = int(MAX_SIMULATE_BYTES // (columns * MEMORY_BYTES_PER_NUMBER))
    if not np.isfinite(need):
        needs = f"more samples than a float can count ({columns} numbers each)"
    else:
        disk = samples * columns * FILE_BYTES_PER_NUMBER
        needs = f"{samples:.4g} samples of {columns} numbers, {size(need)} in memory and {size(disk)} on disk"
    raise HarnessError(
        f"--t-end {t_end:g} s at --dt-out {dt_out:g} s is {needs}; "
        f"the limit is {size(MAX_SIMULATE_BYTES)} in memory ({fits:,} samples of this system): "
        "raise --dt-out or shorten --t-end; nothing written."
    )


def mujoco_timestep(model_dt: float, dt_out: float) -> tuple[float, str | None]:
    """The timestep MuJoCo steps at so that a whole number of steps makes one output step, and, if it
    is not the model's own, the sentence saying so."""
    steps = max(1, round(dt_out / model_dt))
    if np.isclose(steps * model_dt, dt_out, rtol=1e-9, atol=0.0):
        return model_dt, None
    dt = dt_out / steps
    return dt, (
        f"MuJoCo's timestep set to {dt:.6g} s instead of the model's {model_dt:g} s, "
        f"so that {steps} step{'s make' if steps > 1 else ' makes'} one --dt-out of {dt_out:g} s"
    )


class Files(TypedDict):
    """The model and equations files, as the results name them."""

    model: str
    equations: str


class SimulateMeta(TypedDict):
    """What `simulate` writes before the samples: the request, its adjustments and the units."""

    system: str
    model: str
    equations: str
    locked: list[str]  # URDF joints made fixed (--lock)
    source: str
    method: str
    coordinates: list[str]
    q0: list[float]
    v0: list[float]
    tau: list[float]
    t_end: float
    dt_out: float
    samples: int
    mujoco_timestep: float | None
    adjustments: list[str]
    units: dict[str, str | tuple[str, ...] | list[str]]  # a column's unit, or the units of a request's numbers
    harness_version: str


def files_of(system: System) -> Files:
    """The model and equations files, as the results name them (relative for the repository's)."""
    inside = system.mjcf.resolve().parent == MODELS_DIR.resolve()
    return {
        "model": f"models/{system.mjcf.name}" if inside else str(system.mjcf),
        "equations": f"equations/{system.name}.py" if inside else str(getattr(system.equations, "__file__", "?")),
    }


def units(system: System) -> dict[str, str | tuple[str, ...] | list[str]]:
    """The unit of every column and of every number of the request."""
    per = system.units  # "rad" or "m" per coordinate
    rate = [f"{u}/s" for u in per]
    force = ["N m" if u == "rad" else "N" if u == "m" else "N m or N" for u in per]
    return {
        "t": "s",
        **dict(zip(system.coordinates, per, strict=True)),
        **{f"d{c}": r for c, r in zip(system.coordinates, rate, strict=True)},
        "q0": per,
        "v0": rate,
        "tau": force,
        "t_end": "s",
        "dt_out": "s",
        "mujoco_timestep": "s",
    }


def csv_pieces(meta: SimulateMeta, columns: list[str], table: np.ndarray) -> Iterator[str]:
    """The CSV: `# key: value` lines with the request and units, the column names, then the rows."""
    u = meta["units"]

    def numbers(values: list[float], unit: Sequence[str]) -> str:
        return ", ".join(f"{v!r} {w}" for v, w in zip(values, unit, strict=True))

    lines = [
        f"# lagrange-xval {meta['harness_version']} simulate",
        f"# system: {meta['system']} (model {meta['model']}, equations {meta['equations']})",
        *([f"# locked: {', '.join(meta['locked'])} (made fixed at zero)"] if meta["locked"] else []),
        f"# source: {meta['source']}",
        f"# method: {meta['method']}",
        f"# q0: {numbers(meta['q0'], u['q0'])}",
        f"# v0: {numbers(meta['v0'], u['v0'])}",
        f"# tau: {numbers(meta['tau'], u['tau'])} (constant)",
        f"# t_end: {meta['t_end']!r} s",
        f"# dt_out: {meta['dt_out']!r} s",
    ]
    if meta["mujoco_timestep"] is not None:
        lines.append(f"# mujoco_timestep: {meta['mujoco_timestep']!r} s")
    lines += [f"# adjustment: {a}" for a in meta["adjustments"]]
    lines.append("# units: " + ", ".join(f"{c} [{u[c]}]" for c in columns))
    lines.append(",".join(columns))
    yield "\n".join(lines) + "\n"
    for start in range(0, len(table), ROWS_PER_WRITE):
        rows = table[start : start + ROWS_PER_WRITE].tolist()
        yield "".join(",".join(map(repr, row)) + "\n" for row in rows)


def json_pieces(meta: SimulateMeta, columns: list[str], table: np.ndarray) -> Iterator[str]:
    """One JSON object: a key per line, then "rows", one sample (a list in the order of "columns") per line."""
    head = {**meta, "columns": columns}
    yield "{\n" + "".join(f" {json.dumps(k)}: {json.dumps(v, allow_nan=False)},\n" for k, v in head.items())
    yield ' "rows": [\n'
    for start in range(0, len(table), ROWS_PER_WRITE):
        rows = table[start : start + ROWS_PER_WRITE].tolist()
        last = start + ROWS_PER_WRITE >= len(table)
        yield ",\n".join("  " + json.dumps(row) for row in rows) + ("\n" if last else ",\n")
    yield " ]\n}\n"


def cmd_simulate(args: argparse.Namespace, one_system: Callable[[argparse.Namespace], System]) -> int:
    """Integrates, checks every sample is finite, writes the file and prints what it did, each
    adjustment of the request included. `one_system` finds the system the arguments name."""
    suffix = args.out.suffix.lower()
    if suffix not in (".csv", ".json"):
        raise HarnessError(f"--out must end in .csv or .json; got '{args.out.name}'.")
    if args.out.is_dir():
        raise HarnessError(f"--out {args.out} is a directory; give a file name ending in {suffix}.")
    folder = args.out.parent
    if not folder.is_dir():  # a mistyped folder is refused, never created behind the user's back
        raise HarnessError(f"--out {args.out}: the folder {folder} does not exist; create it first.")
    system = one_system(args)
    columns = ["t", *system.coordinates, *[f"d{c}" for c in system.coordinates]]
    refuse_if_too_large(args.t_end, args.dt_out, len(columns))
    st = validate_states(system, args.q0, args.v0, args.tau)
    t = integrate.time_grid(args.t_end, args.dt_out)
    source = make_source(system, args.source)
    adjustments: list[str] = []
    timestep = None
    if args.source == "mujoco":
        source = stepped(source)
        timestep, note = mujoco_timestep(float(source.m.opt.timestep), args.dt_out)
        adjustments += [note] if note else []
        traj = integrate.mujoco_trajectory(
            system, source, Start.of(st.q[0], st.v[0], st.tau[0]), t, integrator="RK4", timestep=timestep
        )
    else:
        traj = integrate.scipy_trajectory(
            system, source, Start.of(st.q[0], st.v[0], st.tau[0]), t, **integrate.SCIPY_DEFAULT
        )
    table = np.column_stack([traj.t, traj.q, traj.v])
    bad = np.argwhere(~np.isfinite(table))
    if len(bad):  # never data: a non-finite sample is the error, with where it happened
        k, j = (int(x) for x in bad[0])
        raise HarnessError(
            f"{args.source} ({traj.method}): {columns[j]} is {table[k, j]} at t = {table[k, 0]:g} s; nothing written."
        )
    meta: SimulateMeta = {
        "system": system.name,
        **files_of(system),
        "locked": list(system.locked),  # URDF joints made fixed (--lock)
        "source": args.source,
        "method": traj.method,
        "coordinates": list(system.coordinates),
        "q0": st.q[0].tolist(),
        "v0": st.v[0].tolist(),
        "tau": st.tau[0].tolist(),
        "t_end": float(args.t_end),
        "dt_out": float(args.dt_out),
        "samples": len(table),
        "mujoco_timestep": timestep,
        "adjustments": adjustments,
        "units": units(system),
        "harness_version": harness_version(),
    }
    pieces = csv_pieces if suffix == ".csv" else json_pieces
    atomic_write(args.out, pieces(meta, columns, table))
    for note in adjustments:
        print(f"adjusted: {note}.")
    print(f"wrote {args.out} ({len(table)} samples, {traj.method})")
    return 0

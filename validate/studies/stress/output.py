"""The whole stress run (`run_stress`), stress.json, the console summary and the command."""

from __future__ import annotations

import sys
import threading
import time
from argparse import Namespace
from collections.abc import Callable, Mapping
from concurrent.futures import Executor
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Literal, TypedDict, cast

from ...core.errors import HarnessError
from ...core.guard import DEFAULT_TIME_LIMIT
from ...core.parallel import completed
from ...dynamics.integrate import energy_missing
from ...model.overrides import parse
from ...results import atomic_write, dumps, provenance
from ...results.schema import (
    ConditioningRow,
    ConditioningSummary,
    DriftRow,
    Skipped,
    SolveTierProposal,
    StabilityRow,
    StiffRow,
    StressResults,
)
from ...sources import Sources, make_sources
from ...systems import System, from_key, key_of, load, system_names
from .conditioning import conditioning_rows, conditioning_summary, no_sweep_reason, proposed_solve_tier
from .energy import conservative, drift_rows
from .runs import minimum_potential, quiet_mujoco_warnings
from .settings import (
    BISECTION_RATIO,
    DT_RANGE,
    ENVELOPE_GROWTH,
    FULL,
    GROWTH,
    LARGE_CHANGE,
    MJ_MINVAL,
    QUICK,
    ROUND_OFF,
    SERIES_POINTS,
    STEADY_R2,
    Settings,
)
from .shapes import Section, SectionRows
from .stability import stability_rows, stiff_rows

if TYPE_CHECKING:  # rich is imported when the summary is printed
    from rich.console import Console


def sort_key(row: Mapping[str, object]) -> tuple[tuple[int, object], ...]:
    keys = (
        "system",
        "sweep",
        "engine",
        "integrator",
        "quantity",
        "pair",
        "horizon",
        "speed",
        "criterion",
        "damping_factor",
        "ratio",
        "timestep",
    )
    return tuple((0, "") if row.get(k) is None else (1, row[k]) for k in keys)


def _stress_systems(
    names: list[str] | None,
    overrides: tuple[tuple[str, float], ...],
    files: list[tuple[Path, Path]] | None,
    locked: tuple[str, ...],
    time_limit: float,
) -> list[System]:
    """The systems named (all when neither names nor files are given) and those of `files`, each with
    `overrides`, compiled by MuJoCo and its parameters read: a bad one is a one-line HarnessError here."""
    systems_ = [load(n, overrides=tuple(overrides)) for n in (names or ([] if files else system_names()))]
    own = [System.from_files(m, e, locked=locked, time_limit=time_limit) for m, e in (files or [])]
    systems_ += [s.derive(overrides=tuple(overrides)) for s in own]
    for s in systems_:
        try:
            s.mujoco_model()
        except HarnessError as exc:
            if "mjMINVAL" not in str(exc):
                raise
            raise HarnessError(
                f"{exc} ({s.name}: MuJoCo refuses masses and principal inertias below {MJ_MINVAL:g}; "
                f"the point bobs carry 1e-14 kg m^2, so scale body/<name>/inertia up with a smaller "
                f"mass)."
            ) from None
        s.params  # noqa: B018 - the equations read the overridden model: a bad value fails here
    return systems_


def _run_sections(
    results: StressResults,
    systems_: list[System],
    overrides: tuple[tuple[str, float], ...],
    settings: Settings,
    executor: Executor | None,
    say: Callable[[str], None],
    start: float,
) -> None:
    """Every section of every system, each collected into `results` and said with the time since `start`
    as it finishes: in this process, or one task per system and section in `executor`."""
    tasks = [(s, section) for s in systems_ for section in settings.sections]
    if executor is None:  # in this process, one system's sources shared by its sections
        with quiet_mujoco_warnings():
            for s in systems_:
                prepared = (s, *prepare(s))
                for section in settings.sections:
                    done = run_section(prepared, section, settings)
                    collect(results, done)
                    say(f"[{time.perf_counter() - start:6.1f} s] {s.name}: {section} ({done['elapsed']:.1f} s)")
    else:  # one task per system and section, each worker keeping the systems it has built
        futures = {
            executor.submit(section_task, key_of(s), tuple(overrides), section, settings): (s, section)
            for s, section in tasks
        }
        for fut in completed(futures):
            done = fut.result()
            collect(results, done)
            say(f"[{time.perf_counter() - start:6.1f} s] {done['system']}: {done['section']} ({done['elapsed']:.1f} s)")


def run_stress(
    names: list[str] | None,
    *,
    overrides: tuple[tuple[str, float], ...] = (),
    quick: bool = False,
    settings: Settings | None = None,
    progress: Callable[[str], None] | None = None,
    files: list[tuple[Path, Path]] | None = None,
    executor: Executor | None = None,
    locked: tuple[str, ...] = (),
    time_limit: float = DEFAULT_TIME_LIMIT,
) -> StressResults:
    """The four stress experiments on the systems named (all when none) and on a person's own
    (`files`: (model, equations) pairs, their URDF joints `locked` made fixed), with `overrides` on
    each; in this process, or with `executor`
    (any `concurrent.futures.Executor`, a dask cluster's included) one task per system and section.

    Every system is loaded and compiled with the overrides first, so an unknown system, an unknown key
    or a model MuJoCo refuses is a one-line HarnessError before any long run starts.
    """
    settings = settings or (QUICK if quick else FULL)
    say = progress or (lambda msg: None)
    systems_ = _stress_systems(names, overrides, files, locked, time_limit)
    results: StressResults = {
        "meta": provenance(settings.seed),  # one provenance block, as in results.json and bench.json
        "quick": quick,
        "settings": asdict(settings),
        "overrides": [list(o) for o in overrides],
        "systems": [s.name for s in systems_],
        "criteria": criteria(),
        "drift": [],
        "stability": [],
        "conditioning": [],
        "stiff_friction": [],
        "skipped": [],
        "timing": {},
    }
    start = time.perf_counter()
    _run_sections(results, systems_, overrides, settings, executor, say, start)
    results["drift"] = sorted(results["drift"], key=sort_key)
    results["stability"] = sorted(results["stability"], key=sort_key)
    results["conditioning"] = sorted(results["conditioning"], key=sort_key)
    results["stiff_friction"] = sorted(results["stiff_friction"], key=sort_key)
    results["skipped"] = sorted(results["skipped"], key=sort_key)
    summary = conditioning_summary(results["conditioning"])
    results["conditioning_summary"] = summary
    results["solve_tier_proposal"] = proposed_solve_tier(summary)
    results["timing"]["total"] = time.perf_counter() - start
    return results


LOCAL = threading.local()


def prepare(system: System) -> tuple[Sources, float]:
    """A system's sources and the smallest potential on its grid (shared by its sections)."""
    sources = make_sources(system)
    if energy_missing(sources["hand"]):  # no V to take the minimum of: the energy criterion is skipped
        return sources, float("nan")
    return sources, minimum_potential(system, sources["hand"])


def section_task(key: str, overrides: tuple[tuple[str, float], ...], section: str, settings: Settings) -> Section:
    """One system's section in a worker (the system found by `systems.key_of`'s key, with the
    overrides); the system, its sources and V_min are built once per worker thread."""
    cache = LOCAL.__dict__.setdefault("systems", {})
    if (key, overrides) not in cache:
        base = from_key(key)
        system = base.derive(overrides=overrides) if overrides else base
        cache[(key, overrides)] = (system, *prepare(system))
    with quiet_mujoco_warnings():
        return run_section(cache[(key, overrides)], section, settings)


def run_section(prepared: tuple[System, Sources, float], section: str, settings: Settings) -> Section:
    """One section's rows on one system: {"system", "section", "rows", "skipped", "elapsed"}."""
    s, sources, V_min = prepared
    t0 = time.perf_counter()
    rows: SectionRows = []
    skipped: list[Skipped] = []
    missing = energy_missing(sources["hand"])
    if section == "drift":
        if missing:
            skipped.append({"system": s.name, "section": section, "why": f"{missing}: no energy to follow"})
        elif conservative(s):
            rows = drift_rows(s, sources, settings, V_min=V_min)
        else:
            why = " and ".join(w for u, w in (("damping", "damping"), ("actuation", "inputs")) if u in s.uses)
            skipped.append({"system": s.name, "section": section, "why": f"not conservative (the model has {why})"})
    elif section == "stability":
        rows = stability_rows(s, sources, settings, V_min=V_min)
        if missing:
            why = f"{missing}: the energy criterion skipped, divergence alone judged"
            skipped.append({"system": s.name, "section": "stability (energy criterion)", "why": why})
    elif section == "conditioning":
        rows = conditioning_rows(s, sources, settings)
        if not rows:
            skipped.append({"system": s.name, "section": section, "why": no_sweep_reason(s)})
    elif section == "stiff_friction":
        if "damping" in s.uses:
            rows = stiff_rows(s, settings, V_min)
        else:
            skipped.append({"system": s.name, "section": section, "why": "no joint damping"})
    else:
        raise HarnessError(f"unknown stress section '{section}'.")
    return {"system": s.name, "section": section, "rows": rows, "skipped": skipped, "elapsed": time.perf_counter() - t0}


def collect(results: StressResults, done: Section) -> None:
    section, rows = done["section"], done["rows"]  # a section's rows are of its kind (run_section)
    if section == "drift":
        results["drift"] += cast(list[DriftRow], rows)
    elif section == "stability":
        results["stability"] += cast(list[StabilityRow], rows)
    elif section == "conditioning":
        results["conditioning"] += cast(list[ConditioningRow], rows)
    elif section == "stiff_friction":
        results["stiff_friction"] += cast(list[StiffRow], rows)
    else:
        raise KeyError(section)
    results["skipped"] += done["skipped"]
    results["timing"][f"{done['system']}/{done['section']}"] = done["elapsed"]


def criteria() -> dict[str, str]:
    return {
        "instability": (
            f"a non-finite state, any MuJoCo warning (d.warning[i].number > 0), an overflow in a mirror, "
            f"or (criterion 'energy x{1 + GROWTH:g}') max(E - E0) > {GROWTH:g} x (E0 - V_min); criterion "
            f"'divergence': the first three only"
        ),
        "classes": (
            f"round-off: max |dE| <= {ROUND_OFF:g} x (E0 - V_min); bounded oscillation: late |dE| envelope "
            f"<= {ENVELOPE_GROWTH:g} x early (last vs first tenth); "
            f"secular drift: grows, a line fits |dE| vs t (R^2 >= {STEADY_R2:g}), < {LARGE_CHANGE:.0%} of "
            f"E0 - V_min; numerical damping / energy injection: the same with a loss / gain >= "
            f"{LARGE_CHANGE:.0%}; irregular: grows, no line fits"
        ),
        "bisection": (
            f"log(dt) in [{DT_RANGE[0]:g}, {DT_RANGE[1]:g}] s until the bracket ratio <= "
            f"{BISECTION_RATIO:g}; the top is tried first, the bottom only if the bisection ends there"
        ),
        "conditioning": (
            "cond(M): 2-norm condition number of the hand M; disagreement: compare.compare's 'scaled' "
            "(max |a - b| / the largest magnitude of the quantity over the sample), tolerance and verdict from its rows"
        ),
        "series": f"downsampled to <= {SERIES_POINTS} points: in each bucket the sample of largest |y|",
    }


def write_stress(results: StressResults, out: Path) -> Path:
    """Writes out/stress.json atomically (rendered in memory first: a failure leaves the old file)."""
    path = Path(out) / "stress.json"
    text = dumps(results)
    atomic_write(path, text)
    return path


def fmt(x: object, spec: str = ".1e") -> str:
    return "-" if x is None else format(x, spec)


NAME_COLUMNS = ("system", "method", "engine", "integrator")


class ColumnStyle(TypedDict, total=False):
    """rich's `Table.add_column` options for one column."""

    overflow: Literal["fold"]
    no_wrap: bool
    min_width: int


def longest_names(results: Mapping[str, object] | None) -> dict[str, int]:
    """The longest value of each name column in any table of `results` (rows are dicts)."""
    out: dict[str, int] = {}
    rows = [r for v in (results or {}).values() if isinstance(v, list) for r in v if isinstance(r, dict)]
    for col in NAME_COLUMNS:
        out[col] = max([len(col)] + [len(str(r[col])) for r in rows if col in r])
    return out


def column_style(col: str, longest: dict[str, int] | None = None) -> ColumnStyle:
    """Names are never cut ("double_pendulum..."): a name column is as wide as its longest name and
    does not wrap; the other columns wrap instead."""
    if col not in NAME_COLUMNS:
        return {"overflow": "fold"}
    return {"no_wrap": True, "min_width": (longest or {}).get(col, len(col))}


def print_summary(results: StressResults, console: Console | None = None) -> None:
    """Readable tables of the results (rich), one per section that ran, then what was skipped."""
    from rich.console import Console

    console = console or Console()
    longest = longest_names(results)
    if results["drift"]:
        drift_table(results["drift"], longest, console)
    if results["stability"]:
        stability_table(results["stability"], longest, console)
    if results["conditioning_summary"]:
        conditioning_table(results["conditioning_summary"], longest, console)
        proposal_line(results.get("solve_tier_proposal") or {}, console)
    if results["stiff_friction"]:
        stiff_table(results["stiff_friction"], longest, console)
    for s in results["skipped"]:
        console.print(f"skipped {s['section']} on {s['system']}: {s['why']}")


def drift_table(rows: list[DriftRow], longest: dict[str, int], console: Console) -> None:
    """Energy over the long horizons: class, direction, worst relative change and rate."""
    from rich.table import Table

    table = Table(title="Energy over long horizons (MJCF timestep; dE = E - E0, E by the hand equations)")
    for col in (
        "system",
        "engine",
        "integrator",
        "horizon s",
        "class",
        "direction",
        "max |dE| / (E0-Vmin)",
        "|dE| rate J/s",
    ):
        table.add_column(col, **column_style(col, longest))
    for r in rows:
        table.add_row(
            r["system"],
            r["engine"],
            r["integrator"],
            f"{r['horizon']:g}",
            r["class"],
            r["direction"] or "-",
            fmt(r["relative_max"], ".2e"),
            fmt(r["rate"], ".1e"),
        )
    console.print(table)


def stability_table(rows: list[StabilityRow], longest: dict[str, int], console: Console) -> None:
    """The largest stable timestep per system, engine and integrator, at each speed and criterion."""
    from rich.table import Table

    speeds = sorted({r["speed"] for r in rows})
    criteria = sorted({r["criterion"] for r in rows}, key=lambda c: c == "divergence")
    table = Table(
        title=f"Largest stable timestep (s) over {rows[0]['t_end']:g} s, bisection on log dt in "
        + ", ".join(f"[{lo:g}, {hi:g}] ({engine})" for engine, (lo, hi) in ranges(rows).items())
        + f" (< x: unstable at the bottom, not searched below); v0 = speed on every coordinate; "
        f"criteria: {' / '.join(criteria)}"
    )
    for col in ("system", "engine", "integrator", *[f"{s:g} rad/s" for s in speeds]):
        table.add_column(col, **column_style(col, longest))
    cells: dict[tuple[str, str, str], dict[float, dict[str, str]]] = {}
    for r in rows:
        by_speed = cells.setdefault((r["system"], r["engine"], r["integrator"]), {})
        by_speed.setdefault(r["speed"], {})[r["criterion"]] = stable_cell(r)
    for (system, engine, integrator), by_speed in cells.items():
        table.add_row(
            system,
            engine,
            integrator,
            *[" / ".join(by_speed.get(s, {}).get(c, "-") for c in criteria) for s in speeds],
        )
    console.print(table)


def ranges(rows: list[StabilityRow]) -> dict[str, tuple[float, float]]:
    """Each engine's search range (the bottom raised where a run would take too many steps)."""
    return {r["engine"]: (float(r.get("range", DT_RANGE)[0]), float(r.get("range", DT_RANGE)[1])) for r in rows}


def stable_cell(r: StabilityRow) -> str:
    """The bisection's answer: the largest stable dt, or a bound where it ran off the bracket."""
    if r["min_unstable"] is None:
        return f">={r['max_stable']:.2g}"
    if r["max_stable"] is None:
        return f"<{r['min_unstable']:.2g}"
    return f"{r['max_stable']:.3g}"


def conditioning_table(summary: list[ConditioningSummary], longest: dict[str, int], console: Console) -> None:
    """Ill-conditioning: the worst pair's disagreement against cond(M), and where each tier fails."""
    from rich.table import Table

    table = Table(
        title="Ill-conditioning: the worst pair's disagreement (compare's scaled error) vs cond(M) over "
        "the sample; C = max per-state error / (cond eps)"
    )
    for col in (
        "system",
        "sweep",
        "quantity",
        "cond(M) max",
        "disagreement",
        "slope",
        "C",
        "C (cond_eq)",
        "base tier fails from cond",
        "current tier fails from cond",
    ):
        table.add_column(col, **column_style(col, longest))
    for s in summary:
        table.add_row(
            s["system"],
            s["sweep"],
            s["quantity"],
            f"{s['cond_range'][0]:.1e} .. {s['cond_range'][1]:.1e}",
            f"{s['disagreement_range'][0]:.1e} .. {s['disagreement_range'][1]:.1e}",
            fmt(s["slope"], ".2f"),
            f"{s['c_state']:.2g}",
            f"{s['c_state_eq']:.2g}",
            fmt(s["base_tier_fails_from_cond"]),
            fmt(s["tier_fails_from_cond"]),
        )
    console.print(table)


def proposal_line(p: SolveTierProposal, console: Console) -> None:
    """The proposed solve tier from the measured disagreement (nothing when none was proposed)."""
    if not p:
        return
    console.print(
        f"Solve tier per state max({p['rtol']:g}, C eps kappa): the states beyond {p['rtol']:g} needed "
        f"C = {p['measured_C_cond']:.2g} with kappa = cond(M) ({p['measured_C_cond_eq']:.2g} with the "
        f"equilibrated cond, whose ratio reaches {p['measured_C_cond_eq_all_states']:.2g} at states below "
        f"{p['rtol']:g}: it does not bound the error); {p['margin']:g}x margin gives C = "
        f"{p['C_cond']:g} on cond(M), binding from cond {fmt(p['kappa_from_cond'])}; "
        f"current cond_factor: {p['current_cond_factor']}.",
        highlight=False,
    )


def stiff_table(rows: list[StiffRow], longest: dict[str, int], console: Console) -> None:
    """Stiff friction: stable or not, and the error against the reference, per timestep."""
    from rich.table import Table

    dts = sorted({r["timestep"] for r in rows})
    table = Table(
        title="Stiff friction: stable? and max |q - q_ref| (rad) vs DOP853 rtol 1e-12 on the hand "
        "equations, per timestep (s)"
    )
    for col in ("system", "damping x", "engine", "integrator", *[f"{d:g}" for d in dts]):
        table.add_column(col, **column_style(col, longest))
    cells: dict[tuple[str, str, str, str], dict[float, str]] = {}
    for r in rows:
        key = (r["system"], f"{r['damping_factor']:g}", r["engine"], r["integrator"])
        cell = "not run" if r["stable"] is None else f"{r['max_error']:.0e}" if r["stable"] else "UNSTABLE"
        cells.setdefault(key, {})[r["timestep"]] = cell
    for key, by_dt in cells.items():
        table.add_row(*key, *[by_dt.get(d, "-") for d in dts])
    console.print(table)


def stress_command(args: Namespace, executor: Executor | None = None) -> int:
    """`lagrange-xval stress [SYSTEM ...] [--set KEY=VALUE ...] [--quick] [--out DIR]`."""
    from rich.console import Console

    raw = list(getattr(args, "set", None) or [])
    overrides = parse(raw) if all(isinstance(x, str) for x in raw) else tuple((str(k), float(v)) for k, v in raw)
    err = Console(stderr=True)
    names = list(getattr(args, "systems", None) or []) or None
    results = run_stress(
        names,
        overrides=overrides,
        quick=bool(getattr(args, "quick", False)),
        progress=lambda msg: err.print(msg, highlight=False),
        files=getattr(args, "files", None),
        executor=executor,
        locked=tuple(getattr(args, "locked", None) or ()),
        time_limit=getattr(args, "time_limit", DEFAULT_TIME_LIMIT),
    )
    path = write_stress(results, Path(getattr(args, "out", None) or "reports"))
    print_summary(results, Console(width=None if sys.stdout.isatty() else 160))
    print(
        f"wrote {path} ({'quick' if results['quick'] else 'full'} stress, {results['timing']['total']:.0f} s)",
        file=sys.stdout,
    )
    return 0

"""The `lagrange-xval` command line. Heavy imports (engines, plotting) happen inside subcommands."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from .errors import HarnessError

DEFAULT_STATES = 1000
DEFAULT_SEED = 0


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a positive finite number, got {text}")
    return value


def _vector(text: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a comma-separated list of numbers") from None


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="lagrange-xval", description=__doc__.splitlines()[0] if __doc__ else None)
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    sub.add_parser("list", help="the systems, their coordinates, degrees of freedom and printed forms")

    run = sub.add_parser("run", help="validate every system (or those named) and write the reports")
    run.add_argument("systems", nargs="*", metavar="SYSTEM")
    run.add_argument("--states", type=_positive_int, default=DEFAULT_STATES, help="random states per system")
    run.add_argument("--seed", type=int, default=DEFAULT_SEED)
    run.add_argument("--out", type=Path, default=Path("reports"), help="report folder (default: reports)")
    run.add_argument("--no-replay", action="store_true", help="skip the rerun .rrd recordings")

    check = sub.add_parser("check", help="pointwise comparison of the three sources")
    check.add_argument("system")
    check.add_argument(
        "--states",
        type=Path,
        metavar="FILE",
        help='JSON list of {"q": [...], "v": [...], "tau": [...]} in the notes\' coordinates',
    )
    check.add_argument("--n", type=_positive_int, default=DEFAULT_STATES, help="random states when no FILE")
    check.add_argument("--seed", type=int, default=DEFAULT_SEED)
    check.add_argument("--json", action="store_true", help="print one JSON object")

    sim = sub.add_parser("simulate", help="one trajectory of one source, sampled every DT")
    sim.add_argument("system")
    sim.add_argument("--source", choices=("hand", "mujoco", "pinocchio"), required=True)
    sim.add_argument("--q0", type=_vector, required=True, help="comma-separated, notes' coordinates (rad)")
    sim.add_argument("--v0", type=_vector, required=True, help="comma-separated (rad/s)")
    sim.add_argument("--tau", type=_vector, help="comma-separated constant input (N m); default zero")
    sim.add_argument("--t-end", type=_positive_float, required=True)
    sim.add_argument("--dt-out", type=_positive_float, required=True)
    sim.add_argument("--out", type=Path, required=True, help="FILE.csv or FILE.json")

    rep = sub.add_parser("report", help="re-render the reports from an existing results.json")
    rep.add_argument("--out", type=Path, default=Path("reports"))

    bench = sub.add_parser("bench", help="run time against error: work-precision sweep and the fast-harness ratios")
    bench.add_argument("systems", nargs="*", metavar="SYSTEM")
    bench.add_argument("--quick", action="store_true", help="2 systems, small plan, 1 repeat (about 10 s)")
    bench.add_argument("--out", type=Path, default=Path("reports"), help="folder for bench.json (default: reports)")
    bench.add_argument("--repeats", type=_positive_int, default=None, help="timing repeats (default 3; --quick 1)")

    stress = sub.add_parser("stress", help="numerical stability: long horizons, stable timesteps, conditioning")
    stress.add_argument("systems", nargs="*", metavar="SYSTEM")
    stress.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="parameter override applied to every system (e.g. scale/mass=2, joint/psi/damping=1)",
    )
    stress.add_argument("--quick", action="store_true", help="100 s horizons and fewer sweep points (~30 s)")
    stress.add_argument("--out", type=Path, default=Path("reports"), help="folder for stress.json")

    replay = sub.add_parser("replay", help="a rerun recording of a system's trajectories")
    replay.add_argument("system")
    replay.add_argument("--save", type=Path, metavar="FILE", help="write an .rrd file instead of spawning a viewer")
    return p


def cmd_list(args: argparse.Namespace) -> int:
    from .systems import load_all

    for s in load_all():
        print(f"{s.name}: {s.nv} dof, coordinates ({', '.join(s.coordinates)}); uses {', '.join(sorted(s.uses))}")
        for v in s.variants:
            print(f"    {v.kind:16s} {v.name}  [{', '.join(v.notes_equations)}]")
    return 0


def _states_from_file(system: Any, path: Path) -> Any:
    from .compare import validate_states

    if not path.is_file():
        raise HarnessError(f"states file not found: {path}.")
    try:
        items = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise HarnessError(f"{path} is not valid JSON: {exc}.") from None
    if not isinstance(items, list) or not items:
        raise HarnessError(f'{path} must hold a non-empty JSON list of {{"q": [...], "v": [...], "tau": [...]}}.')
    qs, vs, taus = [], [], []
    for i, item in enumerate(items):
        if not isinstance(item, dict) or "q" not in item or "v" not in item:
            raise HarnessError(f'{path}: state {i} must be an object with "q" and "v" (and optional "tau").')
        unknown = set(item) - {"q", "v", "tau"}
        if unknown:
            raise HarnessError(f'{path}: state {i} has unknown keys {sorted(unknown)}; valid: "q", "v", "tau".')
        qs.append(item["q"])
        vs.append(item["v"])
        taus.append(item.get("tau", [0.0] * system.nv))
    for name, arr in (("q", qs), ("v", vs), ("tau", taus)):
        for i, x in enumerate(arr):
            if not isinstance(x, list) or len(x) != system.nv:
                raise HarnessError(
                    f"{path}: state {i}: {name} must be a list of {system.nv} numbers "
                    f"({', '.join(system.coordinates)}); got {x!r}."
                )
    if "actuation" not in system.uses and any(any(t) for t in taus):
        pass  # unactuated systems take tau as an applied joint torque
    return validate_states(system, qs, vs, taus)


def _require_same_model(system: Any, sources: dict[str, Any]) -> None:
    """Dynamics are compared only between sources that describe the same model."""
    from . import modelsync

    bad = modelsync.check(system, sources["pinocchio"])["mismatches"]
    if bad:
        keys = ", ".join(r["key"] for r in bad[:4]) + (f" and {len(bad) - 4} more" if len(bad) > 4 else "")
        raise HarnessError(
            f"{system.name}: the sources describe different models ({keys}): {bad[0]['why']}; "
            f"{bad[0]['key']} is {bad[0]['actual']}, expected {bad[0]['expected']}."
        )


def cmd_check(args: argparse.Namespace) -> int:
    import numpy as np

    from . import compare
    from .sources import make_sources
    from .systems import load

    system = load(args.system)
    states = (
        _states_from_file(system, args.states)
        if args.states
        else compare.random_states(system, n=args.n, seed=args.seed)
    )
    sources = make_sources(system)
    _require_same_model(system, sources)
    values = compare.evaluate(sources, states)
    rows = compare.compare(values, states)
    if args.json:
        keys = ("M", "bias", "qacc", "tau_inverse", "T", "V")
        out = {
            "system": system.name,
            "coordinates": list(system.coordinates),
            "states": [
                {
                    "q": states.q[i],
                    "v": states.v[i],
                    "tau": states.tau[i],
                    "sources": {s: {k: values[s][k][i] for k in keys} for s in values},
                }
                for i in range(len(states))
            ],
            "max_disagreement": {r["quantity"]: {} for r in rows},  # filled below
            "passed": all(r["passed"] for r in rows),
        }
        disagreement: dict[str, dict[str, Any]] = out["max_disagreement"]  # type: ignore[assignment]
        for r in rows:
            disagreement[r["quantity"]][r["pair"]] = {
                "max_abs": r["max_abs"],
                "scaled": r["scaled"],
                "tolerance": r["tolerance"],
                "passed": r["passed"],
            }
        from .results import to_jsonable

        print(json.dumps(to_jsonable(out), allow_nan=False))
    else:
        print(f"{system.name}: {len(states)} states, coordinates ({', '.join(system.coordinates)})")
        print(f"{'quantity':15s} {'pair':20s} {'max abs':>10s} {'scaled':>10s} {'tolerance':>10s}  verdict")
        for r in rows:
            print(
                f"{r['quantity']:15s} {r['pair']:20s} {r['max_abs']:10.2e} {r['scaled']:10.2e} "
                f"{r['tolerance']:10.0e}  {'pass' if r['passed'] else 'FAIL'}"
            )
    return 0 if all(r["passed"] for r in rows) and np.isfinite([r["max_abs"] for r in rows]).all() else 1


def cmd_simulate(args: argparse.Namespace) -> int:
    import numpy as np

    from . import integrate
    from .compare import validate_states
    from .results import atomic_write
    from .sources import make_source
    from .systems import load

    suffix = args.out.suffix.lower()
    if suffix not in (".csv", ".json"):
        raise HarnessError(f"--out must end in .csv or .json; got '{args.out.name}'.")
    system = load(args.system)
    st = validate_states(system, args.q0, args.v0, args.tau)
    t = integrate.time_grid(args.t_end, args.dt_out)
    source = make_source(system, args.source)
    if args.source == "mujoco":
        dt = source.m.opt.timestep
        traj = integrate.mujoco_trajectory(
            system,
            source,
            st.q[0],
            st.v[0],
            st.tau[0],
            t,
            integrator="RK4",
            timestep=dt
            if round(args.dt_out / dt) * dt == args.dt_out
            else args.dt_out / max(1, round(args.dt_out / dt)),
        )
    else:
        traj = integrate.scipy_trajectory(system, source, st.q[0], st.v[0], st.tau[0], t, **integrate.SCIPY_DEFAULT)
    cols = ["t", *system.coordinates, *[f"d{c}" for c in system.coordinates]]
    table = np.column_stack([traj.t, traj.q, traj.v])
    if suffix == ".csv":
        lines = [",".join(cols)] + [",".join(repr(float(x)) for x in row) for row in table]
        atomic_write(args.out, "\n".join(lines) + "\n")
    else:
        from .results import dumps

        atomic_write(
            args.out,
            dumps(
                {"system": system.name, "source": args.source, "method": traj.method, "columns": cols, "rows": table}
            ),
        )
    print(f"wrote {args.out} ({len(table)} samples, {traj.method})")
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    from .outputs import write_all
    from .pipeline import run
    from .progress import reporter

    with reporter() as progress:
        results = run(args.systems or None, n_states=args.states, seed=args.seed, progress=progress)
    write_all(results, args.out, replay=not args.no_replay)
    verdict = "all systems pass" if results["passed"] else "some systems FAIL"
    print(f"{verdict}; reports in {args.out}/ (report.html, report.md, results.json)")
    return 0 if results["passed"] else 1


def cmd_report(args: argparse.Namespace) -> int:
    from .outputs import write_reports
    from .results import load

    results = load(args.out / "results.json")
    write_reports(results, args.out)
    print(f"re-rendered {args.out}/report.md and {args.out}/report.html")
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    from .replay import replay_command

    return replay_command(args.system, args.save)


def cmd_bench(args: argparse.Namespace) -> int:
    from .bench import bench_command

    return bench_command(args)


def cmd_stress(args: argparse.Namespace) -> int:
    from .stress import stress_command

    return stress_command(args)


COMMANDS = {
    "list": cmd_list,
    "run": cmd_run,
    "check": cmd_check,
    "simulate": cmd_simulate,
    "report": cmd_report,
    "replay": cmd_replay,
    "stress": cmd_stress,
    "bench": cmd_bench,
}


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        return COMMANDS[args.command](args)
    except HarnessError as exc:
        print(f"lagrange-xval: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("lagrange-xval: interrupted; nothing half-written (previous reports are intact).", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())

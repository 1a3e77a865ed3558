"""The `lagrange-xval` command line. Heavy imports (engines, plotting) happen inside subcommands."""

from __future__ import annotations

import argparse
import contextlib
import errno
import functools
import json
import os
import signal
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from ..checks import modelsync
from ..checks import pointwise as compare
from ..checks.pointwise import validate_states
from ..dynamics import integrate
from ..dynamics.cache import CACHE_ENV
from ..engines import make_source, make_sources
from ..errors import HarnessError, Terminated
from ..inputs import parse_json, regular_file
from ..pipeline import run
from ..replay import replay_command
from ..results import atomic_write, dumps, to_jsonable
from ..results import load as load_results
from ..studies.bench import bench_command
from ..studies.stress import stress_command
from ..systems import System, load, pairs_in, system_names
from .outputs import check_out, render_system, write_all, write_reports
from .progress import reporter

DEFAULT_STATES = 1000
DEFAULT_SEED = 0
MAX_STATES = 100_000  # random states per system: 1e5 evaluate in about a minute; more is a typo
MAX_SAMPLES = 10_000_000  # samples of one `simulate` trajectory (about 1 GB of CSV)
MAX_STATES_FILE_BYTES = 64 * 2**20  # a states file is read whole; 64 MiB holds ~500 000 states
MAX_SEED = 2**63 - 1


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if value < 1 or value > MAX_STATES:
        raise argparse.ArgumentTypeError(f"must be from 1 to {MAX_STATES}, got {value}")
    return value


def _probe_count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if not 0 <= value <= 100:
        raise argparse.ArgumentTypeError(f"must be from 0 to 100, got {value}")
    return value


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be from 0 to 2**63 - 1, got {value}")
    return value


def _path(text: str) -> Path:
    """A path argument; the empty string is refused (Path('') would silently mean '.')."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must not be empty (use . for the current folder)")
    return Path(text)


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
    debug = argparse.ArgumentParser(add_help=False)
    debug.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help="show tracebacks")
    p = argparse.ArgumentParser(
        prog="lagrange-xval", description=__doc__.splitlines()[0] if __doc__ else None, parents=[debug]
    )
    p.set_defaults(debug=False)
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def command(name: str, **kwargs: Any) -> argparse.ArgumentParser:
        return sub.add_parser(name, parents=[debug], **kwargs)

    def model_options(parser: argparse.ArgumentParser) -> None:
        parser.add_argument("--model", type=_path, metavar="PATH", help="your own MJCF (with --equations)")
        parser.add_argument(
            "--equations", type=_path, metavar="PATH", help="your own equations module, .py (with --model)"
        )

    def cache_options(parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "--cache-dir", type=_path, metavar="DIR", help="reference and chaos cache (default: OUT/.cache)"
        )
        parser.add_argument("--no-cache", action="store_true", help="compute everything, read and write no cache")

    command("list", help="the systems, their coordinates, degrees of freedom and printed forms")

    run = command("run", help="validate every system (or those named) and write the reports")
    run.add_argument("systems", nargs="*", metavar="SYSTEM")
    run.add_argument("--states", type=_positive_int, default=DEFAULT_STATES, help="random states per system")
    run.add_argument("--seed", type=_seed, default=DEFAULT_SEED)
    run.add_argument("--out", type=_path, default=Path("reports"), help="report folder (default: reports)")
    run.add_argument("--no-replay", action="store_true", help="skip the rerun .rrd recordings")
    run.add_argument(
        "--probes",
        type=_probe_count,
        default=4,
        help="probe parameter sets per derivation, every parameter moved (default 4; 0: the model's only)",
    )
    model_options(run)
    run.add_argument(
        "--systems",
        dest="systems_dir",
        type=_path,
        metavar="DIR",
        help="a folder of your own systems: each <name>.xml with its <name>.py",
    )
    cache_options(run)

    check = command("check", help="pointwise comparison of the three sources")
    check.add_argument("system", nargs="?", help="a repository system (or give --model and --equations)")
    model_options(check)
    check.add_argument(
        "--states",
        type=_path,
        metavar="FILE",
        help='JSON list of {"q": [...], "v": [...], "tau": [...]} in the notes\' coordinates',
    )
    check.add_argument("--n", type=_positive_int, default=DEFAULT_STATES, help="random states when no FILE")
    check.add_argument("--seed", type=_seed, default=DEFAULT_SEED)
    check.add_argument("--json", action="store_true", help="print one JSON object")

    sim = command("simulate", help="one trajectory of one source, sampled every DT")
    sim.add_argument("system", nargs="?", help="a repository system (or give --model and --equations)")
    model_options(sim)
    sim.add_argument("--source", choices=("hand", "mujoco", "pinocchio"), required=True)
    sim.add_argument("--q0", type=_vector, required=True, help="comma-separated, notes' coordinates (rad)")
    sim.add_argument("--v0", type=_vector, required=True, help="comma-separated (rad/s)")
    sim.add_argument("--tau", type=_vector, help="comma-separated constant input (N m); default zero")
    sim.add_argument("--t-end", type=_positive_float, required=True)
    sim.add_argument("--dt-out", type=_positive_float, required=True)
    sim.add_argument("--out", type=_path, required=True, help="FILE.csv or FILE.json")

    rep = command("report", help="re-render the reports from an existing results.json")
    rep.add_argument("--out", type=_path, default=Path("reports"))

    bench = command("bench", help="run time against error: work-precision sweep and the fast-harness ratios")
    bench.add_argument("systems", nargs="*", metavar="SYSTEM")
    bench.add_argument("--quick", action="store_true", help="2 systems, small plan, 1 repeat (about 10 s)")
    bench.add_argument("--out", type=_path, default=Path("reports"), help="folder for bench.json (default: reports)")
    bench.add_argument("--repeats", type=_positive_int, default=None, help="timing repeats (default 3; --quick 1)")
    bench.add_argument(
        "--run-time",
        action="store_true",
        help="only time `lagrange-xval run`: fresh machine, cold and warm cache (--repeats, default 5); writes nothing",
    )
    cache_options(bench)

    stress = command("stress", help="numerical stability: long horizons, stable timesteps, conditioning")
    stress.add_argument("systems", nargs="*", metavar="SYSTEM")
    stress.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="parameter override applied to every system (e.g. scale/mass=2, joint/psi/damping=1)",
    )
    stress.add_argument("--quick", action="store_true", help="100 s horizons and fewer sweep points (~30 s)")
    stress.add_argument("--out", type=_path, default=Path("reports"), help="folder for stress.json")
    cache_options(stress)

    replay = command("replay", help="a rerun recording of a system's trajectories")
    replay.add_argument("system")
    replay.add_argument("--save", type=_path, metavar="FILE", help="write an .rrd file instead of spawning a viewer")
    replay.add_argument(
        "--results",
        type=_path,
        default=Path("reports") / "results.json",
        metavar="FILE",
        help="the results `run` wrote (default: reports/results.json); nothing is recomputed",
    )
    return p


def cmd_list(args: argparse.Namespace) -> int:

    broken = []
    for name in system_names():
        try:
            s = load(name)
        except HarnessError as exc:  # one broken equations module does not hide the others
            broken.append(str(exc))
            continue
        print(f"{s.name}: {s.nv} dof, coordinates ({', '.join(s.coordinates)}); uses {', '.join(sorted(s.uses))}")
        for v in s.variants:
            print(f"    {v.kind:16s} {v.name}  [{', '.join(v.notes_equations)}]")
    if broken:
        raise HarnessError(
            broken[0] + (f" ({len(broken) - 1} more systems cannot be loaded)" if len(broken) > 1 else "")
        )
    return 0


def _numbers(path: Path, i: int, name: str, x: Any, system: Any) -> list[float]:
    """`x` as a list of nv floats; JSON types are checked, never coerced ("0.5" and true are not numbers)."""
    if not isinstance(x, list) or len(x) != system.nv:
        raise HarnessError(
            f"{path}: state {i}: {name} must be a list of {system.nv} numbers "
            f"({', '.join(system.coordinates)}); got {x!r:.80}."
        )
    out = []
    for value in x:
        if type(value) not in (int, float):  # bool is a subclass of int: refused by the exact type
            raise HarnessError(
                f"{path}: state {i}: {name} must be numbers; got {value!r:.40} ({type(value).__name__})."
            )
        try:
            out.append(float(value))
        except OverflowError:
            raise HarnessError(f"{path}: state {i}: {name} has an integer too large to be a number.") from None
    return out


def _states_from_file(system: Any, path: Path) -> Any:

    items = parse_json(regular_file(path, "states file", max_bytes=MAX_STATES_FILE_BYTES), path)
    if not isinstance(items, list) or not items:
        raise HarnessError(f'{path} must hold a non-empty JSON list of {{"q": [...], "v": [...], "tau": [...]}}.')
    qs, vs, taus = [], [], []
    for i, item in enumerate(items):
        if not isinstance(item, dict) or "q" not in item or "v" not in item:
            raise HarnessError(f'{path}: state {i} must be an object with "q" and "v" (and optional "tau").')
        unknown = set(item) - {"q", "v", "tau"}
        if unknown:
            raise HarnessError(f'{path}: state {i} has unknown keys {sorted(unknown)}; valid: "q", "v", "tau".')
        qs.append(_numbers(path, i, "q", item["q"], system))
        vs.append(_numbers(path, i, "v", item["v"], system))
        taus.append(_numbers(path, i, "tau", item.get("tau", [0.0] * system.nv), system))
    return validate_states(system, qs, vs, taus)


def _require_same_model(system: Any, sources: dict[str, Any]) -> None:
    """Dynamics are compared only between sources that describe the same model."""

    bad = modelsync.check(system, sources["pinocchio"])["mismatches"]
    if bad:
        keys = ", ".join(r["key"] for r in bad[:4]) + (f" and {len(bad) - 4} more" if len(bad) > 4 else "")
        raise HarnessError(
            f"{system.name}: the sources describe different models ({keys}): {bad[0]['why']}; "
            f"{bad[0]['key']} is {bad[0]['actual']}, expected {bad[0]['expected']}."
        )


def cmd_check(args: argparse.Namespace) -> int:
    import numpy as np

    system = _one_system(args)
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

    suffix = args.out.suffix.lower()
    if suffix not in (".csv", ".json"):
        raise HarnessError(f"--out must end in .csv or .json; got '{args.out.name}'.")
    if args.out.is_dir():
        raise HarnessError(f"--out {args.out} is a directory; give a file name ending in {suffix}.")
    samples = args.t_end / args.dt_out
    if samples > MAX_SAMPLES:
        raise HarnessError(
            f"--t-end {args.t_end:g} / --dt-out {args.dt_out:g} gives {samples:.3g} samples; at most {MAX_SAMPLES}."
        )
    system = _one_system(args)
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
    bad = np.argwhere(~np.isfinite(table))
    if len(bad):  # never data: a non-finite sample is the error, with where it happened
        k, j = (int(x) for x in bad[0])
        raise HarnessError(
            f"{args.source} ({traj.method}): {cols[j]} is {table[k, j]} at t = {table[k, 0]:g} s; nothing written."
        )
    if suffix == ".csv":
        lines = [",".join(cols)] + [",".join(repr(float(x)) for x in row) for row in table]
        atomic_write(args.out, "\n".join(lines) + "\n")
    else:
        atomic_write(
            args.out,
            dumps(
                {"system": system.name, "source": args.source, "method": traj.method, "columns": cols, "rows": table}
            ),
        )
    print(f"wrote {args.out} ({len(table)} samples, {traj.method})")
    return 0


@contextlib.contextmanager
def use_cache(args: argparse.Namespace) -> Iterator[None]:
    """Points the reference and chaos caches at --cache-dir (default OUT/.cache) or turns them off,
    through the environment so that pool workers see the same setting; restored afterwards."""

    before = os.environ.get(CACHE_ENV)
    os.environ[CACHE_ENV] = "" if args.no_cache else str((args.cache_dir or args.out / ".cache").absolute())
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(CACHE_ENV, None)
        else:
            os.environ[CACHE_ENV] = before


def cmd_run(args: argparse.Namespace) -> int:

    check_out(args.out)  # before hours of work, not after
    rendered: dict[str, Any] = {}
    with use_cache(args), reporter() as progress:
        results = run(
            args.systems or None,
            n_states=args.states,
            seed=args.seed,
            progress=progress,
            n_probes=args.probes,
            files=_user_files(args),
            after=functools.partial(render_system, replay=not args.no_replay),  # in the workers, overlapped
            rendered=rendered,
        )
    write_all(results, args.out, replay=not args.no_replay, rendered=rendered)
    verdict = "all systems pass" if results["passed"] else "some systems FAIL"
    print(f"{verdict}; reports in {args.out}/ (report.html, report.md, results.json)")
    return 0 if results["passed"] else 1


def _one_system(args: argparse.Namespace) -> Any:
    """The SYSTEM named, or the one given by --model and --equations (exactly one of the two)."""

    files = _user_files(args)
    if files and args.system:
        raise HarnessError("give a SYSTEM name or --model and --equations, not both.")
    if files:
        return System.from_files(*files[0])
    if not args.system:
        raise HarnessError("name a SYSTEM (see `lagrange-xval list`) or give --model PATH --equations PATH.")
    return load(args.system)


def _user_files(args: argparse.Namespace) -> list[tuple[Path, Path]] | None:
    """--model and --equations (both or neither), and the pairs of a --systems folder."""

    model, equations = getattr(args, "model", None), getattr(args, "equations", None)
    if (model is None) != (equations is None):
        raise HarnessError("--model and --equations go together: give your MJCF and your equations module.")
    files = [(model, equations)] if model is not None and equations is not None else []
    folder = getattr(args, "systems_dir", None)
    if folder is not None:
        files += pairs_in(folder)
    return files or None


def cmd_report(args: argparse.Namespace) -> int:

    results = load_results(args.out / "results.json")
    try:
        write_reports(results, args.out)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
        raise HarnessError(
            f"{args.out / 'results.json'} lacks what the report needs ({type(exc).__name__}: {_one_line(exc)}); "
            "rerun `lagrange-xval run`."
        ) from None
    print(f"re-rendered {args.out}/report.md and {args.out}/report.html")
    return 0


def cmd_replay(args: argparse.Namespace) -> int:

    return replay_command(args.system, args.save, args.results)


def cmd_bench(args: argparse.Namespace) -> int:

    with use_cache(args):
        return bench_command(args)


def cmd_stress(args: argparse.Namespace) -> int:

    with use_cache(args):
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


def _handlers(owner: int) -> tuple[Any, Any]:
    """SIGINT and SIGTERM handlers for the process `owner`. A pool worker forked before its initializer
    ran inherits them: there SIGINT is ignored (the parent reports it) and SIGTERM kills silently."""

    def interrupt(signum: int, frame: Any) -> None:
        if os.getpid() == owner:
            raise KeyboardInterrupt

    def terminate(signum: int, frame: Any) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_DFL if os.getpid() != owner else signal.SIG_IGN)
        if os.getpid() != owner:
            os.kill(os.getpid(), signal.SIGTERM)
            return
        raise Terminated  # SIGTERM ignored from here: a second one must not interrupt the clean-up

    return interrupt, terminate


@contextlib.contextmanager
def _stop_on_signals() -> Iterator[None]:
    """Ctrl-C and SIGTERM stop a command the same way (workers terminated, nothing half-written)."""
    interrupt, terminate = _handlers(os.getpid())
    try:
        previous = {signal.SIGINT: signal.signal(signal.SIGINT, interrupt)}
        previous[signal.SIGTERM] = signal.signal(signal.SIGTERM, terminate)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


@contextlib.contextmanager
def _only_own_output() -> Iterator[None]:
    """Nothing but the command's own output on stdout: while it runs, file descriptor 1 points at
    stderr (C++ libraries log there: heyoka warns on stdout when HOME is unset) and `sys.stdout`
    writes to the real stdout through a descriptor of its own."""
    stream = sys.stdout
    fd = -1
    if stream is sys.__stdout__ and stream is not None:
        with contextlib.suppress(OSError, ValueError):  # a closed stdout stays as it is
            fd = stream.fileno()
    if stream is None or fd < 0:  # no stdout, or a test's capture in its place
        yield
        return
    stream.flush()
    saved = os.dup(fd)
    buffering = 1 if os.isatty(saved) else -1  # line by line to a terminal, as Python's own stdout
    own = os.fdopen(os.dup(saved), "w", buffering=buffering, encoding=stream.encoding, errors=stream.errors)
    os.dup2(2, fd)  # stderr
    sys.stdout = own
    try:
        yield
        own.flush()
    finally:
        sys.stdout = stream
        with contextlib.suppress(OSError):  # a broken pipe was reported already
            own.close()
        os.dup2(saved, fd)
        os.close(saved)


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text[:300] + ("..." if len(text) > 300 else "")


def _error(message: str) -> int:
    print(f"lagrange-xval: error: {message}", file=sys.stderr)
    return 2


def main(argv: list[str] | None = None) -> int:
    """The command's exit status. The one error boundary: every failure is one line on stderr
    (`--debug` adds the traceback) and status 2; Ctrl-C is 130, SIGTERM 143."""
    args = _parser().parse_args(argv)
    try:
        with _stop_on_signals(), _only_own_output():
            return COMMANDS[args.command](args)
    except HarnessError as exc:
        print(f"lagrange-xval: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except Terminated:
        print("lagrange-xval: terminated; nothing half-written (previous reports are intact).", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("lagrange-xval: interrupted; nothing half-written (previous reports are intact).", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return _error("the output was closed before it was all written (broken pipe).")
    except OSError as exc:
        if args.debug:
            import traceback

            traceback.print_exc()
        where = f" ({exc.filename})" if exc.filename else ""
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            return _error(f"no space left on device{where}; previous reports are intact.")
        return _error(f"{exc.strerror or _one_line(exc)}{where}.")
    except Exception as exc:  # noqa: BLE001 - the boundary: one line, never a traceback unless asked
        if args.debug:
            import traceback

            traceback.print_exc()
        hint = "" if args.debug else "; rerun with --debug for the traceback"
        return _error(f"unexpected {type(exc).__name__}: {_one_line(exc)}{hint}.")

"""The command line's arguments: every subcommand, its options, and the checks of their values
(each bad value one line naming what is valid).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

DEFAULT_STATES = 1000


DEFAULT_SEED = 0


MAX_STATES = 100_000  # random states per system: 1e5 evaluate in about a minute; more is a typo


MAX_STATES_FILE_BYTES = 64 * 2**20  # a states file is read whole; 64 MiB holds ~500 000 states


MAX_SEED = 2**63 - 1


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if value < 1 or value > MAX_STATES:
        raise argparse.ArgumentTypeError(f"must be from 1 to {MAX_STATES}, got {value}")
    return value


def probe_count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if not 0 <= value <= 100:
        raise argparse.ArgumentTypeError(f"must be from 0 to 100, got {value}")
    return value


def seed_arg(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be from 0 to 2**63 - 1, got {value}")
    return value


def path_arg(text: str) -> Path:
    """A path argument; the empty string is refused (Path('') would silently mean '.')."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must not be empty (use . for the current folder)")
    return Path(text)


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a positive finite number, got {text}")
    return value


def vector_arg(text: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a comma-separated list of numbers") from None


def build_parser() -> argparse.ArgumentParser:
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
        parser.add_argument("--model", type=path_arg, metavar="PATH", help="your own MJCF (with --equations)")
        parser.add_argument(
            "--equations", type=path_arg, metavar="PATH", help="your own equations module, .py (with --model)"
        )

    def cache_options(parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "--cache-dir", type=path_arg, metavar="DIR", help="reference and chaos cache (default: OUT/.cache)"
        )
        parser.add_argument("--no-cache", action="store_true", help="compute everything, read and write no cache")

    command("list", help="the systems, their coordinates, degrees of freedom and printed forms")

    run = command("run", help="validate every system (or those named) and write the reports")
    run.add_argument("systems", nargs="*", metavar="SYSTEM")
    run.add_argument("--states", type=positive_int, default=DEFAULT_STATES, help="random states per system")
    run.add_argument("--seed", type=seed_arg, default=DEFAULT_SEED)
    run.add_argument("--out", type=path_arg, default=Path("reports"), help="report folder (default: reports)")
    run.add_argument("--no-replay", action="store_true", help="skip the rerun .rrd recordings")
    run.add_argument(
        "--probes",
        type=probe_count,
        default=4,
        help="probe parameter sets per derivation, every parameter moved (default 4; 0: the model's only)",
    )
    model_options(run)
    run.add_argument(
        "--systems",
        dest="systems_dir",
        type=path_arg,
        metavar="DIR",
        help="a folder of your own systems: each <name>.xml with its <name>.py",
    )
    cache_options(run)

    check = command("check", help="pointwise comparison of the three sources")
    check.add_argument("system", nargs="?", help="a repository system (or give --model and --equations)")
    model_options(check)
    check.add_argument(
        "--states",
        type=path_arg,
        metavar="FILE",
        help='JSON list of {"q": [...], "v": [...], "tau": [...]} in the notes\' coordinates',
    )
    check.add_argument("--n", type=positive_int, default=DEFAULT_STATES, help="random states when no FILE")
    check.add_argument("--seed", type=seed_arg, default=DEFAULT_SEED)
    check.add_argument("--json", action="store_true", help="print one JSON object")

    sim = command("simulate", help="one trajectory of one source, sampled every DT")
    sim.add_argument("system", nargs="?", help="a repository system (or give --model and --equations)")
    model_options(sim)
    sim.add_argument("--source", choices=("hand", "mujoco", "pinocchio"), required=True)
    sim.add_argument("--q0", type=vector_arg, required=True, help="comma-separated, notes' coordinates (rad)")
    sim.add_argument("--v0", type=vector_arg, required=True, help="comma-separated (rad/s)")
    sim.add_argument("--tau", type=vector_arg, help="comma-separated constant input (N m); default zero")
    sim.add_argument("--t-end", type=positive_float, required=True)
    sim.add_argument("--dt-out", type=positive_float, required=True)
    sim.add_argument(
        "--out",
        type=path_arg,
        required=True,
        help="FILE.csv (a commented # header, then one row per sample) or FILE.json; both record the request and units",
    )

    rep = command("report", help="re-render the reports from an existing results.json")
    rep.add_argument("--out", type=path_arg, default=Path("reports"))

    bench = command("bench", help="run time against error: work-precision sweep and the fast-harness ratios")
    bench.add_argument("systems", nargs="*", metavar="SYSTEM")
    bench.add_argument("--quick", action="store_true", help="2 systems, small plan, 1 repeat (about 10 s)")
    bench.add_argument("--out", type=path_arg, default=Path("reports"), help="folder for bench.json (default: reports)")
    bench.add_argument("--repeats", type=positive_int, default=None, help="timing repeats (default 3; --quick 1)")
    bench.add_argument(
        "--run-time",
        action="store_true",
        help="only time `lagrange-xval run`: fresh machine, cold and warm cache (--repeats, default 5); writes nothing",
    )
    model_options(bench)
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
    stress.add_argument("--out", type=path_arg, default=Path("reports"), help="folder for stress.json")
    model_options(stress)
    cache_options(stress)

    new = command("new", help="write a starting equations module for your own model")
    new.add_argument("name", help="the module's name (NAME.py)")
    new.add_argument("--model", type=path_arg, required=True, metavar="PATH", help="your MJCF model")
    new.add_argument(
        "--dir", type=path_arg, default=None, metavar="DIR", help="where to write NAME.py (default: the model's folder)"
    )
    replay = command("replay", help="a rerun recording of a system's trajectories")
    replay.add_argument("system")
    replay.add_argument("--save", type=path_arg, metavar="FILE", help="write an .rrd file instead of spawning a viewer")
    replay.add_argument(
        "--results",
        type=path_arg,
        default=Path("reports") / "results.json",
        metavar="FILE",
        help="the results `run` wrote (default: reports/results.json); nothing is recomputed",
    )
    return p


def one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text[:300] + ("..." if len(text) > 300 else "")

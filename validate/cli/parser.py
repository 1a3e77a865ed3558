"""The command line's arguments: every subcommand, its options, and the checks of their values
(each bad value one line naming what is valid).

One name per meaning on every command: `--states N` is always a count of random states, `--seed S`
always their seed, `--out` always where the command writes, `--model`/`--equations` always a
person's own files. Every option's help gives its unit or its valid values.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..core.errors import HarnessError
from ..core.guard import DEFAULT_TIME_LIMIT
from ..core.parallel import parse_executor
from ..results import harness_version
from ..systems import system_names
from .values import MAX_STATES, path_arg, positive_float, positive_int, probe_count, seed_arg, state_count

DESCRIPTION = (
    "Checks hand-derived Lagrangian equations of motion against MuJoCo, Pinocchio and Drake. For each system "
    "(a model file, MJCF or URDF, paired with an equations module) it compares the mass matrix, bias "
    "forces, energies, body poses and trajectories of the five sources (the derivation, MuJoCo, Pinocchio, "
    "Drake where installed, and the model's own equations derived symbolically), says which term of the "
    "derivation disagrees and where, and writes a report."
)
EPILOG = (
    "Start with `lagrange-xval run` (every system; reports in reports/) or `lagrange-xval list`. "
    "`lagrange-xval COMMAND -h` describes a command's options."
)

DEFAULT_STATES = 1000


QUICK_DURATION = {  # as the README's command table says them (tests/unit/cli/test_parser.py checks both)
    "bench --quick": "about 1.5 min on 2 cores",
    "bench --chains --quick": "under a minute",
}


HELP_EXAMPLES = (  # every command line the help shows, run as written by tests/unit/cli/test_parser.py
    "lagrange-xval run",
    "lagrange-xval list",
    "lagrange-xval stress --set scale/mass=2",
    "lagrange-xval stress gimbal --set joint/psi/damping=1",
)


DEFAULT_SEED = 0


MAX_STATES_FILE_BYTES = 64 * 2**20  # a states file is read whole; 64 MiB holds ~500 000 states


def executor_arg(text: str) -> str:
    """`--executor local|dask[:ADDRESS]`, checked here so a typo fails before any work."""
    try:
        parse_executor(text)
    except HarnessError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def vector_arg(text: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a comma-separated list of numbers") from None


def joints_arg(text: str) -> tuple[str, ...]:
    """`--lock a,b`: joint names, each once; an empty name (a stray comma) is refused."""
    names = tuple(x.strip() for x in text.split(","))
    if not all(names):
        raise argparse.ArgumentTypeError(f"'{text}' is not a comma-separated list of joint names")
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise argparse.ArgumentTypeError(f"joint '{twice[0]}' is named twice")
    return names


def system_help(what: str) -> str:
    """Help for a SYSTEM argument, naming the valid names (discovered, never listed by hand)."""
    try:
        names = ", ".join(system_names()) or "(none)"
    except Exception:  # noqa: BLE001 - a broken equations package must not take --help down with it
        names = "see `lagrange-xval list`"
    return f"{what}; one of: {names}"


class Deprecated(argparse.Action):
    """An old spelling that still works, with one warning line on stderr naming the new one."""

    def __init__(self, option_strings: Sequence[str], dest: str, *, instead: str, **kwargs: Any) -> None:
        self.instead = instead
        super().__init__(option_strings, dest, **kwargs)

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        print(f"lagrange-xval: warning: {option_string} is deprecated; use {self.instead}.", file=sys.stderr)
        setattr(namespace, self.dest, values)


def _model_options(parser: argparse.ArgumentParser) -> None:
    """`--model`, `--equations` (a person's own files) and `--lock`."""
    parser.add_argument(
        "--model", type=path_arg, metavar="PATH", help="your own model, MJCF .xml or URDF .urdf (with --equations)"
    )
    parser.add_argument(
        "--equations", type=path_arg, metavar="PATH", help="your own equations, .py or .toml (with --model)"
    )
    _lock_option(parser)


def _lock_option(parser: argparse.ArgumentParser) -> None:
    """`--lock JOINTS`: URDF joints made fixed before the model is read."""
    parser.add_argument(
        "--lock",
        type=joints_arg,
        default=(),
        metavar="JOINTS",
        help="comma-separated joints of the --model URDF to make fixed at zero before it is read (a gripper's "
        "fingers), a step the report lists",
    )
    parser.add_argument(
        "--balance-inertia",
        action="store_true",
        help="give every reader of the --model URDF the repaired inertia of each link whose inertia is invalid "
        "(MuJoCo's balanceinertia; without it only MuJoCo, which refuses the file as written, is given it)",
    )


def _probes_option(parser: argparse.ArgumentParser) -> None:
    """`--probes K`: probe parameter sets per derivation."""
    parser.add_argument(
        "--probes",
        type=probe_count,
        default=4,
        metavar="K",
        help="probe parameter sets per derivation, every parameter moved, 0 to 100 (default 4; 0: the model's only)",
    )


def _time_limit_option(parser: argparse.ArgumentParser) -> None:
    """`--time-limit SECONDS`: how long each call into an equations module may take."""
    parser.add_argument(
        "--time-limit",
        type=positive_float,
        default=DEFAULT_TIME_LIMIT,
        metavar="SECONDS",
        help=f"how long each call into an equations module (and its import) may take, s (default "
        f"{DEFAULT_TIME_LIMIT:g}); a call that does not return in time is that system's finding",
    )


def _cache_options(parser: argparse.ArgumentParser) -> None:
    """`--cache-dir DIR` and `--no-cache`."""
    parser.add_argument(
        "--cache-dir", type=path_arg, metavar="DIR", help="reference and chaos cache (default: OUT/.cache)"
    )
    parser.add_argument("--no-cache", action="store_true", help="compute everything, read and write no cache")


def _executor_option(parser: argparse.ArgumentParser, what: str, here: str = "a process pool on every core") -> None:
    """`--executor local|dask[:ADDRESS]`: where `what` run (`here`: what local means for this command)."""
    parser.add_argument(
        "--executor",
        type=executor_arg,
        default="local",
        metavar="local|dask[:ADDRESS]",
        help=f"where {what} run: local (default; {here}), "
        "dask (a dask.distributed LocalCluster, one worker per core) or dask:ADDRESS (a running dask scheduler, "
        "e.g. dask:tcp://HOST:8786; needs the [dask] extra)",
    )


def _seed_option(parser: argparse.ArgumentParser, what: str) -> None:
    """`--seed S`: the seed of the random `what`."""
    parser.add_argument(
        "--seed",
        type=seed_arg,
        default=DEFAULT_SEED,
        metavar="S",
        help=f"seed of the random {what}, 0 to 2**63 - 1 (default {DEFAULT_SEED}); the same seed, the same draws",
    )


def _states_option(parser: argparse._ActionsContainer, what: str) -> argparse.Action:
    """`--states N`: a count of random states, on a parser or a mutually exclusive group."""
    return parser.add_argument(
        "--states",
        type=state_count,
        default=DEFAULT_STATES,
        metavar="N",
        help=f"number of seeded random states {what}, 1 to {MAX_STATES} (default {DEFAULT_STATES})",
    )


def _systems_argument(parser: argparse.ArgumentParser, what: str) -> None:
    """The positional SYSTEM names, any number."""
    parser.add_argument("systems", nargs="*", metavar="SYSTEM", help=system_help(what))


def _one_system_argument(parser: argparse.ArgumentParser) -> None:
    """The positional SYSTEM, one or none (then --model and --equations)."""
    parser.add_argument(
        "system",
        nargs="?",
        metavar="SYSTEM",
        help=system_help("a repository system (or give --model and --equations)"),
    )


def _list_arguments(listing: argparse.ArgumentParser) -> None:
    """`list`: the folder of systems to list."""
    _systems_dir_option(listing, "list the systems of this folder of your own", "instead of the repository's")


def _systems_dir_option(parser: argparse.ArgumentParser, what: str, then: str) -> None:
    """`--systems DIR`: a folder of a person's systems."""
    parser.add_argument(
        "--systems",
        dest="systems_dir",
        type=path_arg,
        metavar="DIR",
        help=f"{what} (each <name>.xml or <name>.urdf with its <name>.py) {then}",
    )


def _run_arguments(run: argparse.ArgumentParser) -> None:
    """`run`: the systems, states, seed, reports folder, probes, a person's own systems, cache, executor."""
    _systems_argument(run, "the systems to validate (default: every one)")
    _states_option(run, "per system")
    _seed_option(run, "states and probe parameter sets")
    run.add_argument(
        "--out",
        type=path_arg,
        default=Path("reports"),
        metavar="DIR",
        help="reports folder: report.html, report.md, results.json, <system>.rrd (default: reports)",
    )
    run.add_argument("--no-replay", action="store_true", help="skip the rerun .rrd recordings")
    _probes_option(run)
    _model_options(run)
    run.add_argument(
        "--systems",
        dest="systems_dir",
        type=path_arg,
        metavar="DIR",
        help="a folder of your own systems: each <name>.xml or <name>.urdf with its <name>.py or <name>.toml (a "
        "file without its partner is named and skipped)",
    )
    _time_limit_option(run)
    _cache_options(run)
    _executor_option(run, "the systems")
    run.add_argument("--verbose", action="store_true", help="print each system's stages and their wall seconds, s")
    run.add_argument(
        "--drake-run",
        action="store_true",
        help="also Drake's own free run (information only, not judged; with its estimate ~5 s a double pendulum)",
    )


def _check_states_options(check: argparse.ArgumentParser) -> None:
    """`check`'s states to compare at: random (`--states N`, old spelling `--n N`) or a file's."""
    given = check.add_mutually_exclusive_group()
    _states_option(given, "to compare at")
    given.add_argument(
        "--states-file",
        type=path_arg,
        metavar="FILE",
        help='compare at the states of a JSON list of {"q": [...], "v": [...], "tau": [...]} in the '
        "notes' coordinates (rad, rad/s, N m; m, m/s, N for a slide) instead of random ones",
    )
    given.add_argument(
        "--n",
        dest="states",
        type=state_count,
        metavar="N",
        action=Deprecated,
        instead="--states N",
        help="deprecated spelling of --states N",
    )


def _check_arguments(check: argparse.ArgumentParser) -> None:
    """`check`: one system, its states, seed, output as JSON, probes or pointwise only, where to keep explanations."""
    _one_system_argument(check)
    _model_options(check)
    _check_states_options(check)
    _seed_option(check, "states (not used with --states-file)")
    check.add_argument("--json", action="store_true", help="print one JSON object (schema in the README)")
    _probes_option(check)
    check.add_argument(
        "--pointwise-only",
        action="store_true",
        help="only compare the sources at the states, at the model's own numbers: no probes, no term verdict "
        "(a mistake the model's values hide passes)",
    )
    check.add_argument(
        "--constraints",
        action="store_true",
        help="also run the model as published (its ranges, contacts, equality constraints and dry friction on) "
        "and compare it with the equations until the first constraint acts: the verdict says when and which",
    )
    check.add_argument(
        "--cache-dir",
        type=path_arg,
        metavar="DIR",
        help="keep the explanations of wrong entries in DIR (default: none; check writes nothing)",
    )
    check.add_argument(
        "--reproduce",
        type=path_arg,
        metavar="DIR",
        help="write a standalone reproducer per disagreeing pair of sources and quantity into DIR "
        "(DIR/<system>_<quantity>_<a>_vs_<b>.py: the libraries' own calls; exit 1 where the disagreement shows)",
    )
    _time_limit_option(check)


def _watch_arguments(watch: argparse.ArgumentParser) -> None:
    """`watch`: `check`'s system and verdict options, a folder of systems instead, and `--once`."""
    _one_system_argument(watch)
    _model_options(watch)
    _systems_dir_option(watch, "watch every system of this folder", "a save re-judges the system whose file it is")
    _states_option(watch, "to compare at")
    _seed_option(watch, "states and probe parameter sets")
    _probes_option(watch)
    _time_limit_option(watch)
    watch.add_argument(
        "--once", action="store_true", help="judge once and exit with check's status (0 pass, 1 fail, 2 error)"
    )


def _simulate_arguments(sim: argparse.ArgumentParser) -> None:
    """`simulate`: one system, the source, the initial state and input, the duration and sampling, the file."""
    _one_system_argument(sim)
    _model_options(sim)
    sim.add_argument(
        "--source",
        choices=("hand", "mujoco", "pinocchio"),
        required=True,
        help="hand: your equations (scipy odeint); mujoco: MuJoCo RK4 at the model's timestep, made to "
        "divide --dt-out if it does not (the output says so); "
        "pinocchio: ABA (scipy odeint)",
    )
    for name, what in (
        ("--q0", "initial coordinates, comma-separated, notes' coordinates (rad; m for a slide)"),
        ("--v0", "initial velocities, comma-separated (rad/s; m/s for a slide)"),
    ):
        sim.add_argument(name, type=vector_arg, required=True, metavar="A,B,...", help=what)
    sim.add_argument(
        "--tau",
        type=vector_arg,
        metavar="A,B,...",
        help="constant generalized input, comma-separated (N m; N for a slide); default zero",
    )
    sim.add_argument(
        "--t-end", type=positive_float, required=True, metavar="T", help="duration (s), a whole multiple of --dt-out"
    )
    sim.add_argument("--dt-out", type=positive_float, required=True, metavar="DT", help="output sampling interval (s)")
    _time_limit_option(sim)
    sim.add_argument(
        "--out",
        type=path_arg,
        required=True,
        metavar="FILE",
        help="FILE.csv (a commented # header, then one row per sample) or FILE.json; both record the request and units",
    )


def _report_arguments(rep: argparse.ArgumentParser) -> None:
    """`report`: the reports folder to re-render."""
    rep.add_argument(
        "--out",
        type=path_arg,
        default=Path("reports"),
        metavar="DIR",
        help="the reports folder: reads its results.json, rewrites report.md, report.html and img/ (default: reports)",
    )


def _bench_study_options(bench: argparse.ArgumentParser) -> None:
    """`bench`'s studies run instead of the default sweep: --chains, --float32, --run-time."""
    bench.add_argument(
        "--chains",
        action="store_true",
        help="only the scaling study: generated n-link chains, n = 2..30, every source's cost and agreement "
        f"against n; writes OUT/chains.json (--quick: {QUICK_DURATION['bench --chains --quick']})",
    )
    bench.add_argument(
        "--float32",
        action="store_true",
        help="only MuJoCo Warp's float32 error (M, bias, qacc, a 1 s run) beside C MuJoCo's float64 error and the "
        "expected rounding, per system, chain (n = 2..30) and arm; written into OUT/bench.json under float32 "
        "(needs the extra: pip install 'lagrange-xval[warp]')",
    )
    bench.add_argument(
        "--run-time",
        action="store_true",
        help="only time `lagrange-xval run`: fresh machine, cold and warm cache (--repeats, default 5); writes nothing",
    )


def _bench_arguments(bench: argparse.ArgumentParser) -> None:
    """`bench`: the systems, quick plan, output folder, repeats, the studies, own systems, cache, executor."""
    _systems_argument(bench, "the systems to time (default: every one)")
    bench.add_argument(
        "--quick", action="store_true", help=f"2 systems, small plan, 1 repeat ({QUICK_DURATION['bench --quick']})"
    )
    bench.add_argument(
        "--out", type=path_arg, default=Path("reports"), metavar="DIR", help="folder for bench.json (default: reports)"
    )
    bench.add_argument(
        "--repeats",
        type=positive_int,
        default=None,
        metavar="N",
        help="timing repeats, the median is kept (default 3; --quick 1; --run-time 5)",
    )
    _bench_study_options(bench)
    _model_options(bench)
    _time_limit_option(bench)
    _cache_options(bench)
    _executor_option(bench, "the timed runs")


def _stress_arguments(stress: argparse.ArgumentParser) -> None:
    """`stress`: the systems, parameter overrides, quick plan, output folder, own systems, cache, executor."""
    _systems_argument(stress, "the systems to stress (default: every one)")
    stress.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="parameter override applied to every system named (default: every one), in the model's units; "
        f"repeat for several. E.g. `{HELP_EXAMPLES[2]}`, or `{HELP_EXAMPLES[3]}` (psi is a joint of the "
        "gimbal only, so name the system)",
    )
    stress.add_argument("--quick", action="store_true", help="100 s horizons and fewer sweep points (~30 s)")
    stress.add_argument(
        "--out", type=path_arg, default=Path("reports"), metavar="DIR", help="folder for stress.json (default: reports)"
    )
    _model_options(stress)
    _time_limit_option(stress)
    _cache_options(stress)
    _executor_option(stress, "the sections", "one after another in this process")


def _new_arguments(new: argparse.ArgumentParser) -> None:
    """`new`: the module's name, the model, where to write it, joints to lock."""
    new.add_argument("name", metavar="NAME", help="the module's name (NAME.py), a Python identifier")
    new.add_argument(
        "--model", type=path_arg, required=True, metavar="PATH", help="your model, MJCF .xml or URDF .urdf"
    )
    new.add_argument(
        "--dir", type=path_arg, default=None, metavar="DIR", help="where to write NAME.py (default: the model's folder)"
    )
    _lock_option(new)


def _derive_output_options(derive: argparse.ArgumentParser) -> None:
    """`derive`'s output: --force, --simplify, and plain text, --latex or --python."""
    derive.add_argument(
        "--force",
        action="store_true",
        help="derive a model however long it is predicted to take (without it, a model whose derivation is "
        "predicted to exceed the budget is refused)",
    )
    derive.add_argument(
        "--simplify",
        action="store_true",
        help="simplify every entry beyond 3 joints too (minutes on a 6-joint arm; without it, a larger model's "
        "equations are printed exact, with their common subexpressions)",
    )
    form = derive.add_mutually_exclusive_group()
    form.add_argument("--latex", action="store_true", help="print LaTeX instead of plain text")
    form.add_argument("--python", action="store_true", help="print numpy code instead of plain text")


def _derive_arguments(derive: argparse.ArgumentParser) -> None:
    """`derive`: the system or model, the equations or coordinates naming it, joints to lock, the output."""
    derive.add_argument("system", nargs="?", help="a repository system (or give --model, with or without --equations)")
    derive.add_argument("--model", type=path_arg, metavar="PATH", help="any MJCF or URDF model")
    derive.add_argument(
        "--equations",
        type=path_arg,
        metavar="PATH",
        help="an equations module: its coordinates (and JOINT_MAP) name the equations",
    )
    derive.add_argument(
        "--coordinates",
        metavar="NAMES",
        help="comma-separated names for the joints' coordinates, in the model's joint order",
    )
    _lock_option(derive)
    _time_limit_option(derive)
    _derive_output_options(derive)


def _audit_arguments(audit: argparse.ArgumentParser) -> None:
    """`audit`: the model (or two files of one robot, and their joint map), joints to lock, output as JSON."""
    audit.add_argument("model", type=path_arg, metavar="MODEL", help="an MJCF .xml or URDF .urdf (or a system name)")
    audit.add_argument("other", type=path_arg, nargs="?", metavar="MODEL_B", help="a second file of the same robot")
    _lock_option(audit)
    audit.add_argument(
        "--map",
        metavar="A=B,...",
        help="with two files: pairs of A's joint = B's joint that set or correct the map (the other joints are "
        "matched by structure: tree, kind, axis and anchor, names only a hint)",
    )
    audit.add_argument("--json", action="store_true", help="print the audit as one JSON object")


def _replay_arguments(replay: argparse.ArgumentParser) -> None:
    """`replay`: the system, a file to save instead of a viewer, the results to replay."""
    replay.add_argument("system", metavar="SYSTEM", help=system_help("a system in the results (or one of yours)"))
    replay.add_argument("--save", type=path_arg, metavar="FILE", help="write a .rrd file instead of spawning a viewer")
    replay.add_argument(
        "--results",
        type=path_arg,
        default=Path("reports") / "results.json",
        metavar="FILE",
        help="the results `run` wrote (default: reports/results.json); nothing is recomputed, and the joints "
        "`run --lock` locked are locked again as the results record them",
    )


def _survey_arguments(survey: argparse.ArgumentParser) -> None:
    """`survey`: the folder, where the table and pages go, workers or an executor, time per model, pairs."""
    survey.add_argument("folder", type=path_arg, nargs="?", metavar="DIR", help="a folder of MJCF and URDF files")
    survey.add_argument(
        "--out",
        type=path_arg,
        default=Path("reports") / "survey",
        metavar="DIR",
        help="where survey.jsonl (a JSON line per model), survey.html, survey.md and the reproducers go "
        "(default: reports/survey; written when the survey is complete)",
    )
    survey.add_argument(
        "--workers", type=positive_int, metavar="N", help="models judged at once (default: one per core)"
    )
    _executor_option(survey, "the models", "--workers processes on this machine")
    survey.add_argument(
        "--timeout",
        type=positive_float,
        default=300.0,
        metavar="SECONDS",
        help="a model's check and audit that take longer are ended, with all they started: one row, crash "
        "(default 300)",
    )
    _states_option(survey, "each model is compared at").default = 20
    survey.add_argument(
        "--pairs",
        metavar="A:B,...",
        help="files of one robot to compare with the two-file audit, besides those that give the robot the same name",
    )
    survey.add_argument("--json", action="store_true", help="print the survey as JSON lines (a line per model)")
    survey.add_argument(
        "--one",
        type=path_arg,
        metavar="FILE",
        help="judge one model file and print its row as JSON (what each model's own process runs)",
    )
    survey.add_argument(
        "--reproduce", type=path_arg, metavar="DIR", help="with --one: where that model's reproducers are written"
    )


COMMANDS: tuple[tuple[str, str, Callable[[argparse.ArgumentParser], None]], ...] = (  # in the order --help lists
    ("list", "the systems, their coordinates, degrees of freedom and printed forms", _list_arguments),
    ("run", "validate every system (or those named) and write the reports", _run_arguments),
    (
        "check",
        "the verdict on one derivation, as `run` and lagrange_xval.check give it, without trajectories; writes nothing",
        _check_arguments,
    ),
    (
        "watch",
        "check's verdict again on every save of the equations module or the model, in one warm process (Ctrl-C stops)",
        _watch_arguments,
    ),
    (
        "simulate",
        "one trajectory of one source, sampled every --dt-out seconds, written as CSV or JSON",
        _simulate_arguments,
    ),
    ("report", "re-render the reports from an existing results.json", _report_arguments),
    ("bench", "run time against error: work-precision sweep and the fast-harness ratios", _bench_arguments),
    ("stress", "numerical stability: long horizons, stable timesteps, conditioning", _stress_arguments),
    ("new", "write a starting equations module for your own model", _new_arguments),
    (
        "derive",
        "the model's own equations of motion, derived symbolically (rotation-matrix method of the notes)",
        _derive_arguments,
    ),
    (
        "audit",
        "each reader of the model judged against what its format means, misreadings named; or two files of one "
        "robot compared, their joints matched by structure (tree, kind, axis, anchor; names a hint) or --map",
        _audit_arguments,
    ),
    ("replay", "a rerun recording of a system's trajectories", _replay_arguments),
    (
        "survey",
        "every MJCF and URDF under a folder judged model-only, in parallel: one table, JSON lines, an HTML page",
        _survey_arguments,
    ),
)


def build_parser() -> argparse.ArgumentParser:
    """The command line: `--debug` and `--version`, then every command of COMMANDS with its arguments."""
    debug = argparse.ArgumentParser(add_help=False)
    debug.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help="print the traceback of an error"
    )
    p = argparse.ArgumentParser(prog="lagrange-xval", description=DESCRIPTION, epilog=EPILOG, parents=[debug])
    p.add_argument(
        "--version",
        action="version",
        version=f"%(prog)s {harness_version()}",
        help="print the harness's version and exit",
    )
    p.set_defaults(debug=False)
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, help_text, add_arguments in COMMANDS:
        add_arguments(sub.add_parser(name, parents=[debug], description=help_text, help=help_text))
    return p


def one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text[:300] + ("..." if len(text) > 300 else "")

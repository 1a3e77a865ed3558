"""What each subcommand does with its parsed arguments, and what it prints.

The pipeline, the studies, the report and the replay are imported by the commands that use them:
`check` and `watch` load only what a verdict needs (scipy's integrators, matplotlib and rerun are not).
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..core.cache import CACHE_ENV, usable
from ..core.cachedir import Cache
from ..core.errors import HarnessError, console, shown
from ..core.guard import DEFAULT_TIME_LIMIT
from ..core.inputs import parse_json, regular_file
from ..core.parallel import named_executor
from ..results import load as load_results
from ..results import to_jsonable
from ..results.stages import stage_line
from ..sources import make_sources
from ..sources.base import Source
from ..systems import System, load, pairs_and_lonely, pairs_in, system_names, unpaired
from ..systems.scaffold import identifier, write_module
from ..verdict import modelsync, reproduce
from ..verdict import pointwise as compare
from ..verdict.decide import Decision, decide
from ..verdict.pointwise import States, validate_states
from . import check as checking
from . import simulate, survey
from .audit import cmd_audit
from .parser import MAX_STATES_FILE_BYTES, one_line
from .watch import cmd_watch

if TYPE_CHECKING:
    from ..model.modelview import ModelView
    from ..report import ReplayHint


def unpaired_lines() -> list[str]:
    """One line per file in models/ or equations/ without its partner: not a system, so not checked."""
    lonely = unpaired()
    return [
        *(f"{n}: not checked: models/{n}.xml has no equations/{n}.py" for n in lonely["models without equations"]),
        *(f"{n}: not checked: equations/{n}.py has no models/{n}.xml" for n in lonely["equations without model"]),
    ]


def describe(name: str) -> tuple[bool, list[str]]:
    """Whether the system loads, and the lines `list` prints for it; a module that cannot be loaded or
    read is one line saying so and why (the others are listed all the same)."""
    try:
        lines = system_lines(load(name))
    except Exception as exc:  # noqa: BLE001 - one broken equations module does not hide the others
        why = str(exc) if isinstance(exc, HarnessError) else f"equations/{name}.py: {type(exc).__name__}: {shown(exc)}"
        return False, [f"{name}: BROKEN: {' '.join(why.split())}"]
    return True, lines


def system_lines(s: System) -> list[str]:
    lines = [f"{s.name}: {s.nv} dof, coordinates ({', '.join(s.coordinates)}); uses {', '.join(sorted(s.uses))}"]
    return lines + [f"    {v.kind:16s} {v.name}  [{', '.join(v.notes_equations)}]" for v in s.variants]


def cmd_list(args: argparse.Namespace) -> int:
    """Every system (of the repository, or of a --systems folder), then the files without a partner;
    status 1 if a system cannot be loaded."""
    folder = getattr(args, "systems_dir", None)
    if folder is None:
        listed = [describe(name) for name in system_names()]
        lonely = unpaired_lines()
    else:
        listed = [describe_files(m, e) for m, e in user_files(args) or []]
        lonely = list(getattr(args, "lonely", None) or [])
    for _, lines in listed:
        print(console(lines))
    for line in lonely:
        print(console([line]))
    return 0 if all(ok for ok, _ in listed) else 1


def describe_files(model: Path, equations: Path | None) -> tuple[bool, list[str]]:
    """`describe` for a user's pair of files."""
    try:
        s = System.from_files(model, equations) if equations is not None else System.model_only(model)
    except Exception as exc:  # noqa: BLE001 - one broken module does not hide the others
        why = str(exc) if isinstance(exc, HarnessError) else f"{equations}: {type(exc).__name__}: {shown(exc)}"
        return False, [f"{model.stem}: BROKEN: {' '.join(why.split())}"]
    return True, system_lines(s)


def numbers(path: Path, i: int, name: str, x: object, system: System) -> list[float]:
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


def states_from_file(system: System, path: Path) -> States:
    """The states of a --states-file, checked (types, shapes, finite values), never coerced."""
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
        qs.append(numbers(path, i, "q", item["q"], system))
        vs.append(numbers(path, i, "v", item["v"], system))
        taus.append(numbers(path, i, "tau", item.get("tau", [0.0] * system.nv), system))
    return validate_states(system, qs, vs, taus)


def require_same_model(system: System, sources: Mapping[str, Source]) -> None:
    """Dynamics are compared only between sources that describe the same model."""

    bad = modelsync.check(system, sources["pinocchio"])["mismatches"]
    if bad:
        keys = ", ".join(r["key"] for r in bad[:4]) + (f" and {len(bad) - 4} more" if len(bad) > 4 else "")
        raise HarnessError(
            f"{system.name}: the sources describe different models ({keys}): {bad[0]['why']}; "
            f"{bad[0]['key']} is {bad[0]['actual']}, expected {bad[0]['expected']}."
        )


def cmd_check(args: argparse.Namespace) -> int:
    """The verdict `lagrange_xval.check` and `run` give (verdict/decide.py): the pointwise table, the
    terms and the verdict line last, or one JSON object; status 0 when the verdict passes.
    `--pointwise-only`: the sources compared at the states alone, no verdict on the derivation."""
    system = one_system(args)
    states = states_from_file(system, args.states_file) if args.states_file else None
    if args.pointwise_only:
        return pointwise_only(args, system, states)
    folder = usable(Path(args.cache_dir).absolute()) if args.cache_dir else ""  # a file there: one warning line
    cache = Cache.at(folder) if folder else None
    decision = decide(system, n_states=args.states, seed=args.seed, probes=args.probes, cache=cache, states=states)
    if cache is not None:
        cache.trim()
    constrained = with_constraints(decision) if args.constraints else None
    passed = decision.passed and (constrained is None or constrained["passed"])
    proofs = reproducers_of(args, reproduce.reproducers(decision))
    if args.json:
        document = {**checking.decision_json(decision), "reproducers": to_jsonable(proofs)}
        if constrained is not None:
            document = {**document, "constraints": constrained, "passed": passed}
        print(json.dumps(document, allow_nan=False))
    else:
        lines = checking.text_lines(decision)
        lines[-1:-1] = checking.reproducer_lines(proofs) if args.reproduce else []
        if constrained is not None:  # the verdict line says when and which constraint, and decides with it
            verdict = "pass" if passed else "FAIL"
            lines[-1] = f"verdict: {system.name}: {verdict}: {decision.statement}; {constrained['statement']}"
        print(console(lines, verdict=True))
    return 0 if passed else 1


def reproducers_of(args: argparse.Namespace, found: list[reproduce.Reproducer]) -> list[reproduce.Reproducer]:
    """The reproducers of `check`'s disagreements: written into --reproduce DIR (each with its path), or
    without it listed only (their texts dropped)."""
    folder = getattr(args, "reproduce", None)
    if folder is not None:
        return reproduce.write(found, folder)
    return [{k: x for k, x in r.items() if k != "script"} for r in found]  # type: ignore[misc]


def with_constraints(decision: Decision) -> dict[str, Any]:
    """`check --constraints`: the model's constrained run against the equations until the first
    constraint acts (validate/dynamics/constrained.py); needs a derivation that reads its model."""
    from ..dynamics.constrained import until_constraint
    from ..sources.base import stepped

    if decision.system.equations is None or decision.sources is None:
        raise HarnessError(
            "--constraints compares the model's constrained motion with your equations: give --equations."
        )
    return until_constraint(decision.system, stepped(decision.sources["mujoco"]))


def pointwise_only(args: argparse.Namespace, system: System, states: States | None) -> int:
    """`check --pointwise-only`: every pair of sources at the states, at the model's own numbers only
    (a mistake the model's values hide passes here; the verdict's probes find it)."""
    import numpy as np

    states = states if states is not None else compare.random_states(system, n=args.states, seed=args.seed)
    sources = make_sources(system)
    require_same_model(system, sources)
    values = compare.evaluate(sources, states)
    rows = compare.compare(values, states, scales=compare.physical_scales(system, states))
    passed = all(r["passed"] for r in rows) and bool(np.isfinite([r["max_abs"] for r in rows]).all())
    engines = {k: x for k, x in values.items() if "error" not in x}  # a derivation that raised has no numbers
    proofs = reproducers_of(args, reproduce.cases(system, engines, states))
    if args.json:
        document = {**checking.json_document(system, states, values, rows, passed), "reproducers": to_jsonable(proofs)}
        print(json.dumps(document, allow_nan=False))
    else:
        title = f"{system.name}: {len(states)} states, coordinates ({', '.join(system.coordinates)}); pointwise only"
        error = values.get("hand", {}).get("error")  # the function that raised or gave a wrong shape
        why = str(error).removeprefix("HarnessError: ")
        last = [f"pointwise: {system.name}: FAIL: your equations gave no values: {why}"] if error else []
        written = checking.reproducer_lines(proofs) if args.reproduce else []
        print(console([*checking.table_lines(rows, title), *written, *last]))
    return 0 if passed else 1


def cmd_simulate(args: argparse.Namespace) -> int:
    return simulate.cmd_simulate(args, one_system)


def cmd_survey(args: argparse.Namespace) -> int:
    return survey.cmd_survey(args, check=cmd_check, audit=cmd_audit)


def cache_of(args: argparse.Namespace) -> Cache:
    """The cache --cache-dir (default OUT/.cache) or --no-cache asks for, as the value every worker
    and stage is handed: off where it cannot be written (one warning line, `cache.usable`)."""
    if args.no_cache:
        return Cache.off()
    folder = usable((args.cache_dir or args.out / ".cache").absolute())
    return Cache.at(folder) if folder else Cache.off()


def cmd_run(args: argparse.Namespace) -> int:
    from ..report.findings import console_lines
    from ..report.render import warm as warm_report
    from ..stages.pipeline import run
    from .outputs import SystemFiles, check_cache_dir, check_out, render_system, write_all
    from .progress import reporter

    check_out(args.out)  # before hours of work, not after
    check_cache_dir(None if args.no_cache else args.cache_dir, args.out)
    rendered: dict[str, SystemFiles | None] = {}
    files = absolute_files(user_files(args))
    locked = locked_joints(args)
    cache = cache_of(args)
    with named_executor(args.executor) as executor, reporter() as progress:
        results = run(
            args.systems or None,
            n_states=args.states,
            seed=args.seed,
            progress=progress,
            executor=executor,
            n_probes=args.probes,
            files=files,
            after=functools.partial(render_system, replay=not args.no_replay, cache=cache),  # in the workers
            rendered=rendered,
            locked=locked,
            cache=cache,
            time_limit=args.time_limit,
            balance_inertia=args.balance_inertia,
            drake_run=args.drake_run,
            meanwhile=warm_report,  # the report's template compiled while the workers compute
        )
    cache.trim()
    hint = replay_hint(args.out, written=not args.no_replay)
    write_all(results, args.out, replay=not args.no_replay, rendered=rendered, hint=hint)
    if args.systems or not files:  # the repository's systems were run: say which files were not
        for line in unpaired_lines():
            print(console([line]))
    for line in getattr(args, "lonely", None) or []:
        print(console([line]))
    verdict = "all systems pass" if results["passed"] else "some systems FAIL"
    print(f"{verdict}; reports in {hint.out}/ (report.html, report.md, results.json)")
    if hint.written and any(s.get("trajectories") for s in results["systems"].values()):
        print(f"replays: {hint.viewer} {hint.out}/<system>.rrd")
    print(console(console_lines(results, f"{hint.out}/report.html")))
    if args.verbose:
        for name, s in sorted(results["systems"].items()):
            print(f"{name}: stages, wall seconds: {stage_line(s.get('stages') or {})}")
    return 0 if results["passed"] else 1


def replay_hint(out: Path, *, written: bool = True) -> ReplayHint:
    """The reports folder and the rerun viewer as a command run from here reaches them."""
    from ..replay import shown_path, viewer_command
    from ..report import ReplayHint

    return ReplayHint(out=shown_path(out), viewer=viewer_command(), written=written)


def locked_joints(args: argparse.Namespace) -> tuple[str, ...]:
    """--lock's joints (none without it); they are joints of a --model URDF, so --lock needs --model."""
    locked = tuple(getattr(args, "lock", None) or ())
    if locked and getattr(args, "model", None) is None:
        raise HarnessError("--lock takes joints of the --model URDF; give --model PATH.")
    return locked


def one_system(args: argparse.Namespace) -> System:
    """The SYSTEM named, or the one given by --model and --equations (exactly one of the two), with
    the --lock joints made fixed."""

    files = user_files(args)
    if files and args.system:
        raise HarnessError("give a SYSTEM name or --model and --equations, not both.")
    locked = locked_joints(args)
    limit = getattr(args, "time_limit", DEFAULT_TIME_LIMIT)
    if files:
        model, equations = files[0]
        balance = bool(getattr(args, "balance_inertia", False))
        if equations is None:
            return System.model_only(model, locked=locked, balance_inertia=balance)
        return System.from_files(model, equations, locked=locked, time_limit=limit, balance_inertia=balance)
    if not args.system:
        raise HarnessError("name a SYSTEM (see `lagrange-xval list`) or give --model PATH --equations PATH.")
    return load(args.system, time_limit=limit)


def user_files(args: argparse.Namespace) -> list[tuple[Path, Path | None]] | None:
    """--model and --equations (both or neither), and the pairs of a --systems folder."""

    model, equations = getattr(args, "model", None), getattr(args, "equations", None)
    if equations is not None and model is None:
        raise HarnessError("--equations needs --model: give your model (MJCF or URDF) and your equations module.")
    if model is not None and equations is None and getattr(args, "command", "") not in ("run", "check", "derive"):
        raise HarnessError(
            "--model and --equations go together here (only `run`, `check` and `derive` take a model alone): "
            "give your equations module."
        )
    files: list[tuple[Path, Path | None]] = [(model, equations)] if model is not None else []
    folder = getattr(args, "systems_dir", None)
    if folder is not None and getattr(args, "command", "") in ("run", "list"):
        pairs, lonely = pairs_and_lonely(folder)  # run and list name a file without its partner and go on
        args.lonely = [lonely_line(p) for p in lonely]
        if not pairs:
            raise HarnessError(f"{folder}: no system found: " + "; ".join(args.lonely) + ".")
        files += pairs
    elif folder is not None:
        files += pairs_in(folder)
    return files or None


def lonely_line(path: Path) -> str:
    """A file of a --systems folder without its partner: not a system, so not checked."""
    written = path.suffix in (".py", ".toml")
    partner = f"{path.stem}.xml or {path.stem}.urdf" if written else f"{path.stem}.py or {path.stem}.toml"
    return f"{path.stem}: not checked: {path} has no {partner} beside it"


def absolute_files(files: list[tuple[Path, Path | None]] | None) -> list[tuple[Path, Path | None]] | None:
    """The user's files as absolute paths, so that the results name them from any folder (`replay`,
    `report`)."""
    if files is None:
        return None
    return [(m.absolute(), None if e is None else e.absolute()) for m, e in files]


def cmd_report(args: argparse.Namespace) -> int:
    from .outputs import write_reports

    results = load_results(args.out / "results.json")
    rrd = any(p.suffix == ".rrd" for p in args.out.iterdir()) if args.out.is_dir() else False
    try:
        write_reports(results, args.out, hint=replay_hint(args.out, written=rrd))
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
        raise HarnessError(
            f"{args.out / 'results.json'} lacks what the report needs ({type(exc).__name__}: {one_line(exc)}); "
            "rerun `lagrange-xval run`."
        ) from None
    print(f"re-rendered {args.out}/report.md and {args.out}/report.html")
    return 0


def cmd_new(args: argparse.Namespace) -> int:
    locked = locked_joints(args)
    path = write_module(args.name, args.model, args.dir, locked=locked)
    lock = f" --lock {','.join(locked)}" if locked else ""
    print(
        f"wrote {path}: write the dynamics in one of the forms it lists, then "
        f"`lagrange-xval check --model {args.model} --equations {path}{lock}`"
    )
    return 0


def cmd_derive(args: argparse.Namespace) -> int:
    """Prints the model's equations of motion, derived symbolically, in the coordinates' names; the
    text is kept in the cache (`derive` kind), keyed by the model's structure, the names, the format
    and the harness's code."""
    from ..stages.derived import SIMPLIFY_MAX_DOF, derived_text

    if args.equations is not None and args.model is None:
        raise HarnessError("--equations needs --model: the model whose equations are derived.")
    if not args.system and args.model is None:
        raise HarnessError("name a SYSTEM (see `lagrange-xval list`) or give --model PATH.")
    system = one_system(args)  # --model alone: the model's joints, in order, as the coordinates
    if not system.joints:
        from ..model.scope import NOTHING_MOVES

        raise HarnessError(f"{system.name}: {NOTHING_MOVES}.")
    view, joints, coordinates, joint_map = system.view, system.joints, system.coordinates, system.joint_map
    if not args.force:
        affordable(len(joints), spatial=is_spatial(view, tuple(joints)), python=bool(args.python), joints=joints)
    if args.coordinates:
        names = tuple(x.strip() for x in args.coordinates.split(","))
        if len(names) != len(joints) or not all(n.isidentifier() for n in names) or len(set(names)) != len(names):
            raise HarnessError(
                f"--coordinates needs {len(joints)} distinct names (letters, digits, _), one per joint "
                f"({', '.join(joints)}); got {args.coordinates!r}."
            )
        coordinates = names
    elif len({identifier(c) for c in coordinates}) == len(coordinates):  # joints `arm/theta`: arm_theta
        coordinates = tuple(identifier(c) for c in coordinates)
    fmt = "latex" if args.latex else "python" if args.python else "text"
    simplify = args.simplify or len(joints) <= SIMPLIFY_MAX_DOF
    how = "simplifying each entry" if simplify else "exact, not simplified (--simplify: minutes)"
    print(f"lagrange-xval: deriving {system.name}'s {len(joints)} joints; {how}", file=sys.stderr, flush=True)
    text = derived_text(
        view, tuple(joints), tuple(coordinates), joint_map, fmt, cache=configured_cache(), simplify=simplify
    )
    print(text, end="")
    return 0


def configured_cache() -> Cache:
    """`derive`'s cache: $LAGRANGE_XVAL_CACHE (empty: none), else the user's cache folder; never a
    folder inside the installed package."""
    value = os.environ.get(CACHE_ENV)
    if value is None:
        return Cache.user()
    return Cache.at(value) if value else Cache.off()


def affordable(n: int, *, spatial: bool = False, python: bool = False, joints: Sequence[str] = ()) -> None:
    """Refuses a derivation predicted to exceed the budget (validate/studies/chains.py's cost model),
    before it starts: a symbolic derivation cannot be interrupted midway."""
    from ..studies.chains import DERIVE_BUDGET, GROWTH, MEASURED, PYTHON_FACTOR, SPATIAL_FACTOR, predicted_derive_s

    predicted = predicted_derive_s(n, spatial=spatial, python=python)
    if predicted > DERIVE_BUDGET:
        extra = (f", x{SPATIAL_FACTOR:g} for a spatial model" if spatial else "") + (
            f", x{PYTHON_FACTOR:g} for --python" if python else ""
        )
        named = f" ({', '.join(joints)})" if joints else ""
        raise HarnessError(
            f"{n} joints{named}: the symbolic derivation is predicted to take about {predicted:.3g} s (it grows "
            f"about as n^{GROWTH}; {MEASURED[0]} planar joints took {MEASURED[1]:g} s{extra}), over the "
            f"{DERIVE_BUDGET:g} s budget; --force derives it anyway, or --lock some of them."
        )


def is_spatial(view: ModelView, joints: tuple[str, ...]) -> bool:
    """Joint axes not all parallel, or a body frame rotated: what makes a derivation cost more than a
    planar chain's (validate/studies/chains.py SPATIAL_FACTOR)."""
    import numpy as np

    axes = [np.asarray(view[f"joint/{j}/axis"], dtype=float) for j in joints if f"joint/{j}/axis" in view]
    unit = [a / (np.linalg.norm(a) or 1.0) for a in axes]
    turned = any(
        not np.allclose(np.abs(np.asarray(view[k], dtype=float)), [1, 0, 0, 0]) for k in view if k.endswith("/quat")
    )
    return turned or any(abs(abs(float(u @ unit[0])) - 1.0) > 1e-9 for u in unit[1:])


def cmd_replay(args: argparse.Namespace) -> int:
    from ..replay import replay_command

    return replay_command(args.system, args.save, args.results)


def cmd_bench(args: argparse.Namespace) -> int:
    from ..stages.pipeline import reference_dir
    from ..studies.bench import bench_command

    if args.chains:
        from ..studies.chains import chains_command

        with named_executor(args.executor) as executor:  # local: in this process, each chain timed alone
            return chains_command(args, executor)
    args.files = user_files(args)  # a person's own systems, beside or instead of SYSTEM names
    args.locked = locked_joints(args)
    cache = cache_of(args)
    args.reference_cache = reference_dir(cache)  # handed to the workers as a value
    if getattr(args, "float32", False):  # MuJoCo Warp's float32 study: in this process (Warp compiles once)
        from ..studies.float32 import float32_command

        status = float32_command(args)
        cache.trim()
        return status
    with named_executor(args.executor) as executor:
        status = bench_command(args, executor=executor)
    cache.trim()
    return status


def cmd_stress(args: argparse.Namespace) -> int:
    from ..studies.stress import stress_command

    args.files = user_files(args)
    args.locked = locked_joints(args)
    with named_executor(args.executor) as executor:  # stress keeps no cache: each section computes what it needs
        return stress_command(args, executor=executor)


COMMANDS = {
    "list": cmd_list,
    "run": cmd_run,
    "check": cmd_check,
    "watch": cmd_watch,
    "simulate": cmd_simulate,
    "report": cmd_report,
    "new": cmd_new,
    "derive": cmd_derive,
    "replay": cmd_replay,
    "stress": cmd_stress,
    "bench": cmd_bench,
    "audit": cmd_audit,
    "survey": cmd_survey,
}

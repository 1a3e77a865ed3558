"""The main job, system by system: model checks -> pointwise -> printed forms -> trajectories.

Each step returns plain data; `run` assembles `results.json` and the reports render from it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from concurrent.futures import BrokenExecutor, Executor, Future
from pathlib import Path
from typing import Protocol, Required, TypedDict, TypeVar, Unpack, cast

from ..core.cachedir import Cache
from ..core.errors import HarnessError
from ..core.guard import DEFAULT_TIME_LIMIT, Stopped
from ..core.parallel import completed, executor_for
from ..core.tolerances import TOLERANCES
from ..dynamics import chaos, experiments, integrate
from ..dynamics.freeruns import (
    RUN_INTEGRATORS,
    divergence_results,
    judge_trajectories,
    reference_dir,
    trajectory_results,
)
from ..dynamics.stagecache import cached_stage, states_digest
from ..results import provenance
from ..results.schema import (
    ChaosStudy,
    Derivation,
    DerivedEquations,
    Equivalence,
    Experiments,
    ModelChecks,
    ParameterKeys,
    Pointwise,
    Provenance,
    RunResults,
    SystemResult,
    Trajectories,
)
from ..results.stages import Clock, records
from ..sources.base import stepped
from ..systems import MODELS_DIR, System, load, load_all
from ..systems.units import parameter_keys
from ..verdict import judge, reproduce
from ..verdict import probes as probing
from ..verdict.decide import Decision, decide
from ..verdict.probes import DEFAULT_PROBES
from . import equivalence
from .derived import SIMPLIFY_MAX_DOF, derived_data

READABLE_MAX_DOF = SIMPLIFY_MAX_DOF  # the report's derived equations: simplified (cached), up to this many joints

T = TypeVar("T")
R = TypeVar("R")  # what `run`'s `after` makes of a system's results (cli/outputs.render_system: its files)


class StageOptions(TypedDict, total=False):
    """`run_system`'s options for the stages after the verdict (`_run_stages`)."""

    t_end: float
    dt_out: float
    n_probes: int
    cache: Cache | None
    drake_run: bool


class RunOptions(StageOptions, total=False):
    """`guarded_run`'s options: the states the verdict is reached on, and the stages' options."""

    n_states: Required[int]
    seed: Required[int]


class Progress(Protocol):
    """`run`'s progress: told of each system's start (`stage` "start") and end ("done", with its results)."""

    def __call__(self, name: str, stage: str, result: SystemResult | None = None, /) -> object: ...


def model_only_result(
    decision: Decision, *, t_end: float, dt_out: float, cache: Cache | None = None, clock: Clock | None = None
) -> SystemResult:
    """The model alone (no derivation given, e.g. a robot's URDF), after `decide` compared the two
    engines' readings of it and MuJoCo, Pinocchio and the model's equations derived symbolically (up
    to SYMBOLIC_MAX_DOF joints) pointwise: their free runs from 0.5 rad at rest, against MuJoCo's."""
    system, sources = decision.system, decision.sources
    model, point, derivation = decision.model_checks, decision.pointwise, decision.derivation
    assert sources is not None and model is not None and point is not None  # decide reached the model
    against = "MuJoCo's" if "symbolic" in sources else "Pinocchio's ABA integrated by DOP853 at rtol 1e-12"
    why = (
        f"no derivation given: the engines' and the derived equations' free runs, against {against} (information only)"
    )
    clock = clock or Clock()
    stages: dict[str, str] = {}
    traj = (
        _stage(
            stages,
            "trajectories",
            lambda: cast(
                "Trajectories",
                divergence_results(
                    system, sources, t_end=t_end, dt_out=dt_out, why=why, aba_reference="symbolic" not in sources
                ),
            ),
            clock,
        )
        if system.nv
        else None
    )
    if not system.nv:  # every body fixed: nothing moves, nothing to integrate or derive
        stages["trajectories"] = stages["derived equations"] = "not run: no joint moves"
        derived = None
    elif system.nv <= READABLE_MAX_DOF and "symbolic" in sources:
        derived = _stage(stages, "derived equations", lambda: derived_data(system, cache=cache), clock)
    else:
        derived = None
        stages["derived equations"] = f"not run: {system.nv} joints (`lagrange-xval derive --model` prints them)"
    failed_stages = [k for k, v in stages.items() if v.startswith("failed")]
    failed = _what_failed(model, point, derivation, None, None, None, failed_stages)
    return {
        **_identity(system),
        "failed": failed,
        "statement": decision.statement,
        "parameters": {},
        "timestep": float(stepped(sources["mujoco"]).m.opt.timestep),
        "model_checks": model,
        "pointwise": point,
        "derivation": derivation,
        "variants": [],
        "derived": derived,
        "trajectories": traj,
        "experiments": None,
        "equivalence": None,
        "chaos": None,
        "stages": records(clock.seconds, stages),
        "skipped": skipped_work(system),
        "passed": model["passed"] and point["passed"] and not failed_stages,
    }


NEVER_USED = ("contact", "constraint", "limit", "frictionloss", "spring")  # no system of the notes has these
OPTIONAL = {"gravity": "gravity", "damping": "damper", "actuation": "actuation"}  # USES name -> MuJoCo flag


def skipped_work(system: System) -> list[str]:
    """What the scene does not need, and so neither MuJoCo nor the harness computes."""
    uses = system.uses
    where = "in the notes" if _from_notes(system) else "that the harness checks"
    out = [f"MuJoCo: {', '.join(NEVER_USED)} disabled (no contacts, limits, dry friction or springs {where})"]
    for use, flag in OPTIONAL.items():
        if use not in uses:
            term = "friction" if use == "damping" else use
            checked = (
                f"; printed forms' {term} term not checked" if system.equations is not None and system.variants else ""
            )
            out.append(f"MuJoCo: {flag} disabled{checked} (the scene has no {term})")
    if uses & {"damping", "actuation"}:
        why = " and ".join(w for u, w in (("damping", "friction"), ("actuation", "motors")) if u in uses)
        out.append(f"energy conservation not judged (the model has {why}, which can change the energy)")
    return out


def _stage(stages: dict[str, str], name: str, fn: Callable[[], T], clock: Clock) -> T | None:
    """Runs one stage after the verdicts, its wall seconds on `clock` (what the stage did not lap
    itself); a failure is recorded (and fails the system), never raised, so the verdicts already
    computed are always written."""
    clock.skip()
    try:
        return fn()
    except KeyboardInterrupt:
        raise
    except Exception as exc:  # noqa: BLE001 - recorded as the stage's outcome, reported as a failure
        stages[name] = f"failed: {type(exc).__name__}: {exc}".strip()
        return None
    finally:
        clock.lap(name)


def run_system(system: System, *, n_states: int, seed: int, **options: Unpack[StageOptions]) -> SystemResult:
    """`_run_stages` (below), and the model audit: the three readers of the model side by side
    (audit/audit.py; an audit that cannot be made says why under "error")."""
    from ..audit.audit import audit_of

    clock = Clock()
    result = _run_stages(system, n_states=n_states, seed=seed, clock=clock, **options)
    clock.skip()
    audit = audit_of(system, seed=seed)
    clock.lap("audit")
    stages = result.get("stages", {})
    return {**result, "audit": audit, "stages": {**stages, **records({"audit": clock.seconds["audit"]}, {})}}


def _run_stages(
    system: System,
    *,
    n_states: int,
    seed: int,
    t_end: float = integrate.DEFAULT_T_END,
    dt_out: float = integrate.DEFAULT_DT_OUT,
    n_probes: int = DEFAULT_PROBES,
    cache: Cache | None = None,
    clock: Clock | None = None,
    drake_run: bool = False,
) -> SystemResult:
    """Everything the harness knows about one system, as plain data. The verdict comes first, from
    `decide` (verdict/decide.py: the same function `check` and the API call); the stages after it
    (printed forms, trajectories, chaos, ...) add to the results and never judge the derivation
    again; they run only for a derivation that agrees (else a bounded divergence run). `cache`: where
    references, chaos summaries, derived equations and explanations are kept (None: nowhere)."""
    clock = clock or Clock()
    t_end, dt_out = integrate.output_grid(t_end, dt_out, float(system.mujoco_model().opt.timestep))
    decision = decide(system, n_states=n_states, seed=seed, probes=n_probes, cache=cache, clock=clock)
    if decision.unreadable:
        return _unreadable(decision)
    proofs = reproduce.in_folder(reproduce.reproducers(decision))  # written beside results.json by `run`
    if decision.model_only:
        result = model_only_result(decision, t_end=t_end, dt_out=dt_out, cache=cache, clock=clock)
        return {**result, "reproducers": proofs}
    probe_set = decision.probe_set
    assert probe_set is not None  # decide judged the derivation
    stages: dict[str, str] = {}
    variants = _printed_forms(decision, stages, n_probes=n_probes, seed=seed, cache=cache, clock=clock)
    same = _stage(stages, "equivalence", lambda: equivalence.check_equivalence(system, probe_set.systems()), clock)
    derived = _derived(system, stages, cache=cache, clock=clock)
    if decision.passed:
        traj, notes_experiments, cross = _agreeing_runs(
            decision, stages, t_end=t_end, dt_out=dt_out, cache=cache, clock=clock, drake_run=drake_run
        )
    else:
        traj, notes_experiments, cross = (
            _divergence(decision, stages, t_end=t_end, dt_out=dt_out, clock=clock),
            None,
            None,
        )
    result = _system_result(
        decision,
        stages,
        clock,
        same=same,
        cross=cross,
        traj=traj,
        variants=variants,
        derived=derived,
        experiments=notes_experiments,
    )
    return {**result, "reproducers": proofs}


def _printed_forms(
    decision: Decision, stages: dict[str, str], *, n_probes: int, seed: int, cache: Cache | None, clock: Clock
) -> list[Derivation]:
    """The verdict on each of the notes' printed forms (kept by content in `cache`); none for a system
    that transcribes none."""
    system, sources, states = decision.system, decision.sources, decision.states
    assert sources is not None and states is not None
    if not system.variants:  # a system with no printed form has no such stage
        return []
    return (
        _stage(
            stages,
            "printed forms",
            lambda: cached_stage(
                cache,
                system,
                sources,
                "printed forms",
                [states_digest(states), n_probes, seed],
                lambda: {
                    "variants": judge.judge_system(
                        system, states, sources, values=decision.values, n_probes=n_probes, seed=seed, cache=cache
                    )
                },
            )["variants"],
            clock,
        )
        or []
    )


def _derived(system: System, stages: dict[str, str], *, cache: Cache | None, clock: Clock) -> DerivedEquations | None:
    """The model's derived equations as a person would read them, for chains short enough to simplify."""
    if system.nv <= READABLE_MAX_DOF:
        return _stage(stages, "derived equations", lambda: derived_data(system, cache=cache), clock)
    stages["derived equations"] = (
        f"not run: {system.nv} joints; simplifying the equations of more than {READABLE_MAX_DOF} takes minutes "
        "(`lagrange-xval derive` prints them on request)"
    )
    return None


def _agreeing_runs(
    decision: Decision,
    stages: dict[str, str],
    *,
    t_end: float,
    dt_out: float,
    cache: Cache | None,
    clock: Clock,
    drake_run: bool,
) -> tuple[Trajectories | None, Experiments | None, ChaosStudy | None]:
    """A derivation that agrees: the free runs against its reference, the notes' experiments and the
    chaos mirrors (each kept by content in `cache`), the runs judged with the chaos stage's amplification."""
    system, sources = decision.system, decision.sources
    assert sources is not None
    numbers_only = getattr(system.equations, "NUMBERS_ONLY", None)
    if isinstance(numbers_only, str):  # equations that cannot be traced: no Taylor reference to run against
        for name in ("trajectories", "experiments", "chaos"):
            stages[name] = f"not run: {numbers_only}"
        return None, None, None
    traj = _stage(
        stages,
        "trajectories",
        lambda: trajectory_results(
            system, sources, t_end=t_end, dt_out=dt_out, cache=cache, clock=clock, drake_run=drake_run
        ),
        clock,
    )
    notes_experiments = _stage(
        stages,
        "experiments",
        lambda: cast(
            "Experiments",
            cached_stage(cache, system, sources, "experiments", [], lambda: experiments.run_experiments(system)),
        ),
        clock,
    )
    mirrors = tuple(e for e in ("hand", "pinocchio") if e not in (decision.excluded or {}))
    cross = _stage(
        stages,
        "chaos",
        lambda: cast(
            "ChaosStudy",
            cached_stage(
                cache,
                system,
                sources,
                "chaos",
                [t_end, dt_out, RUN_INTEGRATORS, mirrors],
                lambda: chaos.crossvalidate(
                    system,
                    sources,
                    t_end=t_end,
                    dt_out=dt_out,
                    integrators=RUN_INTEGRATORS,
                    mirror_engines=mirrors,
                    cache_dir=reference_dir(cache),
                ),
            ),
        ),
        clock,
    )
    if traj is None:
        return None, notes_experiments, cross
    judge_trajectories(traj, cross.get("amplification") if cross else None, stages.get("chaos"))
    runs = cast("Trajectories", traj)  # dynamics/freeruns.trajectory_results: the shape results.json holds
    set_aside_runs(runs, decision.excluded or {})
    return runs, notes_experiments, cross


def _divergence(
    decision: Decision, stages: dict[str, str], *, t_end: float, dt_out: float, clock: Clock
) -> Trajectories | None:
    """A derivation that disagrees: the stages built on its equations named as not run, and a bounded run
    that shows where its motion parts from the engines'."""
    sources = decision.sources
    assert sources is not None
    why = (
        f"not run: {_not_agreeing(decision)}; the reference, chaos and "
        "the perturbation experiments are built on the hand equations, so they would only amplify the same mistake"
    )
    for name in ("reference trajectory", "chaos and mirrors", "perturbation experiments"):
        stages[name] = why
    return _stage(
        stages,
        "divergence run",
        lambda: cast(
            "Trajectories",
            divergence_results(
                decision.system,
                sources,
                t_end=t_end,
                dt_out=dt_out,
                why=f"information only: {_not_agreeing(decision)}, so this shows where its motion parts from the "
                "engines'",
            ),
        ),
        clock,
    )


def _system_result(
    decision: Decision,
    stages: dict[str, str],
    clock: Clock,
    *,
    same: Equivalence | None,
    cross: ChaosStudy | None,
    traj: Trajectories | None,
    variants: list[Derivation],
    derived: DerivedEquations | None,
    experiments: Experiments | None,
) -> SystemResult:
    """The system's results: the verdict's checks, what the stages added, and whether all of it passed."""
    system, sources = decision.system, decision.sources
    model, point, derivation = decision.model_checks, decision.pointwise, decision.derivation
    assert sources is not None and model is not None and point is not None
    failed_stages = [k for k, v in stages.items() if v.startswith("failed")]
    traj_ok = traj is None or all(r.get("passed", True) for r in traj["runs"] if r.get("counts"))
    passed = (
        decision.passed
        and (same is None or same["passed"])
        and (cross is None or cross["passed"])
        and traj_ok
        and not failed_stages
    )
    return {
        **_identity(system),
        "failed": _what_failed(model, point, derivation, same, cross, traj, failed_stages),
        "statement": decision.statement,
        "parameters": {k: float(v) for k, v in probing.param_fields(system.params).items()},
        "parameter_keys": cast("dict[str, ParameterKeys]", parameter_keys(system)),  # systems/units.py's shape
        "timestep": float(stepped(sources["mujoco"]).m.opt.timestep),
        "model_checks": model,
        "pointwise": point,
        "derivation": derivation,
        "variants": variants,
        "derived": derived,
        "trajectories": traj,
        "experiments": experiments,
        "equivalence": same,
        "chaos": cross,
        "stages": records(clock.seconds, stages),
        "skipped": skipped_work(system),
        "passed": passed,
    }


def set_aside_runs(traj: Trajectories, excluded: Mapping[str, str]) -> None:
    """A reader the verdict set aside (audit/audit.py: it misreads the model) is shown, not judged."""
    for run in traj["runs"]:
        if run.get("source") in excluded:
            run["counts"], run["why_not_counted"] = False, f"information only: {excluded[run['source']]}"


def _not_agreeing(decision: Decision) -> str:
    """Why the derivation's verdict is not a pass, in the words its own numbers support: the first
    disagreeing term, and whether the model's own values show it or only a probe does."""
    d = decision.derivation
    if d.get("verdict") != "disagrees":
        return "the model checks or the engines pointwise disagree, so the verdict is not a pass"
    term = d.get("first_disagreeing_term") or "a term"
    where = "at a probe parameter set only" if d.get("hidden_by_model_values") else "at the model's parameters"
    return f"the derivation's {term} disagrees with the engines {where}"


def _what_failed(
    model: ModelChecks,
    point: Pointwise,
    derivation: Derivation,
    same: Equivalence | None,
    cross: ChaosStudy | None,
    traj: Trajectories | None,
    failed_stages: list[str],
) -> list[str]:
    """Each failing check of a system in one short phrase, the derivation's first."""
    out = []
    if derivation.get("verdict") == "disagrees":
        out.append(f"hand derivation: {derivation.get('statement')}")
    if not model["passed"]:
        out.append(f"model checks: {model['mismatches'][0]['key']} ({model['mismatches'][0]['why']})")
    out += [f"harness bug: {b}" for b in point.get("harness_bugs", [])]
    bad = [r for r in point["rows"] if not r["passed"]]
    if bad:
        out.append(f"pointwise: {bad[0]['quantity']} {bad[0]['pair']} (and {len(bad) - 1} more)")
    if same is not None and not same["passed"]:
        row = next(r for r in same["rows"] if not r["passed"])
        out.append(f"equivalence with {same['other']}: {row['quantity']} at {row.get('parameters', 'model')}")
    if cross is not None and not cross["passed"]:
        out.append("trajectory mirrors of MuJoCo's integrators")
    for run in (traj or {}).get("runs", []):
        if run.get("counts") and run.get("passed") is False:
            out.append(f"trajectory {run['source']} ({run['method']}) beyond the threshold")
    out += [f"stage {k} failed" for k in failed_stages]
    return out


def _from_notes(system: System) -> bool:
    """One of the repository's systems (models/ and equations/), not a user's files."""
    return bool(system.mjcf.resolve().parent == MODELS_DIR.resolve())


def _identity(system: System, bodies: list[str] | None = None) -> SystemResult:
    """What a system is: names, files, coordinates, joints, bodies (`bodies`: given, not asked of the
    module) and the physics it uses."""

    inside = _from_notes(system)
    return {
        "name": system.name,
        "description": system.description,
        "origin": "notes" if inside else "user",
        "mjcf": f"models/{system.mjcf.name}" if inside else str(system.mjcf),
        "model_format": system.model_format,
        "locked": list(system.locked),
        "equations": (
            ""
            if system.equations is None
            else f"equations/{system.name}.py"
            if inside
            else str(getattr(system.equations, "__file__", "?"))
        ),
        "coordinates": list(system.coordinates),
        "joints": list(system.joints),
        "bodies": list(system.bodies) if bodies is None else bodies,
        "uses": sorted(system.uses),
    }


def _unreadable(decision: Decision) -> SystemResult:
    """The result of a system whose parameters() or assumptions() raises: nothing else can be checked."""
    why = decision.unreadable
    return {
        **_identity(decision.system),
        "parameters": {},
        "derivation": decision.derivation,
        "variants": [],
        "stages": records({}, {"everything after reading the parameters": f"not run: {why}"}),
        "failed": [f"hand derivation: {decision.statement}"],
        "statement": decision.statement,
        "skipped": [],
        "passed": False,
    }


def _run_one(
    name: str,
    n_states: int,
    seed: int,
    n_probes: int = DEFAULT_PROBES,
    cache: Cache | None = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    drake_run: bool = False,
) -> SystemResult:
    """One system, by name (picklable, for process pools)."""

    system = load(name, time_limit=time_limit)
    return guarded_run(system, n_states=n_states, seed=seed, n_probes=n_probes, cache=cache, drake_run=drake_run)


def _run_files(
    model: str,
    equations: str,
    n_states: int,
    seed: int,
    n_probes: int,
    locked: tuple[str, ...] = (),
    cache: Cache | None = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    balance_inertia: bool = False,
    drake_run: bool = False,
) -> SystemResult:
    """One system from a model file and an equations file (picklable, for process pools)."""

    if equations:
        system = System.from_files(
            model, equations, locked=locked, time_limit=time_limit, balance_inertia=balance_inertia
        )
    else:
        system = System.model_only(model, locked=locked, balance_inertia=balance_inertia)
    return guarded_run(system, n_states=n_states, seed=seed, n_probes=n_probes, cache=cache, drake_run=drake_run)


def guarded_run(system: System, **options: Unpack[RunOptions]) -> SystemResult:
    """`run_system`, with a module that hung or tried to exit (validate/core/guard.py) as its one finding."""
    try:
        return run_system(system, **options)
    except Stopped as stop:
        return stopped_result(system, stop.why)


def stopped_result(system: System, why: str) -> SystemResult:
    """The result of a system whose equations module was stopped (`why`: "mass_matrix did not return
    within 30 s") or whose worker process ended: nothing after it can be checked."""
    return {
        **_identity(system, bodies=[]),
        "parameters": {},
        "derivation": {
            "name": "hand derivation",
            "kind": "hand",
            "verdict": "disagrees",
            "first_disagreeing_term": "parameters",
            "failing_terms": [],
            "statement": why,
            "hidden_by_model_values": False,
            "terms": [],
            "summary": [],
        },
        "variants": [],
        "stages": records({}, {"everything after the stop": f"not run: {why}"}),
        "failed": [why],
        "statement": why,
        "skipped": [],
        "passed": False,
    }


def _task(
    fn: Callable[..., SystemResult],
    args: tuple[object, ...],
    after: Callable[[str, SystemResult, Provenance], R] | None,
    meta: Provenance,
) -> tuple[SystemResult, R | None]:
    """One system's work in a worker: its results, and `after(name, results, meta)` of them (None
    without `after`)."""
    result = fn(*args)
    return result, (after(result["name"], result, meta) if after is not None else None)


def _outcome(future: Future[tuple[SystemResult, R | None]], system: System) -> tuple[SystemResult, R | None]:
    """A finished system's (results, rendered); a worker that ended without an answer (its module
    called os._exit or crashed the interpreter) is that system's failure, not the run's."""
    try:
        return future.result()
    except Stopped as stop:  # stopped before run_system (a Hamiltonian traced as the module was read)
        why = stop.why
    except BrokenExecutor:
        why = "its worker process ended without an answer: the equations module ended it (os._exit, a signal, a crash)"
    except Exception as exc:  # dask's KilledWorker: the worker died, as above
        if type(exc).__name__ != "KilledWorker":
            raise
        why = "its worker process died: the equations module ended it (os._exit, a signal, a crash)"
    return stopped_result(system, why), None


# What every `run` worker imports (engines, symbolic tools, the report's figures and recordings): about
# 3 s of CPU per process on this machine. Imported once in the parent before its pool forks, each
# worker inherits them instead of importing them again (5 systems: about 12 s of CPU saved).
WORKER_MODULES: tuple[str, ...] = (
    "mujoco",
    "pinocchio",
    "pydrake.multibody.plant",
    "pydrake.multibody.parsing",
    "sympy",
    "heyoka",
)
# matplotlib is left to the workers that draw a figure: a warm run finds every figure in its cache
# (report/figstore.py) and never imports it (0.3 s the parent would spend before any worker starts).
WORKER_MODULES += ("scipy.integrate", "rerun")


def preload(modules: tuple[str, ...] = WORKER_MODULES) -> list[str]:
    """Imports `modules` in this process, so that workers forked from it share them; returns those that
    could not be imported (an engine not installed: its worker finds it missing as before)."""
    import importlib

    missing = []
    for name in modules:
        try:
            importlib.import_module(name)
        except ImportError:
            missing.append(name)
    return missing


def _forks(executor: Executor | None) -> bool:
    """Whether `run` makes its own pool and that pool forks (its workers inherit the parent's modules)."""
    import multiprocessing

    return executor is None and multiprocessing.get_start_method(allow_none=True) in (None, "fork")


def _systems_of(
    names: list[str] | None,
    files: list[tuple[Path, Path | None]] | None,
    *,
    locked: tuple[str, ...],
    time_limit: float,
    balance_inertia: bool,
) -> tuple[list[System], list[System]]:
    """The systems named (all, when neither names nor files are given) and those of `files`. Unknown
    names, unreadable files and two systems of one name fail here, before any work starts."""
    systems = load_all(names, time_limit=time_limit) if names or not files else []
    users = [
        System.from_files(m, e, locked=locked, time_limit=time_limit, balance_inertia=balance_inertia)
        if e is not None
        else System.model_only(m, locked=locked, balance_inertia=balance_inertia)
        for m, e in (files or [])
    ]
    taken = [s.name for s in systems + users]
    clash = sorted({n for n in taken if taken.count(n) > 1})
    if clash:
        raise HarnessError(f"two systems are called {', '.join(clash)}: rename one equations file.")
    return systems, users


def _submit(
    pool: Executor,
    systems: list[System],
    users: list[System],
    files: list[tuple[Path, Path | None]],
    after: Callable[[str, SystemResult, Provenance], R | None] | None,
    meta: Provenance,
    common: tuple[int, int, int, Cache | None, float, bool],
    per_file: tuple[tuple[str, ...], Cache | None, float, bool, bool],
) -> dict[Future[tuple[SystemResult, R | None]], System]:
    """One task per system in `pool`, each future with its system. `common`: (n_states, seed, n_probes,
    cache, time_limit, drake_run); `per_file`: (locked, cache, time_limit, balance_inertia, drake_run)."""
    # Longest first, so that two workers finish together: damped scenes (implicit-damping
    # mirrors step the numpy equations), then more coordinates, then more printed forms.
    order = sorted(systems, key=lambda s: ("damping" not in s.uses, -s.nv, -len(s.variants), s.name))
    futures = {pool.submit(_task, _run_one, (s.name, *common), after, meta): s for s in order}
    for (model, equations), user in zip(files, users, strict=True):
        equations_file = "" if equations is None else str(equations)
        args = (str(model), equations_file, *common[:3], *per_file)
        futures[pool.submit(_task, _run_files, args, after, meta)] = user
    return futures


def _collect(
    futures: dict[Future[tuple[SystemResult, R | None]], System],
    progress: Progress | None,
    after: Callable[[str, SystemResult, Provenance], R | None] | None,
    rendered: dict[str, R | None] | None,
) -> dict[str, SystemResult]:
    """Every system's results by name, as its worker finishes; `progress` told of each start and end,
    what `after` returned put in `rendered`."""
    for system in futures.values():
        if progress:
            progress(system.name, "start")
    done: dict[str, SystemResult] = {}
    for future in completed(futures):
        name = futures[future].name
        done[name], extra = _outcome(future, futures[future])
        if rendered is not None and after is not None:
            rendered[name] = extra
        if progress:
            progress(name, "done", done[name])
    return done


def run(
    names: list[str] | None,
    *,
    n_states: int,
    seed: int,
    progress: Progress | None = None,
    executor: Executor | None = None,
    n_probes: int = DEFAULT_PROBES,
    files: list[tuple[Path, Path | None]] | None = None,
    after: Callable[[str, SystemResult, Provenance], R | None] | None = None,
    rendered: dict[str, R | None] | None = None,
    locked: tuple[str, ...] = (),
    cache: Cache | None = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    balance_inertia: bool = False,
    drake_run: bool = False,
    meanwhile: Callable[[], object] | None = None,
) -> RunResults:
    """Every system (or those named), each in a worker of `executor` (default: a process pool on
    every core; any `concurrent.futures.Executor` will do, a distributed one included). `files`:
    (model, equations) pairs of systems outside the repository, run instead of (or beside) names
    (equations None: the model alone, engines and derived equations only, `model_only_result`).
    `after(name, results, meta)`: a picklable function run in the worker on each system's results
    (e.g. rendering its report section); what it returns goes into `rendered[name]`. `locked`: URDF
    joints made fixed in the `files` systems (a gripper's fingers), a named step listed in their report.
    `cache`: the cache every worker keeps its references, summaries and explanations in (None: none),
    handed to them as a value.
    `time_limit`: seconds each call into an equations module may take (validate/core/guard.py); a module
    stopped, or a worker process that ends (`os._exit` in a module), fails its own system alone.
    `drake_run`: Drake's information-only free run beside the judged ones (freeruns.trajectory_results).
    `meanwhile`: work of the caller's own, done in a thread of this process while the workers compute."""

    systems, users = _systems_of(names, files, locked=locked, time_limit=time_limit, balance_inertia=balance_inertia)
    out: RunResults = {"meta": provenance(seed), "tolerances": TOLERANCES.as_dict(), "systems": {}, "passed": False}

    if _forks(executor):
        preload()
    with executor_for(executor, tasks=len(systems) + len(users), isolated=True) as pool:
        common = (n_states, seed, n_probes, cache, time_limit, drake_run)
        per_file = (locked, cache, time_limit, balance_inertia, drake_run)
        futures = _submit(pool, systems, users, files or [], after, out["meta"], common, per_file)
        helper = threading.Thread(target=meanwhile, daemon=True) if meanwhile is not None else None
        if helper is not None:
            helper.start()
        done = _collect(futures, progress, after, rendered)
        if helper is not None:
            helper.join()
    out["systems"] = {name: done[name] for name in sorted(done)}
    out["passed"] = all(s["passed"] for s in out["systems"].values())
    return out

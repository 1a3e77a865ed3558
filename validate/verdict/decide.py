"""The verdict on one system, decided in one place: `decide`.

Every way of asking for a verdict calls it: `lagrange_xval.check`, `lagrange_xval.testing`, the
`check` command and `run` (pipeline.run_system, which adds its trajectory stages after it and never
judges a second time). In order:

    1. parameters() and assumptions(): a derivation that cannot read its model is the verdict
       (nothing else can be checked), said with the function that raised;
    2. a model alone (no equations module): the engines' readings of the model compared, then the
       sources pointwise; there is no derivation to judge;
    3. model checks: what the equations assume of the compiled model, Pinocchio against MuJoCo;
    4. every source at the states (seeded random ones, or those given), every pair pointwise;
    5. the derivation term by term at the model's parameters and at the probe parameter sets
       (verdict/verdict.py), the first disagreeing term named.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..core.cachedir import Cache
from ..core.errors import HarnessError
from ..core.tolerances import TOLERANCES, Tolerances
from ..results.schema import Derivation, ModelChecks, Pointwise
from ..results.stages import Clock, lap
from ..sources import READER_WORDS, SYMBOLIC_MAX_DOF, Sources, left_out, make_sources, two_readers
from ..sources.base import Source
from ..sources.symbolic import keep_derivation
from ..systems import System
from . import modelsync, verdict, words
from . import pointwise as compare
from .pointwise import States
from .probes import DEFAULT_PROBES

NO_DERIVATION = "no equations module given: the engines and the model's derived equations are compared"


@dataclass(frozen=True)
class Decision:
    """What `decide` found: the derivation's verdict and the checks it rests on, with the states,
    sources and values they were computed from (for the stages `run` adds after the verdict).

    `model_checks` and `pointwise` are None when parameters() or assumptions() raised (`unreadable`
    says why); `probe_set` is None for a model alone."""

    system: System
    derivation: Derivation
    model_checks: ModelChecks | None = None
    pointwise: Pointwise | None = None
    states: States | None = None
    sources: Mapping[str, Source] | None = None
    values: dict[str, dict[str, np.ndarray]] | None = None
    probe_set: verdict.ProbeSet | None = None
    unreadable: str = ""
    excluded: Mapping[str, str] | None = None  # reader -> why it was left out: it cannot read the file, or
    # it misreads it (audit/audit.py), "Pinocchio cannot read it; likely ...: excluded"
    misread: Mapping[str, str] | None = None  # reader -> its known misreading, kept as too few would be left

    @property
    def model_only(self) -> bool:
        return self.system.equations is None

    @property
    def passed(self) -> bool:
        """Model checks, every pointwise pair and (given a derivation) every term agree."""
        if self.model_checks is None or self.pointwise is None:
            return False
        checks = bool(self.model_checks["passed"] and self.pointwise["passed"])
        return checks if self.model_only else checks and self.derivation.get("verdict") == "agrees"

    @property
    def statement(self) -> str:
        """The verdict in one sentence: the derivation's statement (for a model alone, which sources
        were compared and whether they agree), with what else failed."""
        text = str(self.derivation.get("statement", ""))
        if self.model_checks is None or self.pointwise is None:
            return text
        if self.model_only:
            text = model_alone_statement(self.pointwise, self.system.nv)
        # A mismatch the file's defect caused (MuJoCo given other numbers) is not a reader's: named below.
        mismatches = [m for m in self.model_checks["mismatches"] if "defect" not in m]
        if mismatches and self.misread:  # the readers that misread, by the audit's known cause
            text = f"{misread_sentence(self.misread)}; {text}"
        elif mismatches:
            key = mismatches[0]["key"]
            check = str(mismatches[0].get("check", ""))
            if self.model_only or not check.startswith("equations~"):  # a reader's, not the derivation's
                reader = check.split("~")[0].capitalize() if "~" in check else "a reader"
                text = f"{reader} reads the model otherwise than MuJoCo ({key}); {text}"
            else:
                text = f"the model differs from what the derivation assumes ({key}); {text}"
        if self.excluded:
            text = "; ".join(self.excluded.values()) + f"; {text}"
        bad = [r for r in self.pointwise["rows"] if not r["passed"]]
        if bad and (self.model_only or self.derivation.get("verdict") == "agrees"):
            more = f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""
            text += f"; but pointwise {bad[0]['quantity']} {bad[0]['pair']} disagrees{more}"
        defects = self.model_checks.get("defects", [])
        if defects:  # first: it is the file's, and says who was given which numbers
            more = f" (and {len(defects) - 1} more)" if len(defects) > 1 else ""
            text = f"the file has a defect: {defects[0]}{more}; {text}"
        floors = self.model_checks.get("floors", [])
        if floors:
            more = f" (and {len(floors) - 1} more)" if len(floors) > 1 else ""
            text += f"; given to every reader as MuJoCo needs it: {floors[0]}{more}"
        typed = words.typed_note(dict(self.derivation.get("typed_numbers") or {}))
        return f"{text}; {typed}" if typed else text


def left_out_line(model_checks: ModelChecks | None) -> str:
    """What every comparison of the model leaves out, said once per command (not in every verdict line):
    "left out, as no equation of motion contains them: contacts between ...; the range of ..."; "" if none."""
    left = model_checks.get("left_out", []) if model_checks is not None else []
    return f"left out, as no equation of motion contains them: {'; '.join(left)}" if left else ""


def misread_sentence(misread: Mapping[str, str]) -> str:
    """ "Pinocchio misreads torso's mass (...: settotalmass); Drake misreads ...: not excluded, as fewer
    than two readers would be left": who misreads, by the known cause, and why it was still compared."""
    return "; ".join(misread.values()) + ": not excluded, as fewer than two readers would be left to judge"


SOURCE_WORDS = {"mujoco": "MuJoCo", "pinocchio": "Pinocchio", "drake": "Drake", "symbolic": "the derived equations"}


def model_alone_statement(point: Pointwise, nv: int = 1) -> str:
    """ "no derivation given; MuJoCo, Pinocchio and Drake agree on the model and its dynamics": the
    sources the pointwise comparison holds, in that order, and whether every pair agrees. A model in
    which no joint moves (nv = 0) has no dynamics: the sentence says what was and was not compared."""
    held = {x for r in point["rows"] for x in str(r["pair"]).split("~")}
    if not nv:  # the derived equations are no reader: MuJoCo's numbers, with no coordinate
        held.discard("symbolic")
    names = [w for k, w in SOURCE_WORDS.items() if k in held]
    listed = ", ".join(names[:-1]) + f" and {names[-1]}" if len(names) > 1 else "".join(names) or "no source"
    if not nv:
        return f"no joint moves (every body is fixed), so there are no equations of motion to compare: {listed} read it"
    verb = "agree" if point["passed"] else "are compared"
    return f"no derivation given; {listed} {verb} on the model and its dynamics"


def decide(
    system: System,
    *,
    n_states: int,
    seed: int,
    probes: int = DEFAULT_PROBES,
    cache: Cache | None = None,
    states: States | None = None,
    tolerances: Tolerances = TOLERANCES,
    clock: Clock | None = None,
) -> Decision:
    """The verdict on `system` (module docstring).

    Args:
        system: the model and its equations module (or the model alone).
        n_states: how many seeded random states the sources are compared at (ignored with `states`).
        seed: the seed of the states and of the probe parameter sets.
        probes: how many probe parameter sets the derivation's terms are judged at.
        cache: where the explanations of wrong entries are kept (None: nowhere).
        states: the states to compare at instead of random ones.
        tolerances: the tiers every comparison is judged against.
        clock: where each stage's wall seconds go ("model checks", "pointwise", "probes", "terms");
            its cancel event, once set, abandons the verdict at the next of them (results/stages.py).

    Returns:
        The Decision. Nothing a derivation computes raises out of here: its exceptions are findings.

    Raises:
        Cancelled: the clock's cancel event was set (only with a clock that has one).
    """
    why = _unreadable(system)
    if why:
        return Decision(system, unreadable_derivation(why), unreadable=why)
    if system.nv <= SYMBOLIC_MAX_DOF:  # the model's own derivation, read back where it was kept
        keep_derivation(system, cache)
    sources = make_sources(system)
    two_readers(system, sources)  # a model only MuJoCo reads is refused, saying who could not and why
    unread = {n: f"{why}: excluded" for n, why in left_out(system, sources).items()}
    model = with_drake(modelsync.check(system, sources.get("pinocchio")), sources)
    lap(clock, "model checks")
    states = states if states is not None else compare.random_states(system, n=n_states, seed=seed)
    values = compare.evaluate(sources, states)  # evaluated once: the judges reuse the engines' values
    scales = compare.physical_scales(system, states)  # the model's floor under every scale
    point = compare.pointwise_result(values, states, seed=seed, tolerances=tolerances, scales=scales)
    misread, named = _misreaders(system, model, point)
    excluded = {**unread, **misread}
    judged = Sources({n: s for n, s in sources.items() if n not in excluded})
    judged.skipped = getattr(sources, "skipped", {})
    if excluded:  # judged against the sources that agree with what the file means
        model = set_aside(model, misread)
        kept = {n: v for n, v in values.items() if n not in excluded}
        point = compare.pointwise_result(kept, states, seed=seed, tolerances=tolerances, scales=scales)
    lap(clock, "pointwise")
    if system.equations is None:
        return Decision(
            system, no_derivation(), model, point, states, sources, values, excluded=excluded, misread=named
        )
    probe_set = verdict.derivation_probes(system, n_probes=probes, seed=seed)
    lap(clock, "probes")
    kept = {n: v for n, v in values.items() if n not in excluded}
    derivation = verdict.judge_derivation(
        system, states, judged, probe_set, values=kept, seed=seed, tolerances=tolerances, cache=cache
    )
    typed = _typed(system)
    if typed:
        derivation["typed_numbers"] = typed
    lap(clock, "terms")
    return Decision(
        system, derivation, model, point, states, sources, values, probe_set, excluded=excluded, misread=named
    )


READERS = {"mujoco", "pinocchio", "drake"}


def _misreaders(system: System, model: ModelChecks, point: Pointwise) -> tuple[dict[str, str], dict[str, str]]:
    """The readers that misread the model, set aside and named only (audit/audit.py `misreaders`), looked
    for only where Pinocchio's reading differs from MuJoCo's or a pointwise pair of two readers disagrees."""
    suspect = any(m.get("check") == "pinocchio~mujoco" for m in model["mismatches"]) or any(
        not r["passed"] and set(r["pair"].split("~")) <= READERS for r in point["rows"]
    )
    if not suspect:
        return {}, {}
    from ..audit.audit import misreaders

    return misreaders(system)


def set_aside(model: ModelChecks, excluded: Mapping[str, str]) -> ModelChecks:
    """The model checks without the rows of a reader set aside, which are listed among the alignments."""
    if "pinocchio" not in excluded:
        return model
    kept = [m for m in model["mismatches"] if m.get("check") != "pinocchio~mujoco"]
    lines = [f"{why} (audit/audit.py: judged against what the file means)" for why in excluded.values()]
    return {**model, "passed": not kept, "mismatches": kept, "alignments": [*model["alignments"], *lines]}


def with_drake(model: ModelChecks, sources: Mapping[str, Source]) -> ModelChecks:
    """The model checks with what was aligned for Drake's reading (sources/drake.py), or why Drake (or
    Pinocchio) was left out, listed beside the other alignments: never silent."""
    lines = [f"Drake: {line}" for line in getattr(sources.get("drake"), "alignments", [])]
    lines += [f"{READER_WORDS[n]} left out: {why}" for n, why in getattr(sources, "skipped", {}).items()]
    return {**model, "alignments": [*model["alignments"], *lines]} if lines else model


def _typed(system: System) -> dict[str, float]:
    """The numbers parameters() returns without reading the model (verdict/words.py `typed_numbers`)."""
    try:
        return words.typed_numbers(system)
    except Exception:  # noqa: BLE001 - a note, never a failed verdict
        return {}


def _unreadable(system: System) -> str:
    """Why the derivation cannot read its model (parameters() or assumptions() raised), or ""."""
    if system.equations is None:
        return ""
    where = "parameters()"
    try:
        params = system.params
        where = "assumptions()"
        system.equations.assumptions(params)
    except Exception as exc:  # noqa: BLE001 - a derivation that cannot read its model is the finding
        return str(exc) if isinstance(exc, HarnessError) else f"{where} raised {type(exc).__name__}: {exc}".strip()
    return ""


def unreadable_derivation(why: str) -> Derivation:
    """The verdict on a derivation whose parameters() or assumptions() raised."""
    return {
        "name": "hand derivation",
        "kind": "hand",
        "verdict": "disagrees",
        "first_disagreeing_term": "parameters",
        "failing_terms": ["parameters"],
        "statement": f"{why}; nothing else could be checked",
        "hidden_by_model_values": False,
        "terms": [],
        "summary": [],
    }


def no_derivation() -> Derivation:
    """The derivation part of a model checked alone."""
    return {
        "name": "no derivation",
        "kind": "none",
        "verdict": "not applicable",
        "statement": NO_DERIVATION,
        "reason": "no equations module given",
    }

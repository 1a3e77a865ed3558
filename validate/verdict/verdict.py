"""The verdict on a derivation: every term, against both engines, at the model's parameters and at
every probe (validate/verdict/probes.py), with the term that holds a mistake named.

The terms of a derivation in the form M(q) a + bias(q, v) = tau + passive(q, v):

    mass matrix       M(q)                                      vs the engines' CRBA / mj_fullM
    gravity           bias(q, 0)                                vs the engines' bias at v = 0
    velocity          bias(q, v) - bias(q, 0)                   Coriolis and centrifugal forces
    friction          passive(q, v)                             joint damping
    kinetic energy    T(q, v);  potential energy  V(q)
    body positions    centres of mass;  body rotations  body frames
    acceleration      M^-1 (tau + passive - bias)               (the solve tier, per state cond(M))
    parameters        what parameters() reads from a probe model built from the derivation's own
                      assumptions (it must read back the values the probe was built with)

A mistake changes the terms it is in; the acceleration changes with any dynamic term, so it is
named only when no term before it disagrees. Nothing a derivation computes raises out of here:
an exception, a wrong shape or a non-finite value is a failing row that says so, and a mass matrix
that is not symmetric positive definite is reported with the state where it is not.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TypedDict, cast

import numpy as np

from ..core.cachedir import Cache
from ..core.errors import HarnessError
from ..core.tolerances import TOLERANCES, PhysicalScales, Tolerances
from ..handwritten.forms import accelerations_only, not_provided_in, written_form
from ..handwritten.values import real_array
from ..results.schema import Derivation, Explanation, NotSpd, TermNotes, TermRow, TermSummary, WorstTerm
from ..sources import SYMBOLIC_MAX_DOF, make_sources
from ..sources.base import Source
from ..systems import System
from . import probes as probing
from . import structure, words
from .asif import as_if
from .explain import explain, statement_tail
from .inputs import acceleration_rows, actuation_rows, ignored_torques
from .modelsync import equations_vs_model
from .pointwise import States, force_scale, physical_scales, random_states
from .terms import EngineTerms, EngineValues, engines_of, term_rows

HAND_TERMS = (
    "parameters",
    "mass matrix",
    "gravity",
    "velocity",
    "friction",
    "actuation",
    "kinetic energy",
    "potential energy",
    "body positions",
    "body rotations",
    "acceleration",
)
TERM_TIER = {t: "algebraic" for t in HAND_TERMS} | {"acceleration": "solve"}
TERM_OF_FUNCTION = {
    "kinetic_energy": "kinetic energy",
    "potential_energy": "potential energy",
    "body_positions": "body positions",
    "body_rotations": "body rotations",
}
PROBE_STATES = 200  # states per probe (the model's own parameters use the pointwise sample)


def _shaped(name: str, value: object, shape: tuple[int, ...]) -> np.ndarray:
    return real_array(name, value, shape)


def hand_terms(system: System, states: States) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """The derivation's terms at `states`, and for each term it could not give, why (one line)."""
    eq, p = system.derivation, system.params
    q, v, tau = states.q, states.v, states.tau
    N, n = q.shape
    nb = len(system.bodies)
    zero = np.zeros_like(q)
    out: dict[str, np.ndarray] = {}
    errors: dict[str, str] = {}
    missing = not_provided_in(eq)

    def call(term: str, fname: str, shape: tuple[int, ...], fn: Callable[[], object]) -> np.ndarray | None:
        if fname in missing:
            return None  # not provided: not checked (listed by judge_derivation), never a failure
        try:
            with np.errstate(all="ignore"):
                arr = _shaped(f"{fname}()", fn(), shape)
        except Exception as exc:  # noqa: BLE001 - the user's code: its failure is the finding
            said = f"{fname}() raised {type(exc).__name__}: {exc}".strip().removesuffix(":")  # KeyboardInterrupt
            errors[term] = str(exc).strip() if isinstance(exc, HarnessError) else said
            return None
        if not np.all(np.isfinite(arr)):
            bad = int(np.argwhere(~np.isfinite(arr.reshape(N, -1)))[0][0])
            errors[term] = f"{fname}() is not finite at q = {np.round(q[bad], 6).tolist()}"
        out[term] = arr
        return arr

    def _of(per_body: Mapping[str, object]) -> list[tuple[str, object]]:
        return [(b, per_body[b]) for b in system.bodies]

    M = call("mass matrix", "mass_matrix", (N, n, n), lambda: eq.mass_matrix(p, q))
    G = call("gravity", "bias", (N, n), lambda: eq.bias(p, q, zero))
    B = call("velocity", "bias", (N, n), lambda: eq.bias(p, q, v))
    if B is not None and G is not None:
        out["velocity"] = B - G
    call("friction", "passive", (N, n), lambda: eq.passive(p, q, v))
    call("kinetic energy", "kinetic_energy", (N,), lambda: eq.kinetic_energy(p, q, v))
    call("potential energy", "potential_energy", (N,), lambda: eq.potential_energy(p, q))
    call(
        "body positions",
        "body_positions",
        (N, nb, 3),
        lambda: np.stack([real_array(f"body_positions()[{b!r}]", x) for b, x in _of(eq.body_positions(p, q))], -2),
    )
    call(
        "body rotations",
        "body_rotations",
        (N, nb, 3, 3),
        lambda: np.stack([real_array(f"body_rotations()[{b!r}]", x) for b, x in _of(eq.body_rotations(p, q))], -3),
    )
    if M is not None and B is not None and "friction" in out:
        out["acceleration"] = _solved(M, tau + out["friction"] - B, like=q)
    return out, errors


def _solved(M: np.ndarray, rhs: np.ndarray, *, like: np.ndarray) -> np.ndarray:
    """a = M^-1 rhs state by state (M: (N, n, n), rhs and `like`, the array a copies: (N, n)); NaN where
    M or rhs is not finite or M is singular."""
    N = len(M)
    a = np.full_like(like, np.nan)
    ok = np.all(np.isfinite(M.reshape(N, -1)), axis=1) & np.all(np.isfinite(rhs), axis=1)
    with np.errstate(all="ignore"):
        for i in np.nonzero(ok)[0]:
            try:
                a[i] = np.linalg.solve(M[i], rhs[i])
            except np.linalg.LinAlgError:
                pass
    return a


def definiteness(M: np.ndarray, states: States) -> NotSpd | None:
    """Where a mass matrix is not symmetric positive definite: the worst state, or None."""
    finite = np.all(np.isfinite(M.reshape(len(M), -1)), axis=1)
    if not finite.any():
        return None
    Mf = M[finite]
    asym = np.abs(Mf - np.swapaxes(Mf, -1, -2)).max(axis=(-1, -2)) / np.maximum(np.abs(Mf).max(axis=(-1, -2)), 1e-300)
    low = np.linalg.eigvalsh(0.5 * (Mf + np.swapaxes(Mf, -1, -2)))[:, 0]
    top = np.abs(Mf).max(axis=(-1, -2))
    bad = (low <= 1e-12 * top) | (asym > 1e-12)
    if not bad.any():
        return None
    idx = np.nonzero(finite)[0]
    worst = int(idx[np.argmin(np.where(bad, low / np.maximum(top, 1e-300), np.inf))])
    i = int(np.nonzero(idx == worst)[0][0])
    what = "not symmetric" if asym[i] > 1e-12 else ("singular" if abs(low[i]) <= 1e-12 * top[i] else "indefinite")
    return {
        "what": what,
        "states": int(bad.sum()),
        "of": len(M),
        "q": states.q[worst].tolist(),
        "smallest_eigenvalue": float(low[i]),
    }


def engine_values(sources: Mapping[str, Source], states: States, values: EngineValues | None = None) -> EngineValues:
    """The engines' quantities at `states` (reusing what the pointwise check computed, if given)."""
    if values is not None:
        return {k: values[k] for k in engines_of(sources)}
    zero = np.zeros_like(states.q)
    return {k: sources[k].evaluate(states.q, states.v, states.tau, zero) for k in engines_of(sources)}


def term_rows_at(
    system: System,
    states: States,
    sources: Mapping[str, Source],
    *,
    values: EngineValues | None = None,
    tolerances: Tolerances = TOLERANCES,
) -> tuple[list[TermRow], TermNotes]:
    """Every term of the derivation against both engines at one parameter set; and notes (errors,
    mass-matrix definiteness)."""
    ev = engine_values(sources, states, values)  # keyed by the engines present
    terms = EngineTerms(system, sources, states, ev)
    e = terms.by_engine
    mine, errors = hand_terms(system, states)
    ignored = ignored_torques(system, states)
    if ignored:  # M^-1 has a zero column: every term built from M names the cause, not a function never written
        for term in ("mass matrix", "gravity", "velocity", "friction", "acceleration"):
            mine.pop(term, None)
            errors[term] = ignored
    theirs = _engine_terms(ev, e, states, physical_scales(system, states))
    cond = np.linalg.cond(e["mujoco"]["M"])
    # Explicit accelerations (form c) give M and the forces only through an inversion of M^-1: their
    # rounding grows with cond(M) like the accelerations', so they are judged with the solve tier.
    tiers = dict(TERM_TIER)
    if written_form(system.equations) == "c":
        tiers.update({t: "solve" for t in ("mass matrix", "gravity", "velocity", "friction")})
    rows: list[TermRow] = []
    absent = {TERM_OF_FUNCTION[fn] for fn in not_provided_in(system.equations)}
    if accelerations_only(system.equations):  # judged in accelerations: M and the forces are not the person's
        absent |= {"mass matrix", "gravity", "velocity", "friction", "acceleration"}
        rows += acceleration_rows(system, states, terms, error_row=_error_row, tolerances=tolerances)
    elif system.inputs == "u":
        rows += actuation_rows(system, states, terms, error_row=_error_row, tolerances=tolerances)
    for term, (refs, floor) in theirs.items():
        if term in absent:
            continue  # not provided: listed as not checked by judge_derivation
        if term not in mine:
            for k in ev:
                rows.append(_error_row(term, k, errors.get(term, "not computed")))
            continue
        new = term_rows(
            term,
            mine[term],
            refs,
            states,
            tier=tiers[term],
            tolerances=tolerances,
            min_scale={k: floor for k in ev},
            who="hand",
            cond=cond if tiers[term] == "solve" else None,
        )
        for row in new:
            if term in errors:
                row["error"] = errors[term]
        rows += new
    notes: TermNotes = {}
    if errors:
        notes["errors"] = errors
    if "mass matrix" in mine:
        spd = definiteness(mine["mass matrix"], states)
        if spd:
            notes["mass_matrix_not_spd"] = spd
    return rows, notes


def _engine_terms(
    ev: EngineValues, e: EngineValues, states: States, scales: PhysicalScales
) -> dict[str, tuple[dict[str, np.ndarray], float]]:
    """Each term's values per engine (from `engine_values` and `EngineTerms.by_engine`), with the
    smallest scale it is judged at: the largest force, energy or length any engine gives, and at least
    the model's physical floor of the term (`scales`: pointwise.physical_scales)."""
    force = max(
        float(np.abs(np.concatenate([e[k][x].ravel() for x in ("G", "Cv", "passive", "tau")])).max(initial=0.0))
        for k in ev
    )
    force = max(force, force_scale(e["mujoco"]["M"], states.v))  # where the velocity terms vanish (gimbal lock)
    energy = max(float(np.abs(np.concatenate([ev[k]["T"], ev[k]["V"]])).max(initial=0.0)) for k in ev)
    length = max(float(np.abs(ev[k]["body_positions"]).max(initial=0.0)) for k in ev)
    theirs = {
        "mass matrix": ({k: e[k]["M"] for k in ev}, 0.0),
        "gravity": ({k: e[k]["G"] for k in ev}, force),
        "velocity": ({k: e[k]["Cv"] for k in ev}, force),
        "friction": ({k: e[k]["passive"] for k in ev}, force),
        "kinetic energy": ({k: ev[k]["T"] for k in ev}, energy),
        "potential energy": ({k: ev[k]["V"] for k in ev}, energy),
        "body positions": ({k: ev[k]["body_positions"] for k in ev}, length),
        "body rotations": ({k: ev[k]["body_rotations"] for k in ev}, 1.0),
        "acceleration": ({k: e[k]["a"] for k in ev}, 0.0),
    }
    return {term: (refs, max(floor, scales.floor(term))) for term, (refs, floor) in theirs.items()}


def _error_row(term: str, engine: str, why: str) -> TermRow:
    return {
        "term": term,
        "pair": f"hand~{engine}",
        "engine": engine,
        "max_abs": float("inf"),
        "max_rel": float("inf"),
        "scale": float("nan"),
        "scaled": float("inf"),
        "tier": TERM_TIER[term],
        "tolerance": getattr(TOLERANCES, TERM_TIER[term]).rtol,
        "passed": False,
        "worst_state": None,
        "error": why,
    }


def _model_rows(system: System) -> list[TermRow]:
    """A failing "parameters" row where the compiled model differs from what the derivation assumes
    of it (its parameters() or assumptions() read or state the wrong element)."""

    try:
        bad = [r for r in equations_vs_model(system) if not r["passed"]]
    except Exception as exc:  # noqa: BLE001 - the user's parameters() or assumptions() raised
        why = f"{type(exc).__name__}: {exc}"
    else:
        if not bad:
            return []
        keys = "; ".join(f"{r['key']}: assumed {r['expected']}, model {r['actual']}" for r in bad[:3])
        why = f"the model differs from what the derivation assumes ({keys})"
    row = _error_row("parameters", "mjcf", why)
    row["probe"] = 0
    return [row]


def _first_term(failing: list[TermRow]) -> str:
    names = {r["term"] for r in failing}
    return next(t for t in HAND_TERMS if t in names)


class Misreading(TypedDict):
    """What parameters() misread at a probe (probes.ParametersMisread)."""

    message: str
    fields: dict[str, list[float]]  # per field, [built with, read back]


@dataclass(frozen=True)
class ProbeSet:
    """The hand derivation's probe models (index 0, the model's own, excluded), why any could not
    be built, and what parameters() misread if it did."""

    probes: list[probing.Probe]
    problems: list[str]
    misread: Misreading | None = None
    asked: int | None = None  # how many probes were asked for (None: as many as were built or tried)

    @property
    def wanted(self) -> int:
        """How many probes were asked for."""
        return len(self.probes) + len(self.problems) if self.asked is None else self.asked

    def systems(self) -> list[System]:
        return [p.system for p in self.probes]


def derivation_probes(system: System, *, n_probes: int = probing.DEFAULT_PROBES, seed: int = 0) -> ProbeSet:
    """Probe models in which every parameter of the derivation moves independently; none where it reads no
    number from the model (a function with its numbers written inside: nothing a probe could move)."""
    if n_probes and not probing.param_fields(system.params):
        return ProbeSet([], [words.NOTHING_TO_PROBE], asked=n_probes)
    try:
        found, problems = probing.probes(system, k=n_probes, seed=seed)
    except probing.ParametersMisread as exc:
        fields = {k: list(v) for k, v in exc.wrong.items()}
        return ProbeSet([], [str(exc)], {"message": str(exc), "fields": fields}, asked=n_probes)
    except HarnessError as exc:
        return ProbeSet([], [str(exc)], asked=n_probes)
    return ProbeSet(found[1:], problems, asked=n_probes)


def _explanations(
    system: System, probe_systems: list[System], terms: list[str], seed: int, cache: Cache | None = None
) -> list[Explanation]:
    """The failing terms' entries as symbolic differences; an explanation that cannot be computed is
    one line saying why, never a failed run."""
    if system.nv > SYMBOLIC_MAX_DOF:
        return [
            {
                "term": terms[0] if terms else "?",
                "entry": "",
                "explained": False,
                "statement": f"no symbolic explanation: {system.nv} joints, more than the {SYMBOLIC_MAX_DOF} the "
                "symbolic derivation is run for",
            }
        ]
    try:
        return explain(system, probe_systems, terms, seed=seed, cache=cache)
    except Exception as exc:  # noqa: BLE001 - the user's code or a model the derivation cannot read
        return [
            {
                "term": terms[0] if terms else "?",
                "entry": "",
                "explained": False,
                "statement": f"no symbolic explanation: {type(exc).__name__}: {exc}".strip(),
            }
        ]


def _rows_at_model(
    system: System, states: States, sources: Mapping[str, Source], values: EngineValues | None, tolerances: Tolerances
) -> tuple[list[TermRow], dict[int, TermNotes]]:
    """Every term's rows at the model's parameters and the model's own checks; its notes, as probe 0's."""
    rows, notes = term_rows_at(system, states, sources, values=values, tolerances=tolerances)
    for r in rows:
        r["probe"] = 0
    return rows + _model_rows(system), ({0: notes} if notes else {})


def _rows_at_probes(
    probe_set: ProbeSet, *, probe_states: int, seed: int, tolerances: Tolerances
) -> tuple[list[TermRow], dict[int, TermNotes]]:
    """What parameters() misread, then every term's rows at each probe; each probe's notes, by index."""
    rows: list[TermRow] = []
    notes: dict[int, TermNotes] = {}
    if probe_set.misread is not None:
        rows.append(
            {
                **_error_row("parameters", "mjcf", probe_set.misread["message"]),
                "pair": "hand~mjcf",
                "engine": "mjcf",
                "probe": None,
                "fields": probe_set.misread["fields"],
            }
        )
    for probe in probe_set.probes:
        ps = random_states(probe.system, n=probe_states, seed=seed + probe.index)
        prow, pnotes = term_rows_at(probe.system, ps, make_sources(probe.system), tolerances=tolerances)
        for r in prow:
            r["probe"] = probe.index
        rows += prow
        if pnotes:
            notes[probe.index] = pnotes
    return rows, notes


def _coverage(result: Derivation, system: System, states: States, probe_set: ProbeSet, probe_states: int) -> None:
    """What the verdict was reached on: the probes, those not built, parameters held at zero,
    functions not provided and the number of states."""
    probe_list = probe_set.probes
    result["probes"] = [{"index": 0, "label": "model", "changed": {}}, *(p.as_dict() for p in probe_list)]
    result["probe_problems"] = probe_set.problems
    # A parameter that is zero in the model stays zero at every probe: the terms it scales are not tested.
    result["held_at_zero"] = sorted(k for k, x in probing.param_fields(system.params).items() if x == 0.0)
    absent = not_provided_in(system.equations)
    if absent:
        result["not_checked"] = [f"{fn}() not provided" for fn in absent]
    result["checked"] = {
        "states_at_model": len(states),
        "states_per_probe": probe_states,
        "probes": len(probe_list),
        "probes_asked": probe_set.wanted,
        "evaluations": len(states) + probe_states * len(probe_list),
    }


def _no_probes(probe_set: ProbeSet) -> str:
    """The words for a verdict at the model's own numbers alone: none asked for says what that leaves
    out (none built is said after the states, with why)."""
    return f" (no probes asked for: {words.NOT_LOOKED_FOR})" if probe_set.wanted == 0 else ""


def _agreement(result: Derivation, sources: Mapping[str, Source], probe_set: ProbeSet) -> None:
    """The verdict and statement where every term agrees."""
    probe_list, problems = probe_set.probes, probe_set.problems
    result["verdict"] = "agrees"
    result["statement"] = (
        f"agrees with {_engine_names(sources)} in every term at the model's parameters"
        + (f" and at {len(probe_list)} probe parameter sets" if probe_list else _no_probes(probe_set))
        + f" ({result['checked']['evaluations']} states)"
    )
    unprobed = words.unbuilt_probes(len(probe_list), probe_set.wanted, problems)
    if unprobed:
        result["statement"] += f"; {unprobed}"
        result["not_looked_for"] = unprobed


def _hidden_statement(
    result: Derivation,
    system: System,
    first: str,
    failing: list[TermRow],
    probe_set: ProbeSet,
    *,
    seed: int,
    tolerances: Tolerances,
) -> None:
    """The statement for a mistake the model's own values hide: the first probe that shows it, the
    parameters that expose it alone, and the assumptions the derivation makes without saying."""
    first_probe = min(p for r in failing if (p := r.get("probe")))
    described = next(p for p in probe_set.probes if p.index == first_probe).describe()
    exposed = exposing_fields(system, first, tolerances=tolerances, seed=seed)
    result["exposed_by"] = exposed
    result["statement"] = (
        f"{first} disagrees at probe {first_probe} but agrees at the model's own parameters: the mistake is "
        f"hidden by the model's values ({described})"
        + (f"; it shows when {' or '.join(exposed)} alone changes" if exposed else "")
    )
    unstated = _unstated(system, first)
    if unstated:
        result["unstated_assumptions"] = unstated
        result["statement"] += "; " + words.assumption_hint(unstated, first)


def _disagreement(
    result: Derivation,
    system: System,
    rows: list[TermRow],
    probe_set: ProbeSet,
    at: tuple[States, Mapping[str, Source]],
    *,
    seed: int,
    tolerances: Tolerances,
    cache: Cache | None,
) -> None:
    """The verdict and statement where a term disagrees: the first such term, where it is worst,
    the failing entries explained, whether the model's own values hide the mistake, and (wrong at the
    model's values) the other chain the derivation is the right derivation of: after the named slip,
    the physical parameter it behaves as (verdict/asif.py). `at`: the model's states and sources."""
    failing = [r for r in rows if not r["passed"]]
    misread = probe_set.misread
    result["verdict"] = "disagrees"
    first = _first_term(failing)
    worst = max((r for r in failing if r["term"] == first), key=lambda r: r["scaled"])
    result["first_disagreeing_term"] = first
    result["failing_terms"] = [t for t in HAND_TERMS if any(r["term"] == t for r in failing)]
    keys = ("term", "engine", "probe", "max_abs", "scaled", "tolerance", "worst_state", "error")
    result["worst_term"] = cast(WorstTerm, {k: worst.get(k) for k in keys})  # absent ones as None, as written
    explained = _explanations(system, probe_set.systems(), result["failing_terms"], seed, cache)
    if explained:
        result["explanations"] = _in_your_words(system, explained)
    at_model = any(not r["passed"] for r in rows if r.get("probe") == 0)
    result["hidden_by_model_values"] = not at_model
    if result["hidden_by_model_values"] and misread is None:
        _hidden_statement(result, system, first, failing, probe_set, seed=seed, tolerances=tolerances)
    elif misread is not None:
        result["statement"] = misread["message"]
    else:
        result["statement"] = f"{first} disagrees at the model's parameters"
        if "error" in worst:
            result["statement"] += f": {worst['error']}"
    named_slip = statement_tail(result.get("explanations", []), at_model=at_model)
    _structure(result, system, at[0], lead=not named_slip and misread is None and "error" not in worst)
    result["statement"] += named_slip
    found = as_if(system, *at, seed=seed) if at_model and misread is None else None
    if found is not None:
        result["as_if"] = found
        result["statement"] += f"; {found['statement']}"


def _structure(result: Derivation, system: System, states: States, *, lead: bool) -> None:
    """The properties of a Lagrangian derivation the person's own functions break (verdict/structure.py), kept
    in the result; with `lead` (no named slip explains the difference, no function failed, parameters() read
    right), the statement leads with the one that concerns the first failing term, before its "disagrees"."""
    found = structure.findings(system, states)
    if not found:
        return
    result["structure"] = found
    said = structure.lead(found, result.get("failing_terms", []))
    if said and lead:
        result["statement"] = f"{said}; {result['statement']}"


def _not_spd_note(result: Derivation, all_notes: dict[int, TermNotes]) -> None:
    """Where the derivation's mass matrix is not symmetric positive definite, said in the statement."""
    spd = next((n["mass_matrix_not_spd"] for n in all_notes.values() if "mass_matrix_not_spd" in n), None)
    if spd:
        result["mass_matrix_not_spd"] = spd
        if "your M is not" in result["statement"]:  # said already, by the entry (verdict/structure.py)
            return
        result["statement"] += (
            f"; your M(q) is {spd['what']} at q = {np.round(spd['q'], 4).tolist()} "
            f"(smallest eigenvalue {spd['smallest_eigenvalue']:.3g}, {spd['states']} of {spd['of']} states)"
        )


def judge_derivation(
    system: System,
    states: States,
    sources: Mapping[str, Source],
    probe_set: ProbeSet | None = None,
    *,
    values: EngineValues | None = None,
    n_probes: int = probing.DEFAULT_PROBES,
    probe_states: int = PROBE_STATES,
    seed: int = 0,
    tolerances: Tolerances = TOLERANCES,
    cache: Cache | None = None,
) -> Derivation:
    """The hand derivation's verdict: every term at the model's parameters (the pointwise states and
    `values`) and at the probe parameter sets (`probe_set`, else `n_probes` drawn here), with the first
    disagreeing term named, where it is worst, whether the model's own values hide it, and which
    parameter alone exposes it. `cache`: where the explanations of wrong entries are kept (None: nowhere)."""

    result: Derivation = {"name": "hand derivation", "kind": "hand", "equations": system.derivation.__name__}
    rows, all_notes = _rows_at_model(system, states, sources, values, tolerances)
    probe_set = probe_set or derivation_probes(system, n_probes=n_probes, seed=seed)
    probe_rows, probe_notes = _rows_at_probes(probe_set, probe_states=probe_states, seed=seed, tolerances=tolerances)
    rows += probe_rows
    all_notes |= probe_notes
    _coverage(result, system, states, probe_set, probe_states)
    result["terms"] = rows
    result["summary"] = summarise(rows)
    if all_notes:
        result["notes"] = {str(k): v for k, v in all_notes.items()}
    if all(r["passed"] for r in rows):
        _agreement(result, sources, probe_set)
        return result
    _disagreement(result, system, rows, probe_set, (states, sources), seed=seed, tolerances=tolerances, cache=cache)
    _not_spd_note(result, all_notes)
    return result


def _in_your_words(system: System, explained: list[Explanation]) -> list[Explanation]:
    """The explanations with the model's symbols replaced by the person's names for them (the model's
    statement kept as `statement_model`)."""
    try:
        names, where = words.person_names(system), words.model_symbol_keys(system)
    except Exception:  # noqa: BLE001 - no names to give: the model's symbols stay
        return explained
    out = []
    for e in explained:
        said = str(e.get("statement", ""))
        mine = words.in_person_words(said, names, where)
        out.append(cast(Explanation, {**e, "statement": mine, "statement_model": said}) if mine != said else e)
    return out


def _unstated(system: System, term: str) -> list[str]:
    """What the failing term depends on that the derivation's parameters() does not read (only for a
    derivation whose probes move what it reads)."""
    if not probing.reads_model(system) or system.nv > SYMBOLIC_MAX_DOF:
        return []
    try:
        return words.unread_numbers(system, term)
    except Exception:  # noqa: BLE001 - a hint, never a failed run
        return []


ENGINE_NAMES = {"mujoco": "MuJoCo", "pinocchio": "Pinocchio", "drake": "Drake"}


def _engine_names(sources: Mapping[str, Source]) -> str:
    """ "MuJoCo, Pinocchio and Drake": the engines a derivation was judged against."""
    names = [ENGINE_NAMES[n] for n in engines_of(sources) if n in ENGINE_NAMES]
    return ", ".join(names[:-1]) + f" and {names[-1]}" if len(names) > 1 else "".join(names)


def exposing_fields(system: System, term: str, *, tolerances: Tolerances = TOLERANCES, seed: int = 0) -> list[str]:
    """The Params fields that, moved alone, make `term` disagree."""

    out = []
    for probe in probing.single_field_probes(system, seed=seed):
        ps = random_states(probe.system, n=64, seed=seed + 1)
        rows, _ = term_rows_at(probe.system, ps, make_sources(probe.system), tolerances=tolerances)
        if any(not r["passed"] for r in rows if r["term"] == term):
            out += list(probe.changed)
    return out


def summarise(rows: list[TermRow]) -> list[TermSummary]:
    """Per term: passed, the worst scaled error (engine and probe), the tolerance it was judged with
    (the smallest relative change of the term the check could have seen) and the term's scale."""
    out: list[TermSummary] = []
    for term in HAND_TERMS:
        mine = [r for r in rows if r["term"] == term]
        if not mine:
            continue
        worst = max(mine, key=lambda r: (not r["passed"], r["scaled"]))
        out.append(
            {
                "term": term,
                "passed": all(r["passed"] for r in mine),
                "worst_scaled": worst["scaled"],
                "engine": worst["engine"],
                "probe": worst.get("probe"),
                "tolerance": max(r["tolerance"] for r in mine),
                "scale": worst["scale"],
                "rows": len(mine),
            }
        )
    return out

"""Judges every printed form of the notes against MuJoCo and Pinocchio, term by term.

Nothing here knows which forms are right: a verdict comes from the comparison alone. A printed
form is split into terms by evaluating it where the other terms vanish (v = 0, tau = 0, zero
joint friction), so a disagreeing form is reported with the first term that disagrees:

    implicit  r(q, v, a, tau) = s * (M a + bias - passive - tau)     (s: the printed row scale)
        mass matrix    r(q, 0, e_j, 0) - r(q, 0, 0, 0)   vs  s M e_j
        gravity        r(q, 0, 0, 0)                      vs  s G
        velocity       r(q, v, 0, 0) - r(q, 0, 0, 0)      vs  s C v        (friction set to zero)
        friction       r(q, v, 0, 0) - r_0(q, v, 0, 0)    vs  -s passive
        actuation      r(q, 0, 0, tau) - r(q, 0, 0, 0)    vs  -s tau
        residual       r(q, v, a_engine, tau)             vs  0
    explicit  f(q, v, tau) = M^-1 (tau + passive - bias)
        gravity, velocity, friction, actuation likewise on accelerations; acceleration overall.
    derivation step: the printed expression vs the engines' kinematics or energies.

Every form is judged with the MJCF's parameters (the notes' values) and at DEFAULT_PROBES probe
parameter sets (validate/verdict/probes.py: every parameter moved by its own factor, keeping only the
equalities the printed forms assume), because a slip such as a missing factor l cannot show where
l = 1.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from ..core.cachedir import Cache
from ..core.errors import HarnessError
from ..core.tolerances import TOLERANCES, Tolerances
from ..forms import DerivationStep, Explicit, Implicit, NotApplicable, Variant
from ..handwritten.values import real_array
from ..results.schema import Derivation, Explanation, TermRow
from ..sources import make_source, make_sources
from ..sources.base import Source
from ..systems import System
from . import probes as probing
from .explain import Item, explain_entries, step_expression
from .explain_inputs import User
from .pointwise import States, force_scale, random_states
from .probes import DEFAULT_PROBES, Probe, describe_ties
from .terms import TERM_ORDER, EngineTerms, EngineValues, engine_quantity, frictionless_params, term_rows


def _printed_parameter_rows(system: System, variant: Variant) -> list[TermRow]:
    rows: list[TermRow] = []
    for field, printed in sorted(getattr(variant, "printed_parameters", {}).items()):
        compiled = float(getattr(system.params, field))
        err = abs(printed - compiled)
        scale = max(abs(compiled), abs(printed), np.finfo(float).tiny)
        rows.append(
            {
                "term": "printed parameters",
                "engine": "mjcf",
                "pair": f"printed~mjcf:{field}",
                "max_abs": err,
                "max_rel": err / scale,
                "scale": scale,
                "scaled": err / scale,
                "tier": "algebraic",
                "tolerance": TOLERANCES.algebraic.rtol,
                "passed": bool(err / scale <= TOLERANCES.algebraic.rtol),
                "worst_state": {"printed": printed, "compiled": compiled},
            }
        )
    return rows


def _step_rows(
    system: System, variant: DerivationStep, terms: EngineTerms, states: States, tolerances: Tolerances
) -> list[TermRow]:
    """A derivation step's printed expression against the engines' kinematics or energies."""
    printed = real_array(f"{variant.name} evaluate()", variant.evaluate(system.params, states.q, states.v))
    refs = {
        n: engine_quantity(system, terms, variant.quantity, n, states, variant.angle_index) for n in terms.by_engine
    }
    printed = np.broadcast_to(printed, refs["mujoco"].shape)
    # An energy with V in it is defined up to a constant (its zero, the bodies welded to the world).
    constant = variant.quantity[0] in ("potential_energy", "lagrangian")
    return term_rows("value", printed, refs, states, tier="algebraic", tolerances=tolerances, up_to_constant=constant)


def _implicit_rows(
    system: System,
    variant: Implicit,
    terms: EngineTerms,
    states: States,
    p0: object,
    tolerances: Tolerances,
) -> list[TermRow]:
    """An implicit form's residual split into terms (module docstring), each against the engines'
    scaled by the printed row scale, and the residual at the engines' accelerations (`p0`: the
    parameters without joint friction)."""
    p = system.params
    q, v, tau = states.q, states.v, states.tau
    zero = np.zeros_like(q)
    uses = system.uses
    e = terms.by_engine

    def r(*args: object) -> np.ndarray:
        return real_array(f"{variant.name} residual()", variant.residual(*args))

    s = real_array(f"{variant.name} row_scale()", variant.row_scale(p))
    r00 = r(p, q, zero, zero, zero)
    n = system.nv
    cols = [r(p, q, zero, np.broadcast_to(np.eye(n)[j], q.shape), zero) - r00 for j in range(n)]
    mass = np.stack(cols, axis=-1)
    rows = term_rows(
        "mass matrix",
        mass,
        {k: s[:, None] * e[k]["M"] for k in e},
        states,
        tier="algebraic",
        tolerances=tolerances,
    )
    if "gravity" in uses:
        rows += term_rows(
            "gravity", r00, {k: s * e[k]["G"] for k in e}, states, tier="algebraic", tolerances=tolerances
        )
    vel = r(p0, q, v, zero, zero) - r(p0, q, zero, zero, zero)
    rows += term_rows(
        "velocity",
        vel,
        {k: s * e[k]["Cv"] for k in e},
        states,
        tier="algebraic",
        tolerances=tolerances,
        min_scale={k: float(np.abs(s).max()) * force_scale(e[k]["M"], v) for k in e},
    )
    if "damping" in uses:
        fr = r(p, q, v, zero, zero) - r(p0, q, v, zero, zero)
        rows += term_rows(
            "friction",
            fr,
            {k: -s * e[k]["passive"] for k in e},
            states,
            tier="algebraic",
            tolerances=tolerances,
        )
    if "actuation" in uses:
        act = r(p, q, zero, zero, tau) - r00
        rows += term_rows("actuation", act, {k: -s * tau for k in e}, states, tier="algebraic", tolerances=tolerances)
    residual = {k: r(p, q, v, e[k]["a"], tau) for k in e}
    for k in e:  # the residual at the engine's own accelerations should vanish
        scale = float(np.abs(s * (e[k]["Cv"] + e[k]["G"])).max())
        rows += term_rows(
            "residual",
            residual[k],
            {k: np.zeros_like(residual[k])},
            states,
            tier="solve",
            tolerances=tolerances,
            min_scale={k: scale},
        )
    return rows


def _explicit_rows(
    system: System,
    variant: Explicit,
    terms: EngineTerms,
    states: States,
    p0: object,
    tolerances: Tolerances,
) -> list[TermRow]:
    """An explicit (or Matlab state-space) form's accelerations split into terms, each against the
    engines' accelerations from that term alone, and the acceleration overall (`p0`: the parameters
    without joint friction)."""
    p = system.params
    q, v, tau = states.q, states.v, states.tau
    zero = np.zeros_like(q)
    uses = system.uses
    e = terms.by_engine

    def f(*args: object) -> np.ndarray:
        return real_array(f"{variant.name} acceleration()", variant.acceleration(*args))

    f00 = f(p, q, zero, zero)

    def against(term: str, value: np.ndarray, key: str) -> list[TermRow]:
        """`term`'s rows: `value` against each engine's accelerations `key`."""
        return term_rows(term, value, {k: e[k][key] for k in e}, states, tier="solve", tolerances=tolerances)

    rows: list[TermRow] = against("gravity", f00, "a_gravity") if "gravity" in uses else []
    rows += against("velocity", f(p0, q, v, zero) - f(p0, q, zero, zero), "a_velocity")
    if "damping" in uses:
        rows += against("friction", f(p, q, v, zero) - f(p0, q, v, zero), "a_friction")
    if "actuation" in uses:
        rows += against("actuation", f(p, q, zero, tau) - f00, "a_actuation")
    rows += against("acceleration", f(p, q, v, tau), "a")
    return rows


def judge_variant(
    system: System,
    variant: Variant,
    terms: EngineTerms,
    states: States,
    *,
    tolerances: Tolerances = TOLERANCES,
    printed_parameters: bool = True,
) -> Derivation:
    """One printed form's verdict, with every separated term against both engines."""
    result: Derivation = {
        "name": variant.name,
        "kind": variant.kind,
        "notes_equations": list(variant.notes_equations),
        "note": variant.note,
    }
    try:
        p0 = frictionless_params(system)
        rows = _printed_parameter_rows(system, variant) if printed_parameters else []
        if isinstance(variant, DerivationStep):
            rows += _step_rows(system, variant, terms, states, tolerances)
        elif isinstance(variant, Implicit):
            rows += _implicit_rows(system, variant, terms, states, p0, tolerances)
        else:  # explicit and Matlab state-space forms
            rows += _explicit_rows(system, variant, terms, states, p0, tolerances)
    except NotApplicable as exc:  # a printed form that does not apply to these parameters
        result.update({"verdict": "not applicable", "reason": str(exc), "terms": []})
        return result
    rows.sort(key=lambda r: (TERM_ORDER.index(r["term"]), r["engine"]))
    failing = [r for r in rows if not r["passed"]]
    result["terms"] = rows
    result["verdict"] = "agrees" if not failing else "disagrees"
    if failing:
        worst = max(failing, key=lambda r: r["scaled"])
        result["first_disagreeing_term"] = failing[0]["term"]
        result["worst_term"] = {
            "term": worst["term"],
            "engine": worst["engine"],
            "max_abs": worst["max_abs"],
            "max_rel": worst["max_rel"],
            "scaled": worst["scaled"],
            "worst_state": worst["worst_state"],
        }
    return result


def _combine(judged: list[tuple[Probe, Derivation]]) -> Derivation:
    """One verdict from every parameter set (the model's first, then the probes); the first
    disagreement named is the one at the earliest parameter set that disagrees."""
    nominal = judged[0][1]
    out = nominal.copy()
    out["terms"] = []
    for probe, verdict in judged:
        for r in verdict.get("terms", []):
            r["parameters"] = probe.label
            r["probe"] = probe.index
        out["terms"] += verdict.get("terms", [])
    out["probes"] = [probe.as_dict() for probe, _ in judged]
    verdicts = [v["verdict"] for _, v in judged]
    if "disagrees" in verdicts:
        probe, first = next((p, v) for p, v in judged if v["verdict"] == "disagrees")
        out["verdict"] = "disagrees"
        out["first_disagreeing_term"] = first["first_disagreeing_term"]
        out["disagrees_at"] = probe.label
        out["hidden_by_model_values"] = probe.index != 0
        if probe.index != 0:
            out["disagrees_where"] = probe.describe()
        failing = [r for r in out["terms"] if not r["passed"]]
        worst = max(failing, key=lambda r: r["scaled"])
        out["worst_term"] = {
            "term": worst["term"],
            "engine": worst["engine"],
            "parameters": worst["parameters"],
            "max_abs": worst["max_abs"],
            "max_rel": worst["max_rel"],
            "scaled": worst["scaled"],
            "worst_state": worst["worst_state"],
        }
    elif set(verdicts) == {"agrees"}:
        out["verdict"] = "agrees"
    else:
        out["verdict"] = "not applicable"
        out["reason"] = next(v["reason"] for _, v in judged if v["verdict"] == "not applicable")  # judge_variant's
    return out


def printed_probes(system: System, *, n_probes: int, seed: int) -> tuple[list[Probe], list[str]]:
    """The parameter sets the printed forms are judged at: the model's, and probes that keep the
    equalities the notes' printed forms assume (`PRINTED_FORMS_ASSUME` of the module)."""

    ties = tuple(getattr(system.equations, "PRINTED_FORMS_ASSUME", ()))
    try:
        return probing.probes(system, k=n_probes, seed=seed, ties=ties, family="printed")
    except HarnessError as exc:  # the derivation's parameters() misreads: judged at the model's only
        return [probing.Probe(0, "model", system, {})], [str(exc)]


def judge_system(
    system: System,
    states: States,
    sources: Mapping[str, Source],
    *,
    tolerances: Tolerances = TOLERANCES,
    values: EngineValues | None = None,
    n_probes: int = DEFAULT_PROBES,
    probe_states: int = 100,
    seed: int = 0,
    cache: Cache | None = None,
) -> list[Derivation]:
    """Verdicts for every printed form of one system, at the model's parameters and at `n_probes`
    probe parameter sets (verdict/probes.py).

    `values`: the engines' quantities `compare.evaluate` already computed at `states`, if any;
    `cache`: where the explanations of wrong forms are kept (None: nowhere)."""
    if not system.variants:
        return []

    probe_list, problems = printed_probes(system, n_probes=n_probes, seed=seed)
    ties = tuple(getattr(system.equations, "PRINTED_FORMS_ASSUME", ()))
    per_probe = [(probe_list[0], states, EngineTerms(system, sources, states, values))]
    for probe in probe_list[1:]:
        ps = random_states(probe.system, n=probe_states, seed=seed + probe.index)
        per_probe.append((probe, ps, EngineTerms(probe.system, make_sources(probe.system), ps)))
    verdicts = [
        _combine(
            [
                (
                    probe,
                    judge_variant(
                        probe.system,
                        var,
                        terms,
                        ps,
                        tolerances=tolerances,
                        printed_parameters=probe.index == 0,
                    ),
                )
                for probe, ps, terms in per_probe
            ]
        )
        for var in system.variants
    ]
    for var, v in zip(system.variants, verdicts, strict=True):
        v["assumes"] = describe_ties(ties)
        v["probe_problems"] = problems
        if v["verdict"] == "disagrees":
            failing = sorted({r["term"] for r in v["terms"] if not r["passed"]})
            v["explanations"] = explain_variant(
                system, var, [p.system for p in probe_list[1:]], failing, seed=seed, cache=cache
            )
    return verdicts


def _entry_label(name: str, shape: tuple[int, ...], index: tuple[int, ...]) -> str:
    if not shape:
        return name
    if len(shape) == 1:
        return f"{name}[{'xyz'[index[0]] if shape == (3,) else index[0]}]"
    return f"{name}[{index[0]},{index[1]}]"


def _step_items(system: System, variant: DerivationStep) -> list[Item]:
    """A derivation step's entries to explain: the model's expression of its quantity entry by entry,
    against the printed form's value of that entry."""
    items: list[Item] = []
    expr = step_expression(system, variant.quantity, variant.angle_index)
    shape = tuple(expr.shape) if hasattr(expr, "shape") else ()
    shape = (shape[0],) if len(shape) == 2 and shape[1] == 1 else shape
    for index in np.ndindex(*shape) if shape else [()]:
        entry = expr[index] if len(index) == 2 else expr[index[0]] if index else expr

        def user(s: System, q: np.ndarray, v: np.ndarray, index: tuple[int, ...] = index) -> np.ndarray:
            out = real_array(f"{variant.name} evaluate()", variant.evaluate(s.params, q, v), (len(q), *shape))
            where: tuple[slice | int, ...] = (slice(None), *index)
            return np.asarray(out[where])

        items.append(("value", _entry_label(variant.name, shape, index), entry, user))
    return items


def _acceleration_items(system: System, variant: Explicit, failing: list[str]) -> list[Item]:
    """An explicit form's failing terms to explain, coordinate by coordinate: the numerators det M times
    the acceleration (-adj(M) G, -adj(M) C v, adj(M) passive), against det M times the printed form's."""
    from ..sources.symbolic import derivation_of
    from ..symbolic.readable import transformed

    items: list[Item] = []
    d, names = derivation_of(system), tuple(system.coordinates)
    M = transformed(d, names, system.joint_map, "M")
    adj = M.adjugate()
    numerators = {
        "gravity": -adj * transformed(d, names, system.joint_map, "G"),
        "velocity": -adj * transformed(d, names, system.joint_map, "Cv"),
        "friction": adj * transformed(d, names, system.joint_map, "passive"),
    }

    sources: dict[int, Source] = {}

    def symbolic_of(s: System) -> Source:  # one per probe system, not one per entry
        if id(s) not in sources:
            sources[id(s)] = make_source(s, "symbolic")
        return sources[id(s)]

    def accel(term: str, i: int) -> User:
        def user(s: System, q: np.ndarray, v: np.ndarray) -> np.ndarray:
            f = variant.acceleration
            zero = np.zeros_like(q)
            p, p0 = s.params, frictionless_params(s)
            parts: dict[str, Callable[[], np.ndarray]] = {
                "gravity": lambda: f(p, q, zero, zero),
                "velocity": lambda: np.asarray(f(p0, q, v, zero)) - np.asarray(f(p0, q, zero, zero)),
                "friction": lambda: np.asarray(f(p, q, v, zero)) - np.asarray(f(p0, q, v, zero)),
            }
            a = parts[term]()
            det = np.linalg.det(symbolic_of(s).mass_matrix(q))
            return np.asarray(det * real_array(f"{variant.name} acceleration()", a)[:, i])

        return user

    for term in failing:
        if term in numerators:
            for i, c in enumerate(names):
                items.append((term, f"det(M) * {term} acceleration[{c}]", numerators[term][i], accel(term, i)))
    return items


def explain_variant(
    system: System,
    variant: Variant,
    probe_systems: list[System],
    failing: list[str],
    *,
    seed: int = 0,
    cache: Cache | None = None,
) -> list[Explanation]:
    """A wrong printed form's disagreeing entries as symbolic differences from the model's own
    equations (verdict/explain.py), at the probes that keep the printed form's equalities: a derivation
    step's value entry by entry; an explicit form's accelerations by term, through their numerators
    (det M times the acceleration, against -adj(M) G, -adj(M) C v, adj(M) passive). Parameters the
    printed form assumes equal cannot be told apart by the fit. An explanation that cannot be computed
    is one line saying why."""
    import sympy as sp

    try:
        items: list[Item] = []
        if isinstance(variant, DerivationStep):
            items = _step_items(system, variant)
        elif hasattr(variant, "acceleration") and not isinstance(variant, Implicit):
            items = _acceleration_items(system, variant, failing)
        return explain_entries(system, probe_systems, items, seed=seed, cache=cache)
    except Exception as exc:  # noqa: BLE001 - a printed form the symbolic basis cannot hold
        return [
            {
                "term": failing[0] if failing else "?",
                "entry": "",
                "explained": False,
                "statement": f"no symbolic explanation: {type(exc).__name__}: {exc}".strip(),
                "expected": sp.sstr(0),
            }
        ]

"""Parts of a system's section: the derivation's terms and probes, equivalence of coordinate sets,
chaos and the mirrors, the notes' experiments, and what the scene skips.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..results.schema import (
    ChaosStudy,
    Derivation,
    EquivalenceRow,
    ExperimentRun,
    Experiments,
    Explanation,
    FreeRun,
    FreeRunCheck,
    MirrorCheck,
    SystemResult,
)
from ..results.stages import outcome
from .document import (
    ERRATA,
    NOT_RUN,
    Cell,
    Code,
    Document,
    Mark,
    Num,
    as_float,
    pass_mark,
    ratio,
    sci,
    slug,
    vec,
    verdict_mark,
)
from .figstore import kept
from .figures import LEGEND_W, legend_right, new_figure, png, rc, series
from .findings import (
    CHAOS_LAMBDA,
    chaos_facts,
    derivation_label,
    has_derivation,
    is_chaotic,
    is_damped,
    is_user,
    whose,
)
from .runs import judged_verdict, run_verdict


def system_skipped(doc: Document, name: str, s: SystemResult) -> None:
    stages = {k: why for k, v in (s.get("stages") or {}).items() if (why := outcome(v))}
    if stages:
        doc.table(
            f"Stages of {name} not run or failed",
            ("stage", "outcome"),
            [(k, Mark("bad", v) if v.startswith("failed") else v) for k, v in sorted(stages.items())],
        )
    skipped = s.get("skipped")
    if skipped:
        doc.table(f"Work {name} does not need, skipped", ("skipped",), [(x,) for x in skipped])


def system_derived(doc: Document, name: str, s: SystemResult) -> None:
    """The model's own equations of motion, derived symbolically: the fourth source, readable."""
    d = s.get("derived")
    doc.h(3, "Equations of motion derived from the model", f"{slug(name)}-derived")
    if not d:
        doc.p(f"Derived equations: {NOT_RUN}.", "missing")
        return
    names = d.get("coordinates", [])
    doc.p(
        "The model's own equations, derived from its compiled numbers by "
        + ("the notes' section-3 method" if not is_user(s) else "the rotation-matrix method")
        + " (rotation matrix per joint, centre-of-mass velocities, body-frame inertia, Lagrange's equations with the "
        "Christoffel symbols of M), independently of both engines"
        + (f" and of {derivation_label(s)}" if has_derivation(s) else "")
        + "; the `symbolic` source of the comparisons. Parameters are named after the model's elements; "
        "`d<name>` is a velocity. `lagrange-xval derive` prints them (`--latex`, `--python`)."
    )
    n = len(names)
    lines = [f"T = {d['T']['text']}", f"V = {d['V']['text']}"]
    lines += [f"M[{names[i]}, {names[j]}] = {d['M'][i][j]['text']}" for i in range(n) for j in range(i, n)]
    lines += [f"(C v)[{c}] = {d['Cv'][i]['text']}" for i, c in enumerate(names)]
    lines += [f"G[{c}] = {d['G'][i]['text']}" for i, c in enumerate(names)]
    if any(x["text"] != "0" for x in d.get("passive", [])):
        lines += [f"passive[{c}] = {d['passive'][i]['text']}" for i, c in enumerate(names)]
    doc.blocks.append(Code("\n".join(lines)))
    doc.table(
        f"Symbols of {name}'s derived equations: each is the model's number read as shown (the symbols are positive)",
        ("symbol", "unit"),
        [symbol_row(k, v) for k, v in sorted(d.get("parameters", {}).items())],
    )


def symbol_row(symbol: str, meaning: str) -> tuple[str, str]:
    """("c_link1 = -body/link1/com[2]", "m") from the results' "-body/link1/com[2], m"."""
    reading, _, unit = str(meaning).rpartition(", ")
    return (f"`{symbol} = {reading or meaning}`", unit if reading else "–")


def system_derivation(doc: Document, name: str, s: SystemResult) -> None:
    """The hand derivation's verdict: every term, at the model's parameters and at every probe."""
    d = s.get("derivation")
    if not d:
        doc.p(f"Derivation verdict: {NOT_RUN}.", "missing")
        return
    if d.get("kind") == "none":  # the model alone
        doc.p(f"No hand derivation was given: {d.get('statement')}.", "note")
        return
    ok = d.get("verdict") == "agrees"
    label = derivation_label(s)
    owner = "yours" if is_user(s) else label
    doc.p(
        f"{'✓' if ok else '✗'} {label[:1].upper()}{label[1:]}: {d.get('statement', d.get('verdict'))}.",
        "pass" if ok else "fail",
    )
    checked = d.get("checked", {})
    at_probes = (
        f" and at {checked.get('states_per_probe')} states with each of {checked.get('probes')} probe parameter sets, "
        "in which every parameter of the derivation moves by its own factor in [0.5, 0.8] or [1.25, 2] (a link's "
        "mass, centre and inertia drawn together, as one rigid body), so that a "
        "mistake the model's values hide (l1 l2 for l2², m2 for m1, a lost factor l) shows"
        if checked.get("probes")
        else " only (no probe parameter sets: a mistake the model's values hide would not show)"
    )
    doc.p(
        f"Each term of `{s.get('equations', '?')}` is compared with both engines at {checked.get('states_at_model')} "
        f"random states with the model's own parameters{at_probes}. `tolerance` is the smallest change of the term, "
        "relative to its largest value over the states (`scale`), that the check could have seen."
    )
    doc.table(
        f"Terms of {name}'s derivation against the engines, at the model's parameters and every probe",
        ("term", "verdict", "worst scaled error", "engine", "at", "tolerance", "scale"),
        [
            (
                r.get("term"),
                pass_mark(r.get("passed")),
                Num(r.get("worst_scaled")),
                r.get("engine"),
                "model" if r.get("probe") == 0 else (f"probe {r.get('probe')}" if r.get("probe") else "–"),
                Num(r.get("tolerance"), short=True),
                Num(r.get("scale")),
            )
            for r in d.get("summary", [])
        ],
    )
    _derivation_differences(doc, name, d.get("explanations", []), owner)
    for finding in d.get("structure", []):  # verdict/structure.py: the person's own functions, by themselves
        doc.p(f"The property of every Lagrangian derivation it breaks: {finding['statement']}.", "note")
    _failing_terms_table(doc, name, d)
    probes = [p for p in d.get("probes", []) if p.get("index")]
    if probes:
        doc.table(
            f"Probe parameter sets of {name}'s derivation",
            ("probe", "parameters moved (model's value -> probe's)"),
            [
                (
                    p.get("label"),
                    ", ".join(f"{k} {a:.4g} -> {b:.4g}" for k, (a, b) in sorted(p.get("changed", {}).items())),
                )
                for p in probes
            ],
        )
    if d.get("not_checked") or s.get("pointwise", {}).get("not_checked"):
        doc.p(
            "Not checked (the derivation does not provide them, so nothing is claimed about them): "
            + "; ".join([*d.get("not_checked", []), *s.get("pointwise", {}).get("not_checked", [])])
            + "."
        )
    if d.get("held_at_zero"):
        doc.p(
            f"Zero in the model and so at every probe (the terms they scale are not tested): "
            f"{', '.join(d['held_at_zero'])}.",
            "note",
        )
    for problem in d.get("probe_problems", []):
        doc.p(f"Probe not built: {problem}", "missing")


def _derivation_differences(doc: Document, name: str, explanations: list[Explanation], owner: str) -> None:
    """The failing entries' symbolic differences: as slips one mistake makes, or folded when no single
    slip reproduces them."""
    explained = [e for e in explanations if e.get("explained")]
    if explanations and not explained:
        entries = ", ".join(str(e.get("entry")) for e in explanations)
        inner = Document()
        differences_table(inner, name, explanations, owner)
        doc.p(
            f"No single slip reproduces the differences of {len(explanations)} "
            f"entr{'y' if len(explanations) == 1 else 'ies'} ({entries}): more than one mistake, or one the "
            "harness does not model (the differences are folded below).",
            "note",
        )
        doc.fold(f"The {len(explanations)} differences against the model's equations", inner)
    elif explanations:
        doc.p(
            "What the wrong expressions lack, against the model's own equations derived symbolically (`lagrange-xval "
            "derive`): each disagreeing entry's difference fitted onto the slips one mistake makes (a lost or doubled "
            "term, a flipped sign, a swapped parameter, a lost factor, sin for cos), kept only where it reproduces "
            "your numbers at states held back from the fit."
        )
        differences_table(doc, name, explanations, owner)


def _failing_terms_table(doc: Document, name: str, d: Derivation) -> None:
    """Where the failing terms are worst (the first 12 failing rows)."""
    failing = [r for r in d.get("terms", []) if not r.get("passed")]
    if failing:
        doc.table(
            f"Where {name}'s failing terms are worst",
            ("term", "pair", "at", "scaled error", "q", "v", "why"),
            [
                (
                    r.get("term"),
                    r.get("pair"),
                    "model" if r.get("probe") == 0 else f"probe {r.get('probe')}",
                    Num(r.get("scaled")),
                    vec((r.get("worst_state") or {}).get("q", [])),
                    vec((r.get("worst_state") or {}).get("v", [])),
                    r.get("error", ""),
                )
                for r in failing[:12]
            ],
        )


def differences_table(doc: Document, name: str, explanations: list[Explanation], owner: str = "yours") -> None:
    doc.table(
        f"Symbolic differences of {name}'s derivation",
        ("entry", "difference from the model's equations", "expected", "parameters"),
        [
            (
                e.get("entry"),
                whose(e.get("statement") if e.get("explained") else f"(not explained) {e.get('statement')}", owner),
                e.get("expected", ""),
                "; ".join(f"{k} = {v}" for k, v in sorted(e.get("symbols", {}).items())),
            )
            for e in explanations
        ],
    )


def system_equivalence(doc: Document, name: str, s: SystemResult) -> None:
    eq = s.get("equivalence")
    if not eq:
        return
    doc.p(
        f"{name} and `{eq['other']}` are the same physical chain in other coordinates (q = B q_other, "
        f"B = {np.asarray(eq['map']).tolist()}): their hand equations must map onto each other."
    )
    rows = eq["rows"]
    worst: dict[str, EquivalenceRow] = {}
    for r in rows:
        if r["quantity"] not in worst or ratio(r) > ratio(worst[r["quantity"]]):
            worst[r["quantity"]] = r
    doc.table(
        f"{name} mapped onto {eq['other']}, one line per quantity: its worst parameter set",
        ("quantity", "worst at", "max abs", "scaled", "tolerance", "verdict"),
        [
            (
                q,
                r.get("parameters", "–"),
                Num(r["max_abs"]),
                Num(r["scaled"]),
                Num(r["tolerance"], short=True),
                pass_mark(all(x["passed"] for x in rows if x["quantity"] == q)),
            )
            for q, r in worst.items()
        ],
    )
    every = Document()
    every.table(
        f"{name} mapped onto {eq['other']} at {eq['n_states']} random states, at each parameter set",
        ("parameters", "quantity", "max abs", "scaled", "tolerance", "verdict"),
        [
            (
                r.get("parameters", "–"),
                r["quantity"],
                Num(r["max_abs"]),
                Num(r["scaled"]),
                Num(r["tolerance"], short=True),
                pass_mark(r["passed"]),
            )
            for r in rows
        ],
        group=True,
    )
    doc.fold(f"All {len(rows)} rows, by parameter set", every)


def system_chaos(doc: Document, name: str, s: SystemResult) -> None:
    cx = s.get("chaos")
    if not cx:
        doc.p(f"Chaos and integrator cross-validation: {NOT_RUN}.", "missing")
        return
    ref, ch = cx.get("reference", {}), cx.get("chaos", {})
    facts = chaos_facts(s)
    chaotic = bool(facts and facts["chaotic"])
    if facts and chaotic:
        doc.p(
            f"{name} moves chaotically from its initial state: the largest Lyapunov exponent is "
            f"{facts['lambda']:.3g} 1/s, and the rounding of the initial state alone grows to "
            f"{sci(facts['tolerance'])} rad by {facts['horizon']:g} s."
        )
    elif facts:
        grows = (
            f"grows to {sci(facts['tolerance'])} rad only by {facts['horizon']:g} s"
            if facts["horizon"] is not None
            else f"stays below {sci(facts['tolerance'])} rad for the {facts['t_end']:g} s computed"
        )
        doc.p(
            f"{name} is not chaotic from its initial state: the largest Lyapunov exponent is {facts['lambda']:.3g} 1/s "
            f"(below {CHAOS_LAMBDA:g} 1/s: no exponential growth of errors over the runs"
            + (", the friction damps the motion" if is_damped(s) else "")
            + f"), and the rounding of the initial state {grows}."
        )
    doc.p(
        f"Reference solution: the hand equations by {ref.get('method', '?')} in {ref.get('precision', '?')} "
        f"(tolerance {sci(ref.get('tolerance'))}); a second method ({ref.get('check_method', '?')}) agrees to "
        f"{sci(ref.get('agreement_q'))} rad in q over the run, and the traced right-hand side matches the "
        f"numpy equations to {sci(ref.get('rhs_check'))} (relative)."
    )
    lyap, lyap2 = ch.get("lyapunov", {}), ch.get("lyapunov_two_trajectories", {})
    amp = ch.get("amplification_at", {})
    hz = ch.get("horizon_from_rounding", {})
    rows: list[tuple[str, Cell]] = [
        ("largest Lyapunov exponent, variational equations (1/s)", Num(lyap.get("lambda"), 3)),
        ("largest Lyapunov exponent, two nearby trajectories (1/s)", Num(lyap2.get("lambda"), 3)),
    ]
    rows += [
        (f"amplification of an initial error at {k}", Num(v, 3))
        for k, v in sorted(amp.items(), key=lambda kv: as_float(kv[0].split()[0]))
    ]
    never = f"never within {as_float(hz.get('t_end')):g} s"
    rows += [
        (
            f"predictability horizon at {sci(hz.get('tolerance'))} rad from rounding ({sci(hz.get('e0'))}) (s)",
            Num(hz.get("horizon"), 3) if hz.get("horizon") is not None else never,
        ),
        (
            "the same, estimated from the exponent (s)",
            Num(ch.get("horizon_estimate_from_lambda"), 3) if chaotic else "– (no chaos: not estimated)",
        ),
    ]
    doc.table(f"{'Chaos' if chaotic else 'Error growth'} of {name} from its initial state", ("quantity", "value"), rows)
    _integrators_table(doc, name, s, cx, chaotic=chaotic)


def _integrators_table(doc: Document, name: str, s: SystemResult, cx: ChaosStudy, *, chaotic: bool) -> None:
    """Per MuJoCo integrator: the free run against the reference with its verdict, the mirrors, the
    convergence order and the energy; then what the mirrors are, and which free runs are judged short."""
    integ = cx.get("integrators", {})
    if not integ:
        return
    rows = []
    short: list[str] = []
    t_end = as_float(cx.get("t_end", (s.get("trajectories") or {}).get("t_end")))
    for iname, r in sorted(integ.items()):
        if "free_run" not in r:
            continue  # every integrator's entry has one (dynamics/chaos._integrator_entry)
        fr = r["free_run"]
        mirrors = r.get("mirrors", {})
        conv = r.get("convergence", {})
        energy = r.get("energy", {})
        verdict, note = _free_run_verdict(s, iname, fr, t_end)
        short += [note] if note else []
        rows.append(
            (
                iname,
                Num(fr.get("max_error")),
                verdict,
                Num(_difference(mirrors, "mujoco~hand")),
                Num(_difference(mirrors, "mujoco~pinocchio")),
                Num(conv.get("order"), 3),
                Num(conv.get("expected"), 2),
                Num(energy.get("relative")),
            )
        )
    doc.table(
        f"MuJoCo integrators on {name} at the MJCF timestep {sci(cx.get('timestep'))} s: free run against the "
        f"reference, mirrors, convergence, energy",
        (
            "integrator",
            "free-run max error, whole run (rad)",
            "verdict of its free run",
            "mirror hand (rad)",
            "mirror Pinocchio (rad)",
            "order",
            "expected",
            "energy change (rel.)" if is_damped(s) else "energy drift (rel.)",
        ),
        rows,
    )
    doc.p(
        "The mirrors apply MuJoCo's own scheme (operation for operation) to the hand equations and to "
        "Pinocchio's ABA: a stepped MuJoCo trajectory and its mirror differ by rounding only"
        + (", amplified by the chaos" if chaotic else "")
        + ". The free run is judged against an error envelope that grows with the measured "
        "amplification, up to where the envelope reaches the tolerance (a free run that is the trajectory table's "
        "MuJoCo run carries that table's verdict, stated once); the order is measured from a timestep sweep."
    )
    short += [note for iname, r in sorted(integ.items()) for note in mirror_notes(iname, r.get("mirrors", {}))]
    if short:
        doc.items(short)


def _free_run_verdict(s: SystemResult, integrator: str, fr: FreeRunCheck, t_end: float) -> tuple[Mark | str, str]:
    """A MuJoCo integrator's free run: its verdict (the trajectory table's, where it is that run), and why it
    is judged short of the run where it is (else "")."""
    same = same_run(s, integrator, fr)
    if same is not None:
        stated = run_verdict(same, s.get("trajectories") or {})
        if isinstance(stated, Mark):
            stated = Mark(stated.state, f"{stated.text} (the trajectory table's run)")
        return stated, ""
    judge = fr.get("judge", {})
    until = judge.get("judged_until")
    why = f"its own error, propagated, reaches {sci(judge.get('tolerance'))} rad there"
    verdict = judged_verdict(judge.get("passed"), until, t_end, why, fr.get("max_error"), judge.get("tolerance"))
    if not (judge.get("passed") is True and until is not None and not (as_float(until) >= t_end)):
        return verdict, ""
    return verdict, (
        f"MuJoCo {integrator}: its own error per output interval (up to {sci(fr.get('max_window_error'))} "
        f"rad), propagated, reaches {sci(judge.get('tolerance'))} rad at {as_float(until):g} s, so its "
        f"free run is judged only until then; its whole-run error {sci(fr.get('max_error'))} rad is "
        "shown, not judged."
    )


def _difference(mirrors: Mapping[str, MirrorCheck], pair: str) -> float | None:
    """A mirror's largest difference from MuJoCo (rad); None where there is no such mirror."""
    mirror = mirrors.get(pair)
    return None if mirror is None else mirror.get("max_difference")


MIRROR_OF = {"mujoco~hand": "the hand equations", "mujoco~pinocchio": "Pinocchio's ABA"}


def mirror_notes(integrator: str, mirrors: Mapping[str, MirrorCheck]) -> list[str]:
    """What a mirror's number alone does not say: not judged, judged short of the run, or failed, and why."""
    notes = []
    for pair, m in sorted(mirrors.items()):
        what = f"MuJoCo {integrator}'s mirror on {MIRROR_OF.get(pair, pair)}"
        if m.get("judged") is False:
            notes.append(f"{what}: {m.get('why_not_judged', 'not judged')}.")
        elif m.get("judged_short"):
            until = (m.get("judge") or {}).get("judged_until")
            verdict = "agrees" if m.get("passed") else "disagrees"
            spent = str(m["judged_short"]).removeprefix("stopped: budget: ")
            notes.append(
                f"{what}: the harness's wall-time budget stopped it ({spent}), which says nothing of the "
                f"equations; it {verdict} until {as_float(until):g} s, as far as it is judged."
            )
        elif m.get("passed") is False and m.get("reason"):
            notes.append(f"{what} fails: {m['reason']}.")
    return notes


def same_run(s: SystemResult, integrator: str, free_run: FreeRunCheck) -> FreeRun | None:
    """The trajectory table's MuJoCo run when it is this integrator's free run (same integrator and
    timestep, from the same start): its verdict is then stated once, in the trajectory table's words."""
    tr = s.get("trajectories") or {}
    step = free_run.get("timestep")
    if step is None:
        return None
    method = f"MuJoCo {integrator} dt {as_float(step):g}"
    return next(
        (
            r
            for r in tr.get("runs", [])
            if r.get("source") == "mujoco" and r.get("method") == method and not r.get("label")
        ),
        None,
    )


def _when(x: float | str | None, t_end: float) -> str:
    """A separation or departure time, or never within the experiment's `t_end`."""
    return f"{as_float(x):.2f} s" if x is not None else f"never ({t_end:g} s)"


def _experiment_intro(doc: Document, ex: Experiments, notes: str | None) -> None:
    """The starts, the perturbation, the integrator, and what separation and departure mean."""
    coord = ex.get("perturbed_coordinate", "q")
    what = f"The notes' experiment ({notes})" if notes else "A perturbation experiment"
    doc.p(
        f"{what}: from q0 = {np.asarray(ex['q0']).tolist()}, v0 = {np.asarray(ex['v0']).tolist()}, "
        f"and from {coord}0 + {ex['perturbation']:g}, every dynamic form integrated by {ex['method']}. "
        f"Separation: when the two starts differ by more than {ex['resemblance']:g} rad; departure: when the "
        f"unperturbed run departs by as much from the accurate solution ({ex['accurate']})."
    )


def _separation_table(doc: Document, name: str, s: SystemResult, notes: str | None, t_end: float) -> None:
    """Every form's separation and departure times beside its verdict; the wrong forms named below."""
    ex = s.get("experiments") or {}  # the callers hold experiments
    verdicts = {v.get("name"): v.get("verdict") for v in s.get("variants", [])}
    of_notes = "notes' " if notes else ""

    def form_verdict(form: str) -> Mark:
        if form == "hand derivation":
            return verdict_mark((s.get("derivation") or {}).get("verdict", ""))
        return verdict_mark(str(verdicts.get(form, "–")))  # as the table prints it

    def integration(r: ExperimentRun) -> str:
        status = str(r.get("status", ""))
        return "completed" if status == "ok" else status

    rows = [
        (
            r["form"],
            form_verdict(r["form"]),
            Num(r["rtol"], 1),
            _when(r.get("separation_time"), t_end),
            _when(r.get("departure_time"), t_end),
            integration(r),
        )
        for r in ex.get("runs", [])
    ]
    doc.table(
        f"When the {of_notes}two starts stop resembling each other, {name}",
        ("form", "form's verdict", "rtol", "separation", "departure", "integration"),
        rows,
    )
    wrong = sorted({r["form"] for r in ex.get("runs", []) if verdicts.get(r["form"]) == "disagrees"})
    if wrong:
        doc.p(
            f"{', '.join(wrong)} {'is' if len(wrong) == 1 else 'are'} wrong (see {ERRATA}): their times say how soon "
            "the wrong equations part from the right motion, not how the system behaves.",
            "note",
        )


def _separation_finding(doc: Document, name: str, s: SystemResult, notes: str | None, t_end: float) -> bool:
    """What the hand derivation's runs at rtol 1e-3 and 1e-6 say about separation; whether the loose
    solver's own error parts the starts first (False where either run is missing)."""
    ex = s.get("experiments") or {}  # the callers hold experiments
    by_rtol = {r["rtol"]: r for r in ex.get("runs", []) if r["form"] == "hand derivation"}
    loose, tight = by_rtol.get(1e-3), by_rtol.get(1e-6)
    if not (loose and tight):
        return False
    chaotic = is_chaotic(s)
    sep, dep = loose.get("separation_time"), loose.get("departure_time")
    tight_sep = tight.get("separation_time")
    solver_first = False
    if sep is None and tight_sep is None:
        finding = (
            f"With the hand derivation the two starts stay within {ex['resemblance']:g} rad of each other for the "
            f"whole {t_end:g} s at both tolerances"
            + ("" if chaotic else f" ({name} is not chaotic from this start)")
            + "."
        )
        if dep is not None:
            finding += f" At rtol 1e-3 the run itself departs from the accurate solution at {_when(dep, t_end)}."
    else:
        finding = (
            f"With the hand derivation at ode45's default tolerance (rtol 1e-3) the two starts separate at "
            f"{_when(sep, t_end)}, and the unperturbed run has itself left the accurate solution at "
            f"{_when(dep, t_end)}: "
        )
        solver_first = dep is not None and (sep is None or as_float(dep) <= as_float(sep))
        if solver_first:
            finding += (
                f"the loose solver's own error, not only the {ex['perturbation']:g} rad perturbation, makes them part. "
            )
        elif chaotic:
            finding += "the perturbation, amplified by the chaos, makes them part. "
        else:
            finding += f"the {ex['perturbation']:g} rad perturbation makes them part. "
        later = f"at {_when(tight_sep, t_end)}" if tight_sep is not None else f"later than {t_end:g} s"
        finding += f"At rtol 1e-6 they separate {later}"
        claim = ex.get("notes_separation") if notes else None
        finding += f" (the notes report about {as_float(claim):g} s by eye)." if claim is not None else "."
    doc.p(finding)
    return solver_first


def _experiment_figure_section(
    doc: Document, name: str, ex: Experiments, notes: str | None, solver_first: bool
) -> None:
    """The figure of the hand derivation's runs from both starts, where they were kept."""
    hand = [r for r in ex.get("runs", []) if r["form"] == "hand derivation" and "q" in r]
    if not hand:
        return
    coord = ex.get("perturbed_coordinate", "q")
    caption = f"The last coordinate ({coord}) from both starts, at each tolerance, with the accurate solution"
    caption += (
        ": at ode45's default tolerance the solver's own error separates the curves as early as the perturbation does."
        if solver_first
        else "."
    )
    doc.figure(
        f"img/{name}_experiment.png",
        experiment_figure(name, ex, hand, notes=bool(notes)),
        f"{coord} against time for the two starts at both tolerances, {name}",
        caption,
    )


def system_experiments(doc: Document, name: str, s: SystemResult) -> None:
    """The notes' (or a perturbation) experiment: what it is, when the starts separate, the finding, the figure."""
    ex = s.get("experiments")
    if not ex:
        label = "Perturbation experiment" if is_user(s) else "The notes' experiments"
        doc.p(f"{label}: {NOT_RUN}.", "missing")
        return
    notes = ex.get("notes_experiment") if not is_user(s) else None
    _experiment_intro(doc, ex, notes)
    t_end = as_float(series(ex["t"])[-1]) if ex.get("t") else float("nan")
    _separation_table(doc, name, s, notes, t_end)
    solver_first = _separation_finding(doc, name, s, notes, t_end)
    _experiment_figure_section(doc, name, ex, notes, solver_first)


@kept
def experiment_figure(name: str, ex: Experiments, runs: list[ExperimentRun], *, notes: bool = False) -> bytes:
    """The perturbed coordinate from both starts at each tolerance, one panel per tolerance; the legend
    on the right, clear of the curves."""
    t = series(ex["t"])
    acc = series(ex["q_accurate"])
    with rc():
        fig, axes = new_figure(8.6, 0.6 + 1.7 * len(runs), nrows=len(runs), sharex=True, legend_right=LEGEND_W + 0.3)
        for ax, r in zip(axes, runs, strict=True):
            q, qb = series(r["q"]), series(r["q_perturbed"])
            ax.plot(t, acc[:, -1], color="#9ca3af", linewidth=2.4, label="accurate\n(Taylor, double)")
            ax.plot(t, q[:, -1], color="#2563eb", linewidth=1.2, label="start as given")
            ax.plot(
                t,
                qb[:, -1],
                color="#d97706",
                linewidth=1.2,
                linestyle="--",
                label=f"perturbed by {ex['perturbation']:g}",
            )
            ax.set_ylabel(f"{ex.get('perturbed_coordinate', 'q')} (rad)")
            ax.text(0.995, 0.97, f"rtol {r['rtol']:g}", transform=ax.transAxes, ha="right", va="top", fontsize=8)
        legend_right(axes[0])
        what = "the notes' perturbation experiment" if notes else "a perturbation experiment"
        axes[0].set_title(f"{name}: {what} (RK45, as ode45)")
        axes[-1].set_xlabel("t (s)")
        return png(fig)

"""The findings the report and the console lead with, read from the results alone: the verdict on
each derivation (the user's own or the hand derivation of the notes), then every wrong printed form
with the term that disagrees, where it is worst and a one-line reason; and the facts every generated
sentence is conditioned on (chaotic or not, damped or conservative, from the notes or the user's).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import SupportsFloat, TypedDict

from ..results.schema import ComparisonRow, Derivation, RunResults, SystemResult, TermSummary

GENERIC_TERMS = ("value", "acceleration")  # the judge's names for "the whole form": never shown as a term
REASON_CHARS = 150  # a one-line reason: longer statements are cut (the whole one is in the details)
CHAOS_LAMBDA = 0.05  # 1/s: a largest Lyapunov exponent below this is no evidence of chaos over the runs


def slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", str(text).lower()).strip("-")


def is_user(s: SystemResult) -> bool:
    """A system the user brought (any folder), not one of the repository's systems of the notes."""
    origin = s.get("origin")
    if origin in ("notes", "user"):
        return origin == "user"
    return not str(s.get("mjcf", "")).startswith("models/")


def has_derivation(s: SystemResult) -> bool:
    """An equations module was given (a run of the model alone has none)."""
    d = s.get("derivation") or {}
    return bool(d) and d.get("kind") != "none"


def derivation_label(s: SystemResult) -> str:
    if not has_derivation(s):
        return "no derivation"
    return "your derivation" if is_user(s) else "the hand derivation"


def has_actuators(s: SystemResult) -> bool:
    return "actuation" in (s.get("uses") or [])


SOURCE_NAMES = {
    "mujoco": "MuJoCo",
    "pinocchio": "Pinocchio",
    "drake": "Drake",
    "symbolic": "the derived equations",
    "hand": "hand",
}


def pointwise_rows(s: SystemResult) -> list[ComparisonRow]:
    """The system's pointwise rows ([] where it has none)."""
    pw = s.get("pointwise")
    return pw.get("rows", []) if pw else []


Cells = tuple[str | None, str | None, float | None, float | None]  # a summary row's term, pair, scaled error, tolerance


def term_cells(w: TermSummary) -> Cells:
    """A derivation's term as the summary table shows it."""
    return w.get("term"), f"hand~{w.get('engine')}", w.get("worst_scaled"), w.get("tolerance")


def pair_cells(w: ComparisonRow) -> Cells:
    """A pointwise pair as the summary table shows it."""
    return w.get("quantity"), w.get("pair"), w.get("scaled"), w.get("tolerance")


def compared_sources(s: SystemResult) -> list[str]:
    """The sources the pointwise comparison holds, in the order hand, MuJoCo, Pinocchio, Drake, symbolic."""
    names = {x for r in pointwise_rows(s) for x in str(r.get("pair", "")).split("~")}
    return [n for n in ("hand", "mujoco", "pinocchio", "drake", "symbolic") if n in names]


def sources_text(s: SystemResult) -> str:
    """ "MuJoCo, Pinocchio and the derived equations": the sources compared, the derivation by its label."""
    label = derivation_label(s)
    names = [label if n == "hand" else SOURCE_NAMES[n] for n in compared_sources(s)]
    return and_join(names) or "no source"


def and_join(items: list[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1] if items else ""


def whose(text: object, owner: str) -> str:
    """A statement of the judge ("yours lacks ...") with "yours" named: "the notes' form lacks ..."."""
    if owner == "yours":
        return str(text)
    return re.sub(r"\byours\b", owner, str(text)).replace("your numbers", "its numbers")


def form_owner(s: SystemResult | None = None) -> str:
    """Who printed a form: the notes for the repository's systems."""
    return "the printed form" if s is not None and is_user(s) else "the notes' form"


def is_damped(s: SystemResult) -> bool:
    return "damping" in (s.get("uses") or [])


def is_driven(s: SystemResult) -> bool:
    """Inputs that do work along the trajectories (a nonzero tau)."""
    tau = (s.get("trajectories") or {}).get("tau") or []
    try:
        return any(float(x) != 0 for x in tau)
    except (TypeError, ValueError):
        return False


# Whether the motion from a start is chaotic, and the numbers that say so ("lambda", 1/s, is a keyword;
# "horizon", s: None where the rounding of the start never grows to "tolerance", rad, within "t_end", s).
ChaosFacts = TypedDict(
    "ChaosFacts", {"chaotic": bool, "lambda": float, "horizon": float | None, "tolerance": float, "t_end": float}
)


def chaos_facts(s: SystemResult) -> ChaosFacts | None:
    """Whether the motion from the system's start is chaotic, with the numbers that say so; None when
    the results hold no chaos study. Chaotic: the largest Lyapunov exponent is at least CHAOS_LAMBDA
    and the initial state's own rounding grows to the horizon tolerance within the study's time."""
    study = s.get("chaos")
    ch = study.get("chaos") if study else None
    lyapunov = ch.get("lyapunov") if ch else None
    lam = lyapunov.get("lambda") if lyapunov else None
    if ch is None or lam is None:
        return None
    lam = _float(lam)
    hz = ch.get("horizon_from_rounding") or {}
    horizon = hz.get("horizon")
    chaotic = math.isfinite(lam) and lam >= CHAOS_LAMBDA and horizon is not None
    return {
        "chaotic": chaotic,
        "lambda": lam,
        "horizon": None if horizon is None else _float(horizon),
        "tolerance": _float(hz.get("tolerance")),
        "t_end": _float(hz.get("t_end")),
    }


def is_chaotic(s: SystemResult) -> bool:
    facts = chaos_facts(s)
    return bool(facts and facts["chaotic"])


def _float(x: object) -> float:
    if not isinstance(x, str | SupportsFloat):  # None, a list: not a number (float() would raise TypeError)
        return math.nan
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def base_name(form: str) -> str:
    """A printed form's name without its equation numbers: "bob 2 position (9)-(10)" -> "bob 2 position"."""
    return re.sub(r"(\s*,?\s*\(\d+\)(-\(\d+\))?)+$", "", form).strip() or form


def form_term(v: Derivation) -> str:
    """The term of a wrong printed form that disagrees, in the judge's term list; where the judge
    judged the form as a whole ("value" of a derivation step, "acceleration" of an explicit form),
    the quantity the form computes and the entry that disagrees."""
    first = v.get("first_disagreeing_term") or ""
    if first and first not in GENERIC_TERMS:
        return first
    failing = [t.get("term") for t in v.get("terms") or [] if not t.get("passed")]
    real = [t for t in failing if t and t not in GENERIC_TERMS]
    if real:
        return real[0]
    name = str(v.get("name", ""))
    explained = [e for e in v.get("explanations") or [] if e.get("entry")]
    entry = next((e["entry"] for e in explained if e.get("explained")), explained[0]["entry"] if explained else "")
    if first == "value" or v.get("kind") == "derivation step":
        base = base_name(name)
        if entry.startswith(name):
            return base + entry[len(name) :]
        return base
    return "acceleration (every separated term agrees; their sum does not)" if first == "acceleration" else first


def shorten(text: str, n: int = REASON_CHARS) -> str:
    """`text` on one line; longer than `n`, cut at the last clause or word boundary before it, with
    "(continued in the details)" so that nothing reads as cut mid-sentence."""
    text = " ".join(str(text).split())
    if len(text) <= n:
        return text
    cut = text[:n]
    for mark in ("; ", ", ", " "):
        at = cut.rfind(mark)
        if at > n // 2:
            return cut[:at].rstrip(",;") + " (continued in the details)"
    return cut + " (continued in the details)"


def one_line_statement(statement: str) -> str:
    """The first slip of a statement, without the algebra that follows it: "yours lacks ... (yours =
    expected - ...); ..." -> "yours lacks ..."; whole (never cut)."""
    first = str(statement).split("; ")[0]
    first = re.sub(r"\s*\(yours = [^()]*(\([^()]*\)[^()]*)*\)$", "", first)
    return " ".join(first.split())


NO_SLIP = "no single slip reproduces it"


def form_reason(v: Derivation, owner: str = "the notes' form") -> str:
    """The one-line reason of a wrong printed form: its first explained symbolic difference (with the
    entry, where the term does not already name it), "yours" named as `owner`; else the plain statement
    that no single slip reproduces it. The transcription note is apart (`form_note`)."""
    for e in v.get("explanations") or []:
        if e.get("explained") and e.get("statement"):
            entry = str(e.get("entry") or "")
            said = whose(one_line_statement(e["statement"]), owner)
            if entry and not entry.startswith(str(v.get("name", ""))):
                entry = entry.replace("det(M) * ", "det(M) ")
                return f"{entry}: {said}"
            return said
    return NO_SLIP


def form_note(v: Derivation) -> str:
    """The transcription note of a printed form (how it was read from the notes), not a reason."""
    return " ".join(str(v.get("note") or "").split())


def where_worst(v: Derivation, prefix: str = "printed") -> str:
    """Where a wrong form (or derivation) is worst: the pair and the parameter set."""
    w = v.get("worst_term") or {}
    engine = w.get("engine")
    at = w.get("parameters") or ("the model's parameters" if w.get("probe") == 0 else None)
    if at is None and w.get("probe"):
        at = f"probe {w['probe']}"
    if at == "model":
        at = "the model's parameters"
    bits = []
    if engine:
        bits.append(f"{prefix}~{engine}")
    if at:
        bits.append(f"worst at {at}")
    if w.get("scaled") is not None:
        bits.append(f"scaled error {_float(w['scaled']):.2g}")
    return ", ".join(bits)


@dataclass(frozen=True)
class Finding:
    """A wrong printed form, as the first screen and the console list it."""

    system: str
    form: str
    term: str
    reason: str
    where: str
    hidden: bool  # the model's own parameter values hide it; a probe shows it
    anchor: str
    note: str = ""  # the transcription note, apart from the reason


def form_anchor(system: str, form: str) -> str:
    return f"wrong-{slug(system)}-{slug(form)}"


def wrong_forms(results: RunResults) -> list[Finding]:
    out = []
    for name, s in sorted(results.get("systems", {}).items()):
        for v in s.get("variants", []):
            if v.get("verdict") != "disagrees":
                continue
            out.append(
                Finding(
                    name,
                    str(v.get("name")),
                    form_term(v),
                    form_reason(v, form_owner(s)),
                    where_worst(v),
                    bool(v.get("hidden_by_model_values")),
                    form_anchor(name, str(v.get("name"))),
                    form_note(v),
                )
            )
    return out


def agreeing_forms(results: RunResults) -> list[tuple[str, str, str]]:
    """(system, form, verdict) of every printed form that does not disagree."""
    return [
        (name, str(v.get("name")), str(v.get("verdict")))
        for name, s in sorted(results.get("systems", {}).items())
        for v in s.get("variants", [])
        if v.get("verdict") != "disagrees"
    ]


IN_THE_STATEMENT = ("hand derivation: ", "model checks: ", "pointwise: ")  # `failed` phrases the verdict says


def after_verdict(s: SystemResult) -> list[str]:
    """What failed in the stages `run` adds after the verdict (trajectories, equivalence, a stage that
    raised): the phrases of `failed` that the verdict's statement does not already say."""
    return [f for f in s.get("failed") or [] if not str(f).startswith(IN_THE_STATEMENT)]


def system_headline(s: SystemResult) -> tuple[bool | None, str]:
    """(passed, one line) of a system. With a derivation the line is the verdict's statement as
    `decide` wrote it (the sentence `check` and the API show; never recomposed here), labelled with
    whose derivation it is, then what failed after the verdict; a model alone, what was compared."""
    d = s.get("derivation") or {}
    statement = str(s.get("statement") or (d.get("statement") if has_derivation(s) else "") or "")
    if statement:
        later = after_verdict(s) if s.get("passed") is False else []
        text = f"{derivation_label(s)}: {statement}" if has_derivation(s) else statement
        if later:
            text += f"; after the verdict, {'; '.join(later[:2])}" + (
                f" (and {len(later) - 2} more)" if len(later) > 2 else ""
            )
        return s.get("passed"), text
    return _model_alone_headline(s)


def _model_alone_headline(s: SystemResult) -> tuple[bool | None, str]:
    """(passed, one line) of results without a statement (written before decide's was kept)."""
    failed = list(s.get("failed") or [])
    if s.get("passed") is False:
        if failed:
            return False, "; ".join(failed[:2])
        bad = [r for r in pointwise_rows(s) if r.get("passed") is False]
        if bad:
            r = bad[0]
            return False, (
                f"pointwise {r.get('quantity')} disagrees ({r.get('pair')}, scaled error {_float(r.get('scaled')):.2g} "
                f"> {_float(r.get('tolerance')):g})" + (f", and {len(bad) - 1} more" if len(bad) > 1 else "")
            )
        return False, "fails (see its section)"
    if not has_derivation(s):  # the model alone
        verb = "agree" if s.get("passed") else "disagree"
        return s.get("passed"), f"no derivation given; {sources_text(s)} {verb} on the model and its dynamics"
    d = s.get("derivation") or {}
    return s.get("passed"), f"{derivation_label(s)}: {d.get('verdict') or 'not judged'}"


MODEL_ONLY = "no derivation given: the engines' readings of the model and their dynamics compared"


def forms_tally(results: RunResults) -> tuple[int, int, int]:
    """(printed forms, wrong, not judged)."""
    variants = [v for s in results.get("systems", {}).values() for v in s.get("variants", [])]
    wrong = sum(1 for v in variants if v.get("verdict") == "disagrees")
    other = sum(1 for v in variants if v.get("verdict") not in ("agrees", "disagrees"))
    return len(variants), wrong, other


def console_lines(results: RunResults, report: str = "report.html") -> list[str]:
    """The last lines of `run`: the verdict on each derivation, then every wrong printed form with
    its term and reason (plain text, one line each)."""
    systems = results.get("systems", {})
    given = any(has_derivation(s) for s in systems.values())
    lines = [
        "derivations, each judged term by term against the engines:"
        if given
        else "models alone (no derivation given), the engines compared:"
    ]
    for name, s in sorted(systems.items()):
        ok, text = system_headline(s)
        lines.append(f"  {'pass' if ok else 'FAIL' if ok is False else '-   '} {name}: {text}")
    n, wrong, _ = forms_tally(results)
    if n:
        found = wrong_forms(results)
        lines.append(
            f"printed forms of the notes: {wrong} of {n} wrong"
            + (f" (details: {report}#errata-of-the-notes)" if found else "; every one agrees with the engines")
        )
        for f in found:
            hidden = " [hidden by the model's values; a probe shows it]" if f.hidden else ""
            note = f" (transcription note: {f.note})" if f.note and f.reason == NO_SLIP else ""
            lines.append(f"  wrong {f.system}, {f.form}: {f.term}: {f.reason}{hidden}{note}")
    return lines

"""The findings the report and the console lead with, read from the results alone: the verdict on
each derivation (the user's own or the hand derivation of the notes), then every wrong printed form
with the term that disagrees, where it is worst and a one-line reason; and the facts every generated
sentence is conditioned on (chaotic or not, damped or conservative, from the notes or the user's).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

GENERIC_TERMS = ("value", "acceleration")  # the judge's names for "the whole form": never shown as a term
REASON_CHARS = 150  # a one-line reason: longer statements are cut (the whole one is in the details)
CHAOS_LAMBDA = 0.05  # 1/s: a largest Lyapunov exponent below this is no evidence of chaos over the runs


def slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", str(text).lower()).strip("-")


def is_user(s: dict[str, Any]) -> bool:
    """A system the user brought (any folder), not one of the repository's systems of the notes."""
    origin = s.get("origin")
    if origin in ("notes", "user"):
        return origin == "user"
    return not str(s.get("mjcf", "")).startswith("models/")


def derivation_label(s: dict[str, Any]) -> str:
    return "your derivation" if is_user(s) else "the hand derivation"


def is_damped(s: dict[str, Any]) -> bool:
    return "damping" in (s.get("uses") or [])


def is_driven(s: dict[str, Any]) -> bool:
    """Inputs that do work along the trajectories (a nonzero tau)."""
    tau = (s.get("trajectories") or {}).get("tau") or []
    try:
        return any(float(x) != 0 for x in tau)
    except (TypeError, ValueError):
        return False


def chaos_facts(s: dict[str, Any]) -> dict[str, Any] | None:
    """Whether the motion from the system's start is chaotic, with the numbers that say so; None when
    the results hold no chaos study. Chaotic: the largest Lyapunov exponent is at least CHAOS_LAMBDA
    and the initial state's own rounding grows to the horizon tolerance within the study's time."""
    ch = (s.get("chaos") or {}).get("chaos") or {}
    lam = (ch.get("lyapunov") or {}).get("lambda")
    if lam is None:
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


def is_chaotic(s: dict[str, Any]) -> bool:
    facts = chaos_facts(s)
    return bool(facts and facts["chaotic"])


def _float(x: Any) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def base_name(form: str) -> str:
    """A printed form's name without its equation numbers: "bob 2 position (9)-(10)" -> "bob 2 position"."""
    return re.sub(r"(\s*,?\s*\(\d+\)(-\(\d+\))?)+$", "", form).strip() or form


def form_term(v: dict[str, Any]) -> str:
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
    text = " ".join(str(text).split())
    return text if len(text) <= n else text[: n - 1].rstrip() + "…"


def one_line_statement(statement: str) -> str:
    """The first slip of a statement, without the algebra that follows it: "yours lacks ... (yours =
    expected - ...); ..." -> "yours lacks ..."."""
    first = str(statement).split("; ")[0]
    first = re.sub(r"\s*\(yours = [^()]*(\([^()]*\)[^()]*)*\)$", "", first)
    return shorten(first)


def form_reason(v: dict[str, Any]) -> str:
    """The one-line reason of a wrong printed form: its first explained symbolic difference (with the
    entry, where the term does not already name it), else its transcription note."""
    for e in v.get("explanations") or []:
        if e.get("explained") and e.get("statement"):
            entry = str(e.get("entry") or "")
            said = one_line_statement(e["statement"])
            if entry and not entry.startswith(str(v.get("name", ""))):
                entry = entry.replace("det(M) * ", "det(M) ")
                return shorten(f"{entry}: {said}")
            return said
    note = str(v.get("note") or "").strip()
    if note:
        return shorten(f"no single slip reproduces it; transcription note: {note}")
    return "no single slip reproduces it (the symbolic differences are in the details)"


def where_worst(v: dict[str, Any], prefix: str = "printed") -> str:
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


def form_anchor(system: str, form: str) -> str:
    return f"wrong-{slug(system)}-{slug(form)}"


def wrong_forms(results: dict[str, Any]) -> list[Finding]:
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
                    form_reason(v),
                    where_worst(v),
                    bool(v.get("hidden_by_model_values")),
                    form_anchor(name, str(v.get("name"))),
                )
            )
    return out


def agreeing_forms(results: dict[str, Any]) -> list[tuple[str, str, str]]:
    """(system, form, verdict) of every printed form that does not disagree."""
    return [
        (name, str(v.get("name")), str(v.get("verdict")))
        for name, s in sorted(results.get("systems", {}).items())
        for v in s.get("variants", [])
        if v.get("verdict") != "disagrees"
    ]


def derivation_reason(d: dict[str, Any]) -> str:
    for e in d.get("explanations") or []:
        if e.get("explained") and e.get("statement"):
            return shorten(f"{e.get('entry')}: {one_line_statement(e['statement'])}")
    return ""


def _hidden_note(d: dict[str, Any]) -> str:
    """What the console line and the headline add where the model's own values hide the mistake, and
    where it may be an unstated assumption."""
    out = ""
    if d.get("hidden_by_model_values"):
        exposed = d.get("exposed_by") or []
        out += " [hidden by the model's values; a probe shows it" + (
            f": it shows when {' or '.join(exposed)} alone changes]" if exposed else "]"
        )
    unstated = d.get("unstated_assumptions") or []
    if unstated:
        out += (
            f"; may be an unstated assumption: parameters() does not read {', '.join(unstated[:3])}"
            " (state it in assumptions())"
        )
    return out


def system_headline(s: dict[str, Any]) -> tuple[bool | None, str]:
    """(passed, one line) of a system: for a failing one the failing term and pair first, and why;
    for a passing one what was judged."""
    d = s.get("derivation") or {}
    who = derivation_label(s)
    if d.get("verdict") == "disagrees":
        term = d.get("first_disagreeing_term") or "a term"
        where = where_worst(d, prefix="hand")
        # where the term depends on a number parameters() does not read, no slip of yours explains it
        reason = "" if d.get("unstated_assumptions") else derivation_reason(d)
        text = f"{who}: {term} disagrees" + (f" ({where})" if where else "")
        error = (d.get("worst_term") or {}).get("error")
        if reason or error:
            text += f"; {reason or shorten(str(error))}"
        elif d.get("statement") and term == "parameters":
            text = f"{who}: {shorten(d['statement'])}"
        return False, text + _hidden_note(d)
    failed = list(s.get("failed") or [])
    if s.get("passed") is False:
        if failed:
            return False, "; ".join(failed[:2])
        bad = [r for r in (s.get("pointwise") or {}).get("rows", []) if r.get("passed") is False]
        if bad:
            r = bad[0]
            return False, (
                f"pointwise {r.get('quantity')} disagrees ({r.get('pair')}, scaled error {_float(r.get('scaled')):.2g} "
                f"> {_float(r.get('tolerance')):g})" + (f", and {len(bad) - 1} more" if len(bad) > 1 else "")
            )
        return False, "fails (see its section)"
    if d.get("verdict") == "agrees":
        checked = d.get("checked") or {}
        probes = checked.get("probes")
        at = f"the model's parameters and {probes} probe sets" if probes else "the model's parameters"
        return (s.get("passed") is True or None), f"{who} agrees with the engines in every term, at {at}"
    if d.get("kind") == "none":  # the model alone
        pairs = {r.get("pair") for r in (s.get("pointwise") or {}).get("rows", [])}
        sources = (
            "MuJoCo, Pinocchio and the derived equations" if "mujoco~symbolic" in pairs else "MuJoCo and Pinocchio"
        )
        return s.get("passed"), (
            f"no derivation given; the engines' readings, and {sources}, agree"
            if s.get("passed")
            else "no derivation given"
        )
    return s.get("passed"), f"{who}: {d.get('verdict') or 'not judged'}"


def forms_tally(results: dict[str, Any]) -> tuple[int, int, int]:
    """(printed forms, wrong, not judged)."""
    variants = [v for s in results.get("systems", {}).values() for v in s.get("variants", [])]
    wrong = sum(1 for v in variants if v.get("verdict") == "disagrees")
    other = sum(1 for v in variants if v.get("verdict") not in ("agrees", "disagrees"))
    return len(variants), wrong, other


def console_lines(results: dict[str, Any], report: str = "report.html") -> list[str]:
    """The last lines of `run`: the verdict on each derivation, then every wrong printed form with
    its term and reason (plain text, one line each)."""
    systems = results.get("systems", {})
    lines = ["derivations, each judged term by term against the engines:"]
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
            lines.append(f"  wrong {f.system}, {f.form}: {f.term}: {f.reason}{hidden}")
    return lines

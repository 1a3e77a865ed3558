"""The one wording of a run's verdict, used by every table a run appears in: "agrees until t s; not
judged beyond (why)" or "agrees over the whole run (t s)".
"""

from __future__ import annotations

from ..results.schema import FreeRun, Trajectories
from .document import Mark, as_float, is_number, pass_mark, sci


def fmt_g(x: object) -> str:
    """A setting (a time step, a duration) as written: 0.01, 10."""
    return f"{x:g}" if is_number(x) else sci(x)


def judged_verdict(
    passed: bool | None, until: object, t_end: object, why: str, error: object = None, tolerance: object = None
) -> Mark:
    """The one wording of a run's verdict, wherever the run appears: "agrees until t s; not judged beyond
    (why)" or "agrees over the whole run (t s)"; a pass mark only where the error shown is within the
    tolerance (a run judged part-way whose whole-run error is past it gets no mark)."""
    if passed is None:
        return pass_mark(None)
    if passed is False:
        return Mark("bad", "disagrees")
    whole = until is None or t_end is None or as_float(until) >= as_float(t_end)
    if whole:
        return Mark("ok", f"agrees over the whole run ({fmt_g(until if until is not None else t_end)} s)")
    text = f"agrees until {fmt_g(until)} s; not judged beyond" + (f" ({why})" if why else "")
    large = error is not None and tolerance is not None and not (as_float(error) <= as_float(tolerance))
    return Mark("na" if large else "ok", text)


def judged_why(tr: Trajectories) -> str:
    """The reason a run is judged only part-way, short: the clause before the first colon."""
    return str(tr.get("judged_because") or "").split(":")[0]


def run_verdict(run: FreeRun, tr: Trajectories) -> Mark | str:
    """A trajectory run's verdict as the table shows it: what interval was judged, or information only."""
    if not run.get("counts", True):
        return "information only"
    if "passed" not in run:
        return "–"
    if run["passed"] is False:
        first = run.get("first_exceeds_threshold")
        return Mark("bad", "disagrees" + (f": above the threshold from {fmt_g(first)} s" if first is not None else ""))
    return judged_verdict(
        run["passed"],
        run.get("judged_until"),
        tr.get("t_end"),
        judged_why(tr),
        run.get("max_error_vs_hand"),
        tr.get("threshold"),
    )

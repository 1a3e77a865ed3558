"""Which engine of a chain with no symbolic source can be trusted, and until when: rendered from the
results' `trajectories.trust` (validate/dynamics/trust.py) and each run's `trust_statement`."""

from __future__ import annotations

from ..results.schema import Trajectories
from .document import Document, Items
from .runs import fmt_g


def trust_section(doc: Document, tr: Trajectories) -> None:
    """The reference's own horizon, the Lyapunov exponent and predictability horizon, and one line per
    engine; nothing where the results hold no trust analysis."""
    found = tr.get("trust")
    if not found:
        return
    rate, horizon = found.get("lyapunov_exponent"), found.get("predictability_horizon")
    chaos = (
        f"The largest Lyapunov exponent from this start is {rate:.3g} 1/s, so no double-precision run "
        f"predicts the motion beyond about {horizon:.3g} s ({found.get('horizon_rule')})."
        if horizon is not None
        else f"The largest Lyapunov exponent from this start is {fmt_g(rate)} 1/s: no exponential growth of errors."
    )
    doc.p(
        f"Which engine can be trusted, and until when. The reference agrees with itself at half its tolerance "
        f"until {fmt_g(found.get('reference_until'))} s. {chaos} Each run is trusted {found.get('trust_rule')}:"
    )
    doc.blocks.append(Items(tuple(str(r["trust_statement"]) for r in tr.get("runs", []) if r.get("trust_statement"))))

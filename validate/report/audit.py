"""The report's model-audit section (checks/audit.py's results): three readers of the model, the
findings (the reader in the minority named) and the mass matrices' gaps."""

from __future__ import annotations

from typing import Any

from .document import Items

LABEL = {"mujoco": "MuJoCo", "pinocchio": "Pinocchio", "drake": "Drake"}


def audit_section(doc: Any, name: str, s: dict[str, Any]) -> None:
    """A short paragraph, the findings as items, and one table of max |M_a - M_b| per reader pair."""
    a = s.get("audit")
    if not a:
        return
    doc.h(4, "Model audit: three readers", f"{name}-audit")
    if "error" in a:
        doc.p(f"The audit could not be made: {a['error']}", "missing")
        return
    readers = ", ".join(LABEL.get(r, r) for r in a.get("readers", []))
    doc.p(f"{a.get('model')} read by {readers}, {len(a.get('rows', []))} fields compared ({a.get('frame')}).")
    skipped = [f"{LABEL.get(r, r)} not a reader: {why}" for r, why in a.get("skipped", {}).items()]
    findings = a.get("findings", [])
    doc.blocks.append(Items(tuple(skipped + findings) or (f"every field agrees between {readers}",)))
    gaps = a.get("mass_matrix", {})
    doc.table(
        f"Mass matrices of {name} as each reader builds them, max |M_a - M_b| at {gaps.get('n_states')} seeded states",
        ("readers", "max |M_a - M_b|"),
        [(pair, gap) for pair, gap in sorted(gaps.get("max_abs", {}).items())],
    )

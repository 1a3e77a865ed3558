"""The report's model-audit section (audit/audit.py's results): three readers of the model, each
judged against what the file means, the findings (each misreading with its known cause), the readers'
warnings and each reading's consequence on M and G."""

from __future__ import annotations

import re

from ..results.schema import SystemResult
from .document import Document, Items

LABEL = {"mujoco": "MuJoCo", "pinocchio": "Pinocchio", "drake": "Drake"}
MAX_ITEMS = 30  # findings listed in the report; results.json keeps every one
# The report is self-contained (no web address): a finding's "[entry: where it was reported]" keeps the
# entry's name; results.json and `lagrange-xval audit` keep the address.
REPORTED = re.compile(r"\[([^\]:]+): https?://[^\]]+\]")


def _offline(line: str) -> str:
    """The line without web addresses (a reader's warning may name its troubleshooting page)."""
    return re.sub(r"https?://\S+", "(its web page)", REPORTED.sub(r"[\1]", line))


def audit_section(doc: Document, name: str, s: SystemResult) -> None:
    """A short paragraph, the findings as items, and one table of max |M_a - M_b| per reader pair."""
    a = s.get("audit")
    if not a:
        return
    doc.h(4, "Model audit: three readers", f"{name}-audit")
    if "error" in a:
        doc.p(f"The audit could not be made: {a['error']}", "missing")
        return
    readers = ", ".join(LABEL.get(r, r) for r in a.get("readers", []))
    doc.p(
        f"{a.get('model')} read by {readers}, each judged against {a.get('reference', 'the format')}; "
        f"{len(a.get('rows', []))} fields compared ({a.get('frame')})."
    )
    skipped = [f"{LABEL.get(r, r)} not a reader: {why}" for r, why in a.get("skipped", {}).items()]
    findings = a.get("findings", [])
    if len(findings) > MAX_ITEMS:
        findings = [*findings[:MAX_ITEMS], f"... and {len(findings) - MAX_ITEMS} more (results.json has them all)"]
    warned = [f"{LABEL.get(r, r)} warned: {w}" for r, said in a.get("warnings", {}).items() for w in said[:5]]
    items = tuple(_offline(line) for line in skipped + findings + warned)
    doc.blocks.append(Items(items or (f"every field agrees between {readers}",)))
    gaps = a.get("mass_matrix", {})
    gravity = gaps.get("gravity_max_abs", {})
    doc.table(
        f"Mass matrices and gravity torques of {name} as each reader's reading implies them, against the format's, "
        f"at {gaps.get('n_states')} seeded configurations",
        ("reader", "max |M_reader - M_format|", "max |G_reader - G_format|"),
        [(reader, gap, gravity.get(reader, float("nan"))) for reader, gap in sorted(gaps.get("max_abs", {}).items())],
    )

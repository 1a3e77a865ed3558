"""Reports rendered from results.json (never recomputing physics): markdown and HTML.

First version: summary, per-system pointwise tables, errata of the notes, tolerances, provenance.
"""

from __future__ import annotations

from typing import Any


def _fmt(x: Any) -> str:
    return f"{x:.2e}" if isinstance(x, float) else str(x)


def summary_rows(results: dict[str, Any]) -> list[dict[str, Any]]:
    rows = []
    for name, s in sorted(results["systems"].items()):
        worst = max(s["pointwise"]["rows"], key=lambda r: r["scaled"] / r["tolerance"])
        rows.append({"system": name, "variant": "hand derivation", "verdict": "pass" if s["passed"] else "FAIL",
                     "worst": f"{worst['quantity']} {worst['pair']}", "error": worst["scaled"]})
        for v in s["variants"]:
            w = v.get("worst_term", {})
            rows.append({"system": name, "variant": v["name"], "verdict": v["verdict"],
                         "worst": f"{w.get('term', '')} {w.get('engine', '')}".strip(), "error": w.get("scaled", "")})
    return rows


def render_markdown(results: dict[str, Any]) -> str:
    meta = results["meta"]
    out = ["# lagrange-xval validation report", ""]
    out += ["## Provenance", "", "Provenance of this run:", "", "| item | value |", "|---|---|"]
    for k in ("harness_version", "git_commit", "date", "command", "cpu", "python", "seed"):
        out.append(f"| {k} | {meta[k]} |")
    for k, v in sorted(meta["versions"].items()):
        out.append(f"| {k} | {v} |")
    out += ["", "## Summary", "", "One row per system and printed form:", "",
            "| system | form | verdict | worst quantity | scaled error |", "|---|---|---|---|---|"]
    for r in summary_rows(results):
        out.append(f"| {r['system']} | {r['variant']} | {r['verdict']} | {r['worst']} | {_fmt(r['error'])} |")
    for name, s in sorted(results["systems"].items()):
        out += ["", f"## {name}", "", s["description"], "",
                f"MJCF: `{s['mjcf']}`; equations: `{s['equations']}`; coordinates: {', '.join(s['coordinates'])}.", "",
                f"Pointwise agreement of {name} at {s['pointwise']['n_states']} random states (seed {s['pointwise']['seed']}):", "",
                "| quantity | pair | max abs | scaled | tolerance | pass |", "|---|---|---|---|---|---|"]
        for r in s["pointwise"]["rows"]:
            out.append(f"| {r['quantity']} | {r['pair']} | {_fmt(r['max_abs'])} | {_fmt(r['scaled'])} | "
                       f"{_fmt(r['tolerance'])} | {'yes' if r['passed'] else 'NO'} |")
    out += ["", "## Errata of the notes", "", "Every printed form and its verdict:", "",
            "| system | printed form | equations | verdict | first disagreeing term | worst term | size |",
            "|---|---|---|---|---|---|---|"]
    for name, s in sorted(results["systems"].items()):
        for v in s["variants"]:
            w = v.get("worst_term", {})
            out.append(f"| {name} | {v['name']} | {', '.join(v['notes_equations'])} | {v['verdict']} | "
                       f"{v.get('first_disagreeing_term', '')} | {w.get('term', '')} | {_fmt(w.get('scaled', ''))} |")
    out += ["", "## Tolerance tiers", "", "The tiers and why each is what it is:", "",
            "| tier | rtol | reason |", "|---|---|---|"]
    for k, t in results["tolerances"].items():
        out.append(f"| {k} | {t['rtol']:.0e} | {t['reason']} |")
    return "\n".join(out) + "\n"


def render_html(results: dict[str, Any], markdown: str) -> str:
    import html

    return ("<!doctype html><html><head><meta charset='utf-8'><title>lagrange-xval report</title></head>"
            f"<body><pre>{html.escape(markdown)}</pre></body></html>\n")


def render(results: dict[str, Any]) -> dict[str, bytes]:
    """Every report file: {file name: contents}."""
    md = render_markdown(results)
    return {"report.md": md.encode(), "report.html": render_html(results, md).encode()}

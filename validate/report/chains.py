"""The scaling study's section, rendered from chains.json (`lagrange-xval bench --chains`), never recomputed."""

from __future__ import annotations

import numpy as np

from ..results.schema import ChainRow, ChainsStudy
from .document import NOT_RUN, Document, Num, as_float
from .figures import LEGEND_W, legend_right, new_figure, png, rc

SOURCE_COLOURS = {"mujoco": "#2563eb", "pinocchio": "#d97706", "symbolic": "#059669"}


def section_chains(doc: Document, chains: ChainsStudy | None) -> None:
    doc.h(2, "Scaling with the number of joints")
    if not chains:
        doc.p(
            f"Scaling study: {NOT_RUN} (`lagrange-xval bench --chains [--quick]` writes reports/chains.json; this "
            "report shows it when present).",
            "missing",
        )
        return
    rows = chains.get("rows", [])
    doc.p(
        f"Generated planar and spatial n-link chains (n = {', '.join(str(n) for n in chains.get('ns', []))}; random "
        f"but valid inertias), {chains.get('n_states')} random states each: the time per state of M, the bias "
        "forces and forward and inverse dynamics through each source's Python interface (best of "
        f"{chains.get('repeats')}), and whether the sources agree within the tolerance tiers. The symbolic source "
        f"runs while its derivation and generated code fit {as_float(chains.get('symbolic_budget_s')):g} s."
    )
    for kind in ("planar", "spatial"):
        krows = [r for r in rows if r.get("kind") == kind]
        if krows:
            doc.figure(
                f"img/chains_{kind}.png",
                _figure(kind, krows),
                f"Time per state against n, {kind} chains",
                f"Time per state of M (solid) and forward dynamics (dashed) against the number of joints, "
                f"{kind} chains, log-log.",
            )
    slopes = chains.get("slopes", {})
    doc.table(
        "Measured growth: log-log slope of the time per state against n (n >= 4)",
        ("chains and source", "M", "bias", "forward", "inverse"),
        [
            (name, *(Num(ops.get(op), 2) for op in ("M", "bias", "forward", "inverse")))
            for name, ops in sorted(slopes.items())
        ],
    )
    stops = chains.get("symbolic_stopped_at", {})
    for kind, where in sorted(stops.items()):
        doc.p(f"The symbolic source stops for {kind} chains at n = {where.get('n')}: {where.get('why')}.")
    sym = [r for r in rows if r.get("symbolic")]
    if sym:
        doc.table(
            "The symbolic derivation's cost",
            ("chains", "n", "derivation s", "generated code s", "operations in M and C v"),
            [
                (
                    r["kind"],
                    r["n"],
                    Num(r["symbolic"].get("derive_s"), 3),
                    Num(r["symbolic"].get("codegen_s"), 3),
                    r["symbolic"].get("ops_M_Cv"),
                )
                for r in sym
            ],
        )
    bad = [f"{r['kind']} n = {r['n']}" for r in rows if not r.get("all_within_tiers")]
    doc.p(
        "Every source agrees within the tiers at every n." if not bad else f"Sources disagree at {', '.join(bad)}.",
        "pass" if not bad else "fail",
    )
    doc.table(
        "Agreement and conditioning against n",
        ("chains", "n", "largest cond(M)", "worst scaled disagreement", "within tiers"),
        [
            (
                r["kind"],
                r["n"],
                Num(r.get("cond_M_max")),
                Num(max((r.get("worst_scaled") or {"": 0.0}).values())),
                "yes" if r.get("all_within_tiers") else "no",
            )
            for r in rows
        ],
    )


def _figure(kind: str, rows: list[ChainRow]) -> bytes:
    with rc():
        fig, (ax,) = new_figure(8.6, 3.6, legend_right=LEGEND_W + 0.4)
        for source, colour in SOURCE_COLOURS.items():
            for op, style in (("M", "-"), ("forward", "--")):
                pts = [
                    (r["n"], as_float(r["per_state_s"][source][op])) for r in rows if source in r.get("per_state_s", {})
                ]
                if pts:
                    n, t = zip(*pts, strict=True)
                    ax.loglog(
                        n, np.asarray(t) * 1e6, style, marker="o", markersize=3, color=colour, label=f"{source} {op}"
                    )
        ax.set_xlabel("joints n")
        ax.set_ylabel("time per state (us)")
        ax.set_title(f"{kind} chains")
        if ax.get_legend_handles_labels()[0]:
            legend_right(ax)
        return png(fig)

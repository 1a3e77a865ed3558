"""The validation report people read, rendered from the results dict (never recomputing physics).

`render(results)` returns every report file by name, relative to the reports folder:

    report.md                          the report as markdown, images beside it in img/
    report.html                        one self-contained page: inline CSS, plots as inline base64
                                       PNG, no JavaScript, no request of any kind
    img/<system>_<figure>.png          the plots report.md references

Both documents are rendered from one list of blocks (headings, paragraphs, titled tables, figures,
code), so they say the same thing. Layout follows qpbenchmark's report: a provenance header, one
subject per section, a one-line title before every table (two reports diff cleanly), and a "Known
limitations" section. Output is deterministic: keys are sorted, figures have fixed sizes and the
PNGs carry no timestamp or software tag, so two renders of the same results are byte-identical and
two runs with the same seed differ only in the provenance lines.

The only arithmetic done here is selection (the worst row of a table) and presentation (E - E0,
downsampling a series for a plot).
"""

from __future__ import annotations

import base64
import io
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

TITLE = "lagrange-xval validation report"
SUBTITLE = "Hand-derived Lagrangian equations of motion, held against MuJoCo and Pinocchio"

# Top-level section titles, in order; per-system sections ("System <name>") sit between SUMMARY
# and ERRATA. Tests import these so a renamed section is caught.
PROVENANCE = "Provenance"
SUMMARY = "Summary"
ERRATA = "Errata of the notes"
TOLERANCE_TIERS = "Tolerance tiers"
BENCHMARK = "Benchmark"
STRESS = "Stress tests"
LIMITATIONS = "Known limitations and omissions"
REPLAY = "How to replay"
SECTION_TITLES = (PROVENANCE, SUMMARY, ERRATA, TOLERANCE_TIERS, BENCHMARK, STRESS, LIMITATIONS, REPLAY)
SYSTEM_SUBSECTIONS = ("Model", "Model checks", "Pointwise agreement", "Trajectories", "Chaos", "Experiments")

NOT_RUN = "not run"
MAX_PLOT_POINTS = 1500  # samples per plotted series; longer series are strided (plots only)
SOURCE_STYLE = {  # colour, line style, width: the reference solid, the engines dashed / dotted
    "hand": ("#1f2937", "-", 1.6),
    "mujoco": ("#2563eb", (0, (5, 3)), 1.4),
    "pinocchio": ("#d97706", (0, (1, 2)), 1.8),
}
PAIR_COLOURS = ("#2563eb", "#d97706", "#059669", "#7c3aed", "#db2777")
FIG_DPI = 110


# ----------------------------------------------------------------------------------------------
# The document model: what both renderers draw.


@dataclass(frozen=True)
class Num:
    """A number shown in scientific notation, right-aligned: `digits` after the point, or with
    `short` an exact power of ten as 1e-12 and any other value with trailing zeros dropped
    (9.81e+00, 8.33333e-02)."""

    value: Any
    digits: int = 2
    unit: str = ""
    short: bool = False


@dataclass(frozen=True)
class Mark:
    """A verdict: state is "ok" (✓), "bad" (✗) or "na" (–)."""

    state: str
    text: str


@dataclass(frozen=True)
class Heading:
    level: int
    text: str
    anchor: str


@dataclass(frozen=True)
class Para:
    text: str  # `backticks` mark code
    kind: str = ""  # "", "note" (a remark) or "missing" (a section that was not run)


@dataclass(frozen=True)
class Table:
    title: str
    columns: tuple[str, ...]
    rows: tuple[tuple[Any, ...], ...]
    numeric: tuple[bool, ...] = ()
    group: bool = False  # HTML: the first column as a heading row each time it changes (markdown keeps it)


@dataclass(frozen=True)
class Figure:
    path: str  # relative to the reports folder
    alt: str
    caption: str


@dataclass(frozen=True)
class Code:
    text: str


@dataclass(frozen=True)
class Items:
    items: tuple[str, ...]


@dataclass
class Document:
    blocks: list[Any] = field(default_factory=list)
    images: dict[str, bytes] = field(default_factory=dict)

    def h(self, level: int, text: str, anchor: str | None = None) -> None:
        self.blocks.append(Heading(level, text, anchor or _slug(text)))

    def p(self, text: str, kind: str = "") -> None:
        self.blocks.append(Para(text, kind))

    def table(
        self,
        title: str,
        columns: tuple[str, ...] | list[str],
        rows: list[tuple[Any, ...]] | list[list[Any]],
        *,
        group: bool = False,
    ) -> None:
        rows_t = tuple(tuple(r) for r in rows)
        numeric = tuple(bool(rows_t) and all(isinstance(r[i], Num) for r in rows_t) for i in range(len(columns)))
        self.blocks.append(Table(title, tuple(columns), rows_t, numeric, group))

    def figure(self, path: str, png: bytes, alt: str, caption: str) -> None:
        self.images[path] = png
        self.blocks.append(Figure(path, alt, caption))


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


# ----------------------------------------------------------------------------------------------
# Formatting


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def sci(x: Any, digits: int = 2) -> str:
    """Scientific notation; exact powers of ten short (1e-12); 0 as 0; inf/nan as given."""
    if x is None:
        return "–"
    if isinstance(x, str):
        try:
            x = float(x)  # JSON stores inf and nan as strings
        except ValueError:
            return x
    if not _is_number(x):
        return str(x)
    x = float(x)
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x == 0:
        return "0"
    short = f"{x:.0e}"
    if float(short) == x:
        return short.replace("e-0", "e-").replace("e+0", "e+").replace("e+", "e")
    return f"{x:.{digits}e}"


def _num_text(c: Num) -> str:
    x = c.value
    if isinstance(x, str):
        try:
            x = float(x)
        except ValueError:
            return x
    if not _is_number(x) or not math.isfinite(x) or x == 0:
        return sci(x, c.digits)
    if not c.short:
        return f"{float(x):.{c.digits}e}"
    mantissa, exponent = f"{float(x):.{max(c.digits, 6)}e}".split("e")
    mantissa = mantissa.rstrip("0").rstrip(".")
    return f"{mantissa}e{exponent}"


def _cell_text(c: Any) -> str:
    if isinstance(c, Num):
        return _num_text(c) + (f" {c.unit}" if c.unit and c.value is not None else "")
    if isinstance(c, Mark):
        return f"{_MARK_SIGN[c.state]} {c.text}"
    if c is None:
        return "–"
    if isinstance(c, bool):
        return "yes" if c else "no"
    if isinstance(c, int):
        return str(c)  # a count
    if _is_number(c):
        return sci(c)
    return str(c)


_MARK_SIGN = {"ok": "✓", "bad": "✗", "na": "–"}


def _plain(x: Any) -> Any:
    """Numpy arrays and scalars to Python lists and scalars (a render from `run`'s dict and one
    from results.json are then the same: formatting treats "nan" and nan alike). Plain lists are
    returned as they are, checked without a call per element (time series are long)."""
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        if all(type(y) in _PLAIN_TYPES for y in x):
            return list(x)
        if all(type(y) is list and all(type(z) in _PLAIN_TYPES for z in y) for y in x):
            return list(x)
        return [_plain(y) for y in x]
    if hasattr(x, "tolist"):  # numpy arrays and scalars
        return x.tolist()
    return x


_PLAIN_TYPES = (float, int, str, bool, type(None))


def _float(x: Any) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def _ratio(row: dict[str, Any], key: str = "scaled") -> float:
    """Error in units of its tolerance: the ordering used to pick a worst row."""
    e, tol = _float(row.get(key)), _float(row.get("tolerance"))
    if math.isnan(e):
        return math.inf
    return e / tol if tol > 0 else e


def _pass_mark(ok: Any, yes: str = "pass", no: str = "FAIL") -> Mark:
    return Mark("ok", yes) if ok is True else Mark("bad", no) if ok is False else Mark("na", NOT_RUN)


def _verdict_mark(verdict: str) -> Mark:
    return {"agrees": Mark("ok", "agrees"), "disagrees": Mark("bad", "disagrees")}.get(verdict, Mark("na", verdict))


def _time(x: Any) -> str:
    return "never" if x is None else f"{_float(x):.2f} s"


def _vec(xs: Any) -> str:
    try:
        return "(" + ", ".join(f"{float(x):g}" for x in xs) + ")"
    except (TypeError, ValueError):
        return str(xs)


# ----------------------------------------------------------------------------------------------
# Figures (matplotlib's object API on Agg: no pyplot state, nothing to close)


def _plain_log_labels(fig: Any) -> None:
    """Log-axis tick labels as plain text (1e-12) instead of mathtext (10^-12): the same reading,
    and mathtext layout was half of the render time."""
    from matplotlib.ticker import FuncFormatter, LogFormatterSciNotation, NullFormatter

    def label(x: float, _pos: Any) -> str:
        if x <= 0 or not math.isfinite(x):
            return ""
        e = math.log10(x)
        if abs(e - round(e)) > 1e-9:
            return ""
        return "1" if round(e) == 0 else f"1e{round(e)}"

    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() == "log":
                if isinstance(axis.get_major_formatter(), LogFormatterSciNotation):
                    axis.set_major_formatter(FuncFormatter(label))
                if isinstance(axis.get_minor_formatter(), LogFormatterSciNotation):
                    axis.set_minor_formatter(NullFormatter())


def _png(fig: Any) -> bytes:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    _plain_log_labels(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=FIG_DPI, metadata={"Software": None})
    return buf.getvalue()


def _new_figure(
    w: float, h: float, nrows: int = 1, sharex: bool = False, *, legend_right: float = 0.0
) -> tuple[Any, Any]:
    """A figure with fixed margins (in inches, so every figure lines up; and no layout engine,
    which would draw each figure twice)."""
    from matplotlib.figure import Figure as MplFigure

    fig = MplFigure(figsize=(w, h))
    left, right, top, bottom, gap = 0.85, 0.2 + legend_right, 0.38, 0.5, 0.12
    fig.subplots_adjust(
        left=left / w,
        right=1 - right / w,
        top=1 - top / h,
        bottom=bottom / h,
        hspace=gap * nrows / max(h - top - bottom - gap * (nrows - 1), 0.1),
    )
    axes = fig.subplots(nrows, 1, sharex=sharex, squeeze=False)[:, 0]
    for ax in axes:
        ax.grid(True, which="major", color="#e5e7eb", linewidth=0.8)
        ax.set_axisbelow(True)
        for side in ("top", "right"):
            ax.spines[side].set_visible(False)
    return fig, axes


LEGEND_W = 1.45  # in: room on the right of a figure for its legend, clear of the curves


def _legend_right(ax: Any) -> None:
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, handlelength=2.6)


def _rc() -> Any:
    import matplotlib

    return matplotlib.rc_context(
        {
            "font.family": "DejaVu Sans",
            "font.size": 9,
            "axes.titlesize": 10,
            "axes.labelsize": 9,
            "legend.fontsize": 8,
            "legend.frameon": False,
            "axes.edgecolor": "#9ca3af",
            "xtick.color": "#374151",
            "ytick.color": "#374151",
            "axes.labelcolor": "#111827",
            "svg.hashsalt": "lagrange-xval",
            "path.simplify": True,
        }
    )


def _stride(n: int) -> int:
    return max(1, math.ceil(n / MAX_PLOT_POINTS))


def _series(values: Any) -> Any:
    """A float array from a list that may hold "nan"/"inf" strings (as results.json stores them)."""
    import numpy as np

    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        return np.asarray(
            [_float(x) if not isinstance(x, list) else [_float(y) for y in x] for x in values], dtype=float
        )


def pointwise_figure(name: str, rows: list[dict[str, Any]]) -> bytes:
    """Scaled error of every quantity and source pair on a log axis, tolerance marked."""
    import numpy as np

    quantities = list(dict.fromkeys(r["quantity"] for r in rows))
    pairs = sorted({r["pair"] for r in rows})
    floor = 1e-18
    with _rc():
        fig, (ax,) = _new_figure(8.6, 3.3)
        width = 0.8 / max(1, len(pairs))
        x = np.arange(len(quantities))
        for j, pair in enumerate(pairs):
            ys, xs = [], []
            for i, q in enumerate(quantities):
                hit = [r for r in rows if r["quantity"] == q and r["pair"] == pair]
                if hit:
                    xs.append(x[i] - 0.4 + width * (j + 0.5))
                    ys.append(_float(hit[0]["scaled"]))
            ys_arr = np.asarray(ys, dtype=float)
            shown = np.where(np.isfinite(ys_arr) & (ys_arr > floor), ys_arr, floor)
            ax.bar(
                xs,
                shown - floor,
                width=width * 0.92,
                bottom=floor,
                color=PAIR_COLOURS[j % len(PAIR_COLOURS)],
                label=pair,
                zorder=2,
            )
            for xi, yi in zip(xs, ys_arr, strict=True):
                if yi == 0:
                    ax.text(xi, floor * 1.6, "0", ha="center", va="bottom", fontsize=7, color="#6b7280")
        tols = [max(_float(r["tolerance"]) for r in rows if r["quantity"] == q) for q in quantities]
        ax.hlines(tols, x - 0.45, x + 0.45, colors="#dc2626", linewidth=2, zorder=3, label="tolerance")
        ax.set_yscale("log")
        from matplotlib.ticker import LogLocator, NullLocator

        ax.yaxis.set_major_locator(LogLocator(base=10, numticks=8))
        ax.yaxis.set_minor_locator(NullLocator())
        top = max(
            [_float(r["tolerance"]) for r in rows]
            + [_float(r["scaled"]) for r in rows if np.isfinite(_float(r["scaled"]))]
        )
        ax.set_ylim(floor, max(1.0, top * 10))
        ax.set_xticks(x, [q.replace("_", "\n") for q in quantities], rotation=0)
        ax.tick_params(axis="x", labelsize=8)
        ax.set_ylabel("max |a - b| / range (log)")
        ax.set_title(f"{name}: largest scaled error over the random states, per quantity and source pair")
        ax.legend(ncols=len(pairs) + 1, loc="upper left")
        return _png(fig)


def _run_label(run: dict[str, Any]) -> str:
    """A run's legend entry: its source, and its own label where one source has several runs."""
    return f"{run['source']} ({run['label']})" if run.get("label") else run["source"]


def _run_style(run: dict[str, Any]) -> tuple[str, Any, float]:
    """Colour, line style and width: by source, green dash-dot for a labelled extra run (a perturbed start)."""
    if run.get("label"):
        return "#059669", (0, (6, 2, 1, 2)), 1.2
    return SOURCE_STYLE.get(run["source"], ("#6b7280", "-", 1.2))


def trajectory_figure(name: str, coords: list[str], t: Any, runs: list[dict[str, Any]]) -> bytes:
    """q against t, every source overlaid, one panel per coordinate."""
    k = _stride(len(t))
    tt = t[::k]
    with _rc():
        fig, axes = _new_figure(8.6, 0.6 + 1.55 * len(coords), nrows=len(coords), sharex=True, legend_right=LEGEND_W)
        for i, (ax, c) in enumerate(zip(axes, coords, strict=True)):
            for run in runs:
                q = _series(run["q"])
                if q.ndim != 2 or q.shape[1] <= i:
                    continue
                colour, style, lw = _run_style(run)
                ax.plot(tt, q[::k, i], color=colour, linestyle=style, linewidth=lw, label=_run_label(run))
            ax.set_ylabel(f"{c} (rad)")
        axes[0].set_title(f"{name}: coordinates against time, every source overlaid")
        _legend_right(axes[0])
        axes[-1].set_xlabel("t (s)")
        return _png(fig)


def error_figure(name: str, t: Any, runs: list[dict[str, Any]], threshold: float, reference: str) -> bytes:
    """log10 of the distance to the reference trajectory, threshold marked."""
    import numpy as np

    k = _stride(len(t))
    tt = t[::k]
    with _rc():
        fig, (ax,) = _new_figure(8.6, 2.9, legend_right=LEGEND_W)
        lows = []
        for run in runs:
            e = _series(run["error_vs_hand"])[::k]
            if not np.any(e > 0):
                continue  # the reference itself, or an exact copy of it
            e = np.where(e > 0, e, np.nan)
            lows.append(np.nanmin(e))
            colour = _run_style(run)[0]
            ax.plot(tt, np.log10(e), color=colour, linewidth=1.2, label=_run_label(run))
            if run.get("first_exceeds_threshold") is not None:
                ax.axvline(_float(run["first_exceeds_threshold"]), color=colour, linewidth=0.8, linestyle=":")
        if np.isfinite(threshold) and threshold > 0:
            ax.axhline(
                math.log10(threshold),
                color="#dc2626",
                linewidth=1.4,
                linestyle="--",
                label=f"threshold {sci(threshold)} rad",
            )
        ax.set_ylabel("log10 max |q - q_ref| (rad)")
        ax.set_xlabel("t (s)")
        from matplotlib.ticker import MaxNLocator

        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_title(f"{name}: distance to the reference solution")
        if ax.get_legend_handles_labels()[0]:
            _legend_right(ax)
        return _png(fig)


def energy_figure(name: str, t: Any, runs: list[dict[str, Any]]) -> bytes:
    """E(t) - E(0) of every source (the hand equations' energy along each trajectory)."""
    k = _stride(len(t))
    tt = t[::k]
    with _rc():
        fig, (ax,) = _new_figure(8.6, 2.9, legend_right=LEGEND_W)
        for run in runs:
            e = _series(run["energy"])
            colour, style, lw = _run_style(run)
            ax.plot(tt, (e - e[0])[::k], color=colour, linestyle=style, linewidth=lw, label=_run_label(run))
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-2, 3), useOffset=False)
        ax.set_ylabel("E(t) - E(0) (J)")
        ax.set_xlabel("t (s)")
        ax.set_title(f"{name}: energy against time")
        _legend_right(ax)
        return _png(fig)


# ----------------------------------------------------------------------------------------------
# Sections


def _variant_worst(v: dict[str, Any]) -> dict[str, Any] | None:
    if v.get("worst_term"):
        return v["worst_term"]
    terms = v.get("terms") or []
    if not terms:
        return None
    w = max(terms, key=_ratio)
    return {k: w.get(k) for k in ("term", "engine", "parameters", "max_abs", "scaled", "tolerance", "pair")}


def _variant_tolerance(v: dict[str, Any], worst: dict[str, Any] | None) -> Any:
    if worst is None:
        return None
    if worst.get("tolerance") is not None:
        return worst["tolerance"]
    for t in v.get("terms") or []:
        if t.get("term") == worst.get("term") and t.get("engine") == worst.get("engine"):
            return t.get("tolerance")
    return None


def _counts(results: dict[str, Any]) -> dict[str, int]:
    systems = results.get("systems", {})
    variants = [v for s in systems.values() for v in s.get("variants", [])]
    return {
        "systems": len(systems),
        "failed": sum(1 for s in systems.values() if s.get("passed") is not True),
        "forms": len(variants),
        "disagree": sum(1 for v in variants if v.get("verdict") == "disagrees"),
        "not_applicable": sum(1 for v in variants if v.get("verdict") not in ("agrees", "disagrees")),
    }


def verdict_line(results: dict[str, Any]) -> tuple[bool, str, str]:
    """(passed, headline, detail) for the top of the report."""
    c = _counts(results)
    passed = results.get("passed") is True and c["failed"] == 0
    if c["systems"] == 0:
        head = "no system was run"
        passed = False
    elif passed:
        head = f"all {c['systems']} systems pass" if c["systems"] > 1 else "the system passes"
    else:
        head = f"{c['failed']} of {c['systems']} systems fail"
    detail = (
        f"{c['forms']} printed forms of the notes judged: {c['forms'] - c['disagree'] - c['not_applicable']} agree "
        f"with the engines, {c['disagree']} disagree (see {ERRATA})"
    )
    if c["not_applicable"]:
        detail += f", {c['not_applicable']} could not be judged"
    return passed, head, detail + "."


def system_statuses(results: dict[str, Any]) -> list[tuple[str, str, Mark, str]]:
    """(name, anchor, verdict mark, one-line detail) of every system, for the top of the report."""
    out = []
    for name, s in sorted(results.get("systems", {}).items()):
        variants = s.get("variants", [])
        wrong = sum(1 for v in variants if v.get("verdict") == "disagrees")
        forms = f"{len(variants)} printed form" + ("s" if len(variants) != 1 else "")
        detail = f"{forms}, {wrong} disagree" if variants else "no printed form"
        d = s.get("derivation") or {}
        if d.get("verdict") == "disagrees":
            detail = f"hand derivation: {d.get('statement')}; {detail}"
        out.append((name, f"system-{_slug(name)}", _pass_mark(s.get("passed")), detail))
    return out


def _cached(results: dict[str, Any]) -> str:
    """Which results were loaded from the cache (validate/cache.py) rather than computed in this run."""
    hits = []
    for name, s in sorted(results.get("systems", {}).items()):
        chaos = s.get("chaos") or {}
        kinds = [
            kind
            for kind, info in (
                ("reference solution", (s.get("trajectories") or {}).get("reference_info")),
                ("chaos summary", chaos.get("chaos")),
            )
            if isinstance(info, dict) and info.get("cache") == "hit"
        ]
        if kinds:
            hits.append(f"{name} ({', '.join(kinds)})")
    return "; ".join(hits) if hits else "nothing: every result computed in this run"


def section_provenance(doc: Document, results: dict[str, Any]) -> None:
    meta = results.get("meta", {})
    doc.h(2, PROVENANCE)
    doc.p(
        "Where and how these results were produced. These lines, and only these, differ between two runs "
        "with the same seed.",
        "note",
    )
    rows = [
        (label, str(meta.get(key, "unknown")))
        for label, key in (
            ("harness version", "harness_version"),
            ("git commit", "git_commit"),
            ("date (UTC)", "date"),
            ("command line", "command"),
            ("CPU", "cpu"),
            ("Python", "python"),
            ("platform", "platform"),
            ("seed", "seed"),
        )
    ]
    rows.append(("from the cache", _cached(results)))
    doc.table("Run", ("item", "value"), rows)
    versions = meta.get("versions", {})
    doc.table("Package versions", ("package", "version"), [(k, str(v)) for k, v in sorted(versions.items())])


def section_summary(doc: Document, results: dict[str, Any]) -> None:
    doc.h(2, SUMMARY)
    doc.p(
        "One row per system and per form of its equations: first the hand derivation (judged on every "
        "quantity against both engines, and on the model checks), then each form printed in the notes. "
        "The error is the largest `|a - b|` over the random states divided by the quantity's range; "
        "the worst row is the one closest to (or furthest past) its tolerance."
    )
    rows: list[tuple[Any, ...]] = []
    for name, s in sorted(results.get("systems", {}).items()):
        prow = s.get("pointwise", {}).get("rows", [])
        d = s.get("derivation") or {}
        if d.get("summary"):
            failing = [r for r in d["summary"] if not r.get("passed")]
            w = (
                failing[0]
                if failing
                else max(
                    d["summary"], key=lambda r: _float(r.get("worst_scaled")) / max(_float(r.get("tolerance")), 1e-300)
                )
            )
            rows.append(
                (
                    name,
                    "hand derivation",
                    "hand",
                    _pass_mark(s.get("passed")),
                    w.get("term"),
                    f"hand~{w.get('engine')}",
                    Num(w.get("worst_scaled")),
                    Num(w.get("tolerance"), short=True),
                )
            )
        elif prow:
            w = max(prow, key=_ratio)
            rows.append(
                (
                    name,
                    "hand derivation",
                    "hand",
                    _pass_mark(s.get("passed")),
                    w.get("quantity"),
                    w.get("pair"),
                    Num(w.get("scaled")),
                    Num(w.get("tolerance"), short=True),
                )
            )
        else:
            rows.append(
                (name, "hand derivation", "hand", _pass_mark(s.get("passed")), None, None, Num(None), Num(None))
            )
        for v in s.get("variants", []):
            w = _variant_worst(v)
            engine = (w or {}).get("engine")
            rows.append(
                (
                    name,
                    v.get("name"),
                    v.get("kind"),
                    _verdict_mark(v.get("verdict", "")),
                    (w or {}).get("term"),
                    f"printed~{engine}" if engine else None,
                    Num((w or {}).get("scaled")),
                    Num(_variant_tolerance(v, w), short=True),
                )
            )
    doc.table(
        "Verdict of every system and printed form",
        ("system", "form", "kind", "verdict", "worst quantity", "pair", "scaled error", "tolerance"),
        rows,
        group=True,
    )


def section_system(doc: Document, name: str, s: dict[str, Any], results: dict[str, Any]) -> None:
    doc.h(2, f"System {name}", f"system-{_slug(name)}")
    doc.p(s.get("description", ""))
    mark = _pass_mark(s.get("passed"))
    doc.p(f"Verdict: {_cell_text(mark)}.", {"ok": "pass", "bad": "fail"}.get(mark.state, ""))

    # Model
    doc.h(3, "Model", f"{_slug(name)}-model")
    doc.p(
        f"MJCF `{s.get('mjcf', '?')}`; hand derivation `{s.get('equations', '?')}`; the scene uses "
        f"{', '.join(s.get('uses', [])) or 'nothing beyond the chain'}; MuJoCo timestep "
        f"{sci(s.get('timestep'))} s."
    )
    params = s.get("parameters", {})
    doc.table(
        f"Parameters of {name}, read from the compiled MJCF",
        ("parameter", "value"),
        [(k, Num(v, short=True)) for k, v in sorted(params.items(), key=lambda kv: (kv[0].lower(), kv[0]))],
    )
    coords, joints = s.get("coordinates", []), s.get("joints", [])
    bodies = s.get("bodies", [])
    doc.table(
        f"Coordinates of {name} and the MJCF joints they map to",
        ("coordinate", "MJCF joint", "body moved"),
        [
            (c, joints[i] if i < len(joints) else None, bodies[i] if i < len(bodies) else None)
            for i, c in enumerate(coords)
        ],
    )

    # Model checks
    mc = s.get("model_checks")
    doc.h(3, "Model checks", f"{_slug(name)}-model-checks")
    if not mc:
        doc.p(f"Model checks: {NOT_RUN}.", "missing")
    else:
        mism = mc.get("mismatches", [])
        by_check: dict[str, int] = {}
        for m in mism:
            by_check[m.get("check", "?")] = by_check.get(m.get("check", "?"), 0) + 1
        doc.p(
            "Before any dynamics: every key of the compiled MJCF against what the hand equations state they "
            "assume (equations~mjcf), and every compared body's mass, centre of mass and inertia as "
            "Pinocchio and MuJoCo compiled them (pinocchio~mujoco)."
        )
        doc.table(
            f"Model checks of {name}",
            ("check", "keys checked", "mismatches", "verdict"),
            [
                ("equations~mjcf and pinocchio~mujoco", mc.get("n_checked"), len(mism), _pass_mark(mc.get("passed"))),
                *[(f"of which {k}", None, n, Mark("bad", "FAIL")) for k, n in sorted(by_check.items())],
            ],
        )
        if mism:
            doc.table(
                f"Model check mismatches of {name}",
                ("check", "key", "expected", "actual", "why"),
                [
                    (m.get("check"), m.get("key"), _short(m.get("expected")), _short(m.get("actual")), m.get("why"))
                    for m in mism
                ],
            )

    from . import studies as report_sections

    doc.h(3, "Derivation verdict", f"{_slug(name)}-derivation")
    report_sections.system_derivation(doc, name, s)

    # Pointwise
    pw = s.get("pointwise")
    doc.h(3, "Pointwise agreement", f"{_slug(name)}-pointwise")
    if not pw:
        doc.p(f"Pointwise agreement: {NOT_RUN}.", "missing")
    else:
        rows = pw.get("rows", [])
        doc.p(
            f"Every quantity of every pair of sources at {pw.get('n_states')} random states (seed "
            f"{pw.get('seed')}). `max abs` is the largest `|a - b|`; `scaled` divides it by the largest "
            "magnitude the quantity takes over the states; a row passes when scaled ≤ tolerance."
        )
        doc.table(
            f"Pointwise agreement of {name} at {pw.get('n_states')} random states (seed {pw.get('seed')})",
            ("quantity", "pair", "tier", "max abs", "scale", "scaled", "tolerance", "verdict"),
            [
                (
                    r.get("quantity"),
                    r.get("pair"),
                    r.get("tier"),
                    Num(r.get("max_abs")),
                    Num(r.get("scale")),
                    Num(r.get("scaled")),
                    Num(r.get("tolerance"), short=True),
                    _pass_mark(r.get("passed")),
                )
                for r in rows
            ],
        )
        failing = [r for r in rows if r.get("passed") is False and r.get("worst_state")]
        if failing:
            doc.table(
                f"States where {name}'s failing quantities disagree most",
                ("quantity", "pair", "q", "v", "tau"),
                [
                    (
                        r["quantity"],
                        r["pair"],
                        _vec(r["worst_state"].get("q", [])),
                        _vec(r["worst_state"].get("v", [])),
                        _vec(r["worst_state"].get("tau", [])),
                    )
                    for r in failing
                ],
            )
        if rows:
            doc.figure(
                f"img/{name}_pointwise.png",
                pointwise_figure(name, rows),
                f"Bar chart of the scaled error of each quantity and source pair for {name}",
                "Scaled error per quantity and source pair, log axis; the red bar over each group is its "
                "tolerance. The results keep only the largest error over the random states, not each "
                "state's, so this is a bar chart of those maxima rather than a histogram of the "
                "per-state errors.",
            )

    # Trajectories
    tr = s.get("trajectories")
    doc.h(3, "Trajectories", f"{_slug(name)}-trajectories")
    if not tr or not tr.get("runs"):
        doc.p(f"Trajectories: {NOT_RUN}.", "missing")
    else:
        t = _series(tr.get("t", []))
        thr = _float(tr.get("threshold"))
        doc.p(
            f"Free motion from q0 = {_vec(tr.get('q0', []))} rad, v0 = {_vec(tr.get('v0', []))} rad/s, "
            f"tau = {_vec(tr.get('tau', []))}, sampled every {_g(tr.get('dt_out'))} s up to {_g(tr.get('t_end'))} s. "
            f"The reference is {tr.get('reference')}; the error is the largest coordinate's distance to it, "
            f"judged against the trajectory threshold {sci(thr)} rad."
        )
        doc.table(
            f"Trajectory runs of {name}",
            ("source", "method", "cost", "max error vs reference", "first above threshold", "energy drift", "verdict"),
            [
                (
                    _run_label(r),
                    r.get("method"),
                    _stats(r.get("stats")),
                    Num(r.get("max_error_vs_hand"), unit="rad"),
                    _time(r.get("first_exceeds_threshold")),
                    Num(r.get("energy_drift"), unit="J"),
                    _run_verdict(r),
                )
                for r in tr["runs"]
            ],
        )
        if tr.get("judged_until") is not None:
            doc.p(f"Runs are judged until {_g(tr['judged_until'])} s, not beyond: {tr.get('judged_because')}.")
        for why in sorted({r["why_not_counted"] for r in tr["runs"] if r.get("why_not_counted")}):
            doc.p(f"Not part of the verdict: {why}.", "note")
        runs = tr["runs"]
        doc.figure(
            f"img/{name}_trajectories.png",
            trajectory_figure(name, s.get("coordinates", []), t, runs),
            f"Coordinates of {name} against time for every source",
            "Coordinates against time: the sources overlay each other while they agree.",
        )
        doc.figure(
            f"img/{name}_error.png",
            error_figure(name, t, runs, thr, str(tr.get("reference"))),
            f"log10 of the distance of each source to the reference trajectory of {name}",
            "Distance to the reference trajectory on a log10 scale; dashed red: the threshold; a dotted "
            "vertical line marks where a source first passes it. Sources identical to the reference "
            "are not drawn.",
        )
        doc.figure(
            f"img/{name}_energy.png",
            energy_figure(name, t, runs),
            f"Energy of {name} against time for every source",
            f"Total energy T + V by the hand equations along each source's trajectory, relative to "
            f"E(0) = {sci(_series(runs[0]['energy'])[0], 6)} J; a conservative system should stay at 0.",
        )

    report_sections.system_equivalence(doc, name, s)
    doc.h(3, "Chaos", f"{_slug(name)}-chaos")
    report_sections.system_chaos(doc, name, s)
    doc.h(3, "Experiments", f"{_slug(name)}-experiments")
    report_sections.system_experiments(doc, name, s)
    report_sections.system_skipped(doc, name, s)


def _run_verdict(run: dict[str, Any]) -> Any:
    """A trajectory run's verdict as the table shows it: judged up to a time, or information only."""
    if not run.get("counts", True):
        return "information only"
    if "passed" not in run:
        return "–"
    mark = _pass_mark(run["passed"])
    return Mark(mark.state, f"{mark.text} (until {_g(run.get('judged_until'))} s)")


def _stats(stats: Any) -> str:
    if not isinstance(stats, dict) or not stats:
        return "–"
    names = {"nfev": "evaluations", "steps": "steps"}
    return ", ".join(f"{v} {names.get(k, k)}" for k, v in sorted(stats.items()) if k != "label") or "–"


def _g(x: Any) -> str:
    """A setting (a time step, a duration) as written: 0.01, 10."""
    return f"{x:g}" if _is_number(x) else sci(x)


def _short(x: Any, n: int = 60) -> str:
    text = _vec(x) if isinstance(x, list) else _cell_text(x)
    return text if len(text) <= n else text[: n - 1] + "…"


def section_errata(doc: Document, results: dict[str, Any]) -> None:
    doc.h(2, ERRATA)
    doc.p(
        "Every form of the equations printed in the notes, transcribed as printed and judged term by term "
        "against both engines, with the notes' parameters and at probe parameter sets in which every parameter "
        "moves by its own factor, keeping only the equalities the printed forms assume (so a slip such as a "
        "missing factor l shows even where l = 1). `first disagreeing term` is the first term, in the order mass "
        "matrix, gravity, velocity, friction, actuation, that disagrees; `worst term` is the largest error; "
        "`disagrees at` says whether the model's own parameters already show it or only a probe does."
    )
    assumed = sorted(
        {
            (name, v["assumes"])
            for name, s in results.get("systems", {}).items()
            for v in s.get("variants", [])
            if v.get("assumes")
        }
    )
    for name, text in assumed:
        doc.p(f"The printed forms of {name} assume {text}; their probes keep these equalities.", "note")
    rows, notes = [], []
    for name, s in sorted(results.get("systems", {}).items()):
        for v in s.get("variants", []):
            w = v.get("worst_term") if v.get("verdict") == "disagrees" else None
            rows.append(
                (
                    name,
                    v.get("name"),
                    ", ".join(v.get("notes_equations", [])),
                    v.get("kind"),
                    _verdict_mark(v.get("verdict", "")),
                    v.get("first_disagreeing_term"),
                    (w or {}).get("term"),
                    (w or {}).get("engine"),
                    Num((w or {}).get("scaled")),
                    v.get("disagrees_at"),
                )
            )
            extra = v.get("note") or ""
            if v.get("reason"):
                extra = (extra + " " if extra else "") + f"Not judged: {v['reason']}"
            if extra:
                notes.append(f"{name}, {v.get('name')}: {extra}")
    if not rows:
        doc.p("No printed form was judged in these results.", "missing")
        return
    doc.table(
        "Printed forms of the notes and their verdicts",
        (
            "system",
            "printed form",
            "notes eqs",
            "kind",
            "verdict",
            "first disagreeing term",
            "worst term",
            "engine",
            "scaled error",
            "disagrees at",
        ),
        rows,
        group=True,
    )
    if notes:
        doc.p("Notes on the transcription:")
        doc.blocks.append(Items(tuple(notes)))


def section_tolerances(doc: Document, results: dict[str, Any]) -> None:
    doc.h(2, TOLERANCE_TIERS)
    tiers = results.get("tolerances") or {}
    used: dict[str, set[str]] = {}
    for s in results.get("systems", {}).values():
        for r in s.get("pointwise", {}).get("rows", []):
            used.setdefault(r.get("tier", "?"), set()).add(r.get("quantity", "?"))
        if s.get("trajectories"):
            used.setdefault("trajectory", set()).add("trajectories")
    doc.p(
        "Every comparison is judged with one named tier: a fraction of the quantity's range over the states "
        "(or, for trajectories, a distance in rad). Each tier says why it is what it is."
    )
    doc.table(
        "Tolerance tiers, what each judges and why",
        ("tier", "rtol", "judges", "reason"),
        [
            (k, Num(t.get("rtol"), short=True), ", ".join(sorted(used.get(k, []))) or "–", t.get("reason", ""))
            for k, t in sorted(tiers.items())
        ],
    )


def section_limitations(doc: Document, results: dict[str, Any]) -> None:
    doc.h(2, LIMITATIONS)
    doc.p("What these results do not show:")
    items = [
        "Point-mass bobs are given a rotational inertia of 1e-14 kg m^2 in the MJCF, because MuJoCo refuses a "
        "moving body without one. The hand derivations include it exactly; the notes' printed forms omit it, an "
        "error of about 1e-14 relative in M, far below the algebraic tier, so it cannot flip a verdict.",
        "Pointwise results keep only the largest error over the random states (and the state where it "
        "occurred), not each state's error: the per-quantity charts show those maxima, not a distribution.",
        "The random states cover a box of angles and velocities; states outside it (very fast motion) are "
        "not sampled. Engines are compared on the quantities listed in each pointwise table; the Coriolis "
        "matrix itself is only compared through C(q, v) v inside the bias.",
        "A printed form is judged at two parameter sets (the notes' and one probe); a slip that happens to "
        "vanish at both would not show.",
        "Each trajectory starts from one initial state. The motion is chaotic, so after the predictability "
        "horizon the sources drift apart by integrator error alone; the trajectory threshold judges the "
        "interval before that, not the equations.",
        "Contacts, joint limits, constraints and closed chains are not part of any system and are not checked.",
        "This report only presents results.json; it recomputes nothing. A number here is only as recent as "
        "that file (see Provenance).",
    ]
    systems = results.get("systems", {})
    skips: dict[str, list[str]] = {}
    for name, s in sorted(systems.items()):
        tiny = sorted(k for k, v in s.get("parameters", {}).items() if _is_number(v) and 0 < abs(v) <= 1e-12)
        if tiny:
            items.append(
                f"{name}: parameters {', '.join(tiny)} are placeholders of order 1e-14 (see above), "
                "not physical values."
            )
        for v in s.get("variants", []):
            if v.get("verdict") not in ("agrees", "disagrees"):
                items.append(
                    f"{name}, printed form {v.get('name')}: not judged ({v.get('verdict')}"
                    + (f": {v['reason']}" if v.get("reason") else "")
                    + ")."
                )
        for key in ("model_checks", "pointwise", "trajectories"):
            if not s.get(key):
                items.append(f"{name}: {key.replace('_', ' ')} {NOT_RUN}.")
        skipped = s.get("skipped")
        for what in skipped if isinstance(skipped, list) else [skipped] if skipped else []:
            skips.setdefault(str(what).rstrip("."), []).append(name)
    for what, names in sorted(skips.items()):
        items.append(f"Skipped for {', '.join(names)}: {what}.")
    missing = [label for key, label in (("bench", "benchmark"), ("stress", "stress tests")) if not results.get(key)]
    missing += [
        f"{label} of {name}"
        for name, s in sorted(systems.items())
        for key, label in (("chaos", "chaos"), ("experiments", "experiments"))
        if not s.get(key)
    ]
    if missing:
        items.append(f"Not run in these results: {', '.join(missing)}.")
    if results.get("skipped"):
        items.append(f"Skipped: {_short(results['skipped'], 200)}.")
    doc.blocks.append(Items(tuple(items)))


def section_replay(doc: Document, results: dict[str, Any]) -> None:
    doc.h(2, REPLAY)
    doc.p(
        "`lagrange-xval run` records every system's trajectories for the rerun viewer next to this report "
        "(`reports/<system>.rrd`, unless run with `--no-replay`). Open one in the native viewer, or in the "
        "web viewer served on this machine only:"
    )
    lines = []
    for name in sorted(results.get("systems", {})):
        lines += [f"rerun reports/{name}.rrd", f"rerun --web-viewer --bind 127.0.0.1 reports/{name}.rrd"]
    doc.blocks.append(Code("\n".join(lines) if lines else "rerun reports/<system>.rrd"))
    doc.p(
        "`lagrange-xval replay SYSTEM` records and opens one system directly; `lagrange-xval report` "
        "re-renders this report from `reports/results.json`."
    )


def system_section(name: str, s: dict[str, Any]) -> Document:
    """One system's section alone (blocks and images): a pure function of that system's results, so
    it can be rendered in the worker that computed them while others still run."""
    doc = Document()
    section_system(doc, name, _plain(s), {})
    return doc


def build(results: dict[str, Any], sections: dict[str, Document] | None = None) -> Document:
    """The whole report as blocks and images (the results must already be plain: see `_plain`);
    `sections`: systems' sections already rendered from these results (`system_section`)."""
    doc = Document()
    section_provenance(doc, results)
    section_summary(doc, results)
    for name, s in sorted(results.get("systems", {}).items()):
        done = (sections or {}).get(name)
        if done is None:
            section_system(doc, name, s, results)
        else:
            doc.blocks += done.blocks
            doc.images.update(done.images)
    section_errata(doc, results)
    section_tolerances(doc, results)
    from . import studies as report_sections

    doc.h(2, BENCHMARK)
    report_sections.section_bench(doc, results.get("bench"))
    doc.h(2, STRESS)
    report_sections.section_stress(doc, results.get("stress"))
    section_limitations(doc, results)
    section_replay(doc, results)
    return doc


# ----------------------------------------------------------------------------------------------
# Renderers


def _md_cell(c: Any) -> str:
    return _cell_text(c).replace("|", "\\|").replace("\n", " ")


def render_markdown(doc: Document, results: dict[str, Any]) -> str:
    passed, head, detail = verdict_line(results)
    out = [
        f"# {TITLE}",
        "",
        f"{SUBTITLE}.",
        "",
        f"**{'✓' if passed else '✗'} {head[0].upper() + head[1:]}.** {detail}",
        "",
    ]
    out += [f"- {_cell_text(mark)} {name}: {text}" for name, _, mark, text in system_statuses(results)] + [""]
    for b in doc.blocks:
        if isinstance(b, Heading):
            out += ["#" * b.level + " " + b.text, ""]
        elif isinstance(b, Para):
            out += [f"*{b.text}*" if b.kind == "missing" else b.text, ""]
        elif isinstance(b, Table):
            out += [
                f"{b.title}:",
                "",
                "| " + " | ".join(b.columns) + " |",
                "|" + "|".join("---:" if num else "---" for num in b.numeric) + "|",
            ]
            out += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in b.rows]
            out.append("")
        elif isinstance(b, Figure):
            out += [f"![{b.alt}]({b.path})", "", f"*{b.caption}*", ""]
        elif isinstance(b, Code):
            out += ["```sh", b.text, "```", ""]
        elif isinstance(b, Items):
            out += [f"- {i}" for i in b.items] + [""]
    return "\n".join(out).rstrip("\n") + "\n"


_ENV: Any = None


def _env() -> Any:
    global _ENV
    if _ENV is None:
        import jinja2
        from markupsafe import Markup, escape

        def inline(text: Any) -> Markup:
            parts = re.split(r"`([^`]+)`", str(text))
            return Markup("").join(
                escape(p) if i % 2 == 0 else Markup("<code>%s</code>") % p for i, p in enumerate(parts)
            )

        def png_size(data: bytes) -> tuple[int, int]:
            return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")

        _ENV = jinja2.Environment(
            loader=jinja2.FileSystemLoader(str(Path(__file__).parent / "templates")),
            autoescape=True,
            undefined=jinja2.StrictUndefined,
            trim_blocks=True,
            lstrip_blocks=True,
            keep_trailing_newline=True,
        )
        _ENV.filters["inline"] = inline
        _ENV.filters["wbr"] = lambda text: Markup("_<wbr>").join(escape(p) for p in str(text).split("_"))

        def breakable(text: Any) -> Markup:
            """A table cell: inline markup, and a break opportunity after ':' in long identifiers."""
            out = inline(text)
            return Markup(re.sub(r":(?=[A-Za-z_])", ":<wbr>", str(out))) if len(str(text)) > 24 else out

        _ENV.filters["breakable"] = breakable
        _ENV.filters["cell"] = _cell_text
        _ENV.filters["b64"] = lambda data: base64.b64encode(data).decode("ascii")
        _ENV.globals["png_size"] = png_size
        _ENV.globals["kind"] = lambda b: type(b).__name__
        _ENV.globals["is_num"] = lambda c: isinstance(c, Num)
        _ENV.globals["is_mark"] = lambda c: isinstance(c, Mark)
    return _ENV


def render_html(doc: Document, results: dict[str, Any]) -> str:
    passed, head, detail = verdict_line(results)
    toc = [(b.anchor, b.text) for b in doc.blocks if isinstance(b, Heading) and b.level == 2]
    systems = results.get("systems", {})
    return (
        _env()
        .get_template("report.html.j2")
        .render(
            title=TITLE,
            subtitle=SUBTITLE,
            passed=passed,
            headline=head[0].upper() + head[1:],
            detail=detail,
            toc=toc,
            blocks=doc.blocks,
            images=doc.images,
            n_systems=len(systems),
            statuses=system_statuses(results),
            mark_sign=_MARK_SIGN,
        )
    )


def render(results: dict[str, Any], sections: dict[str, Document] | None = None) -> dict[str, bytes]:
    """Every report file, {name relative to the reports folder: contents}; `sections` as for `build`."""
    plain = _plain(results)
    doc = build(plain, sections)
    files = {"report.md": render_markdown(doc, plain).encode(), "report.html": render_html(doc, plain).encode()}
    files.update(sorted(doc.images.items()))
    return files

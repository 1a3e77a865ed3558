"""The report's plots: matplotlib's object API on Agg (no pyplot state, nothing to close), fixed
sizes and margins, PNGs without timestamps, so two renders of the same results are identical.
"""

from __future__ import annotations

import io
import math
from collections.abc import Iterable
from contextlib import AbstractContextManager
from typing import TYPE_CHECKING

from ..results.schema import ComparisonRow, FreeRun
from .document import FIG_DPI, MAX_PLOT_POINTS, PAIR_COLOURS, SOURCE_STYLE, LineStyle, as_float, sci
from .figstore import kept

if TYPE_CHECKING:  # matplotlib is imported by the first figure drawn (a warm run draws none)
    import numpy as np
    import numpy.typing as npt
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def _plain_log_labels(fig: Figure) -> None:
    """Log-axis tick labels as plain text (1e-12) instead of mathtext (10^-12): the same reading,
    and mathtext layout was half of the render time."""
    from matplotlib.ticker import FuncFormatter, LogFormatterSciNotation, NullFormatter

    def label(x: float, _pos: int | None) -> str:
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


def fit_legends(fig: Figure) -> None:
    """Widens the figure where a legend placed right of its axes would pass the figure's edge, keeping
    the axes where they are: no legend is cut off, whatever its labels' length."""
    legends = [legend for ax in fig.axes if (legend := ax.get_legend()) is not None]
    if not legends:
        return
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = fig.canvas
    assert isinstance(canvas, FigureCanvasAgg)  # png() drew the figure on Agg
    renderer = canvas.get_renderer()  # type: ignore[no-untyped-call]  # matplotlib leaves it unannotated
    over = max(legend.get_window_extent(renderer).x1 for legend in legends) - fig.bbox.x1
    if over <= 0:
        return
    w, h = fig.get_size_inches()
    extra = over / fig.dpi + 0.08
    left, right = fig.subplotpars.left * w, (1 - fig.subplotpars.right) * w
    fig.set_size_inches(w + extra, h)
    fig.subplots_adjust(left=left / (w + extra), right=1 - (right + extra) / (w + extra))


def png(fig: Figure) -> bytes:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    fit_legends(fig)
    _plain_log_labels(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=FIG_DPI, metadata={"Software": None})
    return buf.getvalue()


def new_figure(
    w: float, h: float, nrows: int = 1, sharex: bool = False, *, legend_right: float = 0.0
) -> tuple[Figure, npt.NDArray[np.object_]]:
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


def legend_right(ax: Axes) -> None:
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, handlelength=2.6)


def rc() -> AbstractContextManager[None]:
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


def stride(n: int) -> int:
    return max(1, math.ceil(n / MAX_PLOT_POINTS))


def series(values: Iterable[object]) -> npt.NDArray[np.float64]:
    """A float array from a list that may hold "nan"/"inf" strings (as results.json stores them)."""
    import numpy as np

    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        return np.asarray(
            [as_float(x) if not isinstance(x, list) else [as_float(y) for y in x] for x in values], dtype=float
        )


@kept
def pointwise_figure(name: str, rows: list[ComparisonRow]) -> bytes:
    """Scaled error of every quantity and source pair on a log axis, tolerance marked."""
    import numpy as np

    quantities = list(dict.fromkeys(r["quantity"] for r in rows))
    pairs = sorted({r["pair"] for r in rows})
    floor = 1e-18
    with rc():
        fig, (ax,) = new_figure(8.6, 3.3, legend_right=LEGEND_W)
        width = 0.8 / max(1, len(pairs))
        x = np.arange(len(quantities))
        for j, pair in enumerate(pairs):
            ys, xs = [], []
            for i, q in enumerate(quantities):
                hit = [r for r in rows if r["quantity"] == q and r["pair"] == pair]
                if hit:
                    xs.append(x[i] - 0.4 + width * (j + 0.5))
                    ys.append(as_float(hit[0]["scaled"]))
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
        tols = [max(as_float(r["tolerance"]) for r in rows if r["quantity"] == q) for q in quantities]
        ax.hlines(tols, x - 0.45, x + 0.45, colors="#dc2626", linewidth=2, zorder=3, label="tolerance")
        ax.set_yscale("log")
        from matplotlib.ticker import LogLocator, NullLocator

        ax.yaxis.set_major_locator(LogLocator(base=10, numticks=8))
        ax.yaxis.set_minor_locator(NullLocator())
        top = max(
            [as_float(r["tolerance"]) for r in rows]
            + [as_float(r["scaled"]) for r in rows if np.isfinite(as_float(r["scaled"]))]
        )
        ax.set_ylim(floor, max(1.0, top * 10))
        ax.set_xticks(x, [q.replace("_", "\n") for q in quantities], rotation=0)
        ax.tick_params(axis="x", labelsize=8)
        ax.set_ylabel("scaled: max |a - b| / max |a|, |b|")
        ax.set_title(f"{name}: largest scaled error over the random states")
        legend_right(ax)
        return png(fig)


def run_label(run: FreeRun) -> str:
    """A run's legend entry: its source, and its own label where one source has several runs."""
    return f"{run['source']} ({run['label']})" if run.get("label") else run["source"]


def run_style(run: FreeRun) -> tuple[str, LineStyle, float]:
    """Colour, line style and width: by source, green dash-dot for a labelled extra run (a perturbed start)."""
    if run.get("label"):
        return "#7c3aed", (0, (6, 2, 1, 2)), 1.2  # not a source's colour: a perturbed start is no source
    return SOURCE_STYLE.get(run["source"], ("#6b7280", "-", 1.2))


@kept
def trajectory_figure(name: str, coords: list[str], t: npt.NDArray[np.float64], runs: list[FreeRun]) -> bytes:
    """q against t, every source overlaid, one panel per coordinate."""
    k = stride(len(t))
    tt = t[::k]
    with rc():
        fig, axes = new_figure(8.6, 0.6 + 1.55 * len(coords), nrows=len(coords), sharex=True, legend_right=LEGEND_W)
        for i, (ax, c) in enumerate(zip(axes, coords, strict=True)):
            for run in runs:
                q = series(run["q"])
                if q.ndim != 2 or q.shape[1] <= i:
                    continue
                colour, style, lw = run_style(run)
                ax.plot(tt, q[::k, i], color=colour, linestyle=style, linewidth=lw, label=run_label(run))
            ax.set_ylabel(f"{c} (rad)")
        axes[0].set_title(f"{name}: coordinates against time, every source overlaid")
        legend_right(axes[0])
        axes[-1].set_xlabel("t (s)")
        return png(fig)


@kept
def error_figure(name: str, t: npt.NDArray[np.float64], runs: list[FreeRun], threshold: float, reference: str) -> bytes:
    """log10 of the distance to the reference trajectory, threshold marked."""
    import numpy as np

    k = stride(len(t))
    tt = t[::k]
    with rc():
        fig, (ax,) = new_figure(8.6, 2.9, legend_right=LEGEND_W)
        lows = []
        for run in runs:
            e = series(run["error_vs_hand"])[::k]
            if not np.any(e > 0):
                continue  # the reference itself, or an exact copy of it
            e = np.where(e > 0, e, np.nan)
            lows.append(np.nanmin(e))
            colour = run_style(run)[0]
            ax.plot(tt, np.log10(e), color=colour, linewidth=1.2, label=run_label(run))
            if run.get("first_exceeds_threshold") is not None:
                ax.axvline(as_float(run["first_exceeds_threshold"]), color=colour, linewidth=0.8, linestyle=":")
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
            legend_right(ax)
        return png(fig)


@kept
def energy_figure(name: str, t: npt.NDArray[np.float64], runs: list[FreeRun]) -> bytes:
    """E(t) - E(0) of every source (the hand equations' energy along each trajectory)."""
    k = stride(len(t))
    tt = t[::k]
    with rc():
        fig, (ax,) = new_figure(8.6, 2.9, legend_right=LEGEND_W)
        for run in runs:
            e = series(run["energy"])
            colour, style, lw = run_style(run)
            ax.plot(tt, (e - e[0])[::k], color=colour, linestyle=style, linewidth=lw, label=run_label(run))
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-2, 3), useOffset=False)
        ax.set_ylabel("E(t) - E(0) (J)")
        ax.set_xlabel("t (s)")
        ax.set_title(f"{name}: energy against time")
        legend_right(ax)
        return png(fig)

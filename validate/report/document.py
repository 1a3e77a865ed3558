"""The document model both renderers draw (headings, paragraphs, titled tables, figures, code,
items), the section titles, and the formatting of numbers and marks.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, SupportsFloat, TypeAlias, TypeGuard

TITLE = "lagrange-xval validation report"


SUBTITLE = "Hand-derived Lagrangian equations of motion, held against MuJoCo, Pinocchio and (where installed) Drake"


SUBTITLE_MODELS = (
    "Models read by each engine (MuJoCo, Pinocchio and, where installed, Drake), each engine's reading and "
    "dynamics held against the others'"
)


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


# A line style as matplotlib takes it: a name ("-", "--") or (offset, dash pattern)
LineStyle: TypeAlias = str | tuple[int, tuple[int, ...]]

SOURCE_STYLE: dict[str, tuple[str, LineStyle, float]] = {  # colour, line style, width: the reference solid,
    # the engines dashed / dotted
    "hand": ("#1f2937", "-", 1.6),
    "mujoco": ("#2563eb", (0, (5, 3)), 1.4),
    "pinocchio": ("#d97706", (0, (1, 2)), 1.8),
    "symbolic": ("#059669", (0, (3, 1, 1, 1)), 1.4),
    "drake": ("#7c3aed", (0, (2, 1, 2, 3)), 1.3),
}


# one per pair of five sources (ten pairs); the work-precision charts add three more (studies.py)
PAIR_COLOURS = (
    "#2563eb",
    "#d97706",
    "#059669",
    "#7c3aed",
    "#db2777",
    "#0891b2",
    "#65a30d",
    "#dc2626",
    "#9333ea",
    "#ea580c",
)


FIG_DPI = 110


@dataclass(frozen=True)
class Num:
    """A number shown in scientific notation, right-aligned: `digits` after the point, or with
    `short` an exact power of ten as 1e-12 and any other value with trailing zeros dropped
    (9.81e+00, 8.33333e-02)."""

    value: float | str | None  # "inf" and "nan" as results.json stores them
    digits: int = 2
    unit: str = ""
    short: bool = False


@dataclass(frozen=True)
class Link:
    """A file of the reports folder, by its path relative to it (a reproducer's script): a link in
    both renderers."""

    text: str
    href: str


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
    kind: str = ""  # "", "note" (a remark), "missing" (a section that was not run), "finding" (what is wrong)


@dataclass(frozen=True)
class Table:
    title: str
    columns: tuple[str, ...]
    rows: tuple[tuple[Cell, ...], ...]
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


@dataclass(frozen=True)
class Fold:
    """Blocks folded under a one-line summary (HTML <details>, closed by default)."""

    summary: str
    blocks: tuple[Block, ...]


Block = Heading | Para | Table | Figure | Code | Items | Fold  # what a document is made of
# A table's cell: a text, a count, a number (shown by `sci`), a Num, a Mark, or None (shown as "–").
Cell: TypeAlias = str | float | Num | Mark | Link | None


@dataclass
class Document:
    blocks: list[Block] = field(default_factory=list)
    images: dict[str, bytes] = field(default_factory=dict)

    def h(self, level: int, text: str, anchor: str | None = None) -> None:
        self.blocks.append(Heading(level, text, anchor or slug(text)))

    def p(self, text: str, kind: str = "") -> None:
        self.blocks.append(Para(text, kind))

    def table(
        self,
        title: str,
        columns: tuple[str, ...] | list[str],
        rows: Sequence[Sequence[Cell]],
        *,
        group: bool = False,
    ) -> None:
        rows_t = tuple(tuple(r) for r in rows)
        numeric = tuple(bool(rows_t) and all(isinstance(r[i], Num) for r in rows_t) for i in range(len(columns)))
        self.blocks.append(Table(title, tuple(columns), rows_t, numeric, group))

    def items(self, items: list[str] | tuple[str, ...]) -> None:
        self.blocks.append(Items(tuple(items)))

    def fold(self, summary: str, inner: Document) -> None:
        """`inner`'s blocks folded under `summary`; its figures join this document's."""
        self.blocks.append(Fold(summary, tuple(inner.blocks)))
        self.images.update(inner.images)

    def figure(self, path: str, png: bytes, alt: str, caption: str) -> None:
        self.images[path] = png
        self.blocks.append(Figure(path, alt, caption))


def slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


def is_number(x: object) -> TypeGuard[int | float]:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def sci(x: object, digits: int = 2) -> str:
    """Scientific notation; exact powers of ten short (1e-12); 0 as 0; inf/nan as given."""
    if x is None:
        return "–"
    if isinstance(x, str):
        try:
            x = float(x)  # JSON stores inf and nan as strings
        except ValueError:
            return str(x)
    if not is_number(x):
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


def num_text(c: Num) -> str:
    x = c.value
    if isinstance(x, str):
        try:
            x = float(x)
        except ValueError:
            return str(x)
    if not is_number(x) or not math.isfinite(x) or x == 0:
        return sci(x, c.digits)
    if not c.short:
        return f"{float(x):.{c.digits}e}"
    mantissa, exponent = f"{float(x):.{max(c.digits, 6)}e}".split("e")
    mantissa = mantissa.rstrip("0").rstrip(".")
    return f"{mantissa}e{exponent}"


def cell_text(c: Cell) -> str:
    if isinstance(c, Num):
        return num_text(c) + (f" {c.unit}" if c.unit and c.value is not None else "")
    if isinstance(c, Mark):
        return f"{MARK_SIGN[c.state]} {c.text}"
    if isinstance(c, Link):
        return c.text
    if c is None:
        return "–"
    if isinstance(c, bool):
        return "yes" if c else "no"
    if isinstance(c, int):
        return str(c)  # a count
    if is_number(c):
        return sci(c)
    return str(c)


MARK_SIGN = {"ok": "✓", "bad": "✗", "na": "–"}


def to_plain(x: Any) -> Any:
    """Numpy arrays and scalars to Python lists and scalars (a render from `run`'s dict and one
    from results.json are then the same: formatting treats "nan" and nan alike). Plain lists are
    returned as they are, checked without a call per element (time series are long)."""
    if isinstance(x, dict):
        return {str(k): to_plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        if all(type(y) in PLAIN_TYPES for y in x):
            return list(x)
        if all(type(y) is list and all(type(z) in PLAIN_TYPES for z in y) for y in x):
            return list(x)
        return [to_plain(y) for y in x]
    if hasattr(x, "tolist"):  # numpy arrays and scalars
        return x.tolist()
    return x


PLAIN_TYPES = (float, int, str, bool, type(None))


def as_float(x: object) -> float:
    if not isinstance(x, str | SupportsFloat):  # None, a list: not a number (float() would raise TypeError)
        return math.nan
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def ratio(row: Mapping[str, object], key: str = "scaled") -> float:
    """Error in units of its tolerance: the ordering used to pick a worst row."""
    e, tol = as_float(row.get(key)), as_float(row.get("tolerance"))
    if math.isnan(e):
        return math.inf
    return e / tol if tol > 0 else e


def pass_mark(ok: object, yes: str = "pass", no: str = "FAIL") -> Mark:
    return Mark("ok", yes) if ok is True else Mark("bad", no) if ok is False else Mark("na", NOT_RUN)


def verdict_mark(verdict: str) -> Mark:
    return {"agrees": Mark("ok", "agrees"), "disagrees": Mark("bad", "disagrees")}.get(verdict, Mark("na", verdict))


def fmt_time(x: object) -> str:
    return "never" if x is None else f"{as_float(x):.2f} s"


def vec(xs: Iterable[float | str] | str) -> str:
    try:
        return "(" + ", ".join(f"{float(x):g}" for x in xs) + ")"
    except (TypeError, ValueError):
        return str(xs)

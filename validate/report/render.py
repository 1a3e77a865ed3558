"""The two renderers of one document: markdown (images beside it) and one self-contained HTML page
(jinja2 template, inline CSS and base64 PNGs, no JavaScript, no request of any kind).
"""

from __future__ import annotations

import base64
import re
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import quote

from ..core.errors import escaped
from ..results.schema import ReportInput, RunResults
from .document import (
    MARK_SIGN,
    SUBTITLE,
    SUBTITLE_MODELS,
    TITLE,
    Block,
    Cell,
    Code,
    Document,
    Figure,
    Fold,
    Heading,
    Items,
    Link,
    Mark,
    Num,
    Para,
    Table,
    cell_text,
    to_plain,
)
from .findings import has_derivation

if TYPE_CHECKING:  # jinja2 is imported by the first HTML render
    import jinja2
from .sections import HIDDEN, ReplayHint, build, header


def subtitle(results: RunResults) -> str:
    """The report's subtitle: the models' when no system of these results has a derivation."""
    systems = results.get("systems", {}).values()
    return SUBTITLE if not systems or any(has_derivation(s) for s in systems) else SUBTITLE_MODELS


def _md_cell(c: Cell) -> str:
    if isinstance(c, Link):
        return f"[{escaped(c.text)}]({quote(c.href)})".replace("|", "\\|")
    return escaped(cell_text(c)).replace("|", "\\|")


def markdown_blocks(blocks: Iterable[Block]) -> list[str]:
    out: list[str] = []
    for b in blocks:
        if isinstance(b, Heading):
            out += ["#" * b.level + " " + escaped(b.text), ""]
        elif isinstance(b, Para):
            text = escaped(b.text)  # a person's message inside cannot start a line of its own
            out += [f"*{text}*" if b.kind == "missing" else f"**{text}**" if b.kind == "finding" else text, ""]
        elif isinstance(b, Table):
            out += [
                f"{escaped(b.title)}:",
                "",
                "| " + " | ".join(b.columns) + " |",
                "|" + "|".join("---:" if num else "---" for num in b.numeric) + "|",
            ]
            out += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in b.rows]
            out.append("")
        elif isinstance(b, Figure):
            out += [f"![{escaped(b.alt)}]({quote(b.path)})", "", f"*{escaped(b.caption)}*", ""]  # a name with spaces
        elif isinstance(b, Code):
            out += ["```sh", b.text, "```", ""]
        elif isinstance(b, Items):
            out += [f"- {escaped(i)}" for i in b.items] + [""]
        elif isinstance(b, Fold):
            out += [f"<details><summary>{b.summary}</summary>", "", *markdown_blocks(b.blocks), "</details>", ""]
    return out


def render_markdown(doc: Document, results: RunResults) -> str:
    head = header(results)
    out = [
        f"# {TITLE}",
        "",
        f"{subtitle(results)}.",
        "",
        f"**{MARK_SIGN[head.state if head.state != 'warn' else 'ok']} {head.headline}.** {head.detail}",
        "",
    ]
    out += [f"- {cell_text(mark)} {name}: {text}" for name, _, mark, text in head.statuses] + [""]
    if head.wrong:
        out += [f"{head.wrong_title}:", ""]
        out += [
            f"- ✗ [{f.system}, {f.form}](#{f.anchor}): `{f.term}`: {f.reason}" + (f" ({HIDDEN})" if f.hidden else "")
            for f in head.wrong
        ]
        out.append("")
    if head.agreeing:
        out += [f"<details><summary>{head.agreeing_title}</summary>", ""]
        out += [f"- {system}, {form}: {verdict}" for system, form, verdict in head.agreeing]
        out += ["", "</details>", ""]
    out += markdown_blocks(doc.blocks)
    return "\n".join(out).rstrip("\n") + "\n"


_ENV: jinja2.Environment | None = None


def environment() -> jinja2.Environment:
    global _ENV
    if _ENV is None:
        import jinja2
        from markupsafe import Markup, escape

        def inline(text: object) -> Markup:
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

        def breakable(text: object) -> Markup:
            """A table cell: inline markup, and a break opportunity after ':' in long identifiers."""
            out = inline(text)
            return Markup(re.sub(r":(?=[A-Za-z_])", ":<wbr>", str(out))) if len(str(text)) > 24 else out

        _ENV.filters["breakable"] = breakable
        _ENV.filters["cell"] = cell_text
        _ENV.filters["b64"] = lambda data: base64.b64encode(data).decode("ascii")
        _ENV.globals["png_size"] = png_size
        _ENV.globals["kind"] = lambda b: type(b).__name__
        _ENV.globals["is_num"] = lambda c: isinstance(c, Num)
        _ENV.globals["is_mark"] = lambda c: isinstance(c, Mark)
        _ENV.globals["is_link"] = lambda c: isinstance(c, Link)
    return _ENV


def warm() -> None:
    """The HTML template compiled ahead (jinja2 imported, its environment made: 0.2 s), for `run` to do
    while its workers compute. A failure here is left to the render, which reports it."""
    try:
        environment().get_template("report.html.j2")
    except Exception:  # noqa: BLE001 - said by render_html, where it matters
        return


def render_html(doc: Document, results: RunResults) -> str:
    head = header(results)
    toc = [(b.anchor, b.text) for b in doc.blocks if isinstance(b, Heading) and b.level == 2]
    return str(
        environment()
        .get_template("report.html.j2")
        .render(
            title=TITLE,
            subtitle=subtitle(results),
            head=head,
            hidden=HIDDEN,
            toc=toc,
            blocks=doc.blocks,
            images=doc.images,
            mark_sign=MARK_SIGN,
        )
    )


def render(
    results: ReportInput, sections: dict[str, Document] | None = None, *, hint: ReplayHint | None = None
) -> dict[str, bytes]:
    """Every report file, {name relative to the reports folder: contents}; `sections` as for `build`;
    `hint`: where the recordings were written and the viewer that opens them (the README's set-up by
    default)."""
    plain = to_plain(results)
    doc = build(plain, sections, hint)
    files = {"report.md": render_markdown(doc, plain).encode(), "report.html": render_html(doc, plain).encode()}
    files.update(sorted(doc.images.items()))
    return files

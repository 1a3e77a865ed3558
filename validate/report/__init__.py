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

Modules: document (the block model, titles, number formatting), findings (what the first screen and the
console lead with), errata, figures, system (one system's
section) and system_parts, sections (the other sections and `build`), studies (bench and stress),
render (markdown and HTML).
"""

from .document import SECTION_TITLES, SUBTITLE, SYSTEM_SUBSECTIONS, TITLE, Document
from .render import render, render_html, render_markdown
from .sections import ReplayHint, build, system_section, system_statuses, verdict_line

__all__ = [
    "SECTION_TITLES",
    "SUBTITLE",
    "SYSTEM_SUBSECTIONS",
    "TITLE",
    "Document",
    "ReplayHint",
    "build",
    "render",
    "render_html",
    "render_markdown",
    "system_section",
    "system_statuses",
    "verdict_line",
]

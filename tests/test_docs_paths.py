"""Docs point to what exists: every repository path the harness's and the equations' source (docstrings
and comments), the README and the command line's help name is a file or folder of the checkout."""

from __future__ import annotations

import argparse
import ast
import functools
import io
import re
import tokenize
from pathlib import Path

import pytest
from lagrange_xval.cli import parser

ROOT = Path(__file__).resolve().parents[1]
SUBPACKAGES = tuple(sorted(p.name for p in (ROOT / "validate").iterdir() if (p / "__init__.py").exists()))
# `validate/...`, `equations/...`, `models/...`, `examples/...`, `tests/...` from the checkout's top, and
# `checks/...` and the other subpackages from validate/ (as the docstrings name them). A pattern
# (`equations/<name>.py`, `models/{name}.xml`, `*.py`) stops the match before its placeholder.
TOKEN = re.compile(rf"(?<![\w/.'\"-])((?:validate|equations|models|examples|tests|{'|'.join(SUBPACKAGES)})/[\w./-]*\w)")
EXTENSIONS = {"py", "xml", "urdf", "toml", "json", "md", "j2", "html", "csv", "rrd", "npz"}


def path_tokens(text: str) -> list[str]:
    return TOKEN.findall(text)


def exists(token: str) -> bool:
    """The path (from the top or from validate/), or the module of `module.name`."""
    stem, _, last = token.rpartition(".")
    candidates = [token] if not stem or last in EXTENSIONS else [token, f"{stem}.py"]
    return any((ROOT / c).exists() or (ROOT / "validate" / c).exists() for c in candidates)


def _help_texts() -> str:
    top = parser.build_parser()
    (sub,) = (a for a in top._actions if isinstance(a, argparse._SubParsersAction))
    return "\n".join([top.format_help(), *(p.format_help() for p in sub.choices.values())])


THIS = Path(__file__).resolve()


def _prose(path: Path) -> str:
    """A Python file's docstrings and comments."""
    text = path.read_text()
    docs = [
        ast.get_docstring(node) or ""
        for node in ast.walk(ast.parse(text))
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef)
    ]
    comments = [t.string for t in tokenize.generate_tokens(io.StringIO(text).readline) if t.type == tokenize.COMMENT]
    return "\n".join(docs + comments)


@functools.cache
def _sources() -> dict[str, str]:
    files = [*sorted(p for folder in ("validate", "equations") for p in (ROOT / folder).rglob("*.py"))]
    out = {str(p.relative_to(ROOT)): p.read_text() for p in files}
    # examples/ and tests/: what they say (docstrings and comments), not the made-up paths their code tests with
    for folder in ("examples", "tests"):
        out |= {str(p.relative_to(ROOT)): _prose(p) for p in sorted((ROOT / folder).rglob("*.py")) if p != THIS}
    out["README.md"] = (ROOT / "README.md").read_text()
    out["lagrange-xval --help"] = _help_texts()
    return out


def test_the_path_finder_sees_paths_and_skips_patterns():
    text = "see validate/model/modelview.py, `equations/<name>.py`, verdict/explain.explain and tests/x.py."
    assert path_tokens(text) == ["validate/model/modelview.py", "verdict/explain.explain", "tests/x.py"]
    assert exists("verdict/explain.explain") and exists("validate/model/modelview.py")
    assert not exists("tests/x.py") and not exists("validate/modelview.py")


@pytest.mark.parametrize("where", sorted(_sources()))
def test_every_path_named_exists(where):
    text = _sources()[where]
    missing = sorted({t for t in path_tokens(text) if not exists(t)})
    assert not missing, f"{where} names paths that do not exist: {', '.join(missing)}"

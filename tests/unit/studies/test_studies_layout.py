"""The shape of validate/studies (bench and stress): the harness's own modules imported at the top of
each module, the engine libraries only through sources/, and no copy of an engine adapter.

Read from the source with `ast` (nothing is imported), so a violation names the file and line.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

STUDIES = Path(__file__).resolve().parents[3] / "validate" / "studies"
MODULES = sorted(STUDIES.rglob("*.py"))
# sources/mujoco.py, pinocchio.py, warp.py and drake.py load their engine when imported: they wait until used.
LAZY_ENGINE_MODULES = {"mujoco", "pinocchio", "warp", "drake"}
# The engine libraries' own names: calling them is the adapters' job (sources/).
ENGINE_LIBRARIES = {"mujoco", "pinocchio"}


def _where(path: Path, node: ast.AST) -> str:
    return f"validate/studies/{path.relative_to(STUDIES)}:{getattr(node, 'lineno', '?')}"


def _function_imports(tree: ast.Module) -> list[ast.Import | ast.ImportFrom]:
    out: list[ast.Import | ast.ImportFrom] = []
    for fn in ast.walk(tree):
        if isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
            out += [n for n in ast.walk(fn) if isinstance(n, ast.Import | ast.ImportFrom)]
    return out


def test_studies_modules_were_found():
    """A guard on the tests below: they read both studies' packages."""
    names = {p.relative_to(STUDIES).parts[0] for p in MODULES}
    assert {"bench", "stress"} <= names, names


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(STUDIES)))
def test_the_harness_is_imported_at_the_top(path):
    """Inside a function, a studies module imports only a third-party library or an engine module
    that loads its engine (sources/mujoco.py, sources/pinocchio.py); every other harness module is
    imported at the top, where a reader sees what the module depends on."""
    bad = []
    for node in _function_imports(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level:
            names = {a.name for a in node.names}
            engine_only = (node.module or "").split(".")[-1] == "sources" and names <= LAZY_ENGINE_MODULES
            if not engine_only:
                bad.append(f"{_where(path, node)} imports from {'.' * node.level}{node.module} inside a function")
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("lagrange_xval"):
            bad.append(f"{_where(path, node)} imports {node.module} inside a function")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(STUDIES)))
def test_no_engine_library_is_called_outside_the_engines(path):
    """No `import mujoco` or `import pinocchio` (nor `getattr(source, "inner", ...)` to reach an
    adapter's engine objects): the studies go through sources/."""
    text = path.read_text()
    bad = []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Import):
            bad += [
                f"{_where(path, node)} imports {a.name}" for a in node.names if a.name.split(".")[0] in ENGINE_LIBRARIES
            ]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            if (node.module or "").split(".")[0] in ENGINE_LIBRARIES:
                bad.append(f"{_where(path, node)} imports from {node.module}")
    if '"inner"' in text:
        bad.append(f"validate/studies/{path.relative_to(STUDIES)} unwraps a source's inner adapter")
    assert not bad, "\n".join(bad)

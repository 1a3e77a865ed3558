"""Packaging: every third-party package the harness or the equations import is a declared dependency
of pyproject.toml, so `pip install .` without the lock file gives a harness that runs.

Imports are read from the source with `ast` (nothing is imported); import names are mapped to
distribution names by the installed packages' metadata, with a table for those whose metadata does
not say (pinocchio ships as `pin`).
"""

from __future__ import annotations

import ast
import functools
import re
import runpy
import sys
import tomllib
from importlib import metadata
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SCANNED = ("validate", "equations")
# Import name -> distribution, where the two differ and the installed metadata does not map them.
DISTRIBUTION_OF = {
    "pinocchio": "pin",
    "yaml": "pyyaml",
    "PIL": "pillow",
    "cv2": "opencv-python",
    "sklearn": "scikit-learn",
    "rerun": "rerun-sdk",
    "jinja2": "jinja2",
    "markupsafe": "markupsafe",
}
OWN = {"lagrange_xval", "__future__"}


def normalized(name: str) -> str:
    """PEP 503: `Jinja2`, `jinja_2` and `jinja-2` are one distribution."""
    return re.sub(r"[-_.]+", "-", name).lower()


def declared() -> tuple[set[str], set[str]]:
    """(core dependencies, those of the optional extras), normalized, from pyproject.toml."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]

    def names(requirements: list[str]) -> set[str]:
        return {normalized(re.match(r"[A-Za-z0-9._-]+", r).group(0)) for r in requirements}  # type: ignore[union-attr]

    extras: set[str] = set()
    for group in project.get("optional-dependencies", {}).values():
        extras |= names(group)
    return names(project.get("dependencies", [])), extras


def third_party_imports(folders: tuple[str, ...] = SCANNED) -> dict[str, list[tuple[str, bool]]]:
    """Top-level import name -> [(file:line, imported when the module is)] of every absolute import
    of a package outside the standard library and the harness itself."""
    found: dict[str, list[tuple[str, bool]]] = {}

    def visit(node: ast.AST, path: Path, in_function: bool) -> None:
        if isinstance(node, ast.If) and ast.unparse(node.test) in {"TYPE_CHECKING", "typing.TYPE_CHECKING"}:
            for child in node.orelse:  # what only the type checker imports never runs
                visit(child, path, in_function)
            return
        tops = []
        if isinstance(node, ast.Import):
            tops = [a.name.split(".")[0] for a in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            tops = [node.module.split(".")[0]]
        for top in tops:
            if top not in sys.stdlib_module_names and top not in OWN:
                found.setdefault(top, []).append((f"{path.relative_to(ROOT)}:{node.lineno}", not in_function))
        inside = in_function or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        for child in ast.iter_child_nodes(node):
            visit(child, path, inside)

    for folder in folders:
        for path in sorted((ROOT / folder).rglob("*.py")):
            visit(ast.parse(path.read_text()), path, False)
    return found


@functools.cache
def installed_providers() -> dict[str, list[str]]:
    """Import name -> the installed distributions that provide it (read once: it walks every one)."""
    return dict(metadata.packages_distributions())


def distributions(import_name: str) -> set[str]:
    """The distributions that may provide `import_name`, normalized."""
    installed = installed_providers().get(import_name, [])
    return {normalized(d) for d in [*installed, DISTRIBUTION_OF.get(import_name, import_name)]}


def undeclared(imports: dict[str, list[tuple[str, bool]]], core: set[str], extras: set[str]) -> list[str]:
    """Imports no declared dependency provides. An import that runs when its module is imported needs
    a core dependency; one inside a function (pytest, for `lagrange_xval.testing`) may use an extra."""
    bad = []
    for name, sites in sorted(imports.items()):
        provided = distributions(name)
        eager = [where for where, top in sites if top]
        if eager and not provided & core:
            bad.append(f"{name} (imported at {eager[0]}) is not in [project] dependencies")
        elif not provided & (core | extras):
            bad.append(f"{name} (imported at {sites[0][0]}) is in no dependency list of pyproject.toml")
    return bad


def test_every_imported_package_is_a_declared_dependency():
    core, extras = declared()
    bad = undeclared(third_party_imports(), core, extras)
    assert not bad, "; ".join(bad)


def test_every_core_dependency_is_imported():
    """A dependency nothing imports is a stale entry (or an import this test cannot see)."""
    core, _ = declared()
    provided = set().union(*(distributions(name) for name in third_party_imports()))
    assert core <= provided, f"declared but never imported: {sorted(core - provided)}"


def test_the_check_catches_a_missing_dependency():
    """The comparison itself can fail: pinocchio maps to `pin`, yaml to `pyyaml`, and a package with
    no declared distribution is named with where it is imported."""
    imports = {"pinocchio": [("validate/x.py:3", True)], "yaml": [("validate/y.py:7", False)]}
    assert undeclared(imports, {"pin"}, {"pyyaml"}) == []
    assert undeclared(imports, set(), {"pin", "pyyaml"}) == [
        "pinocchio (imported at validate/x.py:3) is not in [project] dependencies"
    ]
    assert undeclared(imports, {"pin"}, set()) == [
        "yaml (imported at validate/y.py:7) is in no dependency list of pyproject.toml"
    ]


def _setuptools() -> dict[str, Any]:
    return dict(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"])


def packages_on_disk() -> set[str]:
    """Every installed package name the folders give: each folder of a package-dir mapping, and its
    sub-folders with an `__init__.py` (but those mapped under a name of their own), under the mapped name."""
    mapping = _setuptools()["package-dir"]
    mapped = {(ROOT / folder).resolve() for folder in mapping.values()}
    found = set()
    for name, folder in mapping.items():
        base = ROOT / folder
        found.add(name)
        for init in base.rglob("__init__.py"):
            parts = init.parent.relative_to(base).parts
            if parts and init.parent.resolve() not in mapped:  # equations/ and models/ are mapped by name
                found.add(".".join([name, *parts]))
    return found


def test_the_package_list_is_the_tree():
    """setup.py's list (setuptools cannot find packages under a new name) names every package folder,
    so `pip install .` installs `studies.bench` and `studies.stress` too."""
    listed = set(runpy.run_path(str(ROOT / "setup.py"), run_name="setup")["packages"]())
    on_disk = packages_on_disk()
    assert listed == on_disk, (
        f"missing from pyproject: {sorted(on_disk - listed)}; not on disk: {sorted(listed - on_disk)}"
    )

"""Packaging: every third-party package the harness or the equations import is a declared dependency
of pyproject.toml, so `pip install .` without the lock file gives a harness that runs.

Imports are read from the source with `ast` (nothing is imported); import names are mapped to
distribution names by the installed packages' metadata, with a table for those whose metadata does
not say (pinocchio ships as `pin`).
"""

from __future__ import annotations

import ast
import functools
import importlib.util
import os
import re
import runpy
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from importlib import metadata
from pathlib import Path
from typing import Any

import pytest
from lagrange_xval.cli.commands import COMMANDS

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


COPIED = ("pyproject.toml", "setup.py", "README.md", "validate", "equations", "models")


def _build_wheel(tmp: Path) -> Path:
    """The wheel of a copy of the sources (a build writes build/ and *.egg-info where it runs, so
    never in the checkout). Without build isolation where this venv's setuptools can write a wheel;
    else pip sets up pyproject's build requirements from its configured index."""
    src = tmp / "src"
    src.mkdir()
    for name in COPIED:
        path = ROOT / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(path, src / name)
    isolation = ["--no-build-isolation"] if _can_build_in_place() else []
    dist = tmp / "dist"
    cmd = [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", *isolation, str(src), "-w", str(dist)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=tmp)
    assert done.returncode == 0, done.stdout + done.stderr
    (wheel,) = dist.glob("lagrange_xval-*.whl")
    return wheel


def _can_build_in_place() -> bool:
    """This venv's setuptools writes wheels itself (70.1 and later), or with the `wheel` package."""
    try:
        version = metadata.version("setuptools")
    except metadata.PackageNotFoundError:
        return False
    major_minor = tuple(int(x) for x in re.findall(r"\d+", version)[:2])
    return major_minor >= (70, 1) or importlib.util.find_spec("wheel") is not None


def _venv_with_wheel(tmp: Path, wheel: Path) -> Path:
    """A fresh venv holding the wheel (not editable), which reads every other package from this
    venv's site-packages (a .pth runs site.addsitedir on it, so its own .pth files apply: pinocchio's
    cmeel path); nothing is downloaded. Its python."""
    venv = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    python = venv / "bin" / "python"
    purelib = Path(sysconfig.get_paths()["purelib"])
    target = Path(
        subprocess.run(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    )
    cmd = [sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-deps", "--no-index", str(wheel)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    (target / "zz_harness_dependencies.pth").write_text(f"import site; site.addsitedir({str(purelib)!r})\n")
    return python


@pytest.mark.long
def test_the_built_wheel_installs_whole_and_every_command_runs(tmp_path):
    """`pip wheel .`, installed without -e into a fresh venv: the package resolves there (not to the
    checkout), every module imports, the data files are in, every command's --help works and a short
    `check` gives its verdict."""
    wheel = _build_wheel(tmp_path)
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
    for needed in ("lagrange_xval/py.typed", "lagrange_xval/models/simple_pendulum.xml"):
        assert needed in names, f"{needed} is not in {wheel.name}"
    assert any(n.startswith("lagrange_xval/report/templates/") for n in names)
    python = _venv_with_wheel(tmp_path, wheel)
    venv = python.parent.parent
    work = tmp_path / "work"
    work.mkdir()
    imports = (
        "import importlib, pkgutil, lagrange_xval, lagrange_xval as v\n"
        "for m in pkgutil.walk_packages(v.__path__, 'lagrange_xval.'):\n"
        "    if not m.name.endswith('__main__'): importlib.import_module(m.name)\n"
        "import lagrange_xval.testing, lagrange_xval.forms, lagrange_xval.equations\n"
        "print(lagrange_xval.__file__)\n"
    )
    done = subprocess.run([str(python), "-c", imports], cwd=work, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert Path(done.stdout.strip()).resolve().is_relative_to(venv.resolve()), done.stdout
    cli = str(venv / "bin" / "lagrange-xval")
    for command in [[], *([c] for c in COMMANDS)]:
        done = subprocess.run([cli, *command, "--help"], cwd=work, capture_output=True, text=True, timeout=120)
        assert done.returncode == 0 and "usage:" in done.stdout, (command, done.stderr)
    done = subprocess.run(
        [cli, "check", "simple_pendulum", "--states", "20"], cwd=work, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.splitlines()[-1].startswith("verdict: simple_pendulum: pass"), done.stdout
    assert list(work.iterdir()) == []
    _api_check_writes_nothing(python, _installed_folder(python, work), tmp_path, work)


def _installed_folder(python: Path, work: Path) -> Path:
    """The installed package's folder, as the installed interpreter finds it."""
    code = "import lagrange_xval, pathlib; print(pathlib.Path(lagrange_xval.__file__).parent)"
    found = subprocess.run([str(python), "-c", code], cwd=work, capture_output=True, text=True, check=True)
    return Path(found.stdout.strip())


def _api_check_writes_nothing(python: Path, package: Path, tmp_path: Path, work: Path) -> None:
    """`lx.check` of a wrong derivation (whose explanation a cache would keep) with the installed
    package: the installation and the working folder are as they were (bytecode off)."""
    from .mutations import MUTATIONS, mutated_source

    hidden = next(m for m in MUTATIONS if m.system == "simple_pendulum" and m.name.startswith("g sin th without l"))
    model, module = tmp_path / "in" / "mine.xml", tmp_path / "in" / "mine.py"
    model.parent.mkdir()
    model.write_text((ROOT / "models" / "simple_pendulum.xml").read_text())
    module.write_text(mutated_source(hidden))
    code = (
        "import lagrange_xval as lx, sys\n"
        f"r = lx.check(lx.System.from_files({str(model)!r}, {str(module)!r}), n_states=20, probes=2)\n"
        "sys.exit(0 if not r.passed and 'gravity' in r.statement else 3)\n"
    )
    before = sorted(p for p in package.rglob("*") if "__pycache__" not in p.parts)
    xdg = tmp_path / "xdg"
    env = {k: v for k, v in os.environ.items() if k != "LAGRANGE_XVAL_CACHE"}
    env |= {"PYTHONDONTWRITEBYTECODE": "1", "XDG_CACHE_HOME": str(xdg)}
    done = subprocess.run([str(python), "-c", code], cwd=work, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert sorted(p for p in package.rglob("*") if "__pycache__" not in p.parts) == before
    assert list(work.iterdir()) == [] and not xdg.exists()

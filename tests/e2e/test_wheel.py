"""The built wheel (marker `long`): `pip wheel .`, installed without -e into a fresh venv, resolves there, holds
every module, and every command runs from it. The package's declared shape is tests/test_packaging.py."""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from importlib import metadata
from pathlib import Path

import pytest
from lagrange_xval.cli.commands import COMMANDS

ROOT = Path(__file__).resolve().parents[2]


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
    from tests.mutations import MUTATIONS, mutated_source

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

"""The README's two commands: CI runs the test command verbatim."""

from __future__ import annotations

from lagrange_xval.systems import PACKAGE_ROOT


def _commands():
    return [
        line.strip()
        for line in (PACKAGE_ROOT / "README.md").read_text().splitlines()
        if line.startswith("    python3 -m venv")
    ]


def test_readme_has_exactly_two_setup_commands():
    cmds = _commands()
    assert len(cmds) == 2
    assert cmds[0].endswith("lagrange-xval run") and "pytest" in cmds[1]


def test_ci_runs_the_readme_test_command():
    ci = (PACKAGE_ROOT / ".ci" / "run").read_text()
    assert _commands()[1] in ci


def test_ci_runs_the_long_tests_the_readme_command_leaves_out():
    """The README's command leaves out the tests marked `long` (pyproject's addopts); .ci/run runs them
    after it, so CI covers every test."""
    ci = (PACKAGE_ROOT / ".ci" / "run").read_text()
    addopts = (PACKAGE_ROOT / "pyproject.toml").read_text()
    assert "not long" in addopts
    assert ci.index(_commands()[1]) < ci.index(".venv/bin/python -m pytest -q -m long")

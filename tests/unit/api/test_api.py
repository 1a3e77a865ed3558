"""The public API (`import lagrange_xval`), as a user's own test suite would use it."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import lagrange_xval as lx
import pytest
from lagrange_xval import systems
from lagrange_xval.testing import assert_equations_match, systems_in

from ...mutations import MUTATIONS, mutated_source


def _user_copy(folder: Path, name: str, source: str | None = None) -> tuple[Path, Path]:
    """A repository system copied into a user's folder: its MJCF and its equations module (which
    imports the helpers by their public name, lagrange_xval.forms, so it works as it is)."""
    system = systems.load(name)
    text = source if source is not None else Path(system.equations.__file__).read_text()
    model = folder / f"{name}.xml"
    model.write_text(system.mjcf.read_text())
    module = folder / f"{name}.py"
    module.write_text(text)
    return model, module


def test_check_returns_typed_rows_and_writes_nothing(tmp_path, monkeypatch):
    """check() on a repository system: every row typed, all passing, and no file written anywhere."""
    monkeypatch.chdir(tmp_path)
    result = lx.check("simple_pendulum", n_states=50, probes=2)
    assert result.passed and result.rows and not result.failures
    assert {r.check for r in result.rows} == {"pointwise", "derivation"}
    assert all(isinstance(r, lx.Row) and isinstance(r.scaled, float) for r in result.rows)
    assert {r.probe for r in result.rows if r.check == "derivation"} == {0, 1, 2}
    result.assert_ok()
    assert list(tmp_path.iterdir()) == []


def test_assert_ok_names_term_pair_state_and_probe(tmp_path):
    """A derivation wrong only where l != 1 (g sin th without l): the error names the term, the pair,
    the state and the probe where it shows."""
    m = next(m for m in MUTATIONS if m.system == "simple_pendulum" and m.name.startswith("g sin th without l"))
    model, module = _user_copy(tmp_path, "simple_pendulum", mutated_source(m))
    result = lx.check(lx.System.from_files(model, module), n_states=50, probes=2)
    with pytest.raises(AssertionError) as err:
        result.assert_ok()
    text = str(err.value)
    assert "derivation gravity hand~" in text and "probe " in text and "at q = [" in text, text
    assert "hidden by the model's values" in text, text


def test_a_users_own_suite_in_a_folder_outside_the_repository(tmp_path):
    """A pytest file in a temporary folder uses assert_equations_match on a right and a wrong copy of
    a repository system, and systems_in over the folder: pass, fail naming the term, pass."""
    good = tmp_path / "good"
    good.mkdir()
    _user_copy(good, "double_pendulum_point")
    m = next(m for m in MUTATIONS if m.system == "double_pendulum_point" and m.name.startswith("l1*l2"))
    bad = tmp_path / "bad"
    bad.mkdir()
    _user_copy(bad, "double_pendulum_point", mutated_source(m))
    (tmp_path / "test_mine.py").write_text(
        textwrap.dedent(
            """
            import pytest
            from lagrange_xval.testing import assert_equations_match, systems_in

            def test_right_equations_pass():
                assert_equations_match("good/double_pendulum_point.xml", "good/double_pendulum_point.py",
                                       n_states=50, probes=2)

            def test_wrong_equations_fail_naming_the_term():
                with pytest.raises(AssertionError, match="mass matrix"):
                    assert_equations_match("bad/double_pendulum_point.xml", "bad/double_pendulum_point.py",
                                           n_states=50, probes=2)

            @pytest.mark.parametrize("system", systems_in("good"))
            def test_every_system_in_my_folder(system):
                assert_equations_match(system, n_states=50, probes=1)
            """
        )
    )
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_mine.py"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0 and "3 passed" in run.stdout, run.stdout[-2000:] + run.stderr[-2000:]


def test_from_files_errors_are_one_line(tmp_path):
    """A missing file, a syntax error, an import that raises and a module lacking the contract."""
    model, module = _user_copy(tmp_path, "simple_pendulum")
    cases = {
        "missing.py": ("equations file not found", None),
        "broken.py": ("syntax error", "def f(:\n"),
        "raises.py": ("importing it raised ZeroDivisionError", "x = 1 / 0\n"),
        "empty.py": (r"lacks parameters\(model\)", "X = 1\n"),
    }
    for filename, (message, text) in cases.items():
        path = tmp_path / filename
        if text is not None:
            path.write_text(text)
        with pytest.raises(lx.HarnessError, match=message) as err:
            lx.System.from_files(model, path)
        assert "\n" not in str(err.value)
    with pytest.raises(lx.HarnessError, match="model file not found"):
        lx.System.from_files(tmp_path / "nope.xml", module)


def test_systems_in_reports_files_without_a_partner(tmp_path):
    """A model without its equations (or the reverse) is named, never skipped silently."""
    _user_copy(tmp_path, "simple_pendulum")
    (tmp_path / "lonely.xml").write_text("<mujoco/>")
    with pytest.raises(lx.HarnessError, match="lonely has no partner"):
        systems_in(tmp_path)


def test_with_overrides_changes_the_parameters_every_source_reads():
    """with_overrides edits the MJCF the engines and the equations read."""
    system = lx.load("simple_pendulum").with_overrides(body__link__mass=2.5)
    assert system.params.m == 2.5
    assert lx.check(system, n_states=20, probes=0).passed


def test_assert_equations_match_returns_the_result_when_it_passes():
    assert assert_equations_match(lx.load("simple_pendulum"), n_states=20, probes=0).passed

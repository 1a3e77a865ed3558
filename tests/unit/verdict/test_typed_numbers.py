"""Numbers typed into parameters() (issue 34): a field that parameters() returns without reading it
from the model (g = 9.81, a length typed as a literal) is listed in the verdict, pass or FAIL, since
no probe moves it and so nothing else checks it."""

from __future__ import annotations

from pathlib import Path

import lagrange_xval as lx
import pytest

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"


def without_assumptions(folder: Path, old: str, new: str) -> lx.System:
    """examples/acrobot.py with assumptions() cut out (its probes follow what parameters() reads) and
    `old` in parameters() replaced by the literal `new`."""
    source = (EXAMPLES / "acrobot.py").read_text()
    start, end = source.index("def assumptions("), source.index("def _inertia_terms(")
    source = source[:start] + source[end:]
    assert source.count(old) == 1, old
    (folder / "arm.py").write_text(source.replace(old, new))
    (folder / "arm.xml").write_text((EXAMPLES / "acrobot.xml").read_text())
    return lx.System.from_files(folder / "arm.xml", folder / "arm.py")


@pytest.mark.parametrize(
    ("old", "new", "listed"),
    [
        ('g=float(-model["gravity"][2]),', "g=9.81,", "g = 9.81"),
        ('l1=float(-model["body/link2/pos"][2]),', "l1=1.0,", "l1 = 1"),
    ],
)
def test_a_typed_number_is_listed_even_where_the_verdict_passes(tmp_path, old, new, listed):
    result = lx.check(without_assumptions(tmp_path, old, new), n_states=60, probes=2)
    assert result.passed, result.statement  # the literal equals the model's number: nothing disagrees
    assert f"parameters() does not read {listed} from the model" in result.statement, result.statement


def test_a_module_reading_every_number_lists_none(tmp_path):
    result = lx.check(without_assumptions(tmp_path, "g=", "g="), n_states=60, probes=2)
    assert result.passed and "does not read" not in result.statement, result.statement


def test_a_literal_where_the_model_has_another_number_is_named_in_the_entry(tmp_path):
    """The Furuta pendulum's arm length typed as 0.25 where the model has 0.085: the verdict names
    the literal in the energy that uses it and the entries of M it changes, and lists it as typed."""
    source = (EXAMPLES / "furuta_pendulum.py").read_text()
    start = source.index("def assumptions(")
    end = source.index("\ndef ", start + 1) + 1
    old = 'L=model["body/pendulum/pos"][0],'
    assert source.count(old) == 1
    (tmp_path / "furuta.py").write_text((source[:start] + source[end:]).replace(old, "L=0.25,"))
    (tmp_path / "furuta.xml").write_text((EXAMPLES / "furuta_pendulum.xml").read_text())
    result = lx.check(lx.System.from_files(tmp_path / "furuta.xml", tmp_path / "furuta.py"), n_states=60, probes=2)
    assert not result.passed
    assert "T: yours uses 0.25 where the model's l_pendulum belongs; it changes M[theta, theta]" in result.statement
    assert "parameters() does not read L = 0.25 from the model" in result.statement, result.statement

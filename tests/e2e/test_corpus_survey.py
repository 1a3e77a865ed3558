"""`lagrange-xval survey` over each package of the corpus (issue 43 item 3): one row per model file the
package ships, each row's outcome and phrases those the table (tests/corpus_outcomes.py) expects of
`check --model` on the file alone, no crash, every FAIL with its reproducers written beside the pages."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from lagrange_xval.cli import main

from tests import corpus
from tests.corpus_outcomes import EXPECTED

pytestmark = corpus.marks()


@pytest.mark.parametrize("package", list(corpus.PACKAGES))
def test_a_survey_of_each_package_gives_the_table_of_single_checks(package: str, tmp_path: Path) -> None:
    folder = corpus.package_folder(package)
    assert folder is not None, f"{package} is not installed"
    out = tmp_path / "survey"
    main(["survey", str(folder), "--out", str(out), "--states", corpus.STATES, "--workers", "2"])
    result = json.loads((out / "survey.json").read_text())
    got = {f"{package}/{row['model']}": row for row in result["rows"]}
    expected = {key: want for key, want in EXPECTED.items() if key.startswith(f"{package}/")}
    assert sorted(got) == sorted(expected), "the survey's models are not the corpus's"
    wrong = {
        key: (row["outcome"], row["why"][:200])
        for key, row in got.items()
        if row["outcome"] != expected[key][0] or any(p not in row["why"] for p in expected[key][1])
    }
    assert not wrong, f"rows other than the single checks': {wrong}"
    for key, row in got.items():
        assert row["outcome"] != "FAIL" or row["reproducers"], f"{key}: a FAIL without a reproducer"
        assert all((out / script).is_file() for script in row["reproducers"]), key
    assert result["counts"]["crash"] == 0

"""The corpus of published models (issue 42 item 5, tests/corpus.py): every MJCF and URDF file of
dm-control, gymnasium-robotics and rtb-data, judged model-only from its own folder, against the outcome
the table (tests/corpus_outcomes.py) expects: pass; FAIL with the file's defect or a reader's misreading
named; refused with the reason. Every FAIL comes with its reproducers, and each reproducer, run alone in a
fresh process, must show its difference: a FAIL the libraries do not show is a bug of the harness.
dm_control's models here, the other packages' in test_corpus_robotics.py (a file per xdist worker)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests import corpus
from tests.corpus_outcomes import EXPECTED

MODELS = corpus.models()
INSTALLED = corpus.installed()
pytestmark = corpus.marks()
HERE = [(key, path) for key, path in MODELS if key.startswith("dm_control/")]


def test_the_corpus_is_installed_and_every_model_is_in_the_table():
    """Three packages, over a hundred models, each with its expected outcome (none left out, none stale)."""
    assert INSTALLED, [name for name in corpus.PACKAGES if corpus.package_folder(name) is None]
    keys = {key for key, _ in MODELS}
    assert len(keys) >= 100, len(keys)
    assert sorted(keys - set(EXPECTED)) == [], "models with no expected outcome: add them to EXPECTED"
    assert sorted(set(EXPECTED) - keys) == [], "expected outcomes of models the packages no longer ship"


@pytest.mark.parametrize(("key", "path"), HERE, ids=[key for key, _ in HERE])
def test_each_model_gets_its_expected_outcome_and_every_fail_its_proof(key: str, path: Path, tmp_path: Path):
    """The outcome and its phrase as the table says; a FAIL's reproducers each show their difference."""
    corpus.expect(key, path, EXPECTED.get(key, ("not in the table", ())), tmp_path / "reproduce")

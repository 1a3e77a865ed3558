"""The corpus's gymnasium-robotics and rtb-data models (tests/e2e/test_corpus.py has dm_control's and the
table's own test): each gets its expected outcome, and every reproducer shows its difference."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests import corpus
from tests.corpus_outcomes import EXPECTED
from tests.e2e.test_corpus import MODELS, pytestmark  # noqa: F401 - the same marks: long, skipped where not installed

HERE = [(key, path) for key, path in MODELS if not key.startswith("dm_control/")]


@pytest.mark.parametrize(("key", "path"), HERE, ids=[key for key, _ in HERE])
def test_each_model_gets_its_expected_outcome_and_every_fail_its_proof(key: str, path: Path, tmp_path: Path):
    """The outcome and its phrase as the table says; a FAIL's reproducers each show their difference."""
    corpus.expect(key, path, EXPECTED.get(key, ("not in the table", ())), tmp_path / "reproduce")

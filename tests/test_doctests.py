"""The examples on the public face run as written: the package's docstring (`lagrange_xval.check`),
`System.from_files`, and `lagrange_xval.forms` (collected by the README's test command)."""

from __future__ import annotations

import doctest

import lagrange_xval
import lagrange_xval.forms
import pytest
from lagrange_xval.systems import system


@pytest.mark.parametrize("module", [lagrange_xval, lagrange_xval.forms, system], ids=lambda m: m.__name__)
def test_the_examples_run(module):
    failed, attempted = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert attempted > 0, f"{module.__name__} has no example"
    assert failed == 0

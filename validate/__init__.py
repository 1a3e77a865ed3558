"""lagrange-xval: is your hand-derived Lagrangian right? Held against MuJoCo, Pinocchio and Drake.

This folder (validate/) is the package `lagrange_xval`; the repository's systems are its data packages
`lagrange_xval.equations` and `lagrange_xval.models`. The names below are the whole public face; every
subpackage is private to the harness (each names its own entry points in `__all__`).

Judge a derivation (writes nothing):

    >>> import lagrange_xval as lx
    >>> result = lx.check(lx.load("simple_pendulum"), n_states=20, probes=1)
    >>> result.passed
    True

Judge your own files: `lx.check(lx.System.from_files("my_pendulum.xml", "my_pendulum.py"))`, then
`result.assert_ok()` (an AssertionError naming the term that disagrees) or `result.statement` (the
verdict sentence the `check` command prints). `check(..., cache=lx.Cache.user())` keeps the explanations
of wrong entries in the user's cache folder (`lx.Cache.at(folder)` elsewhere).

By task:
    check, Result, Row               the verdict on one system and the rows it rests on (api.py)
    System, load                     a model and its equations: your files, or a repository system by name
    Cache                            where explanations and references are kept between checks
    HarnessError                     what a person is told about bad input: one line, what is valid
    lagrange_xval.forms              what an equations module imports (helpers, the printed-form kinds,
                                     the EquationsModule contract)
    lagrange_xval.testing            helpers for a pytest suite of your own
    the `lagrange-xval` command      cli/ (run, check, watch, derive, audit, bench, stress, ...)

The rooms inside, in the order the data flows (tests/test_architecture.py holds it):

    core -> model -> handwritten -> systems -> results -> symbolic -> sources -> dynamics, audit
         -> verdict -> stages, studies, api -> report, replay (reading results) -> cli
"""

from .api import Cache, Result, Row, System, check, load
from .core.errors import HarnessError

__all__ = ["Cache", "HarnessError", "Result", "Row", "System", "check", "load"]

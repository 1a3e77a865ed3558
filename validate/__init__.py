"""lagrange-xval: is your hand-derived Lagrangian right? Held against MuJoCo and Pinocchio.

This folder installs as the top-level package `lagrange_xval` (see pyproject.toml); the harness
itself is `lagrange_xval`, the repository's systems `lagrange_xval.equations` and
`lagrange_xval.models`.

    import lagrange_xval as lx

    result = lx.check(lx.System.from_files("my_pendulum.xml", "my_pendulum.py"))
    result.assert_ok()

`check` writes nothing; `check(..., cache=lx.Cache.user())` keeps the explanations of wrong entries in
the user's cache folder (`lx.Cache.at(folder)` elsewhere), so a second check of the same mistake is fast.

`lagrange_xval.testing` has the helpers for a pytest suite of your own, `lagrange_xval.forms` those an
equations module imports (stack_vector, body, hinge, not_provided, the printed-form classes).
"""

from .api import Cache, Result, Row, System, check, load
from .core.errors import HarnessError

__all__ = ["Cache", "HarnessError", "Result", "Row", "System", "check", "load"]

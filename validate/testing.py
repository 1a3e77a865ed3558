"""Helpers for checking your own derivations in your own pytest suite.

    # test_my_equations.py
    import pytest
    from lagrange_xval.testing import assert_equations_match, systems_in

    def test_my_pendulum():
        assert_equations_match("mine/my_pendulum.xml", "mine/my_pendulum.py")

    @pytest.mark.parametrize("system", systems_in("my_systems"))
    def test_every_system(system):
        assert_equations_match(system)

A failure raises AssertionError naming the term that disagrees (mass matrix, gravity, velocity,
friction, energies, body poses, accelerations, parameters), the pair of sources, the worst state
and the probe parameter set where it shows.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Unpack

from .api import CheckOptions, Result, System, check
from .systems import pairs_in

if TYPE_CHECKING:  # pytest is imported when `systems_in` is called
    from _pytest.mark.structures import ParameterSet

__all__ = ["assert_equations_match", "systems_in"]


def assert_equations_match(
    model: str | Path | System, equations: str | Path | None = None, **options: Unpack[CheckOptions]
) -> Result:
    """Checks a derivation against MuJoCo and Pinocchio, with the verdict `lagrange_xval.check` gives
    (its keyword options: n_states, seed, probes, tolerances, cache), and raises AssertionError if
    any comparison fails; returns the Result."""
    if isinstance(model, System):
        if equations is not None:
            raise TypeError("give either a System or a model and an equations file, not both")
        system = model
    else:
        if equations is None:
            raise TypeError("assert_equations_match(model, equations): the equations module's path is missing")
        system = System.from_files(model, equations)
    result = check(system, **options)
    result.assert_ok()
    return result


def systems_in(folder: str | Path) -> list[ParameterSet]:
    """pytest parameters, one per system in `folder`: each `<name>.xml` paired with `<name>.py`.
    A file without its partner is an error naming it (a derivation left unchecked is never silent)."""
    import pytest

    return [pytest.param(System.from_files(m, e), id=m.stem) for m, e in pairs_in(Path(folder))]

"""The public API: check a derivation from Python, in your own test suite, and write nothing.

    import lagrange_xval as lx

    system = lx.System.from_files("my_pendulum.xml", "my_pendulum.py")
    result = lx.check(system, n_states=500, seed=0, probes=4)
    result.assert_ok()          # AssertionError naming the term, the pair, the worst state and probe

`check` gives the verdict `lagrange-xval check` and `lagrange-xval run` give, from the same function
(`decide`, validate/verdict/decide.py), short of trajectories: the model checks, every quantity of
the sources pointwise, and every term of the derivation at the model's parameters and at the probe
parameter sets (validate/verdict/verdict.py).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TypedDict, Unpack

import numpy as np

from .core.cachedir import Cache
from .core.errors import HarnessError
from .core.guard import Stopped
from .core.tolerances import TOLERANCES, Tolerances
from .results.schema import CheckData, ComparisonRow, TermRow, WorstState
from .systems import System, load
from .verdict.decide import Decision, decide
from .verdict.probes import DEFAULT_PROBES

__all__ = ["Cache", "Result", "Row", "System", "check", "load", "result_of"]


@dataclass(frozen=True)
class Row:
    """One comparison: a quantity (pointwise) or term (derivation) between two sources."""

    check: str  # "model", "pointwise" or "derivation"
    quantity: str  # the quantity or term: "M", "qacc", "mass matrix", "gravity", ...
    pair: str  # "hand~mujoco", "mujoco~pinocchio", "hand~mjcf", ...
    max_abs: float  # largest |a - b| over the states
    scaled: float  # max_abs divided by the quantity's scale (its largest magnitude over the states)
    tolerance: float  # the tier `scaled` is judged against
    passed: bool
    worst_state: WorstState | None = None  # q, v, tau where |a - b| is largest
    probe: int | None = None  # 0: the model's own parameters; k: probe k (derivation rows)
    detail: str = ""  # why, where a number cannot say it (a function that raised, a model mismatch)


@dataclass(frozen=True)
class Result:
    """The verdict of `check`: typed rows, a one-line statement, and the raw data it came from."""

    system: str
    rows: tuple[Row, ...]
    statement: str
    data: CheckData = field(repr=False)

    @property
    def passed(self) -> bool:
        return all(r.passed for r in self.rows)

    @property
    def failures(self) -> tuple[Row, ...]:
        return tuple(r for r in self.rows if not r.passed)

    def assert_ok(self) -> None:
        """Raises AssertionError naming the failing term, pair, worst state and probe."""
        if self.passed:
            return
        bad = self.failures
        first = bad[0]
        where = "" if first.worst_state is None else f" at q = {_round(first.worst_state.get('q'))}"
        if first.worst_state and any(first.worst_state.get("v", [])):
            where += f", v = {_round(first.worst_state.get('v'))}"
        probe = (
            "" if first.probe is None else (" (model's parameters)" if first.probe == 0 else f" (probe {first.probe})")
        )
        detail = f"; {first.detail}" if first.detail else ""
        raise AssertionError(
            f"{self.system}: {self.statement}. First failing: {first.check} {first.quantity} {first.pair}"
            f"{probe}: scaled error {first.scaled:.3g} > tolerance {first.tolerance:.3g}{where}{detail}. "
            f"{len(bad)} of {len(self.rows)} comparisons fail."
        )


def _round(x: Iterable[float] | None) -> list[float]:
    return [round(float(v), 6) for v in (x or [])]


def _f(x: float | str) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def _row(check: str, r: ComparisonRow | TermRow, quantity: str, *, probe: int | None = None, detail: str = "") -> Row:
    """A result row of the harness (a pointwise or a derivation row) as a typed Row."""
    return Row(
        check,
        quantity,
        r["pair"],
        _f(r["max_abs"]),
        _f(r["scaled"]),
        _f(r["tolerance"]),
        bool(r["passed"]),
        r["worst_state"],
        probe,
        detail,
    )


class CheckOptions(TypedDict, total=False):
    """`check`'s keyword options."""

    n_states: int
    seed: int
    probes: int
    tolerances: Tolerances
    cache: Cache | None


class DecideOptions(TypedDict):
    """What `check` hands `decide` besides the cache: the key of a kept decision."""

    n_states: int
    seed: int
    probes: int
    tolerances: Tolerances


def _stop_is_a_verdict(fn: Callable[..., Result]) -> Callable[..., Result]:
    """`check`, where an equations module stopped (it hung or tried to exit: validate/core/guard.py) is a
    failing result naming the function, not an exception."""

    @functools.wraps(fn)
    def guarded(system: System | str, **options: Unpack[CheckOptions]) -> Result:
        worker = getattr(getattr(system, "equations", None), "WORKER", None)
        if worker is not None:  # a person's module in its worker: the time limit is per check, as per command
            worker.renew()
        try:
            return fn(system, **options)
        except Stopped as stop:
            name = system if isinstance(system, str) else system.name
            row = Row("derivation", "equations module", "hand~mjcf", np.inf, np.inf, 0.0, False, detail=stop.why)
            return Result(name, (row,), stop.why, {})

    return guarded


@_stop_is_a_verdict
def check(
    system: System | str,
    *,
    n_states: int = 1000,
    seed: int = 0,
    probes: int = DEFAULT_PROBES,
    tolerances: Tolerances = TOLERANCES,
    cache: Cache | None = None,
) -> Result:
    """The verdict on `system`'s derivation (a System, or the name of a repository system): model
    checks, pointwise agreement of the sources at `n_states` seeded states, and every term of the
    derivation at the model's parameters and at `probes` probe parameter sets (verdict/decide.py, the
    verdict `lagrange-xval check` and `run` give). Writes nothing unless given a `cache`
    (`Cache.at(folder)` or `Cache.user()`), where explanations of wrong entries are then kept."""

    if isinstance(system, str):
        system = load(system)
    if not isinstance(n_states, int) or n_states < 1:
        raise HarnessError(f"n_states must be a positive integer; got {n_states!r}.")
    if not isinstance(probes, int) or probes < 0:
        raise HarnessError(f"probes must be a non-negative integer; got {probes!r}.")
    decision = kept_decision(system, n_states=n_states, seed=seed, probes=probes, cache=cache, tolerances=tolerances)
    if cache is not None:
        cache.trim()
    return result_of(decision)


def kept_decision(system: System, *, cache: Cache | None, **options: Unpack[DecideOptions]) -> Decision:
    """`decide`'s Decision, kept with the System (its memo, gone with it): `check` repeated on an unchanged
    System (the same object, the same functions in its module, the same options) is not judged again.
    A System is a snapshot already (its model is compiled once); a function of its module replaced in
    place (a test's monkeypatch) is a different key."""
    module = system.equations
    functions = () if module is None else tuple(sorted((k, id(v)) for k, v in vars(module).items() if callable(v)))
    key = ("lagrange_xval.check", functions, tuple(sorted(options.items())))
    decision: Decision = system.memo.get(key, lambda: decide(system, cache=cache, **options))
    return decision


def result_of(decision: Decision) -> Result:
    """A Decision as the API's Result: typed rows, failing ones first (model, derivation, pointwise)."""
    model, point, derivation = decision.model_checks, decision.pointwise, decision.derivation
    name = decision.system.name
    if model is None or point is None:
        row = Row("derivation", "parameters", "hand~mjcf", np.inf, np.inf, 0.0, False, detail=decision.unreadable)
        return Result(name, (row,), decision.statement, {"derivation": derivation})
    rows = [
        Row("model", m["key"], m["check"], np.inf, np.inf, 0.0, False, detail=m["why"]) for m in model["mismatches"]
    ]
    rows += [_row("pointwise", r, r["quantity"]) for r in point["rows"]]
    rows += [
        _row("derivation", r, r["term"], probe=r.get("probe"), detail=r.get("error", ""))
        for r in derivation.get("terms", [])
    ]
    # Derivation rows first among the failures: they name the term, the pointwise rows the quantity.
    order = {"model": 0, "derivation": 1, "pointwise": 2}
    rows.sort(key=lambda r: (r.passed, order[r.check]))
    data: CheckData = {"model_checks": model, "pointwise": point, "derivation": derivation}
    data["excluded"], data["misread"] = dict(decision.excluded or {}), dict(decision.misread or {})
    return Result(name, tuple(rows), decision.statement, data)

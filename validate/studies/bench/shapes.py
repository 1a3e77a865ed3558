"""The shapes of the bench's own data: what a worker returns, a system's prepared reference, a run's errors,
a timing, a worker's checks. bench.json and its rows, ratios and checks are defined once, in
results/schema.py (imported here and by the bench's modules)."""

from __future__ import annotations

import math
from typing import Literal, TypedDict

import numpy as np

from ...core.arrays import Json, Matrix, Vector
from ...results.schema import BenchRow, Case, CheckRow

ErrorKey = Literal["error_2s", "error_10s"]  # a row's error at a sample of ERROR_TIMES
CostKey = Literal["cpu_s", "wall_s"]  # a row's time


class Outcome(TypedDict):
    """One execution of one spec (runners.result_row)."""

    status: str
    message: str
    cpu_s: float
    wall_s: float
    t: np.ndarray | None
    q: np.ndarray | None
    nfev: int | None
    steps: int | None


class Execution(TypedDict):
    """One timing of one spec (runners.execute): the mean over its executions and their digest."""

    status: str
    message: str
    cpu_s: float
    wall_s: float
    executions: int
    nfev: int | None
    steps: int | None
    digest: str | None
    deterministic: bool
    t: np.ndarray | None
    q: np.ndarray | None


class Prepared(TypedDict):
    """One system's reference and horizon on the plan's grid (runners.prepare)."""

    case: Case
    t: Vector
    q: Matrix
    reference: dict[str, Json]
    horizon_s: float | None
    horizon_window_s: float
    lyapunov_per_s: float | None


class Errors(TypedDict):
    """A run's errors against the reference (analysis.errors_against)."""

    error_2s: float | None
    error_10s: float | None
    error_horizon: float | None
    t_exceeds_tolerance: float | None


class Timed(TypedDict):
    """A callable's medians over interleaved repeats (ratios.interleaved_medians)."""

    cpu_s: float
    wall_s: float
    cpu_s_repeats: list[float]
    wall_s_repeats: list[float]


class MeasuredChecks(TypedDict):
    """The checks of one system (a worker task's result)."""

    system: str
    rows: list[CheckRow]
    repeats: int


def cpu_of(row: BenchRow) -> float:
    """A row's CPU seconds; inf for a run without (readers take the rows that have them first)."""
    cpu = row["cpu_s"]
    return math.inf if cpu is None else cpu

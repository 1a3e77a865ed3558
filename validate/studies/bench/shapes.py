"""The shapes of the bench's data: a run's spec and case, what a worker returns, the sweep's rows, and
bench.json's sections (the ratios, the checks, the configuration)."""

from __future__ import annotations

import math
from typing import Literal, NotRequired, TypedDict

import numpy as np

from ...core.arrays import Json, Matrix, Vector
from ...results.schema import Provenance

ErrorKey = Literal["error_2s", "error_10s"]  # a row's error at a sample of ERROR_TIMES
CostKey = Literal["cpu_s", "wall_s"]  # a row's time


class Spec(TypedDict):
    """One run of the sweep (plan.py): its engine, driver, scheme, setting and value; atol (rtol only)."""

    engine: str
    driver: str
    scheme: str
    setting: str
    value: float
    atol: float | None
    method: NotRequired[str]  # added by Plan.specs
    batch: NotRequired[int]  # a "rollout_batch" run's copies


class Case(TypedDict):
    """The start the bench integrates from (runners.case_for): JSON-able, found again by `system`."""

    system: str
    q0: list[float]
    v0: list[float]
    tau: list[float]
    t_end: float
    dt_out: float


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


class Row(TypedDict):
    """One row of bench.json: a spec on a system, its status, errors, times and counts."""

    system: str
    method: str
    engine: str
    driver: str
    scheme: str
    setting: str
    value: float
    atol: NotRequired[float | None]  # rtol runs only
    status: str
    message: str
    error_2s: float | None
    error_10s: float | None
    error_horizon: float | None
    t_exceeds_tolerance: float | None
    cpu_s: float | None
    wall_s: float | None
    cpu_s_repeats: list[float]
    wall_s_repeats: list[float]
    executions: int | None
    nfev: int | None
    steps: int | None
    deterministic: bool


class FrontPoint(TypedDict, total=False):
    """A run on a Pareto front: its method and setting, its cost and its error (analysis.pareto_front)."""

    method: str
    setting: str
    value: float
    cpu_s: float | None
    wall_s: float | None
    error_2s: float | None
    error_10s: float | None


class Reached(TypedDict):
    """Time to reach an error (analysis.time_to_epsilon): the cheapest run of a method reaching it, or none."""

    system: str
    method: str
    epsilon: float
    result: str  # "reached" or "not reached"
    setting: str | None
    value: float | None
    cpu_s: float | None
    wall_s: float | None
    error: float | None


class Timed(TypedDict):
    """A callable's medians over interleaved repeats (ratios.interleaved_medians)."""

    cpu_s: float
    wall_s: float
    cpu_s_repeats: list[float]
    wall_s_repeats: list[float]


class RhsRatio(TypedDict, total=False):
    """Ratio 1: the generated right-hand side against hand-written math (or why it was not measured)."""

    system: str
    value: float | None
    target: float
    passed: bool | None
    per_call_us: dict[str, float]
    numpy_vs_hand_math: float
    calls_per_measurement: int
    repeats: int
    how: str
    why: str


class BySource(TypedDict):
    """One source's own evaluate against its raw calls."""

    harness_us_per_state: float
    raw_us_per_state: float
    ratio: float


class PointwiseSize(TypedDict):
    """The pointwise ratio at one batch size."""

    n_states: int
    value: float
    harness_us_per_state: float
    raw_us_per_state: float
    harness_wall_s: float
    raw_wall_s: float
    by_source: dict[str, BySource]


class PointwiseRatio(TypedDict):
    """Ratio 2 on one system: the worst size's ratio and every size's."""

    system: str
    value: float
    target: float
    passed: bool
    per_size: list[PointwiseSize]
    by_source: dict[str, BySource]
    repeats: int


class PointwiseSummary(TypedDict):
    """Ratio 2 over every system."""

    value: float
    target: float
    passed: bool
    per_system: list[PointwiseRatio]
    how: str


class FlagsRow(TypedDict):
    """MuJoCo's step cost on one system and integrator, with the model's disable flags and without."""

    system: str
    integrator: str
    timestep: float
    model_flags: list[str]
    us_per_step_model_flags: float
    us_per_step_all_enabled: float
    all_enabled_over_model: float
    saving: float
    steps: int
    repeats: int


class FlagsRatio(TypedDict):
    """MuJoCo's disable flags on every system (no target)."""

    target: None
    rows: list[FlagsRow]
    how: str


class ScipyBrief(TypedDict):
    """A scipy run of the sweep in brief (ratios.default_ratio); the default's says whether it reached eps."""

    method: str
    rtol: float
    atol: float | None
    cpu_s: float | None
    error_2s: float | None
    reached: NotRequired[bool]


class DefaultRatio(TypedDict, total=False):
    """Ratio 3: default scipy against the fastest scipy run at its epsilon (or why it was not measured)."""

    system: str
    epsilon: float
    target: float
    value: float | None
    passed: bool | None
    why: str
    default: ScipyBrief
    fastest: ScipyBrief
    fastest_solve_ivp: ScipyBrief | None
    default_over_fastest_solve_ivp: float | None
    would_pass: list[ScipyBrief]
    how: str


class RunBrief(TypedDict):
    """A run of the sweep in brief (ratios.frontier_ratios)."""

    method: str
    setting: str
    value: float
    cpu_s: float | None
    wall_s: float | None
    error_2s: float | None
    error_10s: float | None


class FrontierEntry(TypedDict):
    """The default path against the fastest run at one epsilon."""

    epsilon: float
    default_path: RunBrief | None
    fastest: RunBrief | None
    fastest_contender: RunBrief | None
    ratio: float | None
    why: str | None


class FrontierRatios(TypedDict):
    """The default trajectory path against the frontier, per system (no target)."""

    target: None
    epsilons: list[float]
    per_system: dict[str, list[FrontierEntry]]
    how: str


class RunWallTimes(TypedDict, total=False):
    """`lagrange-xval run`'s wall time per condition (ratios.run_wall_times), or why it was not measured."""

    value: float | None
    target: float
    passed: bool | None
    median_s: dict[str, float]
    wall_s_all: dict[str, list[float]]
    cpu_s_all: dict[str, list[float]]
    stages_s: dict[str, dict[str, float]]
    exit_codes: list[int]
    repeats: int
    conditions: dict[str, str]
    how: str
    why: str


class CheckRow(TypedDict):
    """One of the harness's own trajectory checks, timed (checks.measure_checks)."""

    system: str
    check: str
    engine: str
    kind: str  # "accurate", "user", "scheme" or "windows"
    method: str
    cpu_s: float
    wall_s: float
    error_2s: float | None
    status: str
    timestep: float | None
    windows_ulps_vs_mujoco: NotRequired[float]
    mujoco_windows_cpu_s: NotRequired[float]


class MeasuredChecks(TypedDict):
    """The checks of one system (a worker task's result)."""

    system: str
    rows: list[CheckRow]
    repeats: int


class Paired(TypedDict):
    """A check and its fastest run timed again side by side (checks.paired_timings)."""

    cpu_s: float
    fastest_cpu_s: float


class CheckBest(TypedDict):
    """The fastest run computing what a check computes; `spec`: a sweep run's, to time it again."""

    method: str
    setting: str
    value: float | None  # MuJoCo's windows: their timestep
    cpu_s: float | None
    error_2s: float | None
    spec: NotRequired[Spec]


class CheckEntry(CheckRow):
    """A check against its fastest run (checks.checks_ratios)."""

    fastest: CheckBest | None
    ratio: float | None
    sweep_ratio: float | None
    paired: Paired | None
    target: float | None
    passed: bool | None
    why: str | None


class ChecksRatios(TypedDict):
    """The harness's checks against the fastest runs computing the same."""

    value: float | None
    target: float
    passed: bool
    rows: list[CheckEntry]
    how: str


class Ratios(TypedDict):
    """bench.json's "ratios"."""

    rhs_fast_path_vs_hand_math: RhsRatio
    pointwise_vs_raw_engine_calls: PointwiseSummary
    default_scipy_vs_fastest_scipy: DefaultRatio
    default_path_vs_frontier: FrontierRatios
    mujoco_disable_flags: FlagsRatio
    run_wall_time: RunWallTimes
    harness_checks_vs_fastest: NotRequired[ChecksRatios]


class Config(TypedDict):
    """bench.json's "config": the plan it ran."""

    quick: bool
    systems: list[str]
    repeats: int
    budget_s: float
    min_timed_s: float
    t_end: float
    dt_out: float
    error_times: list[float]
    atol: str
    horizon_tolerance: float
    epsilons: list[float]
    workers: int | None
    cost: str
    executor: NotRequired[str]


class SystemReference(TypedDict):
    """bench.json's "systems" entry: a system's case, reference and horizon."""

    case: Case
    reference: dict[str, Json]
    horizon_s: float | None
    horizon_window_s: float
    lyapunov_per_s: float | None


class Durations(TypedDict):
    """How long the bench took, and its sweep."""

    duration_s: float
    sweep_s: float


class BenchResults(Durations):
    """bench.json."""

    meta: Provenance
    config: Config
    systems: dict[str, SystemReference]
    rows: list[Row]
    pareto: dict[str, dict[str, list[FrontPoint]]]
    time_to_epsilon: list[Reached]
    ratios: Ratios
    quick_target_s: float | None


def cpu_of(row: Row) -> float:
    """A row's CPU seconds; inf for a run without (readers take the rows that have them first)."""
    cpu = row["cpu_s"]
    return math.inf if cpu is None else cpu

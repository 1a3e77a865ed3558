"""The shapes of the stress study's data: an energy classification, a stability trial and search, the
rows of each section and stress.json."""

from __future__ import annotations

from typing import NotRequired, TypedDict

import numpy as np

from ...results.schema import ComparisonRow, Provenance

# One run's energy behaviour (energy.classify_energy); "class" is a keyword, hence the call form.
EnergyClass = TypedDict(
    "EnergyClass",
    {
        "E0": float,
        "V_min": float,
        "available": float,  # J: E0 - V_min
        "direction": str | None,  # "loss", "gain" or None
        "t_fail": float | None,
        "rate": float | None,  # J/s
        "r2": float | None,
        "early_envelope": float | None,
        "late_envelope": float | None,
        "max_abs": float,
        "final": float,
        "relative_max": float,
        "relative_final": float,
        "class": str,
        "reason": str | None,
    },
    total=False,
)


class Trend(TypedDict):
    """The |dE| envelopes of the first and last tenth, the line fitted to |dE| against t, the direction."""

    early_envelope: float
    late_envelope: float
    rate: float
    r2: float
    direction: str


class Series(TypedDict):
    """A downsampled series for a plot (runs.downsample)."""

    t: list[float]
    y: list[float]


class DriftSeries(TypedDict):
    """A drift row's energy change over its horizon, downsampled."""

    t: list[float]
    dE: list[float]


class DriftRow(EnergyClass):
    """Energy over one horizon of one long run (energy.drift_rows)."""

    system: str
    engine: str
    integrator: str
    timestep: float
    horizon: float
    q0: np.ndarray
    v0: np.ndarray
    series: DriftSeries


class Trial(TypedDict):
    """A stability run at one timestep judged (stability.judged)."""

    timestep: float
    stable: bool
    reason: str | None
    t_fail: float | None
    relative_max: float | None


class Search(TypedDict):
    """The bisection's result (stability.max_stable_timestep)."""

    max_stable: float | None
    min_unstable: float | None
    trials: list[Trial]
    reason: str | None


class Found(Search):
    """A bisection with the range it searched and a mirror step's cost (stability.searches)."""

    range: list[float]
    step_cost_s: float | None


class StabilityRow(Found):
    """The largest stable timestep of one engine and integrator at one speed and criterion."""

    system: str
    engine: str
    integrator: str
    speed: float
    criterion: str
    growth_factor: float | None
    q0: np.ndarray
    v0: np.ndarray
    t_end: float
    bisection_ratio: float


class StiffOutcome(TypedDict):
    """A stiff-friction run judged (none: not run, with why)."""

    stable: bool | None
    reason: str | None
    t_fail: float | None
    max_error: float | None
    final_error: NotRequired[float | None]
    energy_relative_max: NotRequired[float | None]


class StiffBase(TypedDict):
    """A damping factor on one system: the damping per joint and the reference's method."""

    system: str
    damping_factor: float
    t_end: float
    damping: dict[str, float]
    reference: str


class StiffRun(StiffBase):
    """One engine, integrator and timestep at a damping factor."""

    engine: str
    integrator: str
    eulerdamp: bool
    timestep: float


class StiffRow(StiffRun, StiffOutcome):
    """A stiff-friction row (stability.stiff_rows)."""


class CondRow(ComparisonRow):
    """compare.compare's row at one parameter set, with the base tier's verdict and the constants C."""

    passed_base: bool
    base_tolerance: float
    c_state: float
    c_state_eq: float
    c_state_all: float
    c_state_eq_all: float
    worst_state_cond: float


class CondInfo(TypedDict):
    """cond(M) over the sample at one parameter set (conditioning.conditioning_point, without its rows)."""

    cond_median: float
    cond_max: float
    cond_random_max: float
    cond_eq_median: float
    cond_eq_max: float
    q_worst: np.ndarray
    n_states: int
    n_targeted: int


class CondPoint(CondInfo):
    """conditioning.conditioning_point."""

    rows: list[CondRow]


class SweepBase(TypedDict):
    """One ratio of one conditioning sweep."""

    system: str
    sweep: str
    kind: str
    ratio: float
    overrides: list[list[str | float]]


class ConditioningRow(SweepBase, total=False):
    """A conditioning row: a quantity and pair at one ratio, or the ratio refused (quantity None)."""

    quantity: str | None
    pair: str | None
    refused: str
    cond_median: float
    cond_max: float
    cond_random_max: float
    cond_eq_median: float
    cond_eq_max: float
    q_worst: np.ndarray
    n_states: int
    n_targeted: int
    scaled: float
    max_abs: float
    scale: float
    tier: str
    tolerance: float
    passed: bool
    base_tolerance: float
    passed_base: bool
    c_state: float
    c_state_eq: float
    c_state_all: float
    c_state_eq_all: float
    worst_state_cond: float
    per_cond_eps: float


class Skipped(TypedDict):
    """A section not run on a system, and why."""

    system: str
    section: str
    why: str


class Measured(TypedDict):
    """What a conditioning row keeps of compare's row (CondRow)."""

    quantity: str
    pair: str
    scaled: float
    max_abs: float
    scale: float
    tier: str
    tolerance: float
    passed: bool
    base_tolerance: float
    passed_base: bool
    c_state: float
    c_state_eq: float
    c_state_all: float
    c_state_eq_all: float
    worst_state_cond: float


class SweepPoint(TypedDict):
    """The worst pair at one ratio of a sweep, for one quantity (conditioning.conditioning_summary)."""

    cond_max: float
    cond_eq_max: float
    scaled: float
    tolerance: float
    passed: bool
    passed_base: bool
    c_state: float
    c_state_eq: float
    c_state_all: float
    c_state_eq_all: float
    base: float


class SummarySeries(TypedDict):
    """A sweep's points, for a plot."""

    ratio: list[float]
    cond_max: list[float]
    cond_eq_max: list[float]
    scaled: list[float]
    tolerance: list[float]


class ConditioningSummary(TypedDict):
    """Per system, sweep and quantity: disagreement against cond(M), its slope, C and where tiers fail."""

    system: str
    sweep: str
    quantity: str
    points: int
    cond_range: list[float]
    disagreement_range: list[float]
    slope: float | None
    c_state: float
    c_state_eq: float
    c_state_all: float
    c_state_eq_all: float
    base_tolerance: float
    base_tier_fails_from_cond: float | None
    tier_fails_from_cond: float | None
    series: SummarySeries


class SolveTierProposal(TypedDict, total=False):
    """The per-state solve tier the measurements support ({} when nothing was measured)."""

    formula: str
    rtol: float
    eps: float
    margin: float
    current_cond_factor: float | None
    measured_C_cond: float
    measured_C_cond_all_states: float
    C_cond: float
    kappa_from_cond: float | None
    measured_C_cond_eq: float
    measured_C_cond_eq_all_states: float
    C_cond_eq: float
    kappa_from_cond_eq: float | None


SectionRows = list[DriftRow] | list[StabilityRow] | list[ConditioningRow] | list[StiffRow]


class Section(TypedDict):
    """One section's rows on one system (output.run_section)."""

    system: str
    section: str  # "drift", "stability", "conditioning" or "stiff_friction"
    rows: SectionRows
    skipped: list[Skipped]
    elapsed: float


class StressResults(TypedDict):
    """stress.json."""

    meta: Provenance
    quick: bool
    settings: dict[str, object]  # dataclasses.asdict(Settings)
    overrides: list[list[str | float]]
    systems: list[str]
    criteria: dict[str, str]
    drift: list[DriftRow]
    stability: list[StabilityRow]
    conditioning: list[ConditioningRow]
    stiff_friction: list[StiffRow]
    skipped: list[Skipped]
    timing: dict[str, float]
    conditioning_summary: NotRequired[list[ConditioningSummary]]
    solve_tier_proposal: NotRequired[SolveTierProposal]

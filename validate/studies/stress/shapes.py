"""The shapes of the stress study's own data: an energy trend, a conditioning point and its rows, a sweep's
points, a section. The rows of stress.json and stress.json itself are defined once, in results/schema.py
(imported here for the study's modules)."""

from __future__ import annotations

from typing import TypedDict

import numpy as np

from ...results.schema import (
    ComparisonRow,
    ConditioningRow,
    DriftRow,
    Skipped,
    StabilityRow,
    StiffRow,
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


SectionRows = list[DriftRow] | list[StabilityRow] | list[ConditioningRow] | list[StiffRow]


class Section(TypedDict):
    """One section's rows on one system (output.run_section)."""

    system: str
    section: str  # "drift", "stability", "conditioning" or "stiff_friction"
    rows: SectionRows
    skipped: list[Skipped]
    elapsed: float

"""Named tolerance tiers. Each carries the reason it is what it is; pass them by keyword.

An error is measured as `scaled = max |a - b| / scale`, where `scale` is the largest magnitude
either source gives that quantity over the whole sample, over every entry (results.schema.
SCALED_DEFINITION; so a tier is a fraction of the quantity's largest magnitude, not of a value that
happens to pass near zero).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

EPS = 2.220446049250313e-16  # double precision unit roundoff (x2)


@dataclass(frozen=True)
class Tier:
    rtol: float
    reason: str
    cond_factor: float | None = None  # if set: per state, max(rtol, cond_factor * cond(M) * EPS)

    def at(self, cond: float) -> float:
        """The tolerance at a state whose mass matrix has condition number `cond`."""
        return self.rtol if self.cond_factor is None else max(self.rtol, self.cond_factor * cond * EPS)


@dataclass(frozen=True)
class Tolerances:
    algebraic: Tier = Tier(
        1e-12,
        "Closed-form terms (M, bias, energies, positions, velocities) computed by two exact algorithms "
        "in double precision differ by a few ulps times the number of operations (tens): about 1e-14 "
        "of the quantity's largest magnitude; 1e-12 leaves 100x margin and is still 1e10 below any slip in a "
        "derivation (a lost factor or term changes a quantity by a sizeable fraction of it).",
    )
    solve: Tier = Tier(
        1e-10,
        "Accelerations and inverse dynamics pass through a solve with M (or ABA's recursion): the "
        "rounding error grows like cond(M) eps. Where cond(M) < 1e3 (the pendulums and the gimbal), ~1e-13 is "
        "expected and 1e-10 keeps the margin of the algebraic tier; on an ill-conditioned model the "
        "tolerance of each state grows to 20 cond(M) eps (the stress sweeps to cond 2.5e13 needed at "
        "most 1.8 cond(M) eps), so a correct model is not called wrong.",
        cond_factor=20.0,
    )
    trajectory: Tier = Tier(
        1e-6,
        "The floor under each free run's own threshold, max(1e-6 rad, 10 x the run's error estimate) "
        "(dynamics/estimate.py: MuJoCo's step halved, scipy's tolerances divided by 10): the smallest "
        "disagreement the trajectory stage resolves. Wrong equations or a wrong engine setting part from "
        "the reference at 1e-3 to 1e-1 rad within a second; an integrator's own error, which grows with the "
        "model's frequencies (RK4 at 1 ms: 1e-8 rad on the repository's double pendulums, 3e-6 on a held-out one), is "
        "measured per run and never judged as a disagreement.",
    )

    def as_dict(self) -> dict[str, dict[str, float | str | None]]:
        return {f.name: asdict(getattr(self, f.name)) for f in fields(self)}


TOLERANCES = Tolerances()

# Which tier each pointwise quantity is judged with.
QUANTITY_TIER = {
    "M": "algebraic",
    "bias": "algebraic",
    "passive": "algebraic",
    "T": "algebraic",
    "V": "algebraic",
    "body_positions": "algebraic",
    "body_rotations": "algebraic",
    "qacc": "solve",
    "tau_inverse": "solve",
}

# Quantities that are small differences of large terms are scaled by those terms' largest magnitude:
# inverse dynamics returns tau (zero for an unactuated system) as M a + bias - passive.
SCALE_ALSO_BY = {"tau_inverse": ("bias",), "passive": ("bias",)}

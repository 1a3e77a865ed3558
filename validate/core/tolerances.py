"""Named tolerance tiers. Each carries the reason it is what it is; pass them by keyword.

An error is measured as `scaled = max |a - b| / scale`, where `scale` is the largest magnitude
either source gives that quantity over the whole sample, over every entry, and at least the model's
own physical scale of it (`PhysicalScales`: m g L for an energy, g / L for an acceleration, ...);
results.schema.SCALED_DEFINITION. So a tier is a fraction of the quantity's largest magnitude, not of
a value that happens to pass near zero, nor of rounding noise where the quantity is zero for every
source. The potential energy V is compared up to a constant (`UP_TO_A_CONSTANT`).
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

# The structure of a derivation checked on the person's own functions alone (verdict/structure.py): an
# identity between two of them (M and its transpose, C v and the Christoffel form of M, G and dV/dq, T and
# v.M v / 2) is judged relative to the quantity's scale, and where a side is a finite difference, against
# ten times that difference's own error bound too (STRUCTURE_STEP).
STRUCTURE = Tier(
    1e-9,
    "Two of a derivation's own functions that must give one quantity (M[i, j] and M[j, i]; (C v)_i and "
    "sum_jk (dM_ij/dq_k - dM_jk/dq_i / 2) v_j v_k; G_i and dV/dq_i; T and v.M v / 2) differ by the rounding "
    "of bias(q, v) - bias(q, 0) and of the person's arithmetic, about 1e-14 of the scale; a derivative by "
    "the fourth-order central difference of step STRUCTURE_STEP is allowed ten times its error bound as "
    "well (the second- minus the fourth-order difference, plus 4 eps |f| / h). A wrong sign, factor or "
    "term of a structural part changes it by a sizeable fraction; 1e-9 is 1e5 above the rounding.",
)
STRUCTURE_STEP = 1e-3  # rad (or m): the fourth-order error ~h^4 |f'''''| / 30 ~ 3e-14, rounding ~1.5 eps / h

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
# ... and inverse dynamics by its inertial terms too: M a, rounded entry by entry, can be far larger than
# tau and bias where the accelerations are large (a nearly singular M, light links: fetch/reach.xml at
# MuJoCo's qacc of 1e10 has |M||a| of 1.7e12 per row, and MuJoCo's and Pinocchio's tau_inverse differ by
# 2.5e-4 = 3 x 2^-13, below eps |M||a| = 3.9e-4, while M, bias and qacc agree to 1e-15): the rounding of
# M a is what the sources differ by, so the scale is at least max over the states of the rows of |M| |a|.
SCALE_ALSO_BY_INERTIA = ("tau_inverse",)

# What each quantity (pointwise) or term (a derivation's) is, physically: its floor in `PhysicalScales`.
KIND = {
    "M": "inertia",
    "mass matrix": "inertia",
    "bias": "force",
    "passive": "force",
    "tau_inverse": "force",
    "gravity": "force",
    "velocity": "force",
    "friction": "force",
    "actuation": "force",
    "T": "energy",
    "V": "energy",
    "kinetic energy": "energy",
    "potential energy": "energy",
    "qacc": "acceleration",
    "acceleration": "acceleration",
    "body_positions": "length",
    "body positions": "length",
    "body_rotations": "rotation",
    "body rotations": "rotation",
}

# Quantities defined up to a constant (the zero of the potential energy is a choice, and a body welded
# to the world adds a constant a reader may count or not): compared after the best constant is removed.
UP_TO_A_CONSTANT = ("V", "potential energy")


@dataclass(frozen=True)
class PhysicalScales:
    """The model's own physical scales, the absolute floor under every `scale` (SCALED_DEFINITION): a
    quantity that is zero for every source (V of a body gravity does not move, qacc of an unactuated body
    at rest in its own frame) is judged against what the model could give it, not against its rounding
    noise (which, divided by itself, is 1.0 and FAILs).

    mass: the moving bodies' total mass, kg; length: the chain's own size L (the farthest centre of mass
    from the first moving body's frame along the chain, a body's radius of gyration), m; travel: how far
    the slides carry it over the states, m (in positions and energies only: a free root's travel does not
    make its hinges' inertia larger); gravity: |g|, m/s^2; speed: max |v| over the states; hinges /
    slides: whether the coordinates hold angles / lengths (a floor in each coordinate's unit, the larger
    one taken)."""

    mass: float
    length: float
    gravity: float
    speed: float = 0.0
    hinges: bool = True
    slides: bool = False
    travel: float = 0.0

    @property
    def accel(self) -> float:
        """|g| + L max|v|^2: gravity and the centripetal terms, m/s^2."""
        return self.gravity + self.length * self.speed**2

    def floor(self, quantity: str) -> float:
        """The floor of `quantity` (a pointwise quantity or a derivation's term; 0 for another)."""
        m, L, a, reach = self.mass, self.length, self.accel, self.length + self.travel
        # potential m g (L + D), kinetic m L^2 v^2 for a hinge, m v^2 for a slide
        energy = m * (self.gravity * reach + self.speed**2 * max(L * L if self.hinges else 0.0, float(self.slides)))
        per_unit = {  # (angle coordinates, length coordinates)
            "inertia": (m * L * L, m),
            "force": (m * a * L, m * a),
            "energy": (energy, energy),
            "acceleration": (a / L if L > 0 else 0.0, a),
            "length": (reach, reach),
            "rotation": (1.0, 1.0),
        }.get(KIND.get(quantity, ""), (0.0, 0.0))
        return max(per_unit[0] if self.hinges else 0.0, per_unit[1] if self.slides else 0.0)


NO_SCALES = PhysicalScales(0.0, 0.0, 0.0)  # no floor but rotations' 1 (a caller without the model)

"""Pointwise comparison of the three sources at seeded random states.

Results are long-format rows: one per (quantity, pair of sources), sorted, with the worst state.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..core.errors import HarnessError
from ..core.guard import describe
from ..core.tolerances import (
    NO_SCALES,
    QUANTITY_TIER,
    SCALE_ALSO_BY,
    SCALE_ALSO_BY_INERTIA,
    TOLERANCES,
    UP_TO_A_CONSTANT,
    PhysicalScales,
    Tolerances,
)
from ..model.modelview import names as view_names
from ..results.schema import ComparisonRow, Pointwise, WorstState
from ..sources import make_sources
from ..sources.base import Source
from ..systems import System

Q_RANGE = np.pi  # rad: q uniform in [-pi, pi]
V_RANGE = 10.0  # rad/s: v uniform in [-10, 10]
TAU_RANGE = 1.0  # N m: tau uniform in [-1, 1] where the system is actuated

# The largest magnitudes a user state may have. Beyond them double precision has nothing left to
# compare: v^2 terms pass 1e8 times the gravity terms and the tiers would judge rounding noise.
LIMITS = {"q": (1e4, "rad"), "v": (1e4, "rad/s"), "tau": (1e6, "N m")}


@dataclass(frozen=True)
class States:
    q: np.ndarray  # (N, n) rad
    v: np.ndarray  # (N, n) rad/s
    tau: np.ndarray  # (N, n) N m

    def __len__(self) -> int:
        return len(self.q)

    def state(self, i: int) -> WorstState:
        return {"q": self.q[i].tolist(), "v": self.v[i].tolist(), "tau": self.tau[i].tolist()}


def random_states(system: System, *, n: int, seed: int) -> States:
    """N seeded states, inside the joints' stated limits; tau is random only where the scene is actuated."""
    rng = np.random.default_rng(seed)
    nv = system.nv
    ranges = system.joint_ranges  # a joint's stated limits narrow the draw (a real arm's, say)
    lo, hi = np.maximum(-Q_RANGE, ranges[:, 0]), np.minimum(Q_RANGE, ranges[:, 1])
    q = rng.uniform(lo, hi, (n, nv))
    v = rng.uniform(-V_RANGE, V_RANGE, (n, nv))
    if system.inputs == "u":  # the actuators' controls: tau = B u, in the range of the inputs only
        B = system.input_matrix
        tau = rng.uniform(-TAU_RANGE, TAU_RANGE, (n, B.shape[1])) @ B.T
    else:
        tau = rng.uniform(-TAU_RANGE, TAU_RANGE, (n, nv)) if "actuation" in system.uses else np.zeros((n, nv))
    return States(q, v, tau)


def validate_states(system: System, q: object, v: object, tau: object | None = None) -> States:
    """Checks user-given states: shapes (N, n) and finite values; errors name the problem."""
    n = system.nv
    arrays: dict[str, np.ndarray] = {}
    for name, x in (("q", q), ("v", v), ("tau", tau)):
        if x is None:
            x = np.zeros_like(arrays["q"])
        try:
            arr = np.asarray(x, dtype=float)
        except (TypeError, ValueError):
            raise HarnessError(f"{name} must be numbers; got {x!r}.") from None
        if arr.ndim == 1:
            arr = arr[None]
        if arr.ndim != 2 or arr.shape[1] != n:
            raise HarnessError(
                f"{name} must have {n} values per state ({', '.join(system.coordinates)}) for {system.name}; "
                f"got shape {arr.shape[1:] if arr.ndim == 2 else arr.shape}."
            )
        if not np.all(np.isfinite(arr)):
            bad = int(np.argwhere(~np.isfinite(arr))[0][0])
            raise HarnessError(f"{name} of state {bad} is not finite ({arr[bad].tolist()}); give finite numbers.")
        limit, unit = LIMITS[name]
        if np.abs(arr).max(initial=0.0) > limit:
            bad = int(np.argwhere(np.abs(arr) > limit)[0][0])
            raise HarnessError(
                f"{name} of state {bad} is {arr[bad].tolist()}; the harness accepts |{name}| <= {limit:g} {unit}."
            )
        arrays[name] = arr
    if not (len(arrays["q"]) == len(arrays["v"]) == len(arrays["tau"])):
        raise HarnessError("q, v and tau must describe the same number of states.")
    return States(arrays["q"], arrays["v"], arrays["tau"])


def evaluate(sources: Mapping[str, Source], states: States) -> dict[str, dict[str, np.ndarray]]:
    """Every quantity from every source: {source: {quantity: (N, ...) array}}.

    `qacc` is the forward dynamics at the given tau; `tau_inverse` is each source's inverse
    dynamics at the hand source's accelerations (so it should give back tau); without a hand source
    (the model alone), at MuJoCo's.
    """
    q, v, tau = states.q, states.v, states.tau
    engines = {name: src for name, src in sources.items() if name != "hand"}
    if "hand" not in sources:  # the model alone: the engines' inverse dynamics at MuJoCo's accelerations
        first = engines.get("mujoco") or next(iter(engines.values()))
        a_ref = np.nan_to_num(first.forward(q, v, tau))
        return {name: src.evaluate(q, v, tau, a_ref) for name, src in engines.items()}
    try:
        with np.errstate(all="ignore"):
            hand = sources["hand"].evaluate(q, v, tau)  # its inverse dynamics at its own accelerations
    except Exception as exc:  # noqa: BLE001 - a derivation that raises is judged term by term (verdict.py)
        hand = None
        error = describe(exc)  # "mass_matrix raised ZeroDivisionError: division by zero"
    if hand is None:
        # Every quantity NaN, so each pointwise row fails; validate/verdict/verdict.py names the function.
        shapes = {k: np.shape(x) for k, x in next(iter(engines.values())).evaluate(q, v, tau, q * 0).items()}
        hand = {k: np.full(shape, np.nan) for k, shape in shapes.items()}
        hand["error"] = error  # type: ignore[assignment]
    a_hand = np.nan_to_num(hand["qacc"])
    out = {"hand": hand}
    for name, src in engines.items():
        out[name] = src.evaluate(q, v, tau, a_hand)
    return out


def error_row(
    quantity: str,
    pair: str,
    a: np.ndarray,
    b: np.ndarray,
    states: States,
    *,
    tier: str,
    tolerances: Tolerances = TOLERANCES,
    min_scale: float = 0.0,
    cond: np.ndarray | None = None,
    up_to_constant: bool = False,
) -> ComparisonRow:
    """One row: the max absolute error, the max error relative to each state's magnitude, `scaled`
    (results.schema.SCALED_DEFINITION: the max absolute error divided by the largest magnitude either
    source gives the quantity over the states, or `min_scale` if larger: the model's physical floor, a
    force scale; what the tier judges), and the worst state.

    `up_to_constant` (V: `core.tolerances.UP_TO_A_CONSTANT`): a and b are compared after the constant
    that brings them closest (the midrange of a - b over the states) is removed, each one's magnitude
    measured about its own midrange; the constant is kept in the row (`constant`), information that
    changes no equation of motion. A V that differs by more than a constant still differs."""
    with np.errstate(all="ignore"):  # inf and NaN from a wrong derivation are judged, never warned about
        n = len(states)
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        constant = midrange(a - b) if up_to_constant else None
        diff = np.abs(a - b - (constant or 0.0)).reshape(n, -1)
        if up_to_constant:  # each magnitude about its own zero: where it is is not what V is
            a, b = a - midrange(a), b - midrange(b)
        mag = np.maximum(np.abs(a), np.abs(b)).reshape(n, -1)
        per_state = diff.max(axis=1)
        scale = max(float(mag.max()) if mag.size else 0.0, min_scale)
        scale = scale if scale > 0 else 1.0
        rel = per_state / np.maximum(mag.max(axis=1), np.finfo(float).tiny)
        worst = int(np.argmax(per_state))
        t = getattr(tolerances, tier)
        # Per-state tolerances where the tier scales with the mass matrix's conditioning.
        tol = np.full(n, t.rtol) if cond is None or t.cond_factor is None else np.array([t.at(c) for c in cond])
        rtol = float(tol.max())
        scaled = float(per_state.max() / scale)
        finite = bool(np.all(np.isfinite(diff)))
        passed = finite and bool(np.all(per_state / scale <= tol))
    row: ComparisonRow = {
        "quantity": quantity,
        "pair": pair,
        "max_abs": float(per_state.max()),
        "max_rel": float(rel.max()),
        "scale": scale,
        "scaled": scaled if finite else float("inf"),
        "tier": tier,
        "tolerance": rtol,
        "passed": passed,
        "worst_state": states.state(worst),
    }
    if cond is not None:
        row["cond_max"] = float(np.max(cond))
    if constant is not None:
        row["constant"] = constant
    return row


def physical_scales(system: System, states: States | None = None) -> PhysicalScales:
    """The model's own scales (core.tolerances.PhysicalScales), from MuJoCo's compiled view: the total
    mass of the bodies a joint moves, the chain's size (the farthest centre of mass from the first moving
    body's frame, summed along the chain; a body's radius of gyration), the slides' travel over the
    states, |g| + L max|v|^2 over the states."""
    view = system.view
    parent = {b: str(view[f"body/{b}/parent"]) for b in view_names(view, "body", "parent")}
    jointed = {str(view[f"joint/{j}/body"]) for j in view_names(view, "joint", "body")}

    def path(b: str) -> list[str]:  # b and its ancestors below the world
        out = []
        while b in parent:
            out.append(b)
            b = parent[b]
        return out

    reach, mass, gyration = 0.0, 0.0, 0.0
    for b in parent:
        chain = path(b)
        moving = [x for x in chain if x in jointed]
        if not moving:
            continue  # welded to the world
        m = float(view[f"body/{b}/mass"])
        mass += m
        top = chain.index(moving[-1])  # the first moving body: its frame is where the motion starts
        reach = max(
            reach,
            float(np.linalg.norm(view[f"body/{b}/com"]))
            + sum(float(np.linalg.norm(view[f"body/{x}/pos"])) for x in chain[:top]),
        )
        if m > 0:
            gyration = max(gyration, float(np.sqrt(max(np.trace(np.asarray(view[f"body/{b}/inertia"])), 0.0) / m)))
    kinds = [str(view[f"joint/{j}/type"]) for j in system.joints]
    slides = [i for i, k in enumerate(kinds) if k == "slide"]
    travel = float(np.abs(states.q[:, slides]).max(initial=0.0)) if states is not None and slides else 0.0
    L = max(reach, gyration)
    vmax = float(np.abs(states.v).max(initial=0.0)) if states is not None else 0.0
    g = float(np.linalg.norm(np.asarray(view["gravity"], dtype=float)))
    return PhysicalScales(mass, L, g, vmax, hinges="hinge" in kinds, slides=bool(slides), travel=travel)


def midrange(x: np.ndarray) -> float:
    """(max + min) / 2 of the finite entries of x (0 where none is): the constant whose removal leaves
    the smallest largest residual."""
    finite = x[np.isfinite(x)]
    return float(finite.max() + finite.min()) / 2 if finite.size else 0.0


def condition(M: np.ndarray) -> np.ndarray | None:
    """cond(M) per state; None where no joint moves (an empty M has none)."""
    return np.linalg.cond(M) if np.size(M) else None


def force_scale(M: np.ndarray, v: np.ndarray) -> float:
    """A physical scale of the generalized forces at these states (N m): max ||M(q)||_2 x max |v|^2,
    the size the velocity terms C(q, v) v can take. It stays meaningful where the velocity terms
    themselves vanish at every state (a sample at gimbal lock, where they are ~1e-17 and the sample's
    own magnitude would judge rounding noise: 0.8 of it between MuJoCo and Pinocchio)."""
    if not np.size(M):
        return 0.0
    return float(np.linalg.norm(M, ord=2, axis=(-2, -1)).max() * np.max(np.abs(v)) ** 2)


def inertial_scale(M: np.ndarray, qacc: np.ndarray | None) -> float:
    """max over the states and rows of |M| |a| (core.tolerances.SCALE_ALSO_BY_INERTIA): the size of the
    terms of M a whose rounding inverse dynamics carries; 0 without accelerations of M's shape."""
    if qacc is None:
        return 0.0
    M, a = np.nan_to_num(np.asarray(M, dtype=float)), np.nan_to_num(np.asarray(qacc, dtype=float))
    if M.ndim != 3 or a.shape != M.shape[:2] or not M.size:
        return 0.0
    return float(np.einsum("nij,nj->ni", np.abs(M), np.abs(a)).max())


# The quantities scaled at least by `force_scale`: forces, and inverse dynamics (a difference of them).
FORCE_QUANTITIES = ("bias", "passive", "tau_inverse")


def compare(
    values: dict[str, dict[str, np.ndarray]],
    states: States,
    *,
    tolerances: Tolerances = TOLERANCES,
    reference: str = "mujoco",
    scales: PhysicalScales = NO_SCALES,
) -> list[ComparisonRow]:
    """Rows for every quantity and every pair of sources, sorted by quantity then pair; each scale at
    least the model's physical floor (`scales`, from `physical_scales`), V up to a constant."""
    rows: list[ComparisonRow] = []
    names = sorted(values)
    cond = condition(values[reference]["M"]) if reference in values else None
    forces = force_scale(values[reference]["M"], states.v) if reference in values else 0.0
    for quantity, tier in QUANTITY_TIER.items():
        for a, b in itertools.combinations(names, 2):
            if quantity not in values[a] or quantity not in values[b] or np.size(values[a][quantity]) == 0:
                continue  # a quantity the derivation does not provide (or no body to pose): not checked
            also = [values[s][k] for k in SCALE_ALSO_BY.get(quantity, ()) for s in (a, b) if k in values[s]]
            min_scale = max((float(np.abs(x).max()) for x in also), default=0.0)
            min_scale = max(min_scale, forces) if quantity in FORCE_QUANTITIES else min_scale
            if quantity in SCALE_ALSO_BY_INERTIA:  # M a's terms, at the accelerations it was taken at
                accelerations = values["hand" if "hand" in values else reference].get("qacc")
                inertial = [inertial_scale(values[s]["M"], accelerations) for s in (a, b) if "M" in values[s]]
                min_scale = max(min_scale, *inertial)
            rows.append(
                error_row(
                    quantity,
                    f"{a}~{b}",
                    values[a][quantity],
                    values[b][quantity],
                    states,
                    tier=tier,
                    tolerances=tolerances,
                    min_scale=max(min_scale, scales.floor(quantity)),
                    cond=cond,
                    up_to_constant=quantity in UP_TO_A_CONSTANT,
                )
            )
    return sorted(rows, key=lambda r: (r["quantity"], r["pair"]))


def pointwise(
    system: System,
    *,
    n: int,
    seed: int,
    sources: Mapping[str, Source] | None = None,
    tolerances: Tolerances = TOLERANCES,
) -> Pointwise:
    """The pointwise check of one system at `n` seeded states."""

    sources = sources or make_sources(system)
    states = random_states(system, n=n, seed=seed)
    scales = physical_scales(system, states)
    return pointwise_result(evaluate(sources, states), states, seed=seed, tolerances=tolerances, scales=scales)


def harness_bugs(rows: list[ComparisonRow]) -> list[str]:
    """Quantities where the symbolic derivation disagrees with both engines while they agree with
    each other: the model's own equations were derived wrongly, a bug of the harness, not a finding
    about the equations being checked."""
    passed = {(r["quantity"], r["pair"]): r["passed"] for r in rows}
    return [
        f"{quantity}: the model's equations derived symbolically disagree with MuJoCo and Pinocchio, which agree "
        "with each other: a bug of the harness (symbolic/derivation.py), not of the equations checked"
        for quantity in QUANTITY_TIER
        if passed.get((quantity, "mujoco~pinocchio"))
        and passed.get((quantity, "mujoco~symbolic")) is False
        and passed.get((quantity, "pinocchio~symbolic")) is False
    ]


def pointwise_result(
    values: dict[str, dict[str, np.ndarray]],
    states: States,
    *,
    seed: int,
    tolerances: Tolerances = TOLERANCES,
    scales: PhysicalScales = NO_SCALES,
) -> Pointwise:
    """The pointwise check's result from already evaluated quantities (see `evaluate`)."""
    rows = compare(values, states, tolerances=tolerances, scales=scales)
    out: Pointwise = {"n_states": len(states), "seed": seed, "rows": rows, "passed": all(r["passed"] for r in rows)}
    bugs = harness_bugs(rows)
    if bugs:
        out["harness_bugs"] = bugs
    skipped = sorted(q for q in QUANTITY_TIER if any(q not in v for v in values.values()))
    if skipped:
        out["not_checked"] = [f"{q} (not provided by the derivation)" for q in skipped]
    return out

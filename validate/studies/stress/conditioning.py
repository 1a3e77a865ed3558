"""Ill-conditioning: sweeps that split a mass or inertia ratio between two bodies, the states that
approach the worst configuration, and the solve tier they would need.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ...core.errors import HarnessError
from ...core.tolerances import TOLERANCES
from ...results.schema import ConditioningRow, ConditioningSummary, SolveTierProposal, SweepBase
from ...sources import make_sources
from ...sources.base import Source
from ...sources.hand import HandSource
from ...systems import System
from ...verdict import pointwise as compare
from .settings import EPS, FIT_FROM_COND, MAX_FACTOR, PROPOSAL_MARGIN, TARGET_DISTANCES, TARGETED_STATES, Settings
from .shapes import CondInfo, CondPoint, CondRow, Measured, SweepPoint


def equilibrated_cond(M: np.ndarray) -> np.ndarray:
    """cond of D^-1/2 M D^-1/2, D = diag(M): what is left of cond(M) after the best diagonal scaling
    (van der Sluis: within a factor n of it). (N, n, n) -> (N,)."""
    d = 1.0 / np.sqrt(np.einsum("...ii->...i", M))
    return np.linalg.cond(M * d[..., :, None] * d[..., None, :])


def worst_configuration(system: System, hand: Source, search: tuple[int, int] = (65, 4000)) -> np.ndarray:
    """The q (rad) with the largest cond(M): the best point of a grid, refined by Nelder-Mead on log cond.
    `search`: (grid points per coordinate up to 3 joints, 9 beyond; Nelder-Mead's most iterations)."""
    from scipy.optimize import minimize  # heavy: loaded when first used

    n = system.nv
    points, iterations = search
    g = np.linspace(-np.pi, np.pi, points if n <= 3 else 9)
    grid = np.stack(np.meshgrid(*[g] * n, indexing="ij"), axis=-1).reshape(-1, n)
    with np.errstate(all="ignore"):
        cond = np.linalg.cond(hand.mass_matrix(grid))
    start = grid[int(np.nanargmax(np.where(np.isfinite(cond), cond, -np.inf)))]

    def neg_log_cond(q: np.ndarray) -> float:
        c = float(np.linalg.cond(hand.mass_matrix(q[None]))[0])
        return -math.log(c) if np.isfinite(c) else -800.0

    res = minimize(
        neg_log_cond, start, method="Nelder-Mead", options={"xatol": 1e-13, "fatol": 1e-13, "maxiter": iterations}
    )
    return res.x if res.fun <= neg_log_cond(start) else start


def conditioning_states(
    system: System, hand: Source, *, n: int, seed: int, search: tuple[int, int] = (65, 4000)
) -> tuple[compare.States, np.ndarray]:
    """compare.random_states plus TARGETED_STATES approaching the worst configuration (found by
    `worst_configuration` with `search`), and that q."""
    states = compare.random_states(system, n=n, seed=seed)
    q_worst = worst_configuration(system, hand, search)
    rng = np.random.default_rng(seed + 1)
    dist = np.logspace(*TARGET_DISTANCES, TARGETED_STATES)
    u = rng.normal(size=(TARGETED_STATES, system.nv))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    q = q_worst + dist[:, None] * u
    v = rng.uniform(-compare.V_RANGE, compare.V_RANGE, q.shape)
    tau = (
        rng.uniform(-compare.TAU_RANGE, compare.TAU_RANGE, q.shape) if "actuation" in system.uses else np.zeros_like(q)
    )
    return compare.States(np.vstack([states.q, q]), np.vstack([states.v, v]), np.vstack([states.tau, tau])), q_worst


@dataclass(frozen=True)
class Sweep:
    name: str  # e.g. "mass link2/link1"
    kind: str  # "mass" or "inertia"
    heavy: str  # body made heavier
    light: str  # body made lighter beyond MAX_FACTOR


def sweep_overrides(system: System, sweep: Sweep, ratio: float) -> tuple[tuple[str, float], ...]:
    """Overrides (added to the system's own) that make the heavy body `ratio` times the light one's
    mass (or inertia), relative to the system as loaded."""
    heavy_f = min(ratio, MAX_FACTOR)
    light_f = ratio / heavy_f
    out: list[tuple[str, float]] = []
    if sweep.kind == "mass":
        out.append((f"body/{sweep.heavy}/mass", float(system.view[f"body/{sweep.heavy}/mass"]) * heavy_f))
        if light_f > 1.0:
            # keep the light body's inertia tensor: its smallest principal inertia must stay above mjMINVAL
            out.append((f"body/{sweep.light}/inertia", light_f))
            out.append((f"body/{sweep.light}/mass", float(system.view[f"body/{sweep.light}/mass"]) / light_f))
    else:
        out.append((f"body/{sweep.heavy}/inertia", heavy_f))
        if light_f > 1.0:
            out.append((f"body/{sweep.light}/inertia", 1.0 / light_f))
    return tuple(out)


def conditioning_sweeps(system: System, hand: Source) -> list[Sweep]:
    """Ratio sweeps between the first and the last body, both ways: of masses where M depends on them,
    of inertias where it does not (the mass-balanced gimbal). None for one coordinate (cond(M) = 1)."""
    if system.nv < 2 or len(system.bodies) < 2:
        return []
    first, last = system.bodies[0], system.bodies[-1]
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (8, system.nv))
    # twice the mass, the same inertia tensor (body/<b>/mass scales the inertia alike)
    heavier = system.derive(
        overrides=(
            *system.overrides,
            (f"body/{last}/inertia", 0.5),
            (f"body/{last}/mass", 2.0 * float(system.view[f"body/{last}/mass"])),
        ),
    )
    same = np.allclose(HandSource(heavier).mass_matrix(q), hand.mass_matrix(q), rtol=1e-12, atol=0.0)
    kind = "inertia" if same else "mass"
    return [Sweep(f"{kind} {last}/{first}", kind, last, first), Sweep(f"{kind} {first}/{last}", kind, first, last)]


def no_sweep_reason(system: System) -> str:
    """Why `conditioning_sweeps` has no sweep for `system`, in its own terms."""
    if system.nv < 2:
        return "one coordinate: M is a scalar, cond(M) = 1"
    named = ", ".join(system.bodies) or "none"
    return f"fewer than two bodies named (BODIES: {named}): no first and last body to sweep a mass ratio between"


def conditioning_point(system: System, *, n_states: int, seed: int, search: tuple[int, int] = (65, 4000)) -> CondPoint:
    """cond(M) and the sources' disagreement in q'' and tau_inverse at one parameter set.

    Besides compare.compare's rows (their `scaled` error, `tolerance` and verdict), each row gets the
    verdict of the tier's base rtol alone (`passed_base`: what an unscaled tier would say) and the
    constant C that a per-state tier max(rtol, C kappa eps) needs to pass every state: the largest
    per-state error / (kappa eps) over the states whose error exceeds rtol (`c_state` for kappa =
    cond(M), `c_state_eq` for the equilibrated cond; 0 if none does), and over all states (`c_state_all`)."""
    sources = make_sources(system)
    states, q_worst = conditioning_states(system, sources["hand"], n=n_states, seed=seed, search=search)
    values = compare.evaluate(sources, states)
    M = values["mujoco" if "mujoco" in values else "hand"]["M"]  # compare.compare's reference
    cond, cond_eq = np.linalg.cond(M), equilibrated_cond(M)
    rows: list[CondRow] = []
    for r in compare.compare(values, states):
        if r["quantity"] not in ("qacc", "tau_inverse"):
            continue
        a, b = r["pair"].split("~")
        per_state = np.abs(values[a][r["quantity"]] - values[b][r["quantity"]]).reshape(len(states), -1).max(axis=1)
        rel = per_state / r["scale"]
        base = getattr(TOLERANCES, r["tier"]).rtol
        # only states beyond the base rtol constrain C: below it the tier passes whatever C is
        over = rel > base
        rows.append(
            {
                **r,
                "passed_base": bool(np.all(np.isfinite(rel)) and r["scaled"] <= base),
                "base_tolerance": base,
                "c_state": float(np.max(rel[over] / (cond[over] * EPS), initial=0.0)),
                "c_state_eq": float(np.max(rel[over] / (cond_eq[over] * EPS), initial=0.0)),
                "c_state_all": float(np.max(rel / (cond * EPS))),
                "c_state_eq_all": float(np.max(rel / (cond_eq * EPS))),
                "worst_state_cond": float(cond[int(np.argmax(per_state))]),
            }
        )
    return {
        "cond_median": float(np.median(cond)),
        "cond_max": float(cond.max()),
        "cond_random_max": float(cond[:n_states].max()),
        "cond_eq_median": float(np.median(cond_eq)),
        "cond_eq_max": float(cond_eq.max()),
        "q_worst": q_worst,
        "n_states": n_states,
        "n_targeted": TARGETED_STATES,
        "rows": rows,
    }


def conditioning_rows(system: System, sources: Mapping[str, Source], settings: Settings) -> list[ConditioningRow]:

    out: list[ConditioningRow] = []
    for sweep in conditioning_sweeps(system, sources["hand"]):
        for ratio in settings.ratios:
            extra = sweep_overrides(system, sweep, ratio)
            base: SweepBase = {
                "system": system.name,
                "sweep": sweep.name,
                "kind": sweep.kind,
                "ratio": float(ratio),
                "overrides": [list(o) for o in extra],
            }
            try:
                point = conditioning_point(
                    system.derive(overrides=(*system.overrides, *extra)),
                    n_states=settings.cond_states,
                    seed=settings.seed,
                    search=(settings.worst_grid, settings.worst_iterations),
                )
            except HarnessError as exc:
                out.append({**base, "quantity": None, "pair": None, "refused": str(exc)})
                continue
            info: CondInfo = {
                "cond_median": point["cond_median"],
                "cond_max": point["cond_max"],
                "cond_random_max": point["cond_random_max"],
                "cond_eq_median": point["cond_eq_median"],
                "cond_eq_max": point["cond_eq_max"],
                "q_worst": point["q_worst"],
                "n_states": point["n_states"],
                "n_targeted": point["n_targeted"],
            }
            out += [
                {**base, **info, **_measured(r), "per_cond_eps": r["scaled"] / (info["cond_max"] * EPS)}
                for r in point["rows"]
            ]
    return out


def _measured(r: CondRow) -> Measured:
    """What a conditioning row keeps of compare's row and its constants C."""
    return {
        "quantity": r["quantity"],
        "pair": r["pair"],
        "scaled": r["scaled"],
        "max_abs": r["max_abs"],
        "scale": r["scale"],
        "tier": r["tier"],
        "tolerance": r["tolerance"],
        "passed": r["passed"],
        "base_tolerance": r["base_tolerance"],
        "passed_base": r["passed_base"],
        "c_state": r["c_state"],
        "c_state_eq": r["c_state_eq"],
        "c_state_all": r["c_state_all"],
        "c_state_eq_all": r["c_state_eq_all"],
        "worst_state_cond": r["worst_state_cond"],
    }


def conditioning_summary(rows: list[ConditioningRow]) -> list[ConditioningSummary]:
    """Per (system, sweep, quantity): at each point the worst pair's disagreement against cond(M) over
    the sample; the log-log slope where cond >= FIT_FROM_COND; the largest per-state error / (cond eps)
    (C) and / (cond_eq eps) (C_eq); the smallest cond at which the base tier and the current tier fail."""
    groups: dict[tuple[str, str, str], dict[float, SweepPoint]] = {}
    for r in rows:
        quantity = r.get("quantity")
        if quantity is None:
            continue
        p = groups.setdefault((r["system"], r["sweep"], quantity), {}).setdefault(
            r["ratio"],
            {
                "cond_max": r["cond_max"],
                "cond_eq_max": r["cond_eq_max"],
                "scaled": 0.0,
                "tolerance": 0.0,
                "passed": True,
                "passed_base": True,
                "c_state": 0.0,
                "c_state_eq": 0.0,
                "c_state_all": 0.0,
                "c_state_eq_all": 0.0,
                "base": r["base_tolerance"],
            },
        )
        p["scaled"] = max(p["scaled"], r["scaled"])
        p["tolerance"] = max(p["tolerance"], r["tolerance"])
        p["c_state"] = max(p["c_state"], r["c_state"])
        p["c_state_eq"] = max(p["c_state_eq"], r["c_state_eq"])
        p["c_state_all"] = max(p["c_state_all"], r["c_state_all"])
        p["c_state_eq_all"] = max(p["c_state_eq_all"], r["c_state_eq_all"])
        p["passed"] = p["passed"] and r["passed"]
        p["passed_base"] = p["passed_base"] and r["passed_base"]
    out: list[ConditioningSummary] = []
    for (system, sweep, quantity), points in sorted(groups.items()):
        pts = [points[k] for k in sorted(points)]
        cond = np.array([p["cond_max"] for p in pts])
        err = np.array([p["scaled"] for p in pts])
        fit = (cond >= FIT_FROM_COND) & (err > 0) & np.isfinite(err)
        slope = None
        if fit.sum() >= 2 and np.ptp(np.log10(cond[fit])) >= 1:
            slope = float(np.polyfit(np.log10(cond[fit]), np.log10(err[fit]), 1)[0])
        out.append(
            {
                "system": system,
                "sweep": sweep,
                "quantity": quantity,
                "points": len(pts),
                "cond_range": [float(cond.min()), float(cond.max())],
                "disagreement_range": [float(err.min()), float(err.max())],
                "slope": slope,
                "c_state": max(p["c_state"] for p in pts),
                "c_state_eq": max(p["c_state_eq"] for p in pts),
                "c_state_all": max(p["c_state_all"] for p in pts),
                "c_state_eq_all": max(p["c_state_eq_all"] for p in pts),
                "base_tolerance": pts[0]["base"],
                "base_tier_fails_from_cond": min((p["cond_max"] for p in pts if not p["passed_base"]), default=None),
                "tier_fails_from_cond": min((p["cond_max"] for p in pts if not p["passed"]), default=None),
                "series": {
                    "ratio": sorted(points),
                    "cond_max": cond.tolist(),
                    "cond_eq_max": [p["cond_eq_max"] for p in pts],
                    "scaled": err.tolist(),
                    "tolerance": [p["tolerance"] for p in pts],
                },
            }
        )
    return out


def proposed_solve_tier(summary: list[ConditioningSummary]) -> SolveTierProposal:
    """The per-state solve tier max(rtol, C eps kappa) the measurements support: C = PROPOSAL_MARGIN x the
    largest C any state beyond rtol needed (`c_state`), rounded up to one significant digit; for kappa =
    cond(M), and for comparison the equilibrated cond_eq (which does not bound the error: near the
    folded point pendulum with a light elbow M is nearly diagonal yet its entries lose digits to
    cancellation in 2 + 2 cos(phi), so its error follows cond(M), not cond_eq)."""
    if not summary:
        return {}

    def up(x: float) -> float:
        if x <= 0:
            return 0.0
        e = math.floor(math.log10(x))
        return float(math.ceil(round(x / 10**e, 9)) * 10**e)

    c = max(s["c_state"] for s in summary)
    c_eq = max(s["c_state_eq"] for s in summary)
    C, C_eq = up(PROPOSAL_MARGIN * c), up(PROPOSAL_MARGIN * c_eq)
    rtol = TOLERANCES.solve.rtol
    return {
        "formula": "per state: max(rtol, C eps kappa)",
        "rtol": rtol,
        "eps": EPS,
        "margin": PROPOSAL_MARGIN,
        "current_cond_factor": getattr(TOLERANCES.solve, "cond_factor", None),
        "measured_C_cond": c,
        "measured_C_cond_all_states": max(s["c_state_all"] for s in summary),
        "C_cond": C,
        "kappa_from_cond": rtol / (C * EPS) if C else None,
        "measured_C_cond_eq": c_eq,
        "measured_C_cond_eq_all_states": max(s["c_state_eq_all"] for s in summary),
        "C_cond_eq": C_eq,
        "kappa_from_cond_eq": rtol / (C_eq * EPS) if C_eq else None,
    }

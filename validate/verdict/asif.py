""" " "As if": the physical parameter a wrong derivation behaves as.

The equations of motion of a chain are linear in its inertial parameters, 10 per moving joint (the
mass m, the first moment m c and the inertia about the joint's origin, in the joint's frame):
tau = Y(q, v, a) theta + armature a, with Y Pinocchio's joint-torque regressor. The person's
tau_hand = M_hand(q) a + bias_hand(q, v) at STATES of the harness's states (with random a) is fitted
to it, theta* = argmin |Y theta - tau_hand|, on the identifiable combinations only: the base
parameters of the stacked regressor, from a QR with column pivoting, so that a parameter the
equations cannot see (the m of a bar on a fixed hinge, an inertia about an axis it never turns
about) is never said to differ.

Where the fit reproduces tau_hand to rounding (FIT_RTOL) and differs from the model's combinations,
the wrong derivation is the right derivation of another chain. Which one is said in physical words:
each of KINDS (an inertia about the joint where the centre was meant, a mass counted twice, l where
l/2 was meant, a missing 1/2 in a kinetic energy, ...) is applied to each joint's body, and those that
reproduce tau_hand are named with both values, in the person's symbols where `parameters()` reads
them. Where none does, the identifiable combinations that differ are said as such. Where the fit
does not reproduce tau_hand (a Coriolis sign, a term no body has), None: it is not another body.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

import numpy as np

from ..handwritten.forms import not_provided_in
from ..handwritten.reads import Knob, knobs
from ..model.modelview import parallel_axis
from ..results.schema import AsIf, AsIfReading
from ..sources.base import Source
from ..systems import System
from .pointwise import States

if TYPE_CHECKING:  # Pinocchio is imported where its source is made (sources.make_sources), not here
    from ..sources.pinocchio import PinocchioSource

STATES = 30  # states the fit is made at (3 joints: 90 equations for 30 unknowns)
FIT_RTOL = 1e-10  # |Y theta* - tau| / |tau| at rounding level: the person's equations are a chain's
DIFFERS = 1e-8  # a combination moves tau by more than this fraction of |tau|: it differs
RANK_RTOL = 1e-10  # |R_kk| / |R_00| of the normalised regressor below it: not identifiable
MAX_DIFFERING = 3  # more differing combinations than this, and no reading: nothing said
PARAMETER_WORDS = ("m", "m c_x", "m c_y", "m c_z", "I_xx", "I_xy", "I_yy", "I_xz", "I_yz", "I_zz")
AXES = "xyz"

Inertial = tuple[float, np.ndarray, np.ndarray]  # m, centre c (3,), inertia about the centre (3, 3)


# Each mistake as the body it makes of (m, c, I about the centre), and its words.
KINDS: dict[str, Callable[[float, np.ndarray, np.ndarray], Inertial]] = {
    "about its joint": lambda m, c, i: (m, c, i + parallel_axis(m, c)),
    "mass twice": lambda m, c, i: (2 * m, c, i),
    "mass halved": lambda m, c, i: (m / 2, c, i),
    "centre twice": lambda m, c, i: (m, 2 * c, i),
    "centre halved": lambda m, c, i: (m, c / 2, i),
    "centre mirrored": lambda m, c, i: (m, -c, i),
    "central inertia twice": lambda m, c, i: (m, c, 2 * i),
    "no central inertia": lambda m, c, i: (m, c, 0 * i),
    "kinetic energy twice": lambda m, c, i: (m, c, 2 * i + parallel_axis(m, c)),
    "all twice": lambda m, c, i: (2 * m, c, 2 * i),
    "all halved": lambda m, c, i: (m / 2, c, i / 2),
}


# Each kind's words: the quantity it is said in (m: mass, d: the centre's distance from the joint, I: the
# moment of inertia about the centre, J: about the joint, both about the hinge's axis) and the sentence.
WORDS = {
    "about its joint": (
        "I",
        "{body}'s moment of inertia about its joint ({yours:.3g} kg m^2) instead of about its centre "
        "({model:.3g} kg m^2)",
    ),
    "mass twice": ("m", "{body}'s mass counted twice ({yours:.3g} kg instead of {model:.3g} kg)"),
    "mass halved": ("m", "{body}'s mass halved ({yours:.3g} kg instead of {model:.3g} kg)"),
    "centre twice": (
        "d",
        "{body}'s centre at {yours:.3g} m instead of {model:.3g} m from its joint (l where l/2 was meant)",
    ),
    "centre halved": (
        "d",
        "{body}'s centre at {yours:.3g} m instead of {model:.3g} m from its joint (l/2 where l was meant)",
    ),
    "centre mirrored": (
        "d",
        "{body}'s centre on the other side of its joint ({yours:.3g} m from it, its first moment m c of the other "
        "sign: a sign of its gravity terms)",
    ),
    "central inertia twice": (
        "I",
        "{body}'s moment of inertia about its centre counted twice ({yours:.3g} instead of {model:.3g} kg m^2: "
        "a missing 1/2 in its rotational kinetic energy)",
    ),
    "no central inertia": (
        "I",
        "{body} a point mass at its centre (moment of inertia about its centre 0 instead of {model:.3g} kg m^2)",
    ),
    "kinetic energy twice": (
        "J",
        "{body}'s kinetic energy counted twice (moment of inertia about its joint {yours:.3g} instead of "
        "{model:.3g} kg m^2: a missing 1/2 in its T)",
    ),
    "all twice": (
        "m",
        "{body}'s mass and inertia twice the model's ({yours:.3g} kg instead of {model:.3g} kg: the body counted "
        "twice)",
    ),
    "all halved": (
        "m",
        "{body}'s mass and inertia half the model's ({yours:.3g} kg instead of {model:.3g} kg: a 1/2 too many)",
    ),
}
QUANTITIES = {
    "m": "mass",
    "d": "distance of the centre from the joint",
    "I": "moment of inertia about the centre",
    "J": "moment of inertia about the joint",
}
UNITS = {"m": "kg", "d": "m", "I": "kg m^2", "J": "kg m^2"}


def to_physical(theta: np.ndarray) -> Inertial:
    """Pinocchio's 10 dynamic parameters as (m, c, inertia about the centre); c = 0 for no mass."""
    m, h = float(theta[0]), np.asarray(theta[1:4], dtype=float)
    xx, xy, yy, xz, yz, zz = theta[4:]
    origin = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]], dtype=float)
    c = h / m if m > 0 else np.zeros(3)
    return m, c, origin - parallel_axis(m, c)


def to_dynamic(m: float, c: np.ndarray, central: np.ndarray) -> np.ndarray:
    """(m, c, inertia about the centre) as Pinocchio's 10 dynamic parameters."""
    o = central + parallel_axis(m, c)
    return np.array([m, *(m * c), o[0, 0], o[0, 1], o[1, 1], o[0, 2], o[1, 2], o[2, 2]], dtype=float)


@dataclass(frozen=True)
class Fit:
    """The person's tau fitted to the chain's regressor on its base parameters.

    Y: (N n, P) stacked regressor; tau: (N n,) the person's inertial torques; theta: (P,) the model's
    parameters; base, rest: the columns QR picked as identifiable and the others; K: rest's columns as
    combinations of base's (Y[:, rest] = Y[:, base] K); fitted: the base parameters the fit gives."""

    Y: np.ndarray
    tau: np.ndarray
    theta: np.ndarray
    base: np.ndarray
    rest: np.ndarray
    K: np.ndarray
    fitted: np.ndarray

    def combined(self, theta: np.ndarray) -> np.ndarray:
        """The base parameters of a full parameter vector: theta[base] + K theta[rest]."""
        return np.asarray(theta[self.base] + self.K @ theta[self.rest])

    def misfit(self, theta: np.ndarray) -> float:
        """|Y theta - tau| / |tau|."""
        return float(np.linalg.norm(self.Y @ theta - self.tau) / max(float(np.linalg.norm(self.tau)), 1e-300))

    @property
    def residual(self) -> float:
        """The fit's own misfit."""
        Yb = self.Y[:, self.base]
        return float(np.linalg.norm(Yb @ self.fitted - self.tau) / max(float(np.linalg.norm(self.tau)), 1e-300))

    def differing(self) -> list[int]:
        """The base parameters (indices into `base`) whose difference from the model's moves tau."""
        delta = self.fitted - self.combined(self.theta)
        size = np.linalg.norm(self.Y[:, self.base], axis=0) * np.abs(delta)
        return [int(k) for k in np.nonzero(size > DIFFERS * np.linalg.norm(self.tau))[0]]


def fit(Y: np.ndarray, tau: np.ndarray, theta: np.ndarray) -> Fit:
    """The least-squares fit of tau on the base parameters of Y (QR with column pivoting of Y with its
    columns normalised, so that units do not decide what is identifiable)."""
    import scipy.linalg

    norms = np.linalg.norm(Y, axis=0)
    scale = np.where(norms > 0, norms, 1.0)
    _, R, piv = scipy.linalg.qr(Y / scale, mode="economic", pivoting=True)
    diag = np.abs(np.diag(R))
    rank = int(np.sum(diag > RANK_RTOL * max(float(diag[0]) if len(diag) else 0.0, 1e-300)))
    base, rest = piv[:rank], piv[rank:]
    Kn = scipy.linalg.solve_triangular(R[:rank, :rank], R[:rank, rank:])
    K = Kn / scale[base][:, None] * scale[rest][None, :]
    fitted = np.linalg.lstsq(Y[:, base] / scale[base], tau, rcond=None)[0] / scale[base]
    return Fit(Y, tau, theta, base, rest, K, fitted)


def person_torques(system: System, source: PinocchioSource, states: States, seed: int) -> tuple[np.ndarray, ...]:
    """(Y stacked, tau_hand less the armature's part, the model's theta) at the first STATES states,
    with seeded random accelerations. Raises whatever the person's code raises."""
    q, v = states.q[:STATES], states.v[:STATES]
    a = np.random.default_rng(seed).standard_normal(q.shape)
    eq, p = system.derivation, system.params
    with np.errstate(all="ignore"):
        M, bias = np.asarray(eq.mass_matrix(p, q)), np.asarray(eq.bias(p, q, v))
    if not (np.isrealobj(M) and np.isrealobj(bias)):  # complex numbers: the terms' rows name them
        raise ValueError("not real numbers")
    M = M.astype(float).reshape(len(q), q.shape[1], q.shape[1])
    bias = bias.astype(float).reshape(q.shape)
    tau = np.einsum("nij,nj->ni", M, a) + bias - source.armature() * a
    Y = source.regressor(q, v, a)
    return Y.reshape(-1, Y.shape[-1]), tau.ravel(), source.dynamic_parameters().ravel()


def _pinocchio(system: System, sources: Mapping[str, Source]) -> PinocchioSource | None:
    """Pinocchio's source, where it is among the sources and the derivation gives M and bias."""
    source = sources.get("pinocchio")
    if source is None or not hasattr(source, "regressor"):
        return None
    return None if {"mass_matrix", "bias"} & set(not_provided_in(system.equations)) else cast("PinocchioSource", source)


def as_if(system: System, states: States, sources: Mapping[str, Source], *, seed: int = 0) -> AsIf | None:
    """The other chain a wrong derivation's M and bias are the equations of, said in physical words;
    None where they are no chain's (the fit does not reproduce them), are the model's own, or the
    derivation gives no M or bias, or Pinocchio is not among the sources."""
    source = _pinocchio(system, sources)
    if source is None:
        return None
    try:
        Y, tau, theta = person_torques(system, source, states, seed)
    except Exception:  # noqa: BLE001 - the person's code: its failure is said by the terms' rows
        return None
    if not (np.all(np.isfinite(tau)) and np.linalg.norm(tau) > 0):
        return None
    found = fit(Y, tau, theta)
    differing = found.differing()
    if found.residual > FIT_RTOL or not differing:
        return None
    chain = Chain(source.joint_bodies(), source.joint_axes(), theta.reshape(-1, 10))
    readings = chain.readings(found)
    if not readings and len(differing) > MAX_DIFFERING:
        return None
    return _result(system, found, chain, readings, differing)


@dataclass(frozen=True)
class Chain:
    """The model's chain as the fit sees it: the bodies each moving joint carries, its hinge axis (None
    where it is no single hinge), and its 10 parameters (k, 10)."""

    bodies: list[tuple[str, ...]]
    axes: list[np.ndarray | None]
    theta: np.ndarray

    def name(self, j: int) -> str:
        """The joint's body ("link2"), or its bodies ("base+arm") where some are welded to it."""
        return "+".join(self.bodies[j]) or f"joint {j + 1}'s body"

    def changed(self, joints: tuple[int, ...], kind: str) -> np.ndarray:
        """The full parameter vector with `kind` applied to the bodies of `joints`."""
        out = self.theta.copy()
        for j in joints:
            out[j] = to_dynamic(*KINDS[kind](*to_physical(self.theta[j])))
        return out.ravel()

    def readings(self, found: Fit) -> list[AsIfReading]:
        """Each (body, kind) that reproduces the person's tau; where none does, each kind applied to
        every body at once (a habit: every inertia taken about its joint)."""
        moving = [j for j in range(len(self.theta)) if self.theta[j][0] > 0]
        for groups in ([(j,) for j in moving], [tuple(moving)] if len(moving) > 1 else []):
            out = [
                reading
                for joints in groups
                for kind in KINDS
                if found.misfit(self.changed(joints, kind)) <= FIT_RTOL
                for reading in self.words(joints, kind)
            ]
            if out:
                return out
        return []

    def words(self, joints: tuple[int, ...], kind: str) -> list[AsIfReading]:
        """The readings of `kind` on each joint's body, with the model's and the person's values."""
        return [self.word(j, kind, every=len(joints) > 1) for j in joints]

    def word(self, j: int, kind: str, *, every: bool = False) -> AsIfReading:
        """One body's reading of `kind` (WORDS), with the model's value and the one the equations have."""
        m, c, central = to_physical(self.theta[j])
        m2, c2, central2 = KINDS[kind](m, c, central)
        axis = self.axis(j, central, central2, m2, c2)
        joint = float(axis @ (central + parallel_axis(m, c)) @ axis)
        values = {
            "m": (m2, m),
            "d": (float(np.linalg.norm(c2)), float(np.linalg.norm(c))),
            "I": (float(axis @ central2 @ axis), float(axis @ central @ axis)),
            "J": (2 * joint, joint),
        }
        of, template = WORDS[kind]
        yours, model = values[of]
        body = self.name(j)
        quantity = QUANTITIES[of] + (f", axis {self.axis_word(axis)}" if of in "IJ" else "")
        said = template.format(body=body, yours=yours, model=model)
        return {
            "bodies": list(self.bodies[j]),
            "kind": kind,
            "quantity": quantity,
            "model": model,
            "yours": yours,
            "unit": UNITS[of],
            "statement": said if not every else said.replace(f"{body}'s", f"each body's ({body})", 1),
        }

    def axis(self, j: int, central: np.ndarray, changed: np.ndarray, m: float, c: np.ndarray) -> np.ndarray:
        """The axis a moment of inertia is said about: the joint's hinge axis, else the coordinate
        axis whose moment about the joint the reading changes most."""
        axis = self.axes[j]
        if axis is not None:
            return axis
        return np.asarray(
            np.eye(3)[int(np.argmax(np.abs(np.diag(changed - central)) + np.abs(np.diag(parallel_axis(m, c)))))]
        )

    @staticmethod
    def axis_word(axis: np.ndarray) -> str:
        """ "z" for a coordinate axis, else the axis' components."""
        k = int(np.argmax(np.abs(axis)))
        return AXES[k] if abs(abs(axis[k]) - 1.0) < 1e-12 else f"({', '.join(f'{x:.3g}' for x in axis)})"

    def column(self, p: int) -> str:
        """A parameter's words: "link2's m c_y", "link1's I_zz about its joint"."""
        j, i = divmod(p, 10)
        return f"{self.name(j)}'s {PARAMETER_WORDS[i]}" + (" about its joint" if i >= 4 else "")


def combination(found: Fit, chain: Chain, k: int) -> str:
    """The identifiable combination `k` in words, with the model's and the fitted values."""
    terms = [chain.column(int(found.base[k]))]
    for r, coef in zip(found.rest, found.K[k], strict=True):
        if abs(coef) > 1e-9:
            terms.append(f"{'-' if coef < 0 else '+'} {abs(coef):.3g} x {chain.column(int(r))}")
    shown = " ".join(terms[:4]) + (" + ..." if len(terms) > 4 else "")
    model = float(found.combined(found.theta)[k])
    return f"{shown}: {found.fitted[k]:.4g} instead of {model:.4g}"


def _result(system: System, found: Fit, chain: Chain, readings: list[AsIfReading], differing: list[int]) -> AsIf:
    """The record and its statement: the readings, else the differing combinations said as such."""
    combos = [combination(found, chain, k) for k in differing]
    if readings:
        said = " or ".join(r["statement"] for r in readings)
        if len(readings) > 1:
            said += " (the equations cannot tell these apart)"
    else:
        said = (
            "the identifiable combination"
            + ("s " if len(combos) > 1 else " ")
            + "; ".join(combos)
            + " (no single parameter can be told apart)"
        )
    names = person_symbols(system, readings)
    legend = f" [your names: {', '.join(f'{k} = {v}' for k, v in names.items())}]" if names else ""
    return {
        "statement": f"your equations are those of this chain with {said}{legend}",
        "residual": found.residual,
        "states": len(found.tau) // max(system.nv, 1),
        "base_parameters": len(found.base),
        "differing": combos,
        "readings": readings,
        "names": names,
    }


# The model keys of a body each kind of reading speaks of (the person's names for them are said).
KEYS = {
    "about its joint": ("inertia", "mass", "com"),
    "mass twice": ("mass",),
    "mass halved": ("mass",),
    "centre twice": ("com",),
    "centre halved": ("com",),
    "centre mirrored": ("com",),
    "central inertia twice": ("inertia",),
    "no central inertia": ("inertia",),
    "kinetic energy twice": ("inertia", "mass", "com"),
    "all twice": ("mass", "inertia"),
    "all halved": ("mass", "inertia"),
}


def person_symbols(system: System, readings: list[AsIfReading]) -> dict[str, str]:
    """{the person's field: the model number it reads, with its sign and factor} for the numbers the
    readings speak of ("c2": "-body/link2/com[1]"), from what `parameters()` reads."""
    wanted = [{f"body/{b}/{k}" for b in r["bodies"] for k in KEYS[r["kind"]]} for r in readings]
    try:
        knob_list = knobs(system.derivation.parameters, system.view, only=set().union(*wanted))
    except Exception:  # noqa: BLE001 - no names to give: the statement stands without them
        return {}
    out: dict[str, str] = {}
    for r, keys in zip(readings, wanted, strict=True):
        for knob in knob_list:
            if knob.key in keys and len(knob.fields) == 1 and _about(knob, r):
                out.setdefault(knob.fields[0], _read_as(knob))
    return out


def _about(knob: Knob, reading: AsIfReading) -> bool:
    """Whether an inertia's number is the moment the reading is about (its diagonal entry on the axis)."""
    if not knob.key.endswith("/inertia"):
        return True
    axis = reading["quantity"].rsplit(" ", 1)[-1]
    return axis in AXES and knob.index == (AXES.index(axis),) * 2


def _read_as(knob: Knob) -> str:
    """ "-body/link2/com[1]", "2*body/pole/com[2]": the field as parameters() reads it."""
    gain = knob.gains[0]
    sign, size = ("-" if gain < 0 else ""), abs(gain)
    return sign + ("" if abs(size - 1.0) < 1e-9 else f"{size:.6g}*") + knob.label

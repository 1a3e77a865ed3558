"""Two files' joints matched by what they are, names only a hint (issue 43): the two-file audit's map.

Two files of one robot often name its joints differently (`panda_joint1` in one, `joint1` in the other;
`FR_hip_joint` and `FR_hip_leg_joint`). Each joint of a `Reading` carries, at the reference
configuration and in world coordinates, its kind (hinge or slide), anchor and axis, and the joint above
it: enough to tell which joint of B is which joint of A without its name.

- A cost for every pair (a of A, b of B): a different kind is never matched; the anchors' distance
  (after a common base offset, below) in units of ANCHOR_TOL of the robot's extent, the axes' distance
  (a reversed axis is the same line) in units of AXIS_TOL, the depths' difference in the tree, less a
  bonus for an exact name (the old matching by name kept as it was) and a smaller one for names sharing
  tokens or digits once the usual words (joint, jnt) are left out. `scipy.optimize.linear_sum_assignment`
  takes the cheapest one-to-one map.
- The base placement: B may place the robot elsewhere in the world (a URDF's base at the origin, an MJCF's
  on a table in a scene, turned to face it). A turn about the vertical (each quarter turn) and each offset
  that then puts a root joint of A on a root joint of B (and none) are tried; the placement under which
  most joints line up is kept, refined by a least-squares fit (turn and offset, 2-D Procrustes) over the
  joints that line up. Only a turn about the vertical: it leaves gravity, and so G, M and bias, as they are.
- The tree: a pair stays only when the nearest matched joint above a is matched to the nearest matched
  joint above b (or both are at the world), so a matched child is a child of its parent's match.
- Each pair says how it was matched: "name", "anchor, axis, tree" (it lines up), "axis, tree" (its anchor
  is elsewhere: a link above it differs in length), "tree" (its place in the tree alone), "map" (given).
  A pair matched on the tree alone with neither anchor nor axis lining up stays only when both files have
  as many joints (a partial match is not padded with guesses).
- Never by force: two files with different joint counts whose joints mostly do not line up (fewer than
  half of the smaller file's) are different robots, refused with the numbers and the `--map` that compares
  them anyway.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..core.errors import HarnessError
from ..model.meaning import Reading
from .chain import order

ANCHOR_TOL = 0.02  # of the robot's extent: two anchors this close line up (files from two packages round)
AXIS_TOL = 0.05  # |a - b| of unit axes (about 3 degrees)
MIN_EXTENT = 0.05  # m: the extent of a robot whose anchors nearly coincide
CAP = 10.0  # a term's most, in units of its tolerance: a far anchor costs as much as a very far one
EXACT_NAME = 100.0  # outweighs every geometric term: joints of one name stay matched, as before issue 43
NAME_HINT = 1.0  # a shared token or digit: a tie-breaker among joints that line up alike
DEPTH = 2.0  # per level of the tree
FORBIDDEN = 1e6  # a hinge against a slide
GENERIC = {"joint", "jnt", "j", "hinge", "slide", "revolute", "prismatic", "continuous"}


@dataclass(frozen=True)
class JointMap:
    """The map from A's joints to B's, and how sure it is.

    Attributes:
        pairs: A's joint -> B's joint, in A's chain order.
        how: A's joint -> "name", "anchor, axis, tree", "axis, tree", "tree" or "map".
        placed: where B places the robot relative to A (B = turn(A) + offset).
        reversed: A's joints whose B axis points the other way.
    """

    pairs: dict[str, str]
    how: dict[str, str]
    placed: Placement
    reversed: tuple[str, ...] = ()


@dataclass(frozen=True)
class Placement:
    """B's placement of the robot relative to A's: a point x of A is at R(yaw) x + offset in B."""

    yaw: float = 0.0  # rad, about the world's z
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def R(self) -> np.ndarray:
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def moved(self) -> bool:
        return bool(np.any(self.offset)) or self.yaw != 0.0


@dataclass(frozen=True)
class _Side:
    """One file's joints in chain order, with what the cost reads."""

    names: list[str]
    kind: list[str]
    anchor: np.ndarray  # (n, 3)
    axis: np.ndarray  # (n, 3) unit
    depth: np.ndarray  # (n,)
    parent: list[str]


def _side(reading: Reading) -> _Side:
    names = order(reading)
    r = [reading.joints[j] for j in names]
    depth = []
    for x in r:
        d, p = 0, x.parent
        while p in reading.joints:
            d, p = d + 1, reading.joints[p].parent
        depth.append(d)
    return _Side(
        names=names,
        kind=[x.kind for x in r],
        anchor=np.array([x.anchor for x in r], dtype=float).reshape(-1, 3),
        axis=np.array([x.axis / np.linalg.norm(x.axis) for x in r], dtype=float).reshape(-1, 3),
        depth=np.array(depth),
        parent=[x.parent for x in r],
    )


def tokens(name: str) -> set[str]:
    """A name's words and numbers, lowercased, the usual words for a joint left out."""
    parts = re.findall(r"[a-z]+|[0-9]+", name.lower())
    return {p.lstrip("0") or "0" if p.isdigit() else p for p in parts} - GENERIC


def _name_score(a: str, b: str) -> float:
    """EXACT_NAME for one name, else NAME_HINT times the share of tokens the two have in common (Jaccard)."""
    if a == b:
        return EXACT_NAME
    ta, tb = tokens(a), tokens(b)
    return NAME_HINT * len(ta & tb) / len(ta | tb) if ta | tb else 0.0


def _extent(a: _Side, b: _Side) -> float:
    spread = [float(np.linalg.norm(s.anchor - s.anchor.mean(0), axis=1).max()) for s in (a, b) if len(s.names)]
    return max([MIN_EXTENT, *spread])


def _gaps(a: _Side, b: _Side, at: Placement) -> tuple[np.ndarray, np.ndarray]:
    """(anchor distances in m with A placed as B, axis distances, a reversed axis as the same line)."""
    anchor = np.linalg.norm((a.anchor @ at.R.T + at.offset)[:, None] - b.anchor[None], axis=-1)
    axis = a.axis @ at.R.T
    same = np.linalg.norm(axis[:, None] - b.axis[None], axis=-1)
    flipped = np.linalg.norm(axis[:, None] + b.axis[None], axis=-1)
    return anchor, np.minimum(same, flipped)


def _cost(a: _Side, b: _Side, at: Placement, extent: float) -> np.ndarray:
    anchor, axis = _gaps(a, b, at)
    cost = np.minimum(anchor / (ANCHOR_TOL * extent), CAP) + np.minimum(axis / AXIS_TOL, CAP)
    cost += DEPTH * np.abs(a.depth[:, None] - b.depth[None])
    cost -= np.array([[_name_score(x, y) for y in b.names] for x in a.names]).reshape(cost.shape)
    kinds = np.array([[x != y for y in b.kind] for x in a.kind], dtype=bool).reshape(cost.shape)
    return np.where(kinds, FORBIDDEN, cost)


def _lined_up(a: _Side, b: _Side, at: Placement, extent: float) -> tuple[np.ndarray, np.ndarray]:
    """(n_a, n_b) booleans: the anchors line up; the axes line up."""
    anchor, axis = _gaps(a, b, at)
    return anchor <= ANCHOR_TOL * extent, axis <= AXIS_TOL


def _assign(a: _Side, b: _Side, at: Placement, extent: float, fixed: dict[int, int]) -> dict[int, int]:
    """The cheapest one-to-one map (index of A -> index of B) of the joints `fixed` leaves, plus `fixed`."""
    rows = [i for i in range(len(a.names)) if i not in fixed]
    cols = [j for j in range(len(b.names)) if j not in fixed.values()]
    out = dict(fixed)
    if rows and cols:
        cost = _cost(a, b, at, extent)[np.ix_(rows, cols)]
        for r, c in zip(*linear_sum_assignment(cost), strict=True):
            if cost[r, c] < FORBIDDEN:
                out[rows[r]] = cols[c]
    return out


def _placements(a: _Side, b: _Side) -> list[Placement]:
    """The placements worth trying: each quarter turn about the vertical, alone and with each offset that
    then puts a root joint of A on a root joint of B."""
    out = []
    for yaw in (0.0, np.pi / 2, np.pi, -np.pi / 2):
        turn = Placement(yaw).R
        out.append(Placement(yaw))
        for i in np.flatnonzero(a.depth == 0):
            for j in np.flatnonzero(b.depth == 0):
                if a.kind[i] == b.kind[j]:
                    out.append(Placement(yaw, b.anchor[j] - turn @ a.anchor[i]))
    return out


def _fit(a: _Side, b: _Side, pairs: list[tuple[int, int]], at: Placement) -> Placement:
    """The turn about the vertical and the offset that best put A's anchors on B's over `pairs` (2-D
    Procrustes; the turn kept where the anchors do not spread in the horizontal plane)."""
    p = np.array([a.anchor[i] for i, _ in pairs])
    q = np.array([b.anchor[j] for _, j in pairs])
    pc, qc = p.mean(0), q.mean(0)
    h = (p - pc)[:, :2].T @ (q - qc)[:, :2]
    yaw = float(np.arctan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])) if abs(np.trace(h)) + abs(h[0, 1]) > 1e-12 else at.yaw
    if abs(np.angle(np.exp(1j * (yaw - at.yaw)))) > np.pi / 4:  # a fit far from the tried turn: not trusted
        yaw = at.yaw
    return Placement(yaw, qc - Placement(yaw).R @ pc)


def _best(a: _Side, b: _Side, extent: float, fixed: dict[int, int]) -> tuple[dict[int, int], Placement]:
    """The map and base placement under which the most joints line up (then the lowest cost)."""

    def score(m: dict[int, int], at: Placement) -> tuple[int, float]:
        near, same = _lined_up(a, b, at, extent)
        cost = _cost(a, b, at, extent)
        return (-sum(bool(near[i, j] and same[i, j]) for i, j in m.items()), sum(cost[i, j] for i, j in m.items()))

    tried = [(m, at) for at in _placements(a, b) for m in [_assign(a, b, at, extent, fixed)]]
    m, at = min(tried, key=lambda t: score(*t))
    near, same = _lined_up(a, b, at, extent)
    agree = [(i, j) for i, j in m.items() if near[i, j] and same[i, j]]
    if agree:  # fitted over the joints that line up, so that no one root's rounding sets it
        refined = _fit(a, b, agree, at)
        again = _assign(a, b, refined, extent, fixed)
        if score(again, refined) <= score(m, at):
            m, at = again, refined
    return m, at


def _above(side: _Side, i: int, kept: set[int]) -> int:
    """The nearest joint above joint i among `kept` (-1: the world)."""
    index = {n: k for k, n in enumerate(side.names)}
    p = side.parent[i]
    while p in index:
        if index[p] in kept:
            return index[p]
        p = side.parent[index[p]]
    return -1


def _tree_consistent(a: _Side, b: _Side, m: dict[int, int], keep: set[int]) -> dict[int, int]:
    """`m` less the pairs whose nearest matched joints above do not correspond (those in `keep` stay)."""
    m = dict(m)
    while True:
        bad = [
            i
            for i, j in m.items()
            if i not in keep and m.get(_above(a, i, set(m)), -1) != _above(b, j, set(m.values()))
        ]
        if not bad:
            return m
        del m[max(bad, key=lambda i: a.depth[i])]  # the deepest first: its parent's match may be the wrong one


def _fixed(a: _Side, b: _Side, given: dict[str, str], ra: Reading, rb: Reading) -> dict[int, int]:
    """--map's pairs as indices, each checked: joints that exist, once each, of one kind."""
    out: dict[int, int] = {}
    for x, y in given.items():
        for name, side, label in ((x, a, "A"), (y, b, "B")):
            if name not in side.names:
                raise HarnessError(f"--map {x}={y}: no joint '{name}' in {label}; its joints: {', '.join(side.names)}.")
        i, j = a.names.index(x), b.names.index(y)
        if j in out.values():
            raise HarnessError(f"--map: B's joint '{y}' is given twice; each joint of B matches one of A.")
        if ra.joints[x].kind != rb.joints[y].kind:
            raise HarnessError(f"--map {x}={y}: {x} is a {ra.joints[x].kind} in A, {y} a {rb.joints[y].kind} in B.")
        out[i] = j
    return out


def match(ra: Reading, rb: Reading, given: dict[str, str] | None = None) -> JointMap:
    """A's joints matched to B's (the module docstring); `given`: --map's pairs, kept as they are."""
    a, b = _side(ra), _side(rb)
    extent = _extent(a, b)
    fixed = _fixed(a, b, given or {}, ra, rb)
    m, at = _best(a, b, extent, fixed)
    m = _tree_consistent(a, b, m, set(fixed) | {i for i, j in m.items() if a.names[i] == b.names[j]})
    near, same = _lined_up(a, b, at, extent)
    how: dict[str, str] = {}
    for i, j in sorted(m.items()):
        x, y = a.names[i], b.names[j]
        how[x] = (
            "map" if i in fixed else "name" if x == y else
            "anchor, axis, tree" if near[i, j] and same[i, j] else "axis, tree" if same[i, j] else "tree"
        )  # fmt: skip
    if len(a.names) != len(b.names):  # a partial match is not padded with guesses
        how = {x: h for x, h in how.items() if h != "tree"}
    if not fixed:  # a --map is the person's word that the two are one robot
        axes = sum(1 for x in how if same[a.names.index(x), m[a.names.index(x)]])
        _refuse_a_different_robot(a, b, how, axes)
    pairs = {x: b.names[m[a.names.index(x)]] for x in how}
    flipped = tuple(x for x, y in pairs.items() if float((at.R @ ra.joints[x].axis) @ rb.joints[y].axis) < 0.0)
    yaw = 0.0 if abs(at.yaw) <= 1e-9 else at.yaw
    offset = np.zeros(3) if np.linalg.norm(at.offset) <= 1e-9 * extent else at.offset
    return JointMap(pairs, how, Placement(yaw, offset), flipped)


def _refuse_a_different_robot(a: _Side, b: _Side, how: dict[str, str], axes: int) -> None:
    """Two files most of whose matched joints do not turn about the same axis (`axes`: the pairs that do,
    name pairs included: a name is a hint, not a proof), or whose joint counts differ and whose joints
    mostly do not line up, are two robots. A pair whose anchor is elsewhere but whose axis agrees counts:
    a link of another length is a difference to report, not another robot."""
    if not a.names or not b.names:
        raise HarnessError(
            f"no joint to compare: A has {len(a.names)} moving joints, B {len(b.names)}; a two-file audit compares "
            "the joints both files move."
        )
    lined = sum(1 for h in how.values() if h in ("name", "anchor, axis, tree"))
    smaller = min(len(a.names), len(b.names))
    if how and 2 * axes < smaller:
        raise HarnessError(
            f"no structural match: A has {len(a.names)} joints, B {len(b.names)}, and only {axes} of the {len(how)} "
            "joints paired (by name or place in the tree) turn about the same axis after the best base placement: "
            f"they look like two different robots; give --map A=B,... (e.g. --map {a.names[0]}={b.names[0]}) to "
            "compare them anyway."
        )
    if how and (len(a.names) == len(b.names) or 2 * lined >= smaller):
        return
    raise HarnessError(
        f"no structural match: A has {len(a.names)} joints, B {len(b.names)}, and {lined} of A's line up with B's "
        f"(kind, anchor, axis, tree, after the best base placement): they look like two different robots; give "
        f"--map A=B,... (e.g. --map {a.names[0]}={b.names[0]}) to compare them anyway."
    )

"""The model audit: three independent readers of the same file, field by field (issue 29).

Most disagreements between engines are in how a model was read, not in the dynamics: an inertial
frame's rotation dropped, inertias summed wrongly across a fixed joint, a default mass for a link
without <inertial>, damping or armature dropped. With two readers the harness can only say that they
differ; with three it names the odd one out. The readers are MuJoCo (its compiled model), Pinocchio
(`buildModelFromXML` / `buildModelFromMJCF`) and Drake (its URDF or MJCF parser), each on the file as
the harness hands it to them (validate/systems/urdf.py, validate/engines/drake.py say what is aligned).

Per compared body: mass (kg), centre of mass (m) and inertia about it (kg m^2), both in the body's
own frame (a URDF link's frame), the links welded to it by fixed joints included (MuJoCo fuses them,
Pinocchio adds them to the joint's inertia, the Drake source sums Drake's spatial inertias). Per
compared joint at q = 0: its anchor and its motion axis (linear, angular) in the world, its position
limits (rad or m; none: +-inf), damping and armature as each reader read them. Where the readers
differ, the reader in the minority is named, and the consequence shown: max |M_reader - M_other| over
a few seeded states.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..engines import make_source
from ..engines.base import Source, engine_of
from ..errors import HarnessError
from ..systems import System
from ..systems.modelview import key_parts
from .modelsync import mujoco_joint_frames
from .pointwise import random_states

READERS = ("mujoco", "pinocchio", "drake")
LABEL = {"mujoco": "MuJoCo", "pinocchio": "Pinocchio", "drake": "Drake"}
RTOL = 1e-9  # the readers parse the same decimal text through different rotations and sums
UNBOUNDED = 1e10  # a limit this large is none (the harness hands Pinocchio continuous joints so)
N_STATES = 5  # states at which the mass matrices are compared
# Fields no comparison uses (every engine's limits are off): a difference is shown, but fails nothing.
INFORMATIONAL = ("/limits",)
FRAME = (
    "mass kg; centre of mass m and inertia about it kg m^2, in the body's frame (links welded to it "
    "included); joint anchor m and motion axis (linear, angular) in the world at q = 0; limits rad or m; "
    "damping N m s/rad; armature kg m^2"
)


def mujoco_reading(system: System, source: Source) -> dict[str, Any]:
    """MuJoCo's compiled model, keyed as `DrakeSource.reading` keys Drake's."""
    from ..engines.mujoco import MujocoSource

    mj = engine_of(source, MujocoSource)
    view, m = system.view, mj.m
    out: dict[str, Any] = {}
    for b in system.bodies:
        out |= {f"body/{b}/{k}": view[f"body/{b}/{k}"] for k in ("mass", "com", "inertia")}
    frames = mujoco_joint_frames(system)
    for j, qadr in zip(system.joints, mj.qadr, strict=True):
        jid = int(np.nonzero(np.asarray(m.jnt_qposadr) == qadr)[0][0])
        limited = bool(m.jnt_limited[jid])
        limits = np.array(m.jnt_range[jid], dtype=float) if limited else np.array([-np.inf, np.inf])
        out |= {
            f"joint/{j}/anchor": frames[j][0],
            f"joint/{j}/motion": frames[j][1],
            f"joint/{j}/limits": limits,
            f"joint/{j}/damping": float(view[f"joint/{j}/damping"]),
            f"joint/{j}/armature": float(view[f"joint/{j}/armature"]),
        }
    return out


def pinocchio_reading(system: System, source: Source) -> dict[str, Any]:
    """Pinocchio's model (a joint's inertia holds its body and the links welded to it)."""
    from ..engines.pinocchio import PinocchioSource

    pn = engine_of(source, PinocchioSource)
    model = pn.model
    out: dict[str, Any] = {}
    for b, jid in zip(system.bodies, pn.joint_of_body, strict=True):
        inertia = model.inertias[jid]
        out |= {
            f"body/{b}/mass": float(inertia.mass),
            f"body/{b}/com": np.array(inertia.lever, dtype=float),
            f"body/{b}/inertia": np.array(inertia.inertia, dtype=float),
        }
    frames, damping = pn.joint_frames(), pn.read_damping()
    for k, j in enumerate(system.joints):
        lo, hi = float(model.lowerPositionLimit[pn.qidx[k]]), float(model.upperPositionLimit[pn.qidx[k]])
        limits = np.array([-np.inf if lo <= -UNBOUNDED else lo, np.inf if hi >= UNBOUNDED else hi])
        out |= {
            f"joint/{j}/anchor": frames[j][0],
            f"joint/{j}/motion": frames[j][1],
            f"joint/{j}/limits": limits,
            f"joint/{j}/damping": float(damping[k]),
            f"joint/{j}/armature": float(model.armature[pn.vidx[k]]),
        }
    return out


def _same(a: Any, b: Any, floor: float) -> bool:
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if x.shape != y.shape:
        return False
    inf = np.isinf(x) | np.isinf(y)
    if not np.array_equal(x[inf], y[inf]):
        return False
    x, y = x[~inf], y[~inf]
    scale = max(float(np.abs(x).max(initial=0.0)), float(np.abs(y).max(initial=0.0)), floor)
    return bool(np.all(np.abs(x - y) <= RTOL * scale))


def minority(values: dict[str, Any], floor: float) -> tuple[bool, str | None]:
    """(all agree, the one reader the others agree against, or None: all agree, or no two agree)."""
    names = list(values)
    agree = {(a, b): _same(values[a], values[b], floor) for i, a in enumerate(names) for b in names[i + 1 :]}
    if all(agree.values()):
        return True, None
    for (a, b), ok in agree.items():
        if ok and len(names) == 3:
            return False, next(n for n in names if n not in (a, b))
    return False, None


def _hint(field: str, odd: Any, usual: Any) -> str:
    """A likely cause, from the shape of the difference alone."""
    odd, usual = np.asarray(odd, dtype=float), np.asarray(usual, dtype=float)
    if field == "inertia":
        same_moments = np.allclose(np.linalg.eigvalsh(odd), np.linalg.eigvalsh(usual), rtol=1e-6, atol=0.0)
        if same_moments:
            return "the same principal moments in another orientation: the inertial frame's rotation (rpy) lost"
    if field == "mass" and float(odd) == 1.0 and float(usual) == 0.0:
        return "a default mass of 1 kg for a link the others read as massless"
    if field in ("damping", "armature") and not np.any(odd) and np.any(usual):
        return f"{field} dropped"
    if field in ("anchor", "motion"):
        return "the joint placed differently (another parent or frame)"
    if field == "limits":
        return "limits are off in every engine here: no dynamics depend on them"
    return ""


def _fmt(x: Any) -> Any:
    arr = np.asarray(x, dtype=float)
    return float(arr) if arr.ndim == 0 else np.round(arr, 12).tolist()


def _row(key: str, values: dict[str, Any], floor: float) -> dict[str, Any]:
    agree, odd = minority(values, floor)
    row: dict[str, Any] = {"key": key, "values": {r: _fmt(v) for r, v in values.items()}, "agree": agree}
    if agree:
        return row
    row["minority"] = odd
    parts = key_parts(key)
    name, field = (parts[1], parts[2]) if parts else (key, key)
    if odd is None:
        row["finding"] = f"{name}'s {field}: no two readers agree ({', '.join(LABEL[r] for r in values)})"
        return row
    others = [r for r in values if r != odd]
    hint = _hint(field, values[odd], values[others[0]])
    row["finding"] = (
        f"{LABEL[odd]} reads {name}'s {field} differently"
        + (f" ({hint})" if hint else "")
        + f"; {LABEL[others[0]]} and {LABEL[others[1]]} agree"
    )
    return row


def readers_of(system: System, inputs: dict[str, Any]) -> tuple[dict[str, Any], dict[str, str]]:
    """Each reader's source (on `inputs[reader]` where given, else `system`) and why any is missing."""
    sources, skipped = {}, {}
    for name in READERS:
        try:
            sources[name] = make_source(inputs.get(name, system), name)
        except HarnessError as exc:
            skipped[name] = str(exc)
    return sources, skipped


def audit(
    system: System, *, seed: int = 0, n_states: int = N_STATES, inputs: dict[str, Any] | None = None
) -> dict[str, Any]:
    """Every reader's masses, centres of mass, inertias, joint frames, limits, damping and armature side
    by side; the minority named where they differ; the mass matrices' differences at `n_states` states.
    The model is read alone (every joint in the model's coordinates, every body they move), whatever
    equations module `system` has. `inputs`: a reader's own copy of the model (a System of the same
    joints and bodies), to plant a fault in one reader's input only; default: every reader reads `system`."""
    if system.equations is not None:
        system = system.derive(equations=None)
    sources, skipped = readers_of(system, inputs or {})
    if "mujoco" not in sources:
        raise HarnessError(f"{system.mjcf.name}: MuJoCo cannot read the model: {skipped.get('mujoco', '')}")
    readings = {"mujoco": mujoco_reading(sources["mujoco"].system, sources["mujoco"])}
    if "pinocchio" in sources:
        readings["pinocchio"] = pinocchio_reading(sources["pinocchio"].system, sources["pinocchio"])
    if "drake" in sources:
        from ..engines.drake import DrakeSource

        readings["drake"] = engine_of(sources["drake"], DrakeSource).reading()
    extent = max([float(np.abs(v).max()) for k, v in readings["mujoco"].items() if k.endswith("/anchor")] + [1.0])
    lengths = ("/anchor", "/com")  # judged against the chain's extent: a centre at the origin may read 1e-17 m
    rows = [
        _row(key, {r: readings[r][key] for r in readings}, extent if key.endswith(lengths) else 0.0)
        for key in readings["mujoco"]
    ]
    findings = [r["finding"] for r in rows if not r["agree"]]
    dynamic = [r["finding"] for r in rows if not r["agree"] and not r["key"].endswith(INFORMATIONAL)]
    return {
        "system": system.name,
        "model": system.mjcf.name,
        "format": system.model_format,
        "readers": list(readings),
        "skipped": skipped,
        "frame": FRAME,
        "rows": rows,
        "findings": findings,
        "mass_matrix": mass_matrix_gaps(system, sources, seed=seed, n_states=n_states),
        "passed": not dynamic and not skipped,
    }


def mass_matrix_gaps(system: System, sources: Mapping[str, Source], *, seed: int, n_states: int) -> dict[str, Any]:
    """max |M_a - M_b| (kg m^2 or kg) for every pair of readers over `n_states` seeded states."""
    q = random_states(system, n=n_states, seed=seed).q
    M = {name: src.mass_matrix(q) for name, src in sources.items()}
    names = list(M)
    pairs = {f"{a}~{b}": float(np.abs(M[a] - M[b]).max()) for i, a in enumerate(names) for b in names[i + 1 :]}
    return {"n_states": n_states, "seed": seed, "max_abs": pairs}


def lines(result: dict[str, Any]) -> list[str]:
    """The audit in one screen: what was compared, the findings (or that all agree), the M gaps."""
    readers = ", ".join(LABEL[r] for r in result["readers"])
    out = [f"audit: {result['model']} ({result['format'].upper()}), read by {readers}"]
    out += [f"  {LABEL[r]} not a reader here: {why}" for r, why in result["skipped"].items()]
    out.append(f"  compared: {len(result['rows'])} fields ({result['frame']})")
    bad = [r for r in result["rows"] if not r["agree"]]
    if not bad:
        out.append(f"  every field agrees between {readers}")
    for row in bad[:12]:
        out.append(f"  DIFFERS {row['key']}: {row['finding']}")
        for reader, value in row["values"].items():
            mark = " <- minority" if reader == row.get("minority") else ""
            out.append(f"      {LABEL[reader]:9} {value}{mark}")
    if len(bad) > 12:
        out.append(f"  ... and {len(bad) - 12} more differing fields (--json for all)")
    gaps = result["mass_matrix"]
    shown = ", ".join(f"{pair} {gap:.3g}" for pair, gap in gaps["max_abs"].items())
    out.append(f"  mass matrix, max |M_a - M_b| at {gaps['n_states']} seeded states: {shown}")
    return out


def audit_of(system: System, *, seed: int = 0) -> dict[str, Any]:
    """The audit for `run`'s results, or why it could not be made ({"error": ...})."""
    try:
        return audit(system, seed=seed)
    except HarnessError as exc:
        return {"error": str(exc), "passed": False}

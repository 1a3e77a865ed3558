"""The model audit: each reader of a file judged against what the file means (issues 29, 33).

Most disagreements between engines are in how a model was read, not in the dynamics. The format
decides what a file means (validate/model/meaning.py): for an MJCF, MuJoCo's compiled model with
the compiler's options applied; for a URDF, urdfdom's reading. Each reader (MuJoCo, Pinocchio,
Drake: validate/sources/readers.py, each reading the file on its own, nothing aligned) is judged
against that meaning, not against the others, so that two readers that drop the same field are both
named. Every field that enters the equations of motion is compared, in one frame common to the
readers (each at its reference configuration, world coordinates, each joint with the rigid group it
moves): mass, centre of mass, inertia; each joint's anchor (hinges), axis, kind, ref, limits,
damping, stiffness, springref, frictionloss, armature, gravcomp and mimic coupling; the model's number
of joint couplings (a reader that cannot name a coupling's joints, Drake, is compared on that count);
each actuator's joint and gear. A difference is explained by an entry of the catalogue of known importer behaviours
(validate/audit/importers.py) or said to be unexplained; each reader's own warnings are shown.
The consequence of each reading is measured on the dynamics it implies (validate/audit/chain.py):
max |M_reader - M_format| and |G_reader - G_format| at seeded configurations.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..core.arrays import Json
from ..core.errors import HarnessError
from ..model.meaning import FieldValue, Reading, fields, urdf_meaning
from ..model.modelview import key_parts
from ..results.schema import Audit, AuditRow, MassMatrixGaps, Misread
from ..sources import SYMBOLIC_MAX_DOF
from ..sources.readers import read
from ..systems import System
from . import importers
from .chain import chain, dynamics
from .features import features

READERS = ("mujoco", "pinocchio", "drake")
LABEL = {"mujoco": "MuJoCo", "pinocchio": "Pinocchio", "drake": "Drake"}
RTOL = 1e-9  # the readers parse the same decimal text through different rotations and sums
N_STATES = 100  # seeded configurations at which each reading's M and G are compared with the format's
# Fields no smooth dynamics use (limits, a <mimic> coupling and dry friction are constraints, compared
# without them as issue 32 has it; ref moves the coordinate's zero, not the frames; an actuator's gear
# scales the input, not M or the bias): a difference is named, with its cause, but fails nothing.
INFORMATIONAL = ("/limits", "/ref", "/gear", "/target", "/mimic", "/couplings", "/frictionloss")
LENGTHS = ("/anchor", "/com")  # judged against the chain's extent: a centre at the origin may read 1e-17 m
FRAME = (
    "each reader at its reference configuration (MuJoCo's qpos0: a joint's ref; the others' zero), world "
    "coordinates; per joint the rigid group it moves (welded bodies included): mass kg, centre of mass m, "
    "inertia about it kg m^2; hinge anchor m, axis, limits rad or m, damping, stiffness, springref, "
    "frictionloss, armature, gravcomp, mimic; the model's joint couplings; actuator gear"
)
UNITS = {"mass": "kg", "com": "m", "anchor": "m", "damping": "N m s/rad", "armature": "kg m^2", "inertia": "kg m^2"}


def _same(a: FieldValue, b: FieldValue, floor: float) -> bool:
    if a is None or b is None or isinstance(a, str) or isinstance(b, str):
        return a == b
    if isinstance(a, tuple) or isinstance(b, tuple):  # a mimic: (leader, multiplier, offset)
        return (
            isinstance(a, tuple)
            and isinstance(b, tuple)
            and a[0] == b[0]
            and _same(np.array(a[1:]), np.array(b[1:]), 1.0)
        )
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if x.shape != y.shape:
        return False
    inf = np.isinf(x) | np.isinf(y)
    if not np.array_equal(x[inf], y[inf]):
        return False
    x, y = x[~inf], y[~inf]
    scale = max(float(np.abs(x).max(initial=0.0)), float(np.abs(y).max(initial=0.0)), floor)
    return bool(np.all(np.abs(x - y) <= RTOL * scale))


def _fmt(x: FieldValue) -> Json:
    if x is None or isinstance(x, str):
        return x
    if isinstance(x, tuple):
        return [x[0], float(x[1]), float(x[2])]
    arr = np.asarray(x, dtype=float)
    return float(arr) if arr.ndim == 0 else np.round(arr, 12).tolist()


def _short(x: FieldValue) -> str:
    """A value in a finding: a number to 3 significant digits, a short array rounded."""
    v = _fmt(x)
    if isinstance(v, float):
        return f"{v:.3g}"
    if isinstance(v, list) and v and isinstance(v[0], list):
        return (
            "[" + ", ".join("[" + " ".join(f"{e:.3g}" for e in row) + "]" for row in v if isinstance(row, list)) + "]"
        )
    if isinstance(v, list) and all(isinstance(e, float) for e in v):
        return "[" + " ".join(f"{e:.3g}" for e in v) + "]"
    return "none" if v is None else str(v)


def _cause(
    reader: str, fmt: str, field: str, found: set[str], names: tuple[str, ...] | None, rotated: bool = True
) -> tuple[str, str, str]:
    """(entry key, cause, where reported) of the catalogue entry explaining it, or an unexplained note."""
    hits = importers.explain(reader, fmt, field, found, names, rotated=rotated)
    if not hits:
        return "", "no known importer behaviour explains it", ""
    return hits[0].key, hits[0].cause, hits[0].reported


def _joints_cause(reader: str, fmt: str, found: set[str], absent: tuple[str, ...]) -> tuple[str, str, str]:
    """The entry explaining a reader's missing joints: the one whose feature is on most of them (an
    <include> that brought them all before the several joints of one of its bodies), else `_cause`'s."""
    hits = importers.explain(reader, fmt, "joint", found, absent)
    if not hits:
        return _cause(reader, fmt, "joint", found, absent)
    best = max(hits, key=lambda b: sum(f"{b.feature}:{j}" in found for j in absent))  # the first of equals
    return best.key, best.cause, best.reported


def _finding(
    reader: str, key: str, value: FieldValue, reference: FieldValue, fmt: str, found: set[str], names: tuple[str, ...]
) -> Misread:
    parts = key_parts(key)
    name, field = (parts[1], parts[2]) if parts else (key.split("/")[1], key.split("/")[-1])
    rotated = field != "inertia" or bool(
        np.allclose(
            np.linalg.eigvalsh(np.asarray(value, dtype=float)),
            np.linalg.eigvalsh(np.asarray(reference, dtype=float)),
            rtol=1e-6,
            atol=1e-15,
        )
    )
    entry, cause, url = _cause(reader, fmt, field, found, names, rotated)
    unit = f" {UNITS[field]}" if field in UNITS else ""
    text = (
        f"{LABEL[reader]} misreads {name}'s {field} ({_short(value)}{unit}; the {fmt.upper()} means "
        f"{_short(reference)}{unit}): {cause}" + (f" [{entry}: {url}]" if url else "")
    )
    short = (
        f"{LABEL[reader]} misreads {name}'s {field} ({_short(value)}{unit}, {_short(reference)}{unit} by the "
        f"{fmt.upper()}" + (f": {entry}" if entry else ": cause unknown") + ")"
    )
    return {
        "reader": reader,
        "key": key,
        "field": field,
        "entry": entry,
        "reported": url,
        "finding": text,
        "short": short,
    }


def _reference(path: Path, text: str, fmt: str) -> Reading:
    """The format's meaning: urdfdom's reading of a URDF, MuJoCo's compiled model of an MJCF."""
    return urdf_meaning(text, path.name) if fmt == "urdf" else read("mujoco", path, text, fmt)


def _rows(reference: Reading, readings: dict[str, Reading], fmt: str, found: set[str]) -> list[AuditRow]:
    labels = {j: r.body for j, r in reference.joints.items()}
    flat = {name: fields(r, labels) for name, r in readings.items()}
    ref = fields(reference, labels)
    extent = max(
        [float(np.abs(np.asarray(v, dtype=float)).max()) for k, v in ref.items() if k.endswith("/anchor")] + [1.0]
    )
    # an inertia is judged against the largest m l^2 it is added to in M (a point mass's 1e-14 kg m^2 is
    # rounding once its centre is shifted by 1 m)
    masses = [float(np.asarray(v, dtype=float)) for k, v in ref.items() if k.endswith("/mass")]
    inertia_floor = max(masses + [0.0]) * extent**2
    scope = {}  # a key's element -> the names a catalogue feature may be on (the group's links, its joint)
    for j, r in reference.joints.items():
        scope[j] = scope[r.body] = (j, r.body, *reference.members.get(j, ()))
    rows = []
    for key, want in ref.items():
        if key.endswith("/anchor") and ref[key.replace("/anchor", "/kind")] == "slide":
            continue  # a slide joint has no anchor (Drake places its frame elsewhere)
        if key.endswith("/com") and ref[key.replace("/com", "/mass")] == 0.0:
            continue  # a massless group has no centre of mass
        if key.startswith("actuator/"):  # Pinocchio has no actuators; one that drops a transmission reads none
            values = {n: f.get(key) for n, f in flat.items() if readings[n].actuators is not None}
        else:
            values = {name: f[key] for name, f in flat.items() if key in f}
        floor = extent if key.endswith(LENGTHS) else inertia_floor if key.endswith("/inertia") else 0.0
        wrong = [n for n, v in values.items() if not _same(v, want, floor)]
        name = (key_parts(key) or ("", key.split("/")[1], ""))[1]
        names = scope.get(name, (name,))
        row: AuditRow = {
            "key": key,
            "reference": _fmt(want),
            "values": {n: _fmt(v) for n, v in values.items()},
            "agree": not wrong,
            "informational": key.endswith(INFORMATIONAL),
            "misreads": [_finding(n, key, values[n], want, fmt, found, names) for n in wrong],
        }
        rows.append(row)
    return rows


def _missing(reference: Reading, readings: dict[str, Reading], fmt: str, found: set[str]) -> list[Misread]:
    out: list[Misread] = []
    for name, r in readings.items():
        absent = [j for j in reference.joints if j not in r.joints]
        if absent:
            entry, cause, url = _joints_cause(name, fmt, found, tuple(absent))
            out.append(
                {
                    "reader": name,
                    "key": "joints",
                    "field": "joint",
                    "entry": entry,
                    "reported": url,
                    "finding": f"{LABEL[name]} has no joint {', '.join(repr(j) for j in absent)}: {cause}"
                    + (f" [{entry}: {url}]" if url else ""),
                    "short": f"{LABEL[name]} has no joint {absent[0]!r} ({entry or 'cause unknown'})",
                }
            )
    return out


def audit_file(
    path: Path,
    text: str,
    fmt: str,
    *,
    inputs: Mapping[str, tuple[Path, str]] | None = None,
    seed: int = 0,
    n_states: int = N_STATES,
    parts: bool = False,
) -> Audit:
    """Every reader of the model file against the format's meaning. `inputs`: a reader's own copy of the
    file ((path, text)), to plant a fault in one reader's input only; default: every reader reads `text`.
    `parts`: Pinocchio's composite joints read as their parts, as the harness's source maps them (for a
    verdict's `misreaders`; the audit of the raw libraries says Pinocchio has none of their names)."""
    reference = _reference(path, text, fmt)
    readings, skipped = {}, {}
    for name in READERS:
        p, t = (inputs or {}).get(name, (path, text))
        if fmt == "mjcf" and name == "mujoco" and t == text:
            readings[name] = reference  # MuJoCo's compiled model is what an MJCF means
            continue
        try:
            readings[name] = read(name, p, t, fmt, parts=parts)
        except HarnessError as exc:
            skipped[name] = str(exc)
    found = features(text, fmt, path.parent)
    rows = _rows(reference, readings, fmt, found)
    misreads = _missing(reference, readings, fmt, found) + [m for r in rows for m in r["misreads"]]
    skipped_why = {name: why + _skip_cause(name, fmt, found, why) for name, why in skipped.items()}
    dynamic = [m for r in rows if not r["informational"] for m in r["misreads"]] + _missing(
        reference, readings, fmt, found
    )
    return {
        "model": path.name,
        "format": fmt,
        "reference": "urdfdom's reading (URDF)" if fmt == "urdf" else "MuJoCo's compiled model (MJCF)",
        "readers": list(readings),
        "skipped": skipped_why,
        "frame": FRAME,
        "rows": rows,
        "misreads": misreads,
        "findings": [m["finding"] for m in misreads],
        "excluded": sorted({m["reader"] for m in dynamic}),
        "warnings": {name: r.warnings for name, r in readings.items() if r.warnings},
        "mass_matrix": consequences(reference, readings, seed=seed, n_states=n_states),
        "passed": not dynamic and not skipped,
    }


def _skip_cause(reader: str, fmt: str, found: set[str], said: str) -> str:
    """The catalogue entry behind a reader's refusal: one that explains a refusal in these words."""
    hits = [
        b
        for b in importers.explain(reader, fmt, "read", found, None)
        if any(word.lower() in said.lower() for word in b.refusals)
    ]
    return f" [{hits[0].key}: {hits[0].reported}]" if hits else ""


def _file_of(system: System) -> tuple[Path, str, str]:
    """The model file, the text its readers get (the file's own where nothing was changed: its includes
    and meshes then resolve as they do for the file), its format."""
    fmt = system.model_format
    if system.reads_urdf:
        return system.mjcf, system.urdf_text(), fmt
    unchanged = not system.overrides and system.text is None and not system.locked
    return system.mjcf, system.mjcf.read_text() if unchanged else system.mjcf_xml(), fmt


def _read_by_sources(system: System) -> tuple[Path, str, str]:
    """The model file and the text the harness's sources read (an MJCF flattened at the door, its includes
    in it, model/flatten.py), its format: what a verdict sets a reader aside for is what that reader's
    source was given, not a fault (an <include> it does not read) that the harness already works around."""
    if system.reads_urdf:
        return system.mjcf, system.urdf_text(), system.model_format
    return system.mjcf, system.mjcf_xml(), system.model_format


def audit(system: System, *, seed: int = 0, n_states: int = N_STATES, inputs: dict[str, System] | None = None) -> Audit:
    """The audit of the system's model file (`audit_file`), with the mass matrices of the harness's
    sources compared at `n_states` seeded states where the model is in its scope. `inputs`: a reader's
    own copy of the model (a System), to plant a fault in one reader's input only."""
    if system.equations is not None:
        system = system.derive(equations=None)
    path, text, fmt = _file_of(system)
    own = {name: _file_of(s)[:2] for name, s in (inputs or {}).items()}
    result = audit_file(path, text, fmt, inputs=own, seed=seed, n_states=n_states)
    result["system"] = system.name
    return result


def consequences(
    reference: Reading, readings: Mapping[str, Reading], *, seed: int = 0, n_states: int = N_STATES
) -> MassMatrixGaps:
    """What each reading does to the dynamics: max |M_reader - M_format| (kg m^2 or kg) and max
    |G_reader - G_format| (N m or N) at `n_states` seeded configurations of the format's coordinates
    (validate/audit/chain.py on each reading; a reader missing a joint is not compared)."""
    ref = chain(reference)
    out: MassMatrixGaps = {"n_states": n_states, "seed": seed, "max_abs": {}, "gravity_max_abs": {}}
    if not ref.joints:
        return out  # nothing moves
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (n_states, len(ref.joints)))
    want = dynamics(ref, q)
    for name, reading in readings.items():
        if reading is reference or any(j not in reading.joints for j in ref.joints):
            continue  # the format's own reading (MuJoCo's, of an MJCF), or a reader missing a joint
        c = chain(reading)
        full = np.zeros((n_states, len(c.joints)))
        idx = [c.joints.index(j) for j in ref.joints]
        full[:, idx] = q
        got = dynamics(c, full)
        out["max_abs"][name] = float(np.abs(got["M"][:, idx][:, :, idx] - want["M"]).max())
        out["gravity_max_abs"][name] = float(np.abs(got["G"][:, idx] - want["G"]).max())
    return out


SHOWN = 12  # misreadings printed in full; the rest are counted by cause


def _summary(misreads: list[Misread]) -> list[str]:
    """One line per (reader, cause) where there are more misreadings than are printed."""
    if len(misreads) <= SHOWN:
        return []
    counts: dict[tuple[str, str], int] = {}
    for m in misreads:
        key = (m["reader"], m["entry"] or "no known cause")
        counts[key] = counts.get(key, 0) + 1
    return [f"  {LABEL[r]}: {n} fields, {entry}" for (r, entry), n in sorted(counts.items(), key=lambda x: -x[1])]


def lines(result: Audit) -> list[str]:
    """The audit in one screen: what was compared, each misreading named with its cause, the warnings,
    the M gaps."""
    readers = ", ".join(LABEL[r] for r in result["readers"])
    out = [
        f"audit: {result['model']} ({result['format'].upper()}), read by {readers}; "
        f"judged against {result['reference']}"
    ]
    out += [f"  {LABEL[r]} not a reader here: {why}" for r, why in result["skipped"].items()]
    out.append(f"  compared: {len(result['rows'])} fields ({result['frame']})")
    if not result["misreads"]:
        out.append(f"  every field agrees with the format's meaning ({readers})")
    out += _summary(result["misreads"])
    for m in result["misreads"][:SHOWN]:
        info = " (information: no smooth dynamics use it)" if m["key"].endswith(INFORMATIONAL) else ""
        out.append(f"  DIFFERS {m['finding']}{info}")
    if len(result["misreads"]) > SHOWN:
        out.append(f"  ... and {len(result['misreads']) - SHOWN} more (--json for all)")
    for reader, said in result.get("warnings", {}).items():
        out.append(f"  {LABEL[reader]} warned ({len(said)}): " + " | ".join(cut_words(w) for w in said[:3]))
    gaps = result["mass_matrix"]
    shown = ", ".join(
        f"{LABEL[r]} {gap:.3g} (G {gaps['gravity_max_abs'][r]:.3g})" for r, gap in gaps["max_abs"].items()
    )
    out.append(
        f"  consequence, max |M_reader - M_format| (and |G_reader - G_format|) at {gaps['n_states']} seeded "
        f"configurations: {shown or 'no reader has every joint'}"
    )
    return out


SET_ASIDE = ("pinocchio", "drake")  # MuJoCo's compiled model is what the harness's own model view reads
# What the harness's sources set from MuJoCo's model whatever the reader read (sources/pinocchio.py and
# sources/drake.py copy the gravity; Pinocchio's source applies each joint's spring from MuJoCo's stiffness
# and springref, Drake's adds it as its own spring element): a misreading of it is the reader's, not the
# verdict's.
ALIGNED = ("/gravity", "/stiffness", "/springref")
# Faults of a raw reader that the harness's source of that reader works around (sources/pinocchio.py gathers
# the world's body trees in one fixed body and maps a composite joint's parts by name): not the verdict's.
# sources/drake.py gives a joint's armature to Drake as a motor's rotor inertia.
ALIGNED_ENTRIES = {
    ("pinocchio", "several root bodies"),
    ("pinocchio", "several joints in one body"),
    ("drake", "armature without a motor"),
}


def set_aside(system: System) -> dict[str, str]:
    """The readers to leave out of a verdict, each with the sentence that names it: every reader that
    misreads a field the dynamics use (against the format's meaning), as long as two readers still agree
    with that meaning; MuJoCo, whose reading the harness's model view is, is never set aside. {} where
    the audit cannot be made."""
    return misreaders(system)[0]


def misreaders(system: System) -> tuple[dict[str, str], dict[str, str]]:
    """(set aside, named): the readers `set_aside` leaves out, and those that misread a field the dynamics
    use but are kept because fewer than two readers would be left to agree with the format's meaning (each
    with the sentence naming its misreading and the known cause, "Drake misreads torso's mass (...:
    settotalmass)"): the verdict names them, not a reader that merely differs from MuJoCo."""
    from ..sources.pinocchio import one_tree

    try:
        path, text, fmt = _read_by_sources(system)
        # Pinocchio's source reads the body trees gathered in one (a mocap body so gathered MuJoCo refuses)
        gathered = {"pinocchio": (path, one_tree(text))} if fmt == "mjcf" else None
        result = audit_file(path, text, fmt, inputs=gathered, n_states=1, parts=True)
    except HarnessError:
        return {}, {}
    decisive = [
        m
        for m in result["misreads"]
        if not m["key"].endswith(INFORMATIONAL + ALIGNED) and (m["reader"], m.get("entry")) not in ALIGNED_ENTRIES
    ]
    wrong = [r for r in result["readers"] if any(m["reader"] == r for m in decisive)]
    agreeing = [r for r in result["readers"] if r not in wrong]
    out = {}
    for reader in (r for r in wrong if r in SET_ASIDE):
        said = [m["short"] for m in decisive if m["reader"] == reader]
        more = f" (and {len(said) - 1} more)" if len(said) > 1 else ""
        out[reader] = f"{said[0]}{more}"
    # the model's derived equations (sources/symbolic.py) are a second source that reads what the file means
    if len(agreeing) + (system.nv <= SYMBOLIC_MAX_DOF) < 2:
        return {}, out
    return {r: f"{why}: excluded" for r, why in out.items()}, {}


def audit_of(system: System, *, seed: int = 0) -> Audit:
    """The audit for `run`'s results, or why it could not be made ({"error": ...})."""
    try:
        return audit(system, seed=seed)
    except HarnessError as exc:
        return {"error": str(exc), "passed": False}


def cut_words(text: str, limit: int = 110) -> str:
    """`text` cut at a word's end within `limit` characters, saying so ("MultibodyPlant do" was a cut word)."""
    if len(text) <= limit:
        return text
    head = text[:limit].rsplit(" ", 1)[0]
    return f"{head} ..."

"""Every disagreement with its proof: a standalone reproducer per pair of sources and quantity that
disagree in the pointwise comparison, and a way to run one in a fresh process.

A reproducer is a short Python script of the libraries' own calls (MuJoCo, Pinocchio, Drake; the
person's equations module imported by path for the "hand" source) with the model's path, the state,
the quantity and the two numbers the harness saw (validate/verdict/reproducer_text.py writes its
text). It prints both numbers, their difference and the tolerance, and exits 1 when the disagreement
shows, 0 when it does not: a FAIL whose reproducer exits 0 is the harness's own misreading, not the
libraries' (`run_reproducer`, `unshown`). Design points:

- The model is loaded from its path as a person would (`MjModel.from_xml_path`, `buildModelFromMJCF` /
  `buildModelFromUrdf`, `Parser(plant).AddModels`); the joints and bodies are mapped by name; only
  the alignments the harness's sources apply are applied, each commented with why (Pinocchio's
  gravity, damping and springs as a generalized force, Drake's gravity, damping, armature motors and
  springs, MuJoCo's constraints switched off). Where the harness gives a library another text than the
  file (an MJCF's includes expanded and asset files absolute, model/flatten.py; free and ball joints as
  slides and hinges; one body tree for Pinocchio; a URDF's geometry removed, --lock, MuJoCo's floors
  under a massless link for every reader), the script makes the same edit with xml.etree (and
  MjSpec.from_file for the asset files MuJoCo opens) and writes it in a temporary folder of its own,
  never beside the model (a published package's folder may be read-only, and is not ours).
- The script follows the harness's readings: Pinocchio's T is 1/2 v^T M v on CRBA's M (Pinocchio 4.1's
  computeKineticEnergy leaves out an unaligned hinge's armature); V is compared up to a constant, the
  script computing a - b at the state and at the one where a - b is at its other extreme.
- The state is the one where the row disagrees most against its tolerance; the tolerance is absolute
  (the tier's relative tolerance at that state's cond(M), times the row's scale over all states, with
  the model's physical floor under it: pointwise.physical_scales, as the verdict compares).
- The symbolic source (the model's own equations, derived by the harness with sympy) is no library:
  its side is written as the numbers the derivation gave, said so in the script. A person's module
  not in form (a) (M and bias) for a quantity it does not give directly is written the same way. A
  pair where neither side is a library's or the person's call is not written (`skipped`: why).
"""

from __future__ import annotations

import dataclasses
import re
import subprocess
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core.tolerances import NO_SCALES, QUANTITY_TIER, TOLERANCES, PhysicalScales, Tolerances
from ..model.modelview import names, welded
from ..results.schema import Reproducer
from . import pointwise as compare
from .reproducer_text import Case, HandFacts, ModelFacts, script

if TYPE_CHECKING:
    from ..systems import System
    from .pointwise import States

FOLDER = "reproducers"  # under run's out folder: results.json's paths are relative to it
ENGINES = ("mujoco", "pinocchio", "drake")
SHOWS = "the disagreement shows"  # the script's line where it does (reproducer_text.JUDGE)
TIMEOUT = 300.0  # s a reproducer may take in a fresh process (importing pydrake and parsing: a few s)
DIRECT = {  # the functions of a person's module that give each quantity directly, for the script to call
    "M": ("mass_matrix",),
    "bias": ("bias",),
    "passive": ("mass_matrix", "bias"),
    "qacc": ("mass_matrix", "bias"),
    "tau_inverse": ("mass_matrix", "bias"),
    "T": ("kinetic_energy",),
    "V": ("potential_energy",),
    "body_positions": ("body_positions",),
    "body_rotations": ("body_rotations",),
}


def file_name(system: str, quantity: str, a: str, b: str) -> str:
    """ "<system>_<quantity>_<a>_vs_<b>.py", with any character a file name should not hold as "_"."""
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", f"{system}_{quantity}_{a}_vs_{b}").strip("._") or "reproducer"
    return f"{stem}.py"


def model_facts(system: System) -> ModelFacts:
    """What the script needs of the model and of what the harness did with it."""
    view, joints = system.view, system.joints
    urdf = system.model_format == "urdf"
    text = system.mjcf.read_text(errors="replace")
    text, mjcf = (text, "") if urdf else ("", text)

    def each(key: str) -> tuple[float, ...]:
        return tuple(float(view[f"joint/{j}/{key}"]) if f"joint/{j}/{key}" in view else 0.0 for j in joints)

    carriers = welded(view)
    return ModelFacts(
        path=str(system.mjcf.resolve()),
        urdf=urdf,
        joints=tuple(joints),
        bodies=tuple(system.bodies),
        kinds=tuple(str(view[f"joint/{j}/type"]) for j in joints),
        gravity=tuple(float(x) for x in view["gravity"]),
        damping=each("damping"),
        stiffness=each("stiffness"),
        springref=each("springref"),
        armature=each("armature"),
        locked=tuple(system.locked),
        converted=not urdf and bool(system.alignments),  # an MJCF's alignments are its free and ball joints
        several_trees=_several_trees(mjcf),
        named=bool(re.search(r"<mujoco\b[^>]*\bmodel\s*=", mjcf)) if mjcf else True,
        equality="<equality" in mjcf,
        mimic="<mimic" in text,
        composite=_composite(system),
        carrier_com={b: tuple(float(x) for x in view[f"body/{b}/com"]) for b in system.bodies if b in carriers},
        kept=tuple(names(view, "body", "parent")),
        urdf_roots=_urdf_roots(text) if text else (),
        bounded=_bounded(system) if urdf else {},
    )


def _bounded(system: System) -> dict[str, tuple[float, float]]:
    """The URDF links the harness gave MuJoCo's floors (System.floors, for every reader): (mass, moment)
    as System.urdf_text states them, for the script to give every library the same."""
    import xml.etree.ElementTree as ET

    named = {line.split("'")[1] for line in system.floors if "'" in line}
    if not named:
        return {}
    out = {}
    for link in ET.fromstring(system.urdf_text().strip()).iter("link"):
        mass, inertia = link.find("inertial/mass"), link.find("inertial/inertia")
        if link.get("name") in named and mass is not None and inertia is not None:
            out[str(link.get("name"))] = (float(mass.get("value", "0")), float(inertia.get("ixx", "0")))
    return out


def _several_trees(mjcf: str) -> bool:
    if not mjcf:
        return False
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(mjcf)
    except ET.ParseError:
        return False
    return any(len([c for c in w if c.tag in ("body", "frame", "replicate")]) > 1 for w in root.iter("worldbody"))


def _urdf_roots(text: str) -> tuple[str, ...]:
    """A URDF's root links (Drake's parser lets them float; the harness welds them), not "world"."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(text.strip())
    children = {c.get("link") for j in root.findall("joint") for c in j.findall("child")}
    return tuple(str(link.get("name")) for link in root.findall("link") if link.get("name") not in children | {"world"})


def _composite(system: System) -> dict[str, tuple[str, int]]:
    """Each joint that shares its body with others: Pinocchio's composite joint (named after the body's
    first joint) and its place in it."""
    view, out = system.view, {}
    for j in system.joints:
        body = view[f"joint/{j}/body"]
        parts = [k for k in system.model_joints if view[f"joint/{k}/body"] == body]
        if len(parts) > 1:
            out[j] = (f"Composite_{parts[0]}", parts.index(j))
    return out


def hand_facts(system: System) -> tuple[HandFacts | None, str]:
    """The person's module as the script imports it, or None and why it cannot."""
    module = system.equations
    path = getattr(module, "__file__", None)
    if module is None or not path or not str(path).endswith(".py"):
        return None, "the derivation is not a Python module the script can import"
    params = system.params
    if not dataclasses.is_dataclass(params):
        return None, "its parameters are not a dataclass the script can fill"
    values = {f.name: _plain(getattr(params, f.name)) for f in dataclasses.fields(params)}
    return HandFacts(str(Path(path).resolve()), type(params).__name__, values), ""


def _plain(x: object) -> object:
    return np.asarray(x).tolist() if isinstance(x, np.ndarray | np.generic) else x


def _direct(system: System, quantity: str) -> bool:
    """Whether the person's module gives `quantity` through functions the script calls as written (form a,
    generalized forces as inputs, no coordinate map)."""
    module = system.equations
    form = getattr(module, "FORM", "a")
    original = getattr(module, "ORIGINAL", module)
    if system.inputs != "tau":
        return False
    if quantity in ("M", "bias", "passive", "qacc", "tau_inverse") and form != "a":
        return False
    return all(callable(getattr(original, f, None)) for f in DIRECT[quantity])


@dataclass(frozen=True)
class Found:
    """One disagreeing row, where it is worst against its tolerance."""

    quantity: str
    pair: str
    scale: float  # the row's: the largest magnitude of the quantity over the states
    state: int
    entry: tuple[int, ...]
    tolerance: float
    constant: float = 0.0  # what the comparison removes from a - b first (V: up to a constant)
    reference: int | None = None  # V: the state where a - b is at its other extreme (the script's second state)


def disagreements(
    values: Mapping[str, Mapping[str, np.ndarray]],
    states: States,
    *,
    tolerances: Tolerances = TOLERANCES,
    scales: PhysicalScales = NO_SCALES,
) -> list[Found]:
    """Every failing (quantity, pair) of the comparison of `values` (with the model's physical `scales`
    under every scale, as the verdict compares), each at the state where its error over its tolerance is
    largest, with the entry where the two differ most there; V after the row's constant is removed."""
    rows = compare.compare({k: dict(v) for k, v in values.items()}, states, tolerances=tolerances, scales=scales)
    cond = compare.condition(values["mujoco"]["M"]) if "mujoco" in values and "M" in values["mujoco"] else None
    out = []
    for r in rows:
        if r["passed"]:
            continue
        a, b = r["pair"].split("~")
        x, y = np.asarray(values[a][r["quantity"]], dtype=float), np.asarray(values[b][r["quantity"]], dtype=float)
        constant = float(r.get("constant", 0.0))
        with np.errstate(all="ignore"):
            diff = np.nan_to_num(np.abs(x - y - constant), nan=np.inf).reshape(len(states), -1)
        tier = getattr(tolerances, QUANTITY_TIER[r["quantity"]])
        tol = np.array([tier.at(c) for c in cond]) if cond is not None else np.full(len(states), tier.rtol)
        k = int(np.argmax(diff.max(axis=1) / tol))
        entry = np.unravel_index(int(np.argmax(diff[k])), x.shape[1:]) if x.ndim > 1 else ()
        entry_ = tuple(int(i) for i in entry)
        reference = _other_extreme(x - y, k) if "constant" in r else None
        found = Found(r["quantity"], r["pair"], r["scale"], k, entry_, float(tol[k] * r["scale"]), constant, reference)
        out.append(found)
    return out


def _other_extreme(d: np.ndarray, k: int) -> int:
    """The state where the scalar difference `d` is at its other extreme from state `k` (its largest where
    k holds its smallest, and back): the midrange the comparison removes is that of these two states."""
    d = np.nan_to_num(np.asarray(d, dtype=float).reshape(len(d)), nan=0.0)
    high, low = int(np.argmax(d)), int(np.argmin(d))
    return low if abs(d[k] - d[high]) <= abs(d[k] - d[low]) else high


def _number(x: np.ndarray, k: int, entry: tuple[int, ...]) -> float:
    return float(np.asarray(x)[(k, *entry)])


def cases(system: System, values: Mapping[str, Mapping[str, np.ndarray]], states: States) -> list[Reproducer]:
    """A reproducer (its text under "script", or why not under "skipped") for every disagreeing pair and
    quantity of `values` at `states` (every source's, before any reader is set aside)."""
    found = disagreements(values, states, scales=compare.physical_scales(system, states))
    if not found:
        return []
    facts = model_facts(system)
    hand, hand_why = hand_facts(system) if system.equations is not None else (None, "")
    a_ref = values["hand"]["qacc"] if "hand" in values else values.get("mujoco", {}).get("qacc")
    out: list[Reproducer] = []
    for f in found:
        quantity, pair = f.quantity, f.pair
        a, b = pair.split("~")
        record: Reproducer = {
            "system": system.name,
            "pair": pair,
            "quantity": quantity,
            "file": file_name(system.name, quantity, a, b),
            "state_index": f.state,
            "state": {k: [float(x) for x in getattr(states, k)[f.state]] for k in ("q", "v", "tau")},
            "entry": list(f.entry),
            "numbers": {s: _number(values[s][quantity], f.state, f.entry) for s in (a, b)},
            "tolerance": f.tolerance,
        }
        literal, why = _literals(system, values, f, (a, b), hand_why)
        if why:
            out.append({**record, "skipped": why})
            continue
        qacc = None if a_ref is None or quantity != "tau_inverse" else list(map(float, np.asarray(a_ref)[f.state]))
        case = Case(
            system=system.name,
            quantity=quantity,
            a=a,
            b=b,
            state_index=f.state,
            q=record["state"]["q"],
            v=record["state"]["v"],
            tau=record["state"]["tau"],
            qacc=qacc,
            entry=f.entry,
            numbers=record["numbers"],
            tolerance=f.tolerance,
            relative=f.tolerance / f.scale,
            scale=f.scale,
            literal=literal,
            constant=f.constant,
            reference=None if f.reference is None else _state(states, f.reference),
        )
        out.append({**record, "script": script(case, facts, hand if "hand" in (a, b) else None)})
    return out


def _state(states: States, k: int) -> dict[str, object]:
    return {"index": k} | {key: [float(x) for x in getattr(states, key)[k]] for key in ("q", "v", "tau")}


def _literals(
    system: System, values: Mapping[str, Mapping[str, np.ndarray]], f: Found, pair: Sequence[str], hand_why: str
) -> tuple[dict[str, tuple[object, str]], str]:
    """The sides written as the harness's numbers (with why), and why the pair cannot be written ("")."""
    if system.joint_map is not None:
        return {}, "the derivation's coordinates are a map of the joints' (JOINT_MAP): not written yet"
    if system.overrides or system.text is not None:
        return {}, "the model the harness compared is an edited copy (overrides or a probe), not the file"
    quantity = f.quantity
    literal: dict[str, tuple[object, str]] = {}
    for side in pair:
        number = np.asarray(values[side][quantity])[f.state].tolist()
        if f.reference is not None:  # V: the script computes two states (reproducer_text's main)
            number = {k: np.asarray(values[side][quantity])[k].tolist() for k in (f.state, f.reference)}
        if side == "symbolic":
            literal[side] = (
                number,
                "The model's own equations, derived symbolically by the harness (sympy): no "
                "library computes them, so its numbers at this state are written here.",
            )
        elif side == "hand" and (hand_why or not _direct(system, quantity)):
            why = hand_why or f"the module does not give {quantity} directly (its form, or inputs u)"
            literal[side] = (number, f"The harness's reading of the person's module ({why}): its numbers here.")
    if len(literal) == 2:
        return {}, "neither side is a library's or the person's own call (the symbolic derivation, a derived form)"
    return literal, ""


def reproducers(decision: object) -> list[Reproducer]:
    """The reproducers of a Decision (verdict/decide.py): from every source's values at its states,
    readers set aside included (a misreading is what an upstream issue needs); none without values."""
    system, values, states = (getattr(decision, k, None) for k in ("system", "values", "states"))
    if system is None or not values or states is None:
        return []
    # a derivation that raised has no numbers to reproduce (its hand values are NaN, with "error")
    kept = {k: v for k, v in values.items() if isinstance(v, Mapping) and "error" not in v}
    try:
        return cases(system, kept, states)
    except Exception as exc:  # noqa: BLE001 - the proofs are an addition: their failure is said, never the verdict's
        why = f"the reproducers could not be written: {type(exc).__name__}: {exc}"
        return [{"system": system.name, "pair": "", "quantity": "", "file": "", "skipped": why}]


def in_folder(records: Sequence[Reproducer]) -> list[Reproducer]:
    """The records with the path `run` writes each script at, relative to its out folder
    ("reproducers/<file>"); the text stays under "script" until `scripts` takes it out."""
    return [{**r, "path": f"{FOLDER}/{r['file']}"} if "script" in r else {**r} for r in records]


def scripts(records: Sequence[Reproducer]) -> tuple[list[Reproducer], dict[str, bytes]]:
    """The records without their texts, and the texts by their path relative to the out folder."""
    kept: list[Reproducer] = []
    texts: dict[str, bytes] = {}
    for record in records:
        r: Reproducer = {**record}
        text = r.pop("script", None)
        if text is not None and "path" in r:
            texts[r["path"]] = text.encode()
        kept.append(r)
    return kept, texts


def write(records: Sequence[Reproducer], folder: Path) -> list[Reproducer]:
    """Each record's script into `folder` (made if missing), its "path" set and "script" dropped."""
    folder.mkdir(parents=True, exist_ok=True)
    out: list[Reproducer] = []
    for record in records:
        r: Reproducer = {**record}
        text = r.pop("script", None)
        if text is not None:
            path = folder / r["file"]
            path.write_text(text)
            r["path"] = str(path)
        out.append(r)
    return out


@dataclass(frozen=True)
class Shown:
    """A reproducer run in a fresh process: whether it showed its disagreement (exit 1), its status and output."""

    path: str
    shows: bool
    status: int
    output: str


def run_reproducer(path: str | Path, *, timeout: float = TIMEOUT) -> Shown:
    """Runs the script at `path` in a fresh interpreter (this one's), as a person would; `shows` is True
    when it exits 1 saying the disagreement shows. A script that fails otherwise (status 2: a library
    raised; a traceback) or times out does not show it (its status and output say what happened)."""
    try:
        done = subprocess.run(  # noqa: S603 - the harness's own script, with this interpreter
            [sys.executable, str(path)], capture_output=True, text=True, timeout=timeout, check=False
        )
    except subprocess.TimeoutExpired:
        return Shown(str(path), False, -1, f"timed out after {timeout:g} s")
    shows = done.returncode == 1 and SHOWS in done.stdout.splitlines()  # not a traceback's status 1
    return Shown(str(path), shows, done.returncode, done.stdout + done.stderr)


def unshown(paths: Sequence[str | Path], *, timeout: float = TIMEOUT) -> list[Shown]:
    """The reproducers among `paths` that do not show their disagreement when run alone: what a test of a
    corpus asserts is empty (every FAIL of a reader pair is proven by the libraries' own calls)."""
    return [s for s in (run_reproducer(p, timeout=timeout) for p in paths) if not s.shows]


def write_for(model: str | Path, folder: Path, *, n_states: int = 20, seed: int = 0) -> list[Reproducer]:
    """`check --model MODEL --reproduce FOLDER` as a call: the model alone judged (no probes) at
    `n_states` seeded states and its reproducers written into `folder`. A corpus test is then

        records = write_for(model, tmp_path)
        assert not unshown([r["path"] for r in records if "path" in r])
    """
    from ..systems import System
    from .decide import decide

    decision = decide(System.model_only(model), n_states=n_states, seed=seed, probes=0)
    return write(reproducers(decision), folder)

"""`lagrange-xval audit MODEL [MODEL_B] [--lock JOINTS] [--map A=B,...] [--json]`: the audit in one screen.

One file (validate/audit/audit.py): MuJoCo, Pinocchio and Drake each judged against what the format
means, each misreading named with its known cause. Two files of one robot (validate/audit/twofiles.py):
their joints matched by structure (validate/audit/matching.py; `--map` sets or corrects pairs), compared
by their inertial fields, kinematics, gravity torques, M and bias."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ..core.errors import HarnessError, console
from ..systems import System, load, system_names


def audited_system(model: Path, locked: tuple[str, ...]) -> System:
    """The model file (MJCF or URDF), or a repository system by name; `locked`: URDF joints made fixed."""
    if model.is_file():  # not compiled here: a model outside the harness's scope is still audited
        system = System(name=model.stem, mjcf=model, equations=None, locked=locked)
        system.model_format  # noqa: B018 (a file that is not an MJCF or a URDF fails here, in one line)
        _numbers_finite(model)
        return system
    if str(model) in system_names():
        if locked:
            raise HarnessError("--lock takes joints of a URDF file; give its path.")
        return load(str(model))
    raise HarnessError(f"no model file '{model}' (nor a system of that name: {', '.join(system_names())}).")


def _numbers_finite(model: Path) -> None:
    """A model MuJoCo compiles with a number that is not finite or overflows (model/bounds.py) is one
    error line; one MuJoCo refuses for another reason is audited (each reader's failure is a finding)."""
    from ..systems import compile_model

    try:
        compile_model(model)
    except HarnessError as exc:
        if "every number the dynamics read must be finite" in str(exc):
            raise


def cmd_audit(args: argparse.Namespace) -> int:
    """Prints the audit; status 1 when a reader differs in a field the dynamics use (or the two files differ)."""
    if args.other is not None:
        return _two_files(args)
    if args.map is not None:
        raise HarnessError("--map pairs the joints of two files; give two files (audit A B --map A=B,...).")
    from ..audit.audit import audit, lines

    result = audit(audited_system(args.model, tuple(args.lock or ())))
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(console(lines(result)))
    return 0 if result["passed"] else 1


def _two_files(args: argparse.Namespace) -> int:
    from ..audit.twofiles import compare, lines

    if args.lock:
        raise HarnessError("--lock takes one model's joints; with two files, give each file as it is.")
    for path in (args.model, args.other):
        if not path.is_file():
            raise HarnessError(f"no model file '{path}' (two files of one robot: a URDF or an MJCF each).")
    result = compare(args.model, args.other, joint_map=joint_map(args.map))
    print(json.dumps(result, indent=1) if args.json else "\n".join(lines(result)))
    return 0 if result["passed"] else 1


MAP_FORM = "--map A_JOINT=B_JOINT,... (a joint of the first file = a joint of the second, comma-separated)"


def joint_map(text: str | None) -> dict[str, str] | None:
    """`--map`'s text as A's joint -> B's; one error line for a bad form or a joint of A given twice."""
    if text is None:
        return None
    out: dict[str, str] = {}
    for entry in text.split(","):
        a, eq, b = (part.strip() for part in entry.partition("="))
        if not eq or not a or not b or "=" in b:
            raise HarnessError(f"--map: {entry.strip()!r} is not A=B; the form is {MAP_FORM}.")
        if a in out:
            raise HarnessError(f"--map: A's joint '{a}' is given twice; each joint of A matches one of B.")
        out[a] = b
    return out

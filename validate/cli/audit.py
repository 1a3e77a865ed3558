"""`lagrange-xval audit MODEL [MODEL_B] [--lock JOINTS] [--json]`: the model audit in one screen.

One file (validate/audit/audit.py): MuJoCo, Pinocchio and Drake each judged against what the format
means, each misreading named with its known cause. Two files of one robot (validate/audit/twofiles.py):
matched by name, compared by their inertial fields, kinematics, gravity torques, M and bias."""

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
    result = compare(args.model, args.other)
    print(json.dumps(result, indent=1) if args.json else "\n".join(lines(result)))
    return 0 if result["passed"] else 1

"""`lagrange-xval audit MODEL [--lock JOINTS] [--json]`: the model audit (validate/checks/audit.py) in
one screen: three readers of the same file, the reader in the minority named where they differ."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ..errors import HarnessError, console
from ..systems import System, load, system_names


def audited_system(model: Path, locked: tuple[str, ...]) -> System:
    """The model file (MJCF or URDF), or a repository system by name; `locked`: URDF joints made fixed."""
    if model.is_file():
        return System.model_only(model, locked=locked)
    if str(model) in system_names():
        if locked:
            raise HarnessError("--lock takes joints of a URDF file; give its path.")
        return load(str(model))
    raise HarnessError(f"no model file '{model}' (nor a system of that name: {', '.join(system_names())}).")


def cmd_audit(args: argparse.Namespace) -> int:
    """Prints the audit; status 1 when a reader differs in a field the dynamics use."""
    from ..checks.audit import audit, lines

    result = audit(audited_system(args.model, tuple(args.lock or ())))
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(console(lines(result)))
    return 0 if result["passed"] else 1

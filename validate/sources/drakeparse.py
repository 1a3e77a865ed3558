"""Drake's parser where its death is one line: a model on which Drake 1.51's parser aborts the process.

Drake's MJCF parser aborts the whole process (a C++ assertion, "condition 'mass > 0' failed", exit
status 1, no Python exception) on an `<inertial>` whose mass is zero or negative, and its URDF parser
on a joint `<limit>` whose lower bound is above its upper one ("pos_lower_limits <= pos_upper_limits").
The harness must not die with it: MuJoCo, Pinocchio and the symbolic source still judge the model. So a
text that a cheap look (`may_abort`: microseconds, regular expressions over the `<inertial>` masses and
the `<limit>`s) finds such an element in is first parsed in a child process (`abort_line`, about a
second: the child imports pydrake); if
the child dies, Drake is left out with "Drake cannot read it: ..." and its own first line. Every other
text is parsed in-process, at no cost.
"""

from __future__ import annotations

import re
import subprocess
import sys

CHILD_SECONDS = 300
_MASS = re.compile(r"<inertial\b[^>]*?\bmass\s*=\s*([\"'])(.*?)\1", re.S)
_CHILD = """
import sys
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
text, kind = sys.stdin.read(), sys.argv[1]
try:
    plant = MultibodyPlant(time_step=0.0)
    Parser(plant).AddModelsFromString(text, kind)
except Exception:  # a refusal Drake raises is read, and said, by the parse in the harness's process
    pass
"""


_LIMIT = re.compile(r"<limit\b[^>]*>", re.S)
_BOUND = re.compile(r"\b(lower|upper)\s*=\s*([\"'])(.*?)\2", re.S)


def _reversed_limit(text: str) -> bool:
    """A URDF joint `<limit>` whose lower bound is above its upper one (pybullet's "no limit" spelling,
    lower="1" upper="-1"): Drake's Joint constructor aborts on it."""
    for match in _LIMIT.finditer(text):
        bounds = {m.group(1): m.group(3) for m in _BOUND.finditer(match.group(0))}
        try:
            if float(bounds.get("lower", "0")) > float(bounds.get("upper", "0")):
                return True
        except ValueError:
            return True
    return False


def may_abort(text: str, kind: str) -> bool:
    """Whether Drake's parser may abort the process on the text: an MJCF `<inertial>` whose mass is not a
    positive number (its URDF parser reads a zero mass), a URDF joint limit whose lower bound is above its
    upper one."""
    if kind != "xml":
        return _reversed_limit(text)
    for match in _MASS.finditer(text):
        try:
            if not float(match.group(2)) > 0:
                return True
        except ValueError:
            return True
    return False


def abort_line(text: str, kind: str) -> str:
    """ "" where Drake's parser reads `text` (format `kind`: "xml" or "urdf") without ending the process,
    else what it said as it died (its last line: the failed condition), parsed in a child process."""
    if not may_abort(text, kind):
        return ""
    try:
        child = subprocess.run(
            [sys.executable, "-c", _CHILD, kind], input=text, capture_output=True, text=True, timeout=CHILD_SECONDS
        )
    except subprocess.TimeoutExpired:
        return f"its parser did not finish in {CHILD_SECONDS} s"
    if child.returncode == 0:
        return ""
    said = [line.strip() for line in child.stderr.splitlines() if line.strip()]
    failure = next(
        (line for line in reversed(said) if "condition" in line or "Failure" in line), said[-1] if said else ""
    )
    why = failure.split(" in ", 1)[-1] if failure.startswith("Failure at") else failure
    return f"its parser ends the process (exit status {child.returncode}): {why[:200] or 'no message'}"


def likely_cause(died: str) -> str:
    """What in the file the failed condition Drake died on points at."""
    if "limits" in died:
        return "likely a joint <limit> whose lower bound is above its upper one"
    return "likely an <inertial> with zero mass"

"""A person's equations module, or a repository system's, loaded once and held to the contract:
`parameters(model)` and the dynamics in one form, brought to form (a).
"""

from __future__ import annotations

import functools
import importlib
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

from ..core.errors import HarnessError
from ..core.guard import DEFAULT_TIME_LIMIT, Guard, Stopped, guard_module
from ..core.package import EQUATIONS_PACKAGE
from ..handwritten import matlab, textform
from ..handwritten.forms import normalize
from ..model.modelfile import model_view

if TYPE_CHECKING:
    from ..forms import FormA

# The contract's one required name (and the dynamics in one form: validate/handwritten/forms.py). Everything
# else has a default: COORDINATES and JOINTS the model's joints in order, DESCRIPTION the module's
# docstring, BODIES none (pose checks "not provided"), assumptions() none (the probes move what
# parameters() reads); the physics a scene uses is read from the model.
REQUIRED_ATTRIBUTES = ("parameters",)


def _check_contract(module: ModuleType, where: str) -> FormA:
    """The module, brought to form (a) (validate/handwritten/forms.py) once it is known to meet the contract."""

    missing = [a for a in REQUIRED_ATTRIBUTES if not callable(getattr(module, a, None))]
    if missing:
        raise HarnessError(
            f"{where} lacks {', '.join(f'{a}(model)' for a in missing)}: a derivation is parameters(model), returning "
            "a dataclass of the numbers it reads from the model, and its dynamics in one form (see the README's "
            "'Your own system')."
        )
    try:
        return normalize(module)
    except HarnessError as exc:
        text = str(exc)
        named = text.split(": ", 1)[0].endswith(Path(where).name)  # the module named already (its file)
        raise HarnessError(text if named else f"{where}: {text}") from None


@functools.lru_cache(maxsize=64)  # one per repository system (and time limit)
def repository_module(name: str, time_limit: float = DEFAULT_TIME_LIMIT) -> FormA:
    where = f"equations/{name}.py"
    guard = Guard(where, time_limit)
    try:
        module = guard.call("importing it", importlib.import_module, f"{EQUATIONS_PACKAGE}.{name}")
    except SyntaxError as exc:
        raise HarnessError(f"{where}: syntax error at line {exc.lineno}: {exc.msg}.") from None
    except Stopped as stop:
        raise HarnessError(str(stop)) from None
    except Exception as exc:  # noqa: BLE001 - a module that fails to import is that system's error alone
        raise HarnessError(f"{where} cannot be imported ({type(exc).__name__}: {exc}).") from None
    return _check_contract(guard_module(module, guard), where)


def load_module(path: Path, *, model: Path | None = None, time_limit: float = DEFAULT_TIME_LIMIT) -> FormA:
    """An equations module from any file, executed under a name of its own (so two files with the
    same stem never share a module); a missing file, a syntax error or an exception while importing
    it, and a module that lacks part of the contract, are one-line HarnessErrors. A `.toml` file is
    equations as text, read against `model` (validate/handwritten/textform.py). The import and every call
    into the module run in a worker process of its own (validate/handwritten/worker.py, handwritten/proxy.py), within
    one budget of `time_limit` seconds for all of them."""
    path = Path(path)
    if not path.is_file():
        raise HarnessError(
            f"equations file not found: {path} (give a Python module, .py, a .toml file or a Matlab function, .m)."
        )
    if path.suffix == ".toml":
        if model is None:
            raise HarnessError(f"{path}: equations as text are read against their model; give the model file too.")
        module = textform.module_from_file(path, model_view(model), time_limit=time_limit)
    elif path.suffix == ".m":
        if model is None:
            raise HarnessError(f"{path}: a Matlab function is read against its model; give the model file too.")
        module = matlab.module_from_file(path, model_view(model), time_limit=time_limit)
    else:
        from ..handwritten.proxy import worker_module

        module = worker_module(path, time_limit)
    try:
        return _check_contract(module, str(path))
    except BaseException:
        module.WORKER.close()
        raise

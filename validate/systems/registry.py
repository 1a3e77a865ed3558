"""The systems registry: `models/<name>.xml` paired with `equations/<name>.py` by file stem, a folder of a
person's own systems paired the same way, and the key that finds a system again in another process.
"""

from __future__ import annotations

import importlib
import json
import pkgutil
from pathlib import Path

from ..core.errors import HarnessError, unknown_name
from ..core.guard import DEFAULT_TIME_LIMIT
from ..core.package import EQUATIONS_PACKAGE, MODELS_DIR
from ..model.modelfile import model_file
from .loader import repository_module
from .system import System

MODEL_SUFFIXES = (".xml", ".urdf")  # what a folder of systems is searched for (the format is the root element's)
PAIR = "<name>.xml or <name>.urdf, and <name>.py or <name>.toml"  # the files of a system in a user's folder


def model_stems() -> set[str]:
    return {p.stem for p in MODELS_DIR.glob("*.xml")}


def equation_stems() -> set[str]:
    package = importlib.import_module(EQUATIONS_PACKAGE)
    return {m.name for m in pkgutil.iter_modules(package.__path__) if not m.name.startswith("_")}


def system_names() -> list[str]:
    """Names of the complete systems (an MJCF and an equations module with the same stem)."""
    return sorted(model_stems() & equation_stems())


def unpaired() -> dict[str, list[str]]:
    """Files without their partner: {"models without equations": [...], "equations without model": [...]}."""
    models, eqs = model_stems(), equation_stems()
    return {"models without equations": sorted(models - eqs), "equations without model": sorted(eqs - models)}


def pairs_in(folder: Path) -> list[tuple[Path, Path]]:
    """(model, equations) of every system in a user's folder (each one `PAIR`). A file without its
    partner is an error naming it: a derivation left unchecked is never silent."""
    pairs, lonely = pairs_and_lonely(folder)
    if lonely:
        raise HarnessError(
            f"{folder}: {', '.join(sorted(p.stem for p in lonely))} has no partner (each system is {PAIR})."
        )
    return pairs


def pairs_and_lonely(folder: Path) -> tuple[list[tuple[Path, Path]], list[Path]]:
    """The systems of a user's folder (as `pairs_in`) and the files without a partner, each named by
    the caller (`run --systems` reports them and goes on with the rest)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise HarnessError(f"systems folder not found: {folder} (give a folder of <name>.xml and <name>.py).")
    found = sorted(p for p in folder.iterdir() if p.suffix in MODEL_SUFFIXES and p.is_file())
    twice = sorted({p.stem for p in found if sum(q.stem == p.stem for q in found) > 1})
    if twice:
        raise HarnessError(f"{folder}: {', '.join(twice)} has both an .xml and a .urdf model; keep one.")
    models = {p.stem: p for p in found}
    written = sorted(p for p in folder.iterdir() if p.suffix in (".py", ".toml") and p.stem != "__init__")
    if both := sorted({p.stem for p in written if sum(q.stem == p.stem for q in written) > 1}):
        raise HarnessError(f"{folder}: {', '.join(both)} has both a .py and a .toml derivation; keep one.")
    modules = {p.stem: p for p in written if p.is_file()}  # `_arm` is refused, by name; .toml: the text form
    lonely = sorted((models | modules)[n] for n in models.keys() ^ modules.keys())
    paired = sorted(models.keys() & modules.keys())
    if not paired and not lonely:
        raise HarnessError(f"{folder}: no system found (each system is {PAIR}).")
    return [(models[n], modules[n]) for n in paired], lonely


def load(name: str, overrides: tuple[tuple[str, float], ...] = (), *, time_limit: float = DEFAULT_TIME_LIMIT) -> System:
    """The system called `name`; an unknown name lists the valid ones and the closest. `time_limit`:
    seconds each call into its equations module may take (validate/core/guard.py)."""
    names = system_names()
    if name not in names:
        lonely = unpaired()
        if name in lonely["models without equations"]:
            raise HarnessError(f"models/{name}.xml has no equations/{name}.py, so '{name}' is not a system yet.")
        if name in lonely["equations without model"]:
            raise HarnessError(f"equations/{name}.py has no models/{name}.xml, so '{name}' is not a system yet.")
        raise unknown_name("system", name, names)
    _repository_model(name)
    module = repository_module(name, float(time_limit))
    return System(name=name, mjcf=MODELS_DIR / f"{name}.xml", equations=module, overrides=overrides)


def _repository_model(name: str) -> None:
    """models/<name>.xml read and bounded before anything is judged (malformed, a DOCTYPE, an include
    by absolute path: one line naming the cause, as for --model), and MJCF: a repository model is."""
    root, _ = model_file(MODELS_DIR / f"{name}.xml")
    if root != "mujoco":
        raise HarnessError(
            f"models/{name}.xml: a repository model is MJCF (root <mujoco>), this one is <{root}>; "
            "check it with --model FILE --equations FILE, or in a folder of your own (run --systems DIR)."
        )


def load_all(names: list[str] | None = None, *, time_limit: float = DEFAULT_TIME_LIMIT) -> list[System]:
    return [load(n, time_limit=time_limit) for n in (names or system_names())]


FILES_KEY = "file:"  # the key of a system from a person's own files: paths and name as a JSON list (any path)


def key_of(system: System) -> str:
    """A string that finds `system` again in another process (`from_key`): a repository system's name,
    or the paths of a person's model and equations module with its time limit (overrides travel
    separately)."""
    repository = system.text is None and system.name in system_names()
    if repository and system.mjcf.resolve() == (MODELS_DIR / f"{system.name}.xml").resolve():
        return system.name
    equations = Path(getattr(system.equations, "__file__", "") or "")
    limit = getattr(getattr(system.equations, "GUARD", None), "time_limit", DEFAULT_TIME_LIMIT)
    return FILES_KEY + json.dumps(
        [str(system.mjcf.resolve()), str(equations.resolve()), system.name, list(system.locked), limit]
    )


def from_key(key: str) -> System:
    """The system `key_of` gave the key of."""
    if key.startswith(FILES_KEY):
        model, equations, name, locked, limit = json.loads(key[len(FILES_KEY) :])
        return System.from_files(model, equations, name=name, locked=tuple(locked), time_limit=limit)
    return load(key)

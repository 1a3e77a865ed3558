"""The systems registry: `models/<name>.xml` paired with `equations/<name>.py` by file stem.

Nothing lists systems by hand: they are discovered. The compiled MJCF is the only source of
numbers; `System.params` is what the equations module reads from it.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

from .errors import HarnessError, unknown_name
from .modelview import ModelView

PACKAGE_ROOT = Path(__file__).resolve().parent.parent
MODELS_DIR = PACKAGE_ROOT / "models"
EQUATIONS_PACKAGE = "lagrange_xval.equations"
MAX_MJCF_BYTES = 16 * 2**20  # the models of the notes are ~3 kB

REQUIRED_ATTRIBUTES = (
    "DESCRIPTION",
    "COORDINATES",
    "JOINTS",
    "BODIES",
    "USES",
    "Params",
    "parameters",
    "assumptions",
    "mass_matrix",
    "bias",
    "passive",
    "kinetic_energy",
    "potential_energy",
    "body_positions",
    "body_rotations",
    "VARIANTS",
)


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


def mjcf_text(path: Path, overrides: tuple[tuple[str, float], ...] = ()) -> str:
    """The MJCF text the engines parse: the file, with any overrides applied at full precision."""
    import xml.etree.ElementTree as ET

    from .inputs import regular_file

    try:
        text = regular_file(path, "MJCF file", max_bytes=MAX_MJCF_BYTES).decode()
        root = ET.fromstring(text).tag
    except (ET.ParseError, UnicodeDecodeError) as exc:
        raise HarnessError(f"{path.name}: not well-formed XML ({exc}).") from None
    if root != "mujoco":
        # MuJoCo would also compile URDF; the harness reads MJCF only.
        raise HarnessError(f"{path.name}: not an MJCF file (root element <{root}>, expected <mujoco>).")
    if overrides:
        from .overrides import apply_overrides

        text = apply_overrides(text, overrides)
    return _absolute_includes(text, path.resolve().parent)


def _absolute_includes(text: str, folder: Path) -> str:
    """Relative `<include file=...>` resolved against the model's folder: the engines parse the text,
    which has no folder of its own, and would otherwise read them from the working directory."""
    import re
    from xml.sax.saxutils import quoteattr

    def absolute(match: re.Match[str]) -> str:
        name = match.group(3)
        return match.group(1) + quoteattr(name if Path(name).is_absolute() else str(folder / name))

    return re.sub(r"(<include\b[^>]*?\bfile\s*=\s*)([\"'])(.*?)\2", absolute, text)


def _ignore_warning(message: str) -> None:
    pass


def compile_mjcf(path: Path, overrides: tuple[tuple[str, float], ...] = ()) -> Any:
    """Compiles an MJCF file with MuJoCo; a bad file becomes a one-line HarnessError."""
    import mujoco

    # MuJoCo's default warning handler appends to MUJOCO_LOG.TXT in the working directory; the
    # harness reads the warning counters of MjData instead (validate/integrate.py).
    mujoco.set_mju_user_warning(_ignore_warning)
    text = mjcf_text(path, overrides)
    try:
        return mujoco.MjModel.from_xml_string(text)
    except Exception as exc:  # mujoco raises ValueError with a multi-line message
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise HarnessError(f"{path.name}: not a valid MJCF model: {first}") from None


@dataclass(frozen=True)
class System:
    """One system: its MJCF, its equations module and the parameters read from the compiled model."""

    name: str
    mjcf: Path
    equations: ModuleType
    overrides: tuple[tuple[str, float], ...] = ()
    _cache: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    @property
    def coordinates(self) -> tuple[str, ...]:
        return tuple(self.equations.COORDINATES)

    @property
    def joints(self) -> tuple[str, ...]:
        return tuple(self.equations.JOINTS)

    @property
    def joint_map(self) -> Any:
        """A with q_notes = A q_joints, or None where each coordinate is its joint's own angle."""
        A = getattr(self.equations, "JOINT_MAP", None)
        if A is None:
            return None
        import numpy as np

        A = np.asarray(A, dtype=float)
        if A.shape != (self.nv, self.nv) or abs(np.linalg.det(A)) < 1e-12:
            raise HarnessError(f"equations/{self.name}.py: JOINT_MAP must be an invertible {self.nv}x{self.nv} matrix.")
        return A

    @property
    def bodies(self) -> tuple[str, ...]:
        return tuple(self.equations.BODIES)

    @property
    def uses(self) -> frozenset[str]:
        return frozenset(self.equations.USES)

    @property
    def nv(self) -> int:
        return len(self.coordinates)

    @property
    def description(self) -> str:
        return str(self.equations.DESCRIPTION)

    def mujoco_model(self) -> Any:
        """The compiled MjModel (compiled once per System)."""
        if "model" not in self._cache:
            self._cache["model"] = compile_mjcf(self.mjcf, self.overrides)
        return self._cache["model"]

    def mjcf_xml(self) -> str:
        """The MJCF text both engines parse, with overrides applied."""
        return mjcf_text(self.mjcf, self.overrides)

    @property
    def view(self) -> ModelView:
        if "view" not in self._cache:
            from .modelview import from_mujoco

            self._cache["view"] = from_mujoco(self.mujoco_model(), self.mjcf.name)
        return self._cache["view"]

    @property
    def params(self) -> Any:
        if "params" not in self._cache:
            self._cache["params"] = self.equations.parameters(self.view)
        return self._cache["params"]

    @property
    def variants(self) -> tuple[Any, ...]:
        return tuple(self.equations.VARIANTS)


@functools.cache
def _equations_module(name: str) -> ModuleType:
    try:
        module = importlib.import_module(f"{EQUATIONS_PACKAGE}.{name}")
    except SyntaxError as exc:
        raise HarnessError(f"equations/{name}.py: syntax error at line {exc.lineno}: {exc.msg}.") from None
    except Exception as exc:  # noqa: BLE001 - a module that fails to import is that system's error alone
        raise HarnessError(f"equations/{name}.py cannot be imported ({type(exc).__name__}: {exc}).") from None
    missing = [a for a in REQUIRED_ATTRIBUTES if not hasattr(module, a)]
    if missing:
        raise HarnessError(f"equations/{name}.py lacks {', '.join(missing)} (see equations/__init__.py).")
    return module


def load(name: str, overrides: tuple[tuple[str, float], ...] = ()) -> System:
    """The system called `name`; an unknown name lists the valid ones and the closest."""
    names = system_names()
    if name not in names:
        raise unknown_name("system", name, names)
    return System(name=name, mjcf=MODELS_DIR / f"{name}.xml", equations=_equations_module(name), overrides=overrides)


def load_all(names: list[str] | None = None) -> list[System]:
    return [load(n) for n in (names or system_names())]

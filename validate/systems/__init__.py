"""Systems: a model and its equations. `System` (system.py), the registry of the repository's systems and of a
person's folder (registry.py), and the loader that holds a module to the contract (loader.py).

Nothing lists systems by hand: they are discovered. The compiled model (MJCF, or a URDF read by
both engines: validate/model/urdf.py) is the only source of numbers; `System.params` is what the
equations module reads from it.
"""

from ..core.package import EQUATIONS_PACKAGE, MODELS_DIR, PACKAGE_ROOT
from ..model.modelfile import compile_mjcf, compile_model, model_view
from .loader import load_module
from .registry import (
    from_key,
    key_of,
    load,
    load_all,
    pairs_and_lonely,
    pairs_in,
    system_names,
    unpaired,
)
from .system import System

__all__ = [
    "EQUATIONS_PACKAGE",
    "MODELS_DIR",
    "PACKAGE_ROOT",
    "System",
    "compile_mjcf",
    "compile_model",
    "from_key",
    "key_of",
    "load",
    "load_all",
    "load_module",
    "model_view",
    "pairs_and_lonely",
    "pairs_in",
    "system_names",
    "unpaired",
]

"""Where the package's own files are: the harness folder, and the data packages that hold the notes'
systems (`lagrange_xval.models`, `lagrange_xval.equations`), found by their import names whether the
package is a checkout installed in place or a wheel. Nothing here imports them."""

from __future__ import annotations

import functools
import importlib.util
from importlib import metadata
from pathlib import Path

__all__ = [
    "EQUATIONS_DIR",
    "EQUATIONS_PACKAGE",
    "HARNESS_DIR",
    "MODELS_DIR",
    "PACKAGE_ROOT",
    "SOURCE_DIRS",
    "installed_version",
]

HARNESS_DIR = Path(__file__).resolve().parents[1]  # validate/ in a checkout, lagrange_xval/ in a wheel
PACKAGE_ROOT = HARNESS_DIR.parent  # the checkout (README.md, .ci/, .git) where there is one
EQUATIONS_PACKAGE = "lagrange_xval.equations"


def _data_dir(package: str) -> Path:
    """The folder of a data package, from its import spec (the package itself is not imported)."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise ImportError(f"the package {package} is not installed with lagrange_xval")
    return Path(next(iter(spec.submodule_search_locations))).resolve()


MODELS_DIR = _data_dir("lagrange_xval.models")
EQUATIONS_DIR = _data_dir(EQUATIONS_PACKAGE)
# The source files every cache key covers: the harness's and the notes' derivations'
SOURCE_DIRS = {"validate": HARNESS_DIR, "equations": EQUATIONS_DIR}


@functools.lru_cache(maxsize=64)  # what is installed does not change under a running process (it imported it)
def installed_version(distribution: str) -> str | None:
    """The installed version of `distribution` (importlib.metadata, about 3 ms a lookup), or None."""
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return None

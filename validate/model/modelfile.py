"""A model file as the engines read it: the file's format and text (an MJCF's includes expanded and its
asset files absolute, as `MjModel.from_xml_path` reads it: model/flatten.py), the MJCF text every reader
parses (overrides applied, free and ball joints as slides and hinges), and MuJoCo's compiled model of it,
bounded before compiling and its numbers checked after (model/bounds.py).

`model_file` is the one door: check, run, audit, derive, new, the probes and the overrides all read a
model file through it, so every reader gets the model as from the file's own path."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ..core.errors import HarnessError
from ..core.inputs import regular_file
from . import bounds, floating, urdf
from .modelview import ModelView, from_mujoco
from .overrides import apply_overrides

if TYPE_CHECKING:
    import mujoco

MAX_MJCF_BYTES = 16 * 2**20  # the models of the notes are ~3 kB


def model_file(path: Path) -> tuple[str, str]:
    """(root element, text) of a model file: <mujoco> (MJCF, flattened: model/flatten.py) or <robot>
    (URDF); anything else is a one-line error. Whitespace before the XML declaration and a byte-order
    mark are dropped, as MuJoCo's and urdfdom's parsers (tinyxml2) drop them."""
    from .flatten import flattened

    try:
        text = regular_file(path, "model file", max_bytes=MAX_MJCF_BYTES).decode("utf-8-sig").lstrip()
    except UnicodeDecodeError as exc:
        raise HarnessError(f"{path.name}: not well-formed XML ({exc}).") from None
    bounds.no_doctype(text, path.name)  # before any parse: DOCTYPE
    text = bounds.declare_prefixes(text)  # a `drake:` prefix no xmlns declares, read as tinyxml2 reads it
    root = bounds.parse(text, path.name).tag
    if root not in ("mujoco", urdf.ROOT):
        raise HarnessError(
            f"{path.name}: not a model file (root element <{root}>, expected <mujoco> for MJCF or <robot> for URDF)."
        )
    if root == "mujoco":
        text = flattened(path, text)
    bounds.check_text(text, path.name)  # sizes, joints and bodies (an MJCF's includes expanded)
    return root, text


def mjcf_text(path: Path, overrides: tuple[tuple[str, float], ...] = (), text: str | None = None) -> str:
    """The MJCF text the engines parse: the file (or `text`, an edited copy of it), with any overrides
    applied at full precision. A URDF file becomes the MJCF of MuJoCo's reading of it (every number
    written back at full precision: validate/model/urdf.py)."""
    import xml.etree.ElementTree as ET

    if text is None:
        root, text = model_file(path)
        if root == urdf.ROOT:
            text = urdf.as_mjcf(text, path.name)
    else:
        try:
            root = ET.fromstring(text).tag
        except ET.ParseError as exc:
            raise HarnessError(f"{path.name}: not well-formed XML ({exc}).") from None
        if root != "mujoco":
            raise HarnessError(f"{path.name}: not an MJCF document (root element <{root}>, expected <mujoco>).")
    text = floating.convert(text)[0]  # free and ball joints as slides and hinges (model/floating.py)
    if overrides:
        text = apply_overrides(text, overrides)
    return text


def _ignore_warning(message: str) -> None:
    pass


def compile_model(path: Path) -> mujoco.MjModel:
    """MuJoCo's model of a model file, MJCF or URDF (validate/model/urdf.py)."""
    root, text = model_file(path)
    return urdf.compile_urdf(text, path.name) if root == urdf.ROOT else compile_mjcf(path)


def model_view(path: Path) -> ModelView:
    """The compiled model of a file (MJCF or URDF) as a ModelView, after the scope's refusals: what
    `derive` reads when no equations module is given."""
    from .scope import NOTHING_MOVES, refusals, unconstrained

    model = compile_model(Path(path))
    refused = refusals(model) + ([] if model.nv else [NOTHING_MOVES])
    if refused:
        more = f" (and {len(refused) - 1} more)" if len(refused) > 1 else ""
        raise HarnessError(f"{Path(path).name}: {refused[0]}{more}.")
    unconstrained(model)
    return from_mujoco(model, Path(path).name)


def compile_mjcf(path: Path, overrides: tuple[tuple[str, float], ...] = (), text: str | None = None) -> mujoco.MjModel:
    """Compiles an MJCF file (or `text`, an edited copy of it) with MuJoCo; a bad file becomes a
    one-line HarnessError."""
    import mujoco

    # MuJoCo's default warning handler appends to MUJOCO_LOG.TXT in the working directory; the
    # harness reads the warning counters of MjData instead (validate/dynamics/integrate.py).
    mujoco.set_mju_user_warning(_ignore_warning)
    text = mjcf_text(path, overrides, text)
    try:
        model = mujoco.MjModel.from_xml_string(text)
    except Exception as exc:  # mujoco raises ValueError with a multi-line message
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        if "Error opening file" in first:
            _loads_from_its_path(path, first)
        raise HarnessError(f"{path.name}: not a valid MJCF model: {first}") from None
    return bounds.check_numbers(model, path.name)


def _loads_from_its_path(path: Path, first: str) -> None:
    """Refuses, as the harness's own fault, a missing file where MuJoCo loads the model from its path:
    a refusal for a missing file is the model's only where `MjModel.from_xml_path` fails too."""
    import os

    import mujoco

    try:
        mujoco.MjModel.from_xml_path(os.path.abspath(path))
    except Exception:  # MuJoCo cannot open it either: the model's own missing file
        return
    raise HarnessError(
        f"{path.name}: MuJoCo loads the model from its path, but not the text the harness made of it ({first}): "
        "a bug of the harness; please report it with the files."
    )

"""An MJCF file as one self-contained document, read as `mujoco.MjModel.from_xml_path` reads it.

Every reader parses a text (MuJoCo from a string, Pinocchio and Drake from a copy in a temporary
folder), and a text has no folder of its own: its `<include>`s, its `<compiler meshdir texturedir
assetdir>` and the files of its meshes, textures, height fields and skins would be looked up in the
working directory. So the file is flattened first, once, at the door (modelfile.model_file):

- each `<include file=...>` is replaced by the children of the included file's root element, as
  MuJoCo's parser does, wherever MuJoCo accepts it (above the model's folder, by absolute path, inside
  an included file: looked up in the model's folder, then in the including file's), each included
  file bounded as the model is (a regular file, UTF-8, no DOCTYPE, MAX_MODEL_BYTES in all);
- each asset's file is written as the absolute path MuJoCo opens: the file names come from MuJoCo's own
  parse of the model's path (`MjSpec.from_file`, which gives an included file's assets the folder
  MuJoCo finds them in), joined to the model's folder and the final meshdir (meshes, height fields,
  skins) or texturedir (textures) as MuJoCo joins them; the folders are then removed from `<compiler>`.

The text is unchanged where it has no include and no asset file. Where MuJoCo's parse and the
expansion disagree on what the model holds (bodies, joints, assets), the harness says so rather than
compare another model.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import TYPE_CHECKING

from ..core.errors import HarnessError, shown
from ..core.inputs import regular_file
from .bounds import MAX_INCLUDES, MAX_MODEL_BYTES, no_doctype, parse

if TYPE_CHECKING:  # MuJoCo is imported when a model with includes or asset files is first read
    import mujoco

ASSETS = {"mesh": "meshes", "hfield": "hfields", "skin": "skins", "texture": "textures"}  # tag: MjSpec list
CUBE = ("fileright", "fileleft", "fileup", "filedown", "filefront", "fileback")  # MjsTexture.cubefiles' order
FOLDERS = ("meshdir", "texturedir", "assetdir")
MERGED = ("default", "asset", "worldbody", "contact", "equality", "tendon", "actuator", "sensor", "keyframe", "custom")


def flattened(path: Path, text: str) -> str:
    """The MJCF `text` of the file `path` with its includes expanded and its asset files absolute
    (module docstring); `text` itself where it has neither."""
    root = parse(text, path.name)
    folder = Path(os.path.abspath(path)).parent
    included = _expand(root, folder, folder, path.name, [len(text.encode())])
    if not included and not _files(root):
        return text
    spec = _spec(path)
    if included:
        _same_model(root, spec, path.name)
    _absolute_files(root, spec, folder, path.name)
    for compiler in root.iter("compiler"):
        for attribute in FOLDERS:
            compiler.attrib.pop(attribute, None)
    if included:
        _merge_sections(root)
    return ET.tostring(root, encoding="unicode")


def _merge_sections(root: ET.Element) -> None:
    """The model's repeated top-level sections (a `<worldbody>` of the scene and one of each included
    file, say) as one each, their children in order: MuJoCo merges them so, and Pinocchio's parser reads
    the first `<worldbody>` (twice, where there are two) and the first `<default>` only."""
    for tag in MERGED:
        sections = root.findall(tag)
        if len(sections) < 2:
            continue
        first, later = sections[0], sections[1:]
        if tag == "default" and not _mergeable(first, later):
            continue
        for section in later:
            first.extend(list(section))
            root.remove(section)


def _mergeable(first: ET.Element, later: list[ET.Element]) -> bool:
    """Whether top-level `<default>`s merge into one without two defaults of one element in the top class."""
    tags = [c.tag for d in (first, *later) for c in d if c.tag != "default"]
    return len(tags) == len(set(tags)) and all(d.get("class", "main") == "main" for d in (first, *later))


def _expand(node: ET.Element, folder: Path, here: Path, source: str, sizes: list[int]) -> int:
    """Replaces every `<include>` under `node` (in place, recursively) by the included file's
    children; `folder`: the model's, `here`: the including file's; `sizes`: the bytes read so far.
    Returns the number of files included."""
    count = 0
    for i, child in reversed(list(enumerate(node))):
        if child.tag != "include":
            count += _expand(child, folder, here, source, sizes)
            continue
        path = _include_path(child.get("file", ""), folder, here, source)
        root = _read_include(path, child.get("file", ""), source, sizes)
        count += 1 + _expand(root, folder, path.parent, source, sizes)
        node.remove(child)
        for k, part in enumerate(list(root)):
            node.insert(i + k, part)
    return count


def _include_path(name: str, folder: Path, here: Path, source: str) -> Path:
    """The file an `<include file=name>` reads: as MuJoCo looks for it, relative to the model's folder,
    then to the including file's (the same for an include in the model itself)."""
    if not name:
        raise HarnessError(f'{source}: an <include> without a file; give it file="...".')
    candidates = [Path(name)] if os.path.isabs(name) else [folder / name, here / name]
    for candidate in candidates:
        if candidate.exists():
            return Path(os.path.normpath(candidate))
    looked = " or ".join(str(Path(os.path.normpath(c))) for c in dict.fromkeys(candidates))
    raise HarnessError(
        f'{source}: <include file="{shown(name, 200)}">: no such file ({looked}); MuJoCo cannot load the model either.'
    )


def _read_include(path: Path, name: str, source: str, sizes: list[int]) -> ET.Element:
    """The root of an included file, bounded as the model is."""
    if len(sizes) > MAX_INCLUDES:
        raise HarnessError(f"{source}: more than {MAX_INCLUDES} includes (one including itself?).")
    data = regular_file(path, "included model file", max_bytes=max(MAX_MODEL_BYTES - sum(sizes), 0))
    sizes.append(len(data))
    where = f"{source} (included {shown(name, 200)})"
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise HarnessError(f"{where}: not UTF-8 text.") from None
    no_doctype(text, where)
    return parse(text.lstrip(), where)


def _assets(root: ET.Element, tag: str) -> list[ET.Element]:
    """The model's `<asset><tag>` elements that name a file, in the order MuJoCo's spec lists them."""
    return [e for a in root.findall("asset") for e in a.findall(tag) if any(e.get(k) for k in ("file", *CUBE))]


def _files(root: ET.Element) -> bool:
    return any(_assets(root, tag) for tag in ASSETS)


def _spec(path: Path) -> mujoco.MjSpec:
    """MuJoCo's parse of the model from its absolute path (its includes read, nothing compiled)."""
    import mujoco

    try:
        return mujoco.MjSpec.from_file(os.path.abspath(path))
    except Exception as exc:  # mujoco raises ValueError with a multi-line message
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise HarnessError(f"{path.name}: not a valid MJCF model: {first}") from None


def _absolute_files(root: ET.Element, spec: mujoco.MjSpec, folder: Path, source: str) -> None:
    """Each asset's file (a texture's six cube files too) as the absolute path MuJoCo opens."""
    for tag, listed in ASSETS.items():
        mine = _assets(root, tag)
        theirs = [s for s in getattr(spec, listed) if s.file or any(getattr(s, "cubefiles", ()))]
        if len(mine) != len(theirs):
            _disagree(source, f"{len(mine)} <{tag}> file(s) in the expanded text, {len(theirs)} in MuJoCo's parse")
        base = spec.texturedir if tag == "texture" else spec.meshdir
        for element, asset in zip(mine, theirs, strict=True):
            if element.get("name") and element.get("name") != asset.name:
                _disagree(source, f"<{tag} name={element.get('name')!r}> where MuJoCo's parse has {asset.name!r}")
            if element.get("file"):
                element.set("file", _opened(folder, base, asset.file))
            for attribute, name in zip(CUBE, getattr(asset, "cubefiles", ()), strict=False):
                if element.get(attribute):
                    element.set(attribute, _opened(folder, base, name))


def _opened(folder: Path, base: str, name: str) -> str:
    """The path MuJoCo opens for an asset file: the model's folder, the asset folder, the file name,
    each absolute one replacing what comes before it."""
    return os.path.normpath(os.path.join(folder, base, name))


def _same_model(root: ET.Element, spec: mujoco.MjSpec, source: str) -> None:
    """The expanded text holds the bodies and joints MuJoCo's own parse of the file holds."""
    tags = {e.tag for e in root.iter()}
    if tags & {"replicate", "attach", "model", "composite", "flexcomp"}:
        return  # MuJoCo's parse multiplies, generates or attaches what the text states once
    world = [w for w in root.iter("worldbody")]
    bodies = sum(1 for w in world for _ in w.iter("body"))
    joints = sum(1 for w in world for e in w.iter() if e.tag in ("joint", "freejoint"))
    if (bodies + 1, joints) != (len(spec.bodies), len(spec.joints)):
        _disagree(
            source,
            f"{bodies} bodies and {joints} joints in the expanded text, {len(spec.bodies) - 1} and "
            f"{len(spec.joints)} in MuJoCo's parse",
        )


def _disagree(source: str, what: str) -> None:
    raise HarnessError(
        f"{source}: the harness expands this model's includes otherwise than MuJoCo ({what}); it does not "
        "compare a model other than MuJoCo's (a bug of the harness: please report it with the files)."
    )

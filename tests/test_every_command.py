"""Every command takes every module the verdict takes (issue 34): a `--systems` folder pairs a model
with its text form (`<name>.toml`) as with a `.py`; `bench` and `stress` run on a module that leaves
out its energies, skip what needs them and say so."""

from __future__ import annotations

import shutil
import textwrap
from pathlib import Path

import pytest
from lagrange_xval.validate.cli import main
from lagrange_xval.validate.errors import HarnessError
from lagrange_xval.validate.systems import pairs_and_lonely, textform

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def toml_example() -> str:
    """The cart-pole TOML of textform's docstring, as a person would copy it."""
    lines = (textform.__doc__ or "").splitlines()
    first = next(i for i, line in enumerate(lines) if line.strip().startswith("# cart_pole.toml"))
    last = next(i for i in range(first, len(lines)) if not lines[i].strip())
    return textwrap.dedent("\n".join(lines[first:last])) + "\n"


def without_energies(folder: Path, name: str = "acro") -> tuple[Path, Path]:
    """examples/acrobot (explicit accelerations) with kinetic_energy and potential_energy cut out."""
    source = (EXAMPLES / "acrobot.py").read_text()
    start, end = source.index("def kinetic_energy("), source.index("def body_positions(")
    (folder / f"{name}.py").write_text(source[:start] + source[end:])
    shutil.copy(EXAMPLES / "acrobot.xml", folder / f"{name}.xml")
    return folder / f"{name}.xml", folder / f"{name}.py"


def test_a_systems_folder_pairs_a_model_with_its_text_form(tmp_path, capsys):
    shutil.copy(EXAMPLES / "cart_pole.xml", tmp_path / "cart.xml")
    (tmp_path / "cart.toml").write_text(toml_example())
    pairs, lonely = pairs_and_lonely(tmp_path)
    assert pairs == [(tmp_path / "cart.xml", tmp_path / "cart.toml")] and lonely == []
    assert main(["list", "--systems", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "cart" in out and "not checked" not in out, out
    (tmp_path / "cart.py").write_text((EXAMPLES / "cart_pole.py").read_text())
    with pytest.raises(HarnessError, match=r"cart has both a \.py and a \.toml derivation; keep one"):
        pairs_and_lonely(tmp_path)

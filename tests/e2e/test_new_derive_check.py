"""Issue 42: the module `lagrange-xval new` writes, filled in with what `lagrange-xval derive --python`
prints, passes `check` with its probes on a model with what dm_control's suite has: a body welded to
its parent with no joint of its own (reacher's `finger` on `hand`: Pinocchio keeps one inertia per
joint, the group's, where MuJoCo keeps the body apart), hinge and slide `ref`s (finger's `ref="-90"`)
and `springref`s in a degree compiler. Before, the welded body FAILed as "the model differs from what
the derivation assumes (body/finger/mass)", and `derive --python` stopped at KeyError 'springref'."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

MODEL = """<mujoco model="welded_reacher">
  <compiler angle="degree"/>
  <worldbody>
    <body name="arm" pos="0 0 0.5">
      <joint name="shoulder" type="hinge" axis="0 1 0" ref="-90" springref="10" stiffness="0.5" damping="0.01"/>
      <geom type="capsule" fromto="0 0 0 0.12 0 0" size="0.01" mass="0.3"/>
      <body name="hand" pos="0.12 0 0">
        <joint name="wrist" type="slide" axis="1 0 0" ref="0.02" springref="0.05" stiffness="3"/>
        <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.01" mass="0.2"/>
        <body name="finger" pos="0.12 0 0.01" euler="0 30 0">
          <geom type="box" size="0.02 0.01 0.015" mass="0.05" pos="0.01 0 0.005"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "lagrange_xval.cli", *args], cwd=cwd, capture_output=True, text=True, timeout=600
    )


@pytest.fixture(scope="module")
def filled(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(model, module): `new welded --model ...` with its stubs replaced by `derive --python`'s dynamics."""
    folder = tmp_path_factory.mktemp("welded")
    model = folder / "welded_reacher.xml"
    model.write_text(MODEL)
    made = _cli("new", "welded", "--model", str(model), "--dir", str(folder), cwd=folder)
    assert made.returncode == 0, made.stderr
    derived = _cli("derive", "--model", str(model), "--python", cwd=folder)
    assert derived.returncode == 0, derived.stderr
    module = folder / "welded.py"
    text = module.read_text()
    stubs = text.index("@not_provided\ndef kinetic_energy")
    module.write_text(text[:stubs] + derived.stdout[derived.stdout.index("import numpy as np") :])
    return model, module


def _check(model: Path, module: Path) -> dict:
    done = _cli("check", "--model", str(model), "--equations", str(module), "--json", cwd=module.parent)
    assert done.stdout.strip(), done.stderr
    return json.loads(done.stdout)


def test_new_and_derive_python_pass_check_on_a_welded_body_with_refs_and_springrefs(filled):
    model, module = filled
    text = module.read_text()
    assert "'finger'" in text.split("BODIES = ", 1)[1].split("\n", 1)[0], "the welded body is a compared body"
    verdict = _check(model, module)["verdict"]
    assert verdict["passed"], verdict["statement"]
    assert verdict["probes"]["built"] >= 3, verdict["statement"]


def test_a_springref_typed_in_fails_at_the_probes(filled):
    """The converse: the shoulder's springref typed in as the model's number (right at the model's own
    values only) FAILs at the probes, which move it."""
    model, module = filled
    wrong = module.with_name("welded_typed.py")
    typed = module.read_text().replace("q0_shoulder = p.q0_shoulder", "q0_shoulder = 0.17453292519943295")
    assert typed != module.read_text()
    wrong.write_text(typed)
    verdict = _check(model, wrong)["verdict"]
    assert not verdict["passed"], verdict["statement"]

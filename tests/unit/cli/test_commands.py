"""Every command takes every module the verdict takes (issue 34): a `--systems` folder pairs a model
with its text form (`<name>.toml`) as with a `.py`; `bench` and `stress` run on a module that leaves
out its energies, skip what needs them and say so."""

from __future__ import annotations

import shutil
import textwrap
from pathlib import Path

import pytest
from lagrange_xval.cli import main
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.handwritten import textform
from lagrange_xval.systems import pairs_and_lonely

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"


def toml_example() -> str:
    """The cart-pole TOML of textform's docstring, as a person would copy it."""
    lines = (textform.__doc__ or "").splitlines()
    first = next(i for i, line in enumerate(lines) if line.strip().startswith("# cart_pole.toml"))
    last = next(i for i in range(first, len(lines)) if not lines[i].strip())
    return textwrap.dedent("\n".join(lines[first:last])) + "\n"


def without_energies(folder: Path, name: str = "acro") -> tuple[Path, Path]:
    """examples/acrobot.py (explicit accelerations) with kinetic_energy and potential_energy cut out."""
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


def test_the_bench_baseline_computes_what_a_module_without_energies_provides(tmp_path):
    """The bench's raw loops (what `bench` times the harness against) skip T and V where the module
    leaves them out, as the hand source does, instead of raising NotImplementedError."""
    import numpy as np
    from lagrange_xval.studies.bench.baselines import raw_hand
    from lagrange_xval.systems import System
    from lagrange_xval.verdict import pointwise as compare

    system = System.from_files(*without_energies(tmp_path))
    states = compare.random_states(system, n=8, seed=0)
    raw = raw_hand(system, states)
    assert np.isnan(raw["T"]).all() and np.isnan(raw["V"]).all()
    assert np.isfinite(raw["qacc"]).all() and raw["body_positions"]


def test_stress_on_a_module_without_energies_judges_divergence_and_says_what_it_skipped(tmp_path):
    """Without T and V: no drift, the energy criterion skipped (each said), and the stability search
    still finds every integrator's boundary from divergence alone, above the bottom of its range."""
    from dataclasses import replace

    from lagrange_xval.studies import stress

    settings = replace(stress.QUICK, sections=("drift", "stability"))
    results = stress.run_stress(None, files=[without_energies(tmp_path)], settings=settings)
    skipped = {s["section"]: s["why"] for s in results["skipped"]}
    assert skipped == {
        "drift": "T and V not provided: no energy to follow",
        "stability (energy criterion)": "T and V not provided: the energy criterion skipped, divergence alone judged",
    }, skipped
    rows = results["stability"]
    assert {r["criterion"] for r in rows} == {"divergence"}
    for r in rows:
        if r["engine"] == "mujoco":  # MuJoCo's boundaries lie far above the bottom of the range
            assert r["max_stable"] is not None and r["max_stable"] > 1e-3, r


def test_stress_skip_reasons_are_true():
    """A damped, driven model is "not conservative" for its damping and inputs, never its gravity; a
    3-joint system without two bodies named is not "one coordinate"."""
    from types import SimpleNamespace

    from lagrange_xval.studies import stress
    from lagrange_xval.studies.stress.conditioning import no_sweep_reason
    from lagrange_xval.studies.stress.output import prepare, run_section
    from lagrange_xval.systems import System

    acrobot = System.from_files(EXAMPLES / "acrobot.xml", EXAMPLES / "acrobot.py")
    done = run_section((acrobot, *prepare(acrobot)), "drift", stress.QUICK)
    assert [s["why"] for s in done["skipped"]] == ["not conservative (the model has damping and inputs)"]
    assert no_sweep_reason(SimpleNamespace(nv=1, bodies=("a",))).startswith("one coordinate")
    three = no_sweep_reason(SimpleNamespace(nv=3, bodies=()))
    assert "one coordinate" not in three and "fewer than two bodies named" in three, three


def test_derive_predicts_a_spatial_model_and_python_before_working(tmp_path):
    """A 7-joint spatial chain (as the Panda with its fingers locked) is refused at once with its
    prediction, --python more so; the planar chain of 7 is not (its prediction is under the budget)."""
    from lagrange_xval.cli.commands import affordable, is_spatial
    from lagrange_xval.studies.chains import chain_mjcf
    from lagrange_xval.systems import System

    views = {}
    for kind in ("planar", "spatial"):
        (tmp_path / f"{kind}.xml").write_text(chain_mjcf(7, kind))
        system = System.model_only(tmp_path / f"{kind}.xml")
        views[kind] = (system.view, tuple(system.joints))
    assert not is_spatial(*views["planar"]) and is_spatial(*views["spatial"])
    affordable(7, spatial=False)
    with pytest.raises(HarnessError, match=r"7 joints: .* about 137 s .* x8 for a spatial model\), over the 120 s"):
        affordable(7, spatial=True)
    with pytest.raises(HarnessError, match=r"about 165 s .* x1.2 for --python"):
        affordable(7, spatial=True, python=True)
    with pytest.raises(HarnessError, match=r"^7 joints \(j0, j1, j2, j3, j4, j5, j6\): .* or --lock some of them"):
        affordable(7, spatial=True, joints=[f"j{i}" for i in range(7)])  # the README: it names the joints


ROTATED = """<mujoco model="rotated">
  <compiler angle="radian"/>
  <option gravity="0 -9.81 0"/>
  <worldbody>
    <body name="arm" pos="0 0 0" quat="{w} {x} 0 0">
      <joint name="hinge" type="hinge" axis="0 0 1"/>
      <inertial pos="0.3 0 0" mass="1.5" diaginertia="0.01 0.02 0.03"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.mark.parametrize("fmt", [[], ["--python"]])
def test_derive_rounds_rotation_noise_and_says_so(tmp_path, capsys, fmt):
    """A body turned by pi/2 + 2e-11 about x (an rpy angle written to 11 digits), gravity along -y: its
    rotation's 2e-11 entries (which would put a 2e-11 term in G) are 0 in the derived equations, and the
    header says how many entries were rounded."""
    import math

    half = (math.pi / 2 + 2e-11) / 2
    (tmp_path / "rotated.xml").write_text(ROTATED.format(w=repr(math.cos(half)), x=repr(math.sin(half))))
    assert main(["derive", "--model", str(tmp_path / "rotated.xml"), *fmt]) == 0
    out = capsys.readouterr().out
    assert "rotation entries within 1e-10 of 0 or +-1 rounded to them (" in out, out[:600]
    assert "e-11" not in out and "e-12" not in out, out


def test_derive_python_of_a_spatial_chain_is_short_and_computes_the_engines_dynamics(tmp_path, capsys):
    """A 4-joint spatial chain (exact, not simplified): `--python` writes each function's common
    subexpressions once (70 KB; 1.2 MB expanded before) and gives MuJoCo's M and bias."""
    import runpy

    import numpy as np
    from lagrange_xval.sources import make_source
    from lagrange_xval.studies.chains import chain_mjcf
    from lagrange_xval.systems import System
    from lagrange_xval.systems.scaffold import module_text

    model = tmp_path / "chain4.xml"
    model.write_text(chain_mjcf(4, "spatial"))
    assert main(["derive", "--model", str(model), "--python"]) == 0
    code = capsys.readouterr().out
    assert len(code) < 200_000 and "cse_0 = " in code, len(code)
    (tmp_path / "mine.py").write_text(module_text("mine", model) + "\n\n" + code)
    derived = runpy.run_path(str(tmp_path / "mine.py"))
    system = System.model_only(model)
    p = derived["parameters"](system.view)
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (5, 4))
    v = np.random.default_rng(1).uniform(-2, 2, (5, 4))
    mj = make_source(system, "mujoco")
    np.testing.assert_allclose(derived["mass_matrix"](p, q), mj.mass_matrix(q), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(derived["bias"](p, q, v), mj.bias(q, v), rtol=1e-10, atol=1e-10)

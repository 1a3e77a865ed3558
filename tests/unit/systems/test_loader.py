"""Systems beyond the notes, as a user brings them: a folder of their own, each derivation in one of
the four forms, checked through the public API (examples/, copied to a temporary folder).

    furuta_pendulum   the rotary inverted pendulum, full 3D inertias, motor on the arm only   (d) energies
    cart_pole         a slide joint with a force input                                       (b) implicit
    acrobot           Spong's acrobot, Drake's parameters, torque at the elbow only          (c) explicit
    spatial_arm       3 DOF, non-diagonal inertias, damping and motors on every joint        (a) M + bias
"""

from __future__ import annotations

import shutil
from pathlib import Path

import lagrange_xval as lx
import pytest
from lagrange_xval import systems
from lagrange_xval.handwritten.forms import written_form
from lagrange_xval.testing import systems_in

FOLDER = Path(__file__).resolve().parents[3] / "examples"
FORMS = {"furuta_pendulum": "d", "cart_pole": "b", "acrobot": "c", "spatial_arm": "a"}

# One realistic mistake per system, written into its own form, and the term it is in.
MISTAKES = {
    "furuta_pendulum": (
        'np.sum(k["vc1"] ** 2, axis=-1) + 0.5 * p.I1zz',
        'np.sum(k["vc1"] ** 2, axis=-1) + p.I1zz',
        "mass matrix",
    ),
    "cart_pole": ("- p.mp * lc * s * dth**2 + p.kx * dx", "+ p.mp * lc * s * dth**2 + p.kx * dx", "velocity"),
    "acrobot": ("G2 = p.m2 * p.lc2 * p.g * s12", "G2 = p.m2 * p.l1 * p.g * s12", "gravity"),
    "spatial_arm": ("b = np.array([p.b1, p.b2, p.b3])", "b = np.array([p.b1, p.b3, p.b2])", "friction"),
}


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("my_systems")
    for f in FOLDER.iterdir():
        if f.suffix in (".py", ".xml"):
            shutil.copy(f, out / f.name)
    return out


def test_the_folder_holds_every_form(folder):
    found = {p.id: written_form(p.values[0].equations) for p in systems_in(folder)}
    assert found == FORMS


@pytest.mark.parametrize("name", sorted(FORMS))
def test_user_system_passes_every_check(folder, name):
    """Model checks, pointwise agreement of the three sources and every term at 4 probes."""
    result = lx.check(lx.System.from_files(folder / f"{name}.xml", folder / f"{name}.py"), n_states=200, probes=4)
    result.assert_ok()
    assert {r.probe for r in result.rows if r.check == "derivation"} >= {0, 1, 2, 3, 4}


@pytest.mark.parametrize("name", sorted(MISTAKES))
def test_a_wrong_variant_of_each_user_system_is_caught(tmp_path, folder, name):
    """The same system with one mistake in its own form: the term that holds it is named."""
    old, new, term = MISTAKES[name]
    text = (folder / f"{name}.py").read_text()
    assert text.count(old) == 1, old
    (tmp_path / f"{name}.py").write_text(text.replace(old, new))
    shutil.copy(folder / f"{name}.xml", tmp_path / f"{name}.xml")
    result = lx.check(lx.System.from_files(tmp_path / f"{name}.xml", tmp_path / f"{name}.py"), n_states=200, probes=2)
    assert not result.passed
    assert result.data["derivation"]["first_disagreeing_term"] == term, result.statement
    with pytest.raises(AssertionError, match=term):
        result.assert_ok()


def test_run_on_a_model_and_equations_outside_the_repository(tmp_path):
    """`lagrange-xval run --model --equations` from a folder of one's own: a derivation wrong only where
    l != 1 fails with the term named on the console, and the report set (with its replay) is written there."""
    import subprocess
    import sys

    source = (FOLDER / "cart_pole.py").read_text()
    old = "- p.mp * p.g * lc * s - tau[..., 1]"
    assert source.count(old) == 1
    (tmp_path / "my_cart.py").write_text(source.replace(old, "- p.mp * p.g * p.l * s - tau[..., 1]"))
    shutil.copy(FOLDER / "cart_pole.xml", tmp_path / "my_cart.xml")
    run = subprocess.run(
        [sys.executable, "-m", "lagrange_xval.cli", "run", "--model", "my_cart.xml"]
        + ["--equations", "my_cart.py", "--out", "out", "--states", "100", "--probes", "2"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 1, run.stderr[-2000:]
    assert "my_cart: FAIL; your derivation: gravity disagrees at the model's parameters; G[theta]" in run.stderr, (
        run.stderr[-2000:]
    )
    assert {p.name for p in (tmp_path / "out").iterdir()} >= {"report.html", "report.md", "results.json", "my_cart.rrd"}


def test_check_and_simulate_take_a_model_and_equations(tmp_path):
    """`check` and `simulate` on a user's files; a SYSTEM name and files together, or neither, is one line."""
    import json
    import subprocess
    import sys

    shutil.copy(FOLDER / "acrobot.xml", tmp_path / "acro.xml")
    shutil.copy(FOLDER / "acrobot.py", tmp_path / "acro.py")
    files = ["--model", "acro.xml", "--equations", "acro.py"]

    def cli(*args: str) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, "-m", "lagrange_xval.cli", *args]
        return subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=600)

    checked = cli("check", *files, "--states", "20", "--json")
    assert checked.returncode == 0, checked.stderr[-2000:]
    assert json.loads(checked.stdout)["system"] == "acro"
    simulated = cli("simulate", *files, "--source", "mujoco", "--q0", "0.1,0.2", "--v0", "0,0")
    assert simulated.returncode == 2 and "--t-end" in simulated.stderr  # argparse: the required options
    simulated = cli(
        "simulate",
        *files,
        "--source",
        "hand",
        "--q0",
        "0.1,0.2",
        "--v0",
        "0,0",
        "--t-end",
        "1",
        "--dt-out",
        "0.5",
        "--out",
        "sim.csv",
    )
    assert simulated.returncode == 0, simulated.stderr
    rows = [line for line in (tmp_path / "sim.csv").read_text().splitlines() if not line.startswith("#")]
    assert len(rows) == 4  # column names and t = 0, 0.5, 1 under the commented header
    both = cli("check", "simple_pendulum", *files)
    neither = cli("check")
    assert both.returncode == 2 and "not both" in both.stderr and both.stderr.count("\n") == 1
    assert neither.returncode == 2 and "name a SYSTEM" in neither.stderr and neither.stderr.count("\n") == 1


def test_a_system_is_found_again_by_its_key_in_another_process():
    """bench and stress workers find a person's system by its files (systems.key_of / from_key), and a
    repository system by its name."""
    from lagrange_xval.systems import from_key, key_of

    own = systems.System.from_files(FOLDER / "acrobot.xml", FOLDER / "acrobot.py")
    key = key_of(own)
    assert key.startswith("file:") and str((FOLDER / "acrobot.xml").resolve()) in key
    again = from_key(key)
    assert again.name == own.name and again.mjcf.resolve() == own.mjcf.resolve()
    assert vars(again.params) == vars(own.params)  # the module is loaded again: its own Params class
    assert key_of(systems.load("gimbal")) == "gimbal" and from_key("gimbal").name == "gimbal"


@pytest.mark.parametrize("command", ["bench", "stress"])
def test_bench_and_stress_take_model_and_equations_together(command, capsys):
    from lagrange_xval.cli import main

    assert main([command, "--model", str(FOLDER / "acrobot.xml")]) == 2
    assert "--model and --equations go together" in capsys.readouterr().err


def _without(text: str, names: tuple[str, ...]) -> str:
    """The module's source without the top-level functions (and assignments) called `names`."""
    import ast

    lines = text.splitlines(keepends=True)
    for node in sorted(ast.parse(text).body, key=lambda n: -n.lineno):
        named = getattr(node, "name", None) or next(
            (t.id for t in getattr(node, "targets", []) if isinstance(t, ast.Name)), None
        )
        if named in names:
            del lines[node.lineno - 1 - len(getattr(node, "decorator_list", [])) : node.end_lineno]
    return "".join(lines)


def _repository_modules() -> list[tuple[Path, Path]]:
    """(model, equations module) of every repository system and every example, discovered."""
    pairs = [
        (systems.MODELS_DIR / f"{n}.xml", systems.PACKAGE_ROOT / "equations" / f"{n}.py")
        for n in systems.system_names()
    ]
    return pairs + [(m, e) for m, e in systems.pairs_in(FOLDER)]


@pytest.mark.parametrize(("model", "module"), _repository_modules(), ids=lambda p: Path(p).stem)
def test_a_copy_of_every_repository_module_loads_from_any_folder(tmp_path, model, module):
    """Every repository module imports its helpers by their public name (lagrange_xval.forms), never
    relatively: copied with its model into a folder of a person's own, it loads as it is."""
    text = module.read_text()
    assert "from lagrange_xval.forms import" in text and "_forms" not in text, f"{module.name}: imports"
    shutil.copy(model, tmp_path / model.name)
    shutil.copy(module, tmp_path / module.name)
    system = lx.System.from_files(tmp_path / model.name, tmp_path / module.name)
    assert system.nv == len(system.coordinates) >= 1


def test_a_copied_repository_module_is_checked_from_any_folder(tmp_path, monkeypatch):
    """One copy checked end to end through the public API, from a folder outside the repository."""
    monkeypatch.chdir(tmp_path)
    for f in ("cart_pole.xml", "cart_pole.py"):
        shutil.copy(FOLDER / f, tmp_path / f)
    lx.check(lx.System.from_files("cart_pole.xml", "cart_pole.py"), n_states=50, probes=1).assert_ok()


def test_the_public_forms_module_documents_every_helper_it_exports():
    """lagrange_xval.forms re-exports the implementation (no second copy) and its docstring names each helper."""
    import lagrange_xval.forms as forms
    from lagrange_xval import forms as _forms

    assert forms.__all__ and forms.__doc__
    for name in forms.__all__:
        assert getattr(forms, name) is getattr(_forms, name), name
        assert name in forms.__doc__, f"lagrange_xval.forms's docstring does not document {name}"


def test_a_module_with_a_plain_dataclass_is_judged_in_process_too(tmp_path):
    """`Params` as a plain `@dataclass` (unhashable) in a module handed to `System` as an object: the caches
    that key on parameter sets take it (before: TypeError: unhashable type: 'Params' at the traced dynamics)."""
    import importlib.util
    import sys

    from lagrange_xval.dynamics.reference import rhs_check

    text = (FOLDER.parent / "equations" / "simple_pendulum.py").read_text()
    assert "@dataclass(frozen=True)" in text
    (tmp_path / "plain_pendulum.py").write_text(text.replace("@dataclass(frozen=True)", "@dataclass"))
    spec = importlib.util.spec_from_file_location("plain_pendulum", tmp_path / "plain_pendulum.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["plain_pendulum"] = module
    try:
        spec.loader.exec_module(module)
        system = systems.System(
            name="plain_pendulum", mjcf=FOLDER.parent / "models" / "simple_pendulum.xml", equations=module
        )
        assert type(system.params).__name__ == "Params" and hash(system.params) == hash(system.params)
        assert rhs_check(system) < 1e-12
        assert lx.check(system).passed
    finally:
        del sys.modules["plain_pendulum"]


def test_a_module_without_dynamics_is_named_once(tmp_path, capsys):
    """Issue 44 item 4: "lagrange-xval: error: triple.py: triple.py: the dynamics are not provided" named
    the module twice."""
    from lagrange_xval.cli import main

    root = Path(__file__).resolve().parents[3]
    module = (root / "equations" / "simple_pendulum.py").read_text()
    stubbed = tmp_path / "bare.py"
    for name in ("mass_matrix", "kinetic_energy", "residual", "qacc", "hamiltonian"):
        module = module.replace(f"def {name}(", f"def {name}_unused(")
    stubbed.write_text(module)
    assert main(["check", "--model", str(root / "models" / "simple_pendulum.xml"), "--equations", str(stubbed)]) == 2
    err = capsys.readouterr().err.strip()
    assert "bare.py: the dynamics are not provided" in err and err.count("bare.py") == 1, err

"""The whole end-to-end jobs (marker `long`) of systems/; their helpers stay with the unit tests in
tests/unit/systems/."""

from __future__ import annotations

import shutil

import pytest
from lagrange_xval import systems
from lagrange_xval.cli import main

from tests.unit.systems.test_loader import FOLDER, FORMS, _without
from tests.unit.systems.test_scaffold import ARM, _derive_python


@pytest.mark.long
def test_new_filled_in_from_derive_passes_every_check_locked(tmp_path, capsys):
    """`new --lock` and `derive --python --lock` on the same URDF: derive's code is the dynamics of
    new's module as it is, which passes check (the model's numbers and probes moving every field),
    and `check` and `simulate` take the same --lock; a mass written as the model's number is caught
    by the probes. The last joint is locked: a locked joint above a moving body puts that body in an
    MJCF <frame>, which the probes' writer (set_values) cannot edit yet."""
    import lagrange_xval as lx

    assert main(["new", "mine", "--model", str(ARM), "--dir", str(tmp_path), "--lock", "elbow"]) == 0
    module = tmp_path / "mine.py"
    module.write_text(module.read_text() + "\n\n" + _derive_python(ARM, "--lock", "elbow"))
    system = lx.System.from_files(ARM, module, locked=("elbow",))
    assert system.coordinates == ("yaw", "shoulder")
    lx.check(system, n_states=50, probes=2).assert_ok()
    files = ["--model", str(ARM), "--equations", str(module), "--lock", "elbow"]
    assert main(["check", *files, "--states", "50"]) == 0, capsys.readouterr().out[-2000:]
    out = tmp_path / "sim.csv"
    args = ["--source", "hand", "--q0", "0.1,0.2", "--v0", "0,0", "--t-end", "0.1", "--dt-out", "0.05"]
    assert main(["simulate", *files, *args, "--out", str(out)]) == 0
    assert "# locked: elbow (made fixed at zero)" in out.read_text()
    wrong = tmp_path / "wrong.py"
    wrong.write_text(module.read_text().replace("m_link2 = p.m_link2", f"m_link2 = {system.params.m_link2!r}"))
    result = lx.check(lx.System.from_files(ARM, wrong, locked=("elbow",)), n_states=50, probes=2)
    assert not result.passed and all(f.probe for f in result.failures if f.check == "derivation")


@pytest.mark.long
def test_run_systems_folder(tmp_path):
    """`run --systems DIR` runs every <name>.xml with its <name>.py; a file without its partner is
    named, and the others run all the same."""
    import subprocess
    import sys

    from lagrange_xval import systems

    source = systems.load("simple_pendulum")
    (tmp_path / "mine").mkdir()
    shutil.copy(source.mjcf, tmp_path / "mine" / "pendulum.xml")
    shutil.copy(source.equations.__file__, tmp_path / "mine" / "pendulum.py")  # imports lagrange_xval.forms
    command = [sys.executable, "-m", "lagrange_xval.cli", "run", "--systems", "mine", "--out", "out"]
    ok = subprocess.run(
        command + ["--states", "50", "--probes", "1", "--no-replay"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert ok.returncode == 0 and "pendulum: pass" in ok.stderr, ok.stderr[-2000:]
    (tmp_path / "mine" / "lonely.xml").write_text("<mujoco/>")
    # issue 26: a file without its partner is named, and the rest are validated all the same
    more = subprocess.run(
        command + ["--states", "50", "--probes", "1", "--no-replay"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert more.returncode == 0 and "pendulum: pass" in more.stderr, more.stderr[-2000:]
    assert (
        "lonely: not checked: " in more.stdout and "lonely.xml has no lonely.py or lonely.toml beside it" in more.stdout
    )


@pytest.mark.long
@pytest.mark.parametrize("name", sorted(FORMS))
def test_every_new_system_passes_the_whole_job(name):
    """Verdicts, trajectories, chaos and the mirrors of MuJoCo's integrators: a 3-DOF damped arm (whose
    flow contracts phase volume until Phi is singular in double precision) and explicit accelerations
    under Euler's implicit damping included."""
    from lagrange_xval.stages.pipeline import run_system

    result = run_system(
        systems.System.from_files(FOLDER / f"{name}.xml", FOLDER / f"{name}.py"), n_states=100, seed=0, n_probes=1
    )
    assert result["passed"], result["failed"]
    assert not [k for k, v in result["stages"].items() if "outcome" in v], result["stages"]


@pytest.mark.long
def test_optional_functions_left_out_are_not_checked_never_failed(tmp_path):
    """A derivation with only its dynamics (no energies, no body poses, no printed variants) gets the
    whole job; what it leaves out is listed as not checked, in the derivation and the pointwise check."""
    import json

    from lagrange_xval.cli import main

    left_out = ("kinetic_energy", "potential_energy", "body_positions", "body_rotations", "VARIANTS")
    shutil.copy(FOLDER / "acrobot.xml", tmp_path / "acrobot.xml")
    (tmp_path / "acrobot.py").write_text(_without((FOLDER / "acrobot.py").read_text(), left_out))
    system = systems.System.from_files(tmp_path / "acrobot.xml", tmp_path / "acrobot.py")
    assert not hasattr(system.equations.ORIGINAL, "kinetic_energy")
    out = tmp_path / "reports"
    code = main(
        [
            "run",
            "--model",
            str(tmp_path / "acrobot.xml"),
            "--equations",
            str(tmp_path / "acrobot.py"),
            "--out",
            str(out),
            "--states",
            "200",
        ]
    )
    result = json.loads((out / "results.json").read_text())["systems"]["acrobot"]
    assert code == 0 and result["passed"], result["failed"]
    assert result["derivation"]["not_checked"] == [f"{n}() not provided" for n in left_out[:4]]
    assert {"T", "V", "body_positions", "body_rotations"} <= {s.split()[0] for s in result["pointwise"]["not_checked"]}
    assert not {"T", "V"} & {r["quantity"] for r in result["pointwise"]["rows"] if "hand" in r["pair"]}
    assert {"T", "V"} <= {r["quantity"] for r in result["pointwise"]["rows"]}  # the engines still agree on them
    assert (out / "acrobot.rrd").is_file()
    assert "Not checked (the derivation does not provide them" in (out / "report.md").read_text()

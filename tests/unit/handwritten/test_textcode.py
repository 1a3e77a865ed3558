"""Issue 35's last gaps: the text form evaluated in a worker like a person's module, a step's three calls
in one round trip, `check SYSTEM` on a repository model that cannot be read, a busy loop in `run`.

The other cases of the issue's list are tested where their surface is: tests/unit/handwritten/test_worker.py (the
worker: alarms, C calls, forks, threads, atexit, numpy patched, exceptions of any kind, forged lines),
tests/unit/handwritten/test_expression.py (text-form bombs, names, cache headers, huge models, non-finite numbers,
HOME),
tests/unit/core/test_guard.py (time limits).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.core.guard import Stopped
from lagrange_xval.handwritten import textform
from lagrange_xval.handwritten.worker import Raised
from lagrange_xval.model.start import Scheme
from lagrange_xval.sources.hand import HandSource
from lagrange_xval.systems import System, load_module, model_view

from tests.unit.core.test_guard import CLI, ROOT, TIMEOUT, _system

TOML = """
coordinates = ["theta"]
T = "(m*l^2 + I)/2*dtheta^2"
V = "-m*g*l*cos(theta)"
friction = ["-d*dtheta"]
[symbols]
m = "body/link/mass"
l = "-body/link/com[1]"
I = "body/link/inertia[2][2]"
g = "-gravity[1]"
d = "joint/theta/damping"
"""


def _text_system(folder: Path) -> tuple[Path, Path]:
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(ROOT / "models/simple_pendulum.xml", folder / "tp.xml")
    (folder / "tp.toml").write_text(TOML)
    return folder / "tp.xml", folder / "tp.toml"


def test_the_text_form_is_evaluated_in_its_worker(tmp_path: Path) -> None:
    """The energies of a text form are called in a worker process (each call counted there, none left
    once it is closed), and give the numbers of the file's expressions."""
    model, toml = _text_system(tmp_path)
    module = textform.module_from_file(toml, model_view(model), time_limit=7.0)
    worker = module.WORKER
    assert worker.time_limit == 7.0 and module.__file__ == str(toml)
    p = module.parameters(model_view(model))
    q, v = np.array([[0.3], [1.1]]), np.array([[0.5], [-2.0]])
    before = worker.calls
    energy = module.potential_energy(p, q) + module.kinetic_energy(p, q, v)
    assert worker.calls == before + 2
    expected = -p.m * p.g * p.l * np.cos(q[:, 0]) + (p.m * p.l**2 + p.I) / 2 * v[:, 0] ** 2
    assert np.allclose(energy, expected, rtol=1e-14, atol=0)
    assert np.allclose(module.passive(p, q, v), -p.d * v, rtol=1e-14, atol=0)
    worker.close()
    with pytest.raises(Stopped, match="tp.toml"):
        module.potential_energy(p, q + 1)


def test_a_forked_copy_of_the_harness_evaluates_a_text_form_in_a_worker_of_its_own(tmp_path: Path) -> None:
    """The text form's code has no file: a process forked after loading it imports it again from its
    text in a worker of its own, with the same numbers."""
    model, toml = _text_system(tmp_path)
    module = textform.module_from_file(toml, model_view(model), time_limit=30.0)
    p, q = module.parameters(model_view(model)), np.array([[0.4]])
    expected = module.potential_energy(p, q)
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the forked copy
        try:
            os.write(write, b"1" if np.array_equal(module.potential_energy(p, q), expected) else b"0")
            module.WORKER.close()
        finally:
            os._exit(0)
    os.waitpid(pid, 0)
    assert os.read(read, 1) == b"1"
    assert np.array_equal(module.potential_energy(p, q), expected)
    module.WORKER.close()


def test_a_text_form_takes_the_time_limit_of_its_system(tmp_path: Path) -> None:
    """load_module of a .toml gives its worker the time limit asked for (one budget for its calls)."""
    model, toml = _text_system(tmp_path)
    module = load_module(toml, model=model, time_limit=11.0)
    assert module.WORKER.time_limit == 11.0
    module.WORKER.close()


def test_a_text_form_passes_check(tmp_path: Path) -> None:
    """The pendulum as text, its energies run in the worker: check passes (the derivatives are traced
    through the worker and rebuilt in the judge's sympy)."""
    model, toml = _text_system(tmp_path)
    proc = subprocess.run(
        [*CLI, "check", "--model", str(model), "--equations", str(toml), "--states", "5", "--probes", "0"],
        capture_output=True, text=True, timeout=TIMEOUT,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip().splitlines()[-1].startswith("verdict: tp: pass"), proc.stdout[-2000:]


def test_a_step_asks_the_worker_once(tmp_path: Path) -> None:
    """forward (a mirror's step) sends passive, bias and M in one request, with the numbers of three."""
    system = System.from_files(*_system(tmp_path, "pend"))
    source, worker = HandSource(system), system.equations.WORKER
    q, v, tau = np.array([[0.3], [0.9]]), np.array([[0.5], [-1.0]]), np.array([[0.2], [0.0]])
    before = worker.calls
    a = source.forward(q, v, tau)
    assert worker.calls == before + 1
    separate = (tau + source.passive(q, v) - source.bias(q, v))[..., 0] / source.mass_matrix(q)[..., 0, 0]
    assert np.array_equal(a[..., 0], separate)


def test_a_step_names_the_function_that_raised(tmp_path: Path) -> None:
    """In the batched step, the exception is the function's that raised it (bias), named as before."""
    model, equations = _system(tmp_path, "pend")
    text = equations.read_text().replace(
        "    return p.m * p.g", "    raise ValueError('bias is wrong')\n    return p.m"
    )
    equations.write_text(text)
    system = System.from_files(model, equations)
    with pytest.raises(Raised, match="bias is wrong") as caught:
        HandSource(system).forward(np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)))
    assert caught.value.function == "bias" and caught.value.kind == "ValueError"


BOMB = (
    '<?xml version="1.0"?>\n<!DOCTYPE mujoco [<!ENTITY a "aaaaaaaaaa">'
    + "".join(f'<!ENTITY {c} "{("&" + p + ";") * 10}">' for p, c in zip("abcdefg", "bcdefgh", strict=True))
    + "]>\n"
)
XXE = '<?xml version="1.0"?>\n<!DOCTYPE mujoco [<!ENTITY x SYSTEM "file:///etc/hostname">]>\n'


def _repository_model(case: str, folder: Path) -> str:
    text = (ROOT / "models/simple_pendulum.xml").read_text()
    head = text.index("<mujoco")
    return {
        "malformed": lambda: text[:300],
        "entity-bomb": lambda: BOMB + text[head:].replace("<mujoco", '<mujoco model="&h;"', 1),
        "xxe": lambda: XXE + text[head:].replace("<mujoco", '<mujoco model="&x;"', 1),
        "missing-include": lambda: text.replace("<worldbody>", f'<include file="{folder / "gone.xml"}"/><worldbody>'),
        "urdf": lambda: (ROOT / "examples/urdf/spatial_arm.urdf").read_text(),
    }[case]()


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("malformed", r"simple_pendulum.xml: not well-formed XML"),
        ("entity-bomb", r"simple_pendulum.xml: declares <!DOCTYPE \.\.\.>"),
        ("xxe", r"simple_pendulum.xml: declares <!DOCTYPE \.\.\.>"),
        ("missing-include", r'<include file="[^"]*gone.xml">: no such file'),
        ("urdf", r"models/simple_pendulum.xml: a repository model is MJCF \(root <mujoco>\), this one is <robot>"),
    ],
    ids=["malformed", "entity-bomb", "xxe", "missing-include", "urdf"],
)
def test_check_of_a_repository_system_whose_model_cannot_be_read_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, case: str, message: str
) -> None:
    """`check SYSTEM` on a repository model that is malformed, holds an entity bomb or an external entity,
    includes a file that does not exist, or is a URDF: status 2 and one error line naming the cause (not a
    failing verdict, status 1)."""
    from lagrange_xval.cli import main

    models = tmp_path / "models"
    models.mkdir()
    for path in (ROOT / "models").glob("*.xml"):
        shutil.copy(path, models / path.name)
    (tmp_path / "inc.xml").write_text('<mujoco><option timestep="0.002"/></mujoco>')
    (models / "simple_pendulum.xml").write_text(_repository_model(case, tmp_path))
    monkeypatch.setattr(systems.registry, "MODELS_DIR", models)
    assert main(["check", "simple_pendulum", "--states", "5"]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and re.search(message, lines[0]), captured.err[-2000:]
    assert lines[0].startswith("lagrange-xval: error: ") and "verdict:" not in captured.out


def test_audit_of_a_urdf_with_a_mass_of_1e308_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A URDF whose masses are 1e308 (their products overflow): status 2, one error line naming each body's
    mass, no numpy warning and no NaN difference."""
    from lagrange_xval.cli import main

    text = (ROOT / "examples/urdf/spatial_arm.urdf").read_text()
    (tmp_path / "big.urdf").write_text(re.sub(r'<mass value="[^"]*"', '<mass value="1e308"', text))
    assert main(["audit", str(tmp_path / "big.urdf")]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and "body 'link1' mass (1e+308) exceeds 1e+100" in lines[0], captured.err[-2000:]
    assert "nan" not in captured.out.lower()


class _OneByOne:
    """A hand source asked function by function (no batch): the reference of the batched step."""

    def __init__(self, source: HandSource) -> None:
        self.source = source

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        return self.source.mass_matrix(q)

    def bias(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self.source.bias(q, v)

    def passive(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self.source.passive(q, v)


def test_an_implicit_mirror_step_asks_m_passive_and_bias_together(tmp_path: Path) -> None:
    """MuJoCo's implicit scheme mirrored on a worker's module: M, passive and bias in one request (and the
    velocity derivative's bias in another), the same bits as asking one by one."""
    from lagrange_xval.dynamics.mirror import Stepper

    system = System.from_files(*_system(tmp_path, "pend"))
    source, worker = HandSource(system), system.equations.WORKER
    q, v, tau = np.array([[0.3], [0.9]]), np.array([[0.5], [-1.0]]), np.array([[0.2], [0.0]])
    before = worker.calls
    batched = Stepper(system, source, Scheme("implicit", 0.01)).step(q, v, tau)
    assert worker.calls == before + 2  # M, passive and bias; then bias at the shifted velocities
    alone = Stepper(system, _OneByOne(source), Scheme("implicit", 0.01)).step(q, v, tau)  # type: ignore[arg-type]
    assert all(np.array_equal(a, b) for a, b in zip(batched, alone, strict=True))

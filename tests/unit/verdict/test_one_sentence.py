"""One sentence, one author (issue 34): the verdict's statement that `decide` writes is the line
`check` prints, `run`'s console and the report's headline show, and `lagrange_xval.check` returns;
the renderers label it, never recompose it. Wrong modules are written here, from examples/, with
one realistic slip each; and no row or section says what its own numbers do not show."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import lagrange_xval as lx
import pytest
from lagrange_xval.cli import main
from lagrange_xval.report.sections import derivation_row

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"

# (example, the line as written, the slip, the term the slip is in)
SLIPS = {
    "acrobot_l_for_lc": (
        "acrobot",
        "G1 = (p.m1 * p.lc1 + p.m2 * p.l1) * p.g",
        "G1 = (p.m1 * p.lc1 + p.m2 * p.lc1) * p.g",
        "gravity",
    ),
    "cart_pole_sign": (
        "cart_pole",
        "- p.mp * p.g * lc * s - tau[..., 1]",
        "+ p.mp * p.g * lc * s - tau[..., 1]",
        "gravity",
    ),
}
ARGS = ["--states", "40", "--probes", "2"]


@pytest.fixture(scope="module")
def wrong(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("wrong")
    for name, (example, old, new, _) in SLIPS.items():
        source = (EXAMPLES / f"{example}.py").read_text()
        assert source.count(old) == 1, f"{example}.py no longer has {old!r}"
        (folder / f"{name}.py").write_text(source.replace(old, new))
        shutil.copy(EXAMPLES / f"{example}.xml", folder / f"{name}.xml")
    return folder


def check_statement(folder: Path, name: str, capsys: pytest.CaptureFixture[str]) -> str:
    files = ["--model", str(folder / f"{name}.xml"), "--equations", str(folder / f"{name}.py")]
    assert main(["check", *files, *ARGS]) == 1
    last = capsys.readouterr().out.splitlines()[-1]
    prefix = f"verdict: {name}: FAIL: "
    assert last.startswith(prefix), last
    return last[len(prefix) :]


@pytest.mark.parametrize("name", sorted(SLIPS))
def test_check_run_report_and_api_show_the_same_sentence(name, wrong, tmp_path, capsys):
    statement = check_statement(wrong, name, capsys)
    assert statement.startswith(f"{SLIPS[name][3]} disagrees"), statement
    files = ["--model", str(wrong / f"{name}.xml"), "--equations", str(wrong / f"{name}.py")]
    out = tmp_path / "out"
    assert main(["run", *files, *ARGS, "--out", str(out), "--no-replay", "--no-cache"]) == 1
    console = capsys.readouterr().out.splitlines()
    assert console[-1] == f"  FAIL {name}: your derivation: {statement}", (console[-1], statement)
    results = json.loads((out / "results.json").read_text())
    s = results["systems"][name]
    assert s["statement"] == statement
    why = s["trajectories"]["information_only"]
    assert f"{SLIPS[name][3]} disagrees with the engines at the model's parameters" in why and "pointwise" not in why
    md = (out / "report.md").read_text()
    assert f"fails: your derivation: {statement}" in md.split("## Summary")[0], md[:800]
    system = lx.System.from_files(wrong / f"{name}.xml", wrong / f"{name}.py")
    assert lx.check(system, n_states=40, probes=2).statement == statement


def test_a_summary_row_marks_only_what_its_own_numbers_show():
    """A derivation that agrees in every term, in a system that fails after the verdict: the row names
    that failure, not a passing term beside ✗ FAIL."""
    s = {
        "derivation": {
            "kind": "hand",
            "verdict": "agrees",
            "summary": [
                {"term": "gravity", "passed": True, "worst_scaled": 3e-15, "tolerance": 1e-10, "engine": "mujoco"}
            ],
        },
        "pointwise": {"rows": []},
        "failed": ["trajectory hand (RK45) beyond the threshold"],
        "passed": False,
        "origin": "user",
    }
    row = derivation_row("arm", s)
    assert row[4] == "trajectory hand (RK45) beyond the threshold" and row[5] is None, row
    s["passed"] = True
    s["failed"] = []
    row = derivation_row("arm", s)
    assert row[4] == "gravity" and row[3].text == "pass", row


def test_an_energy_the_module_leaves_out_is_said_not_provided(tmp_path):
    """A free run's energy change, measured by a derivation without T and V: "T and V not provided",
    never an infinite change."""
    from lagrange_xval.dynamics.integrate import energy_missing
    from lagrange_xval.sources import make_sources

    source = (EXAMPLES / "acrobot.py").read_text()
    start, end = source.index("def kinetic_energy("), source.index("def body_positions(")
    (tmp_path / "acro.py").write_text(source[:start] + source[end:])
    shutil.copy(EXAMPLES / "acrobot.xml", tmp_path / "acro.xml")
    system = lx.System.from_files(tmp_path / "acro.xml", tmp_path / "acro.py")
    assert energy_missing(make_sources(system)["hand"]) == "T and V not provided"
    whole = lx.System.from_files(EXAMPLES / "acrobot.xml", EXAMPLES / "acrobot.py")
    assert energy_missing(make_sources(whole)["hand"]) == ""


def test_a_model_alone_gets_the_same_sentence_from_check_and_run(wrong, tmp_path, capsys):
    """No derivation: `check` and `run` say which sources were compared and that they agree, in one
    sentence (decide's)."""
    model = str(wrong / "acrobot_l_for_lc.xml")
    assert main(["check", "--model", model, "--states", "40"]) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    prefix = "verdict: acrobot_l_for_lc: pass: "
    assert last.startswith(prefix + "no derivation given; MuJoCo, Pinocchio"), last
    args = ["run", "--model", model, "--states", "40", "--out", str(tmp_path / "out"), "--no-replay", "--no-cache"]
    assert main(args) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"  pass acrobot_l_for_lc: {last[len(prefix) :]}"

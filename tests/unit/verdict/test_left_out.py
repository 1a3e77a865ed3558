"""A reader that cannot read the file is left out, not a refusal; a reader that misreads it is named
(issue 42). Pinocchio reads no height field, Drake's parser would end the process on a body of zero mass
(it is left out with one line), and MuJoCo's compiler rescales every mass to `<compiler settotalmass>`,
which Pinocchio and Drake ignore: each model is small and written here, each rule asked of the CLI."""

from __future__ import annotations

import importlib.util
import json
import os
from pathlib import Path

import pytest
from lagrange_xval import check
from lagrange_xval.cli import main
from lagrange_xval.sources import make_sources
from lagrange_xval.systems import System

HAS_DRAKE = importlib.util.find_spec("pydrake") is not None
needs_drake = pytest.mark.skipif(not HAS_DRAKE and os.environ.get("CI") != "true", reason="pydrake not installed")

HINGE = """<body name="{name}" pos="{pos}">
  <joint name="j{name}" axis="0 1 0"/>
  <geom type="capsule" fromto="0 0 0 0 0 -1" size="0.05" mass="{mass}"/>
  {inner}
</body>"""


def chain(n: int, *, world: str = "", compiler: str = "", tip: str = "") -> str:
    """An n-link planar pendulum (capsules of 1 m), with `world` beside it and `tip` in its last body."""
    inner = tip
    for i in reversed(range(n)):
        inner = HINGE.format(name=f"l{i}", pos="0 0 2" if i == 0 else "0 0 -1", mass=1.0 + 0.5 * i, inner=inner)
    asset = '<asset><hfield name="ground" nrow="3" ncol="3" size="1 1 0.1 0.1"/></asset>' if "hfield" in world else ""
    return f'<mujoco model="m">{compiler}{asset}<worldbody>{world}{inner}</worldbody></mujoco>'


HFIELD = '<geom type="hfield" hfield="ground"/>'
ZERO_MASS = '<body name="tool" pos="0 0 -1"><inertial pos="0 0 0" mass="0" diaginertia="0 0 0"/></body>'


def _json(capsys: pytest.CaptureFixture[str], path: Path, states: str = "5") -> tuple[int, dict]:
    status = main(["check", "--model", str(path), "--states", states, "--probes", "0", "--json"])
    return status, json.loads(capsys.readouterr().out)


@needs_drake
def test_a_file_pinocchio_refuses_is_judged_by_mujoco_and_drake(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "hf.xml"
    path.write_text(chain(2, world=HFIELD))
    sources = make_sources(System.model_only(path))
    assert "pinocchio" not in sources and {"mujoco", "drake"} <= set(sources)
    assert "Pinocchio cannot read it; likely a height-field geom" in sources.skipped["pinocchio"]
    status, out = _json(capsys, path)
    verdict = out["verdict"]
    assert status == 0 and verdict["passed"], verdict["statement"]
    why = verdict["excluded"]["pinocchio"]
    assert why.startswith("Pinocchio cannot read it; likely a height-field geom") and why.endswith(": excluded")
    assert verdict["statement"].startswith(why), verdict["statement"]
    assert "MuJoCo, Drake and the derived equations agree" in verdict["statement"]
    pairs = {pair for rows in out["max_disagreement"].values() for pair in rows}
    assert "drake~mujoco" in pairs and not any("pinocchio" in p for p in pairs), pairs
    result = check(System.model_only(path), n_states=5, probes=0)
    assert result.passed and result.data["excluded"] == verdict["excluded"]


@needs_drake
def test_a_file_only_mujoco_reads_is_refused_saying_who_could_not_and_why(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "alone.xml"
    path.write_text(chain(2, world=HFIELD, tip=ZERO_MASS))
    status = main(["check", "--model", str(path), "--states", "5", "--probes", "0"])
    err = capsys.readouterr().err
    assert status != 0 and "alone.xml: fewer than two readers can read it (MuJoCo only)" in err, err
    assert "Pinocchio cannot read it; likely a height-field geom" in err, err
    assert "Drake cannot read it: its parser ends the process" in err, err


@needs_drake
def test_one_reader_left_out_leaves_the_others_to_judge_when_the_model_has_no_symbolic_source(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Five joints (beyond the symbolic source): MuJoCo and Drake still judge without Pinocchio."""
    path = tmp_path / "five.xml"
    path.write_text(chain(5, world=HFIELD))
    status, out = _json(capsys, path, states="3")
    assert status == 0 and "pinocchio" in out["verdict"]["excluded"], out["verdict"]["statement"]
    assert "MuJoCo and Drake agree" in out["verdict"]["statement"], out["verdict"]["statement"]


SETTOTALMASS = '<compiler settotalmass="14"/>'


@needs_drake
def test_settotalmass_names_the_readers_that_ignore_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """MuJoCo scales every mass to the total; Pinocchio and Drake agree with each other and not with it:
    each is named with the known cause, not "Pinocchio reads the model otherwise than MuJoCo"."""
    path = tmp_path / "total.xml"
    path.write_text(chain(5, compiler=SETTOTALMASS))
    status, out = _json(capsys, path, states="3")
    statement = out["verdict"]["statement"]
    assert status != 0 and "reads the model otherwise than MuJoCo" not in statement, statement
    for reader in ("Pinocchio", "Drake"):
        assert f"{reader} misreads" in statement and "settotalmass" in statement, statement
    assert "not excluded, as fewer than two readers would be left" in statement, statement
    assert out["verdict"]["excluded"] == {}


@needs_drake
def test_settotalmass_on_a_small_chain_sets_both_readers_aside_for_the_derived_equations(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two joints: the model's derived equations read what MuJoCo compiled, so both misreaders are set
    aside, each named with the cause, and MuJoCo is held against the derived equations."""
    path = tmp_path / "total2.xml"
    path.write_text(chain(2, compiler=SETTOTALMASS))
    status, out = _json(capsys, path)
    excluded = out["verdict"]["excluded"]
    assert set(excluded) == {"pinocchio", "drake"}, out["verdict"]["statement"]
    assert all("settotalmass" in why and why.endswith(": excluded") for why in excluded.values()), excluded
    assert status == 0 and "MuJoCo and the derived equations agree" in out["verdict"]["statement"]


TARGET = """<body name="target" pos="0.5 0 0.1">
  <joint name="tx" type="slide" axis="1 0 0"/>
  <joint name="ty" type="slide" axis="0 1 0"/>
  <geom type="sphere" size="0.05" mass="0.2" contype="0" conaffinity="0"/>
</body>"""


@needs_drake
def test_a_misreading_on_a_body_with_several_joints_in_a_second_tree_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A second body tree whose body has two slides (one composite joint in Pinocchio) and a visual geom
    (contype="0" conaffinity="0"), whose mass Pinocchio leaves out: the audit reads the composite's parts
    and the tree as the harness's source does, so Pinocchio is set aside with that cause, not named as one
    that "reads the model otherwise than MuJoCo"."""
    path = tmp_path / "reach.xml"
    path.write_text(chain(2, world=TARGET))
    status, out = _json(capsys, path)
    statement = out["verdict"]["statement"]
    why = out["verdict"]["excluded"].get("pinocchio", "")
    assert "Pinocchio misreads target's mass" in why and "collision-free geoms" in why, statement
    assert status == 0 and "MuJoCo, Drake and the derived equations agree" in statement, statement


@needs_drake
def test_a_derivation_is_held_against_the_readers_that_can_read_the_model(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """simple_pendulum's model with a height field beside it: Pinocchio is left out with its reason and the
    derivation is judged against MuJoCo, Drake and the derived equations."""
    from lagrange_xval import systems

    system = systems.load("simple_pendulum")
    text = system.mjcf.read_text().replace(
        "<worldbody>",
        '<asset><hfield name="ground" nrow="3" ncol="3" size="1 1 0.1 0.1"/></asset><worldbody>' + HFIELD,
    )
    model, module = tmp_path / "mine.xml", tmp_path / "mine.py"
    model.write_text(text)
    module.write_text(Path(system.equations.__file__).read_text())
    status = main(["check", "--model", str(model), "--equations", str(module), "--states", "5", "--probes", "1"])
    out = capsys.readouterr().out
    verdict = next(line for line in out.splitlines() if line.startswith("verdict:"))
    assert status == 0 and "pass" in verdict, out[-1500:]
    assert "Pinocchio cannot read it; likely a height-field geom" in verdict and ": excluded" in verdict, verdict
    rows = [line.split() for line in out.splitlines() if line.split()[1:2] and "~" in line.split()[1]]
    assert rows and not any("pinocchio" in row[1] for row in rows), out[-1500:]

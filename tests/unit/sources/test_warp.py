"""MuJoCo Warp as a float32 source (issue 29): it agrees with C MuJoCo within the float32 tiers
(studies/float32.FLOAT32: eps32 x the term's scale, x cond(M) for qacc) on every repository system
and example, term by term; the float32 table's shape; `bench --float32` writes into bench.json.
Skipped only where the optional extra `warp` is not installed (and never under CI, whose lock has it)."""

from __future__ import annotations

import importlib.util
import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest
from lagrange_xval.cli import main
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.core.tolerances import SCALE_ALSO_BY
from lagrange_xval.sources import SOURCE_NAMES, make_source, make_sources
from lagrange_xval.studies.float32 import COLUMNS, EPS32, FLOAT32, QUANTITIES, run_float32
from lagrange_xval.systems import System, load, system_names
from lagrange_xval.verdict import pointwise

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
INSTALLED = importlib.util.find_spec("mujoco_warp") is not None and importlib.util.find_spec("warp") is not None
needs_warp = pytest.mark.skipif(
    not INSTALLED and os.environ.get("CI") != "true",  # under CI the lock installs it: a missing one fails
    reason="MuJoCo Warp is not installed: pip install 'lagrange-xval[warp]' (or -r requirements.lock)",
)
SYSTEMS = [*system_names(), *(f"example:{p.stem}" for p in sorted(EXAMPLES.glob("*.xml")))]
N_STATES = 64


def _system(name: str) -> System:
    if name.startswith("example:"):
        stem = name.removeprefix("example:")
        return System.from_files(EXAMPLES / f"{stem}.xml", EXAMPLES / f"{stem}.py")
    return load(name)


def test_warp_is_importable_under_ci():
    """The lock pins mujoco-warp and warp-lang: under CI a missing one is a failure, not a skip."""
    if os.environ.get("CI") != "true":
        pytest.skip("only under CI=true, where requirements.lock is installed")
    import mujoco_warp
    import warp

    assert mujoco_warp.__version__ == "4.0.0" and warp.__version__


def test_warp_is_never_a_default_source():
    """Float32 would fail the float64 tiers: `run` and `check` never compare it unless asked by name."""
    assert "warp" not in SOURCE_NAMES
    assert "warp" not in make_sources(load("simple_pendulum"))


def test_the_float32_tiers_are_eps32_times_the_scale():
    assert EPS32 == 2.0**-23
    assert FLOAT32.term.expected(3.0) == 3.0 * EPS32 and FLOAT32.term.expected(3.0, cond=50.0) == 3.0 * EPS32
    assert FLOAT32.of("qacc").expected(3.0, cond=50.0) == 150.0 * EPS32
    assert all(FLOAT32.of(q).tolerance(1.0) == FLOAT32.of(q).factor * EPS32 for q in QUANTITIES)


def test_a_missing_extra_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco_warp", None)  # an import of it raises ImportError
    with pytest.raises(HarnessError, match=r"pip install 'lagrange-xval\[warp\]'"):
        make_source(load("simple_pendulum"), "warp")


@needs_warp
@pytest.mark.parametrize("name", SYSTEMS)
def test_warp_agrees_with_c_mujoco_within_the_float32_tiers(name):
    """Every term at seeded random states (one Warp world each), within factor x eps32 x scale (x cond(M))."""
    system = _system(name)
    states = pointwise.random_states(system, n=N_STATES, seed=3)
    c, w = make_source(system, "mujoco"), make_source(system, "warp")
    a_ref = c.forward(states.q, states.v, states.tau)
    ours = c.evaluate(states.q, states.v, states.tau, a_ref)
    theirs = w.evaluate(states.q, states.v, states.tau, a_ref)
    cond = float(np.max(np.linalg.cond(ours["M"])))
    bad = []
    for term in QUANTITIES:
        scale = max(
            [float(np.abs(ours[term]).max())] + [float(np.abs(ours[k]).max()) for k in SCALE_ALSO_BY.get(term, ())]
        )
        error = float(np.abs(theirs[term] - ours[term]).max())
        tier = FLOAT32.of(term)
        expected = tier.expected(scale, cond)
        if not error <= tier.tolerance(scale, cond):
            how = f"eps32 x scale {scale:.3g}" + (f" x cond(M) {cond:.3g}" if tier.cond else "")
            bad.append(
                f"{term}: |warp - mujoco| {error:.2e} = {error / expected:.1f} x the expected {expected:.2e} "
                f"({how}); tier {tier.factor:g}x"
            )
    assert not bad, f"{name} on {w.device}: " + "; ".join(bad)


@needs_warp
def test_the_float32_table_has_every_term_and_the_trajectory_per_system():
    """A system whose notes map the joints (JOINT_MAP) and a generated chain: rows, references, runs."""
    results = run_float32(["double_pendulum_absolute"], chain_ns=(2,), robots=False, n_states=8, horizon=0.02)
    assert results["config"]["device"] in ("cpu", "cuda:0") and results["config"]["eps32"] == EPS32
    table = results["table"]
    assert all(tuple(r) == COLUMNS for r in table), [tuple(r) for r in table[:1]]
    for system in ("double_pendulum_absolute", "chain2"):
        terms = [r["term"] for r in table if r["system"] == system]
        assert terms == [*QUANTITIES, "q(0.02 s)"], terms
        run = results["systems"][system]["trajectory"]
        assert run["warp_vs_mujoco"]["max_abs"] < 1e-5, f"{system}: Warp's run left C MuJoCo's: {run}"
    reference = {r["system"]: r["reference"] for r in table if r["term"] == "M"}
    assert reference == {"double_pendulum_absolute": "hand", "chain2": "pinocchio"}
    chain = results["systems"]["chain2"]["trajectory"]
    assert (chain["integrator"], chain["steps"]) == ("Euler", 10)
    assert all(r["within_tier"] for s in results["systems"].values() for r in s["pointwise"])


@needs_warp
def test_bench_float32_writes_into_bench_json_and_keeps_the_rest(tmp_path, capsys):
    (tmp_path / "bench.json").write_text(json.dumps({"rows": [], "config": {"quick": True}}))
    assert main(["bench", "--float32", "simple_pendulum", "--quick", "--out", str(tmp_path)]) == 0
    bench = json.loads((tmp_path / "bench.json").read_text())
    assert bench["rows"] == [] and bench["config"] == {"quick": True}
    assert [r["term"] for r in bench["float32"]["table"]] == [*QUANTITIES, "q(0.2 s)"]
    out = capsys.readouterr().out
    assert "MuJoCo Warp 4.0.0 (float32, device" in out and "wrote" in out


@needs_warp
def test_bench_float32_measures_a_persons_own_system(tmp_path, capsys):
    """`--model PATH --equations PATH` alone: that system only (no repository systems, chains or arms)."""
    files = ["--model", str(EXAMPLES / "acrobot.xml"), "--equations", str(EXAMPLES / "acrobot.py")]
    assert main(["bench", "--float32", *files, "--quick", "--out", str(tmp_path)]) == 0
    table = json.loads((tmp_path / "bench.json").read_text())["float32"]["table"]
    assert {r["system"] for r in table} == {"acrobot"}
    assert {r["reference"] for r in table if r["term"] == "M"} == {"hand"}


@needs_warp
def test_a_reused_batch_carries_nothing_from_the_last_call():
    """Warp's Data of N worlds is kept per N: the same states after other states and after a run give the same bits."""
    system = load("gimbal")  # damped and actuated
    w = make_source(system, "warp")
    a, b = (pointwise.random_states(system, n=4, seed=s) for s in (1, 2))
    first = w.evaluate(a.q, a.v, a.tau, a.q)
    w.evaluate(b.q, b.v, b.tau, b.q)
    w.run(b.q, b.v, b.tau, 3, 2)
    again = w.evaluate(a.q, a.v, a.tau, a.q)
    assert all(np.array_equal(first[k], again[k]) for k in first), [
        k for k in first if not np.array_equal(first[k], again[k])
    ]
    runs = [w.run(a.q, a.v, a.tau, 3, 2)["q"] for _ in range(2)]
    assert np.array_equal(*runs)

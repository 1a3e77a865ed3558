"""Sweeps on a dask.distributed cluster give what the local executor gives: a small bench sweep and a
small stress run on a two-worker LocalCluster (threads of this process, for speed), compared with the
local process pool and the in-process run; `--executor` names the cluster. Nothing here is timed."""

from __future__ import annotations

import uuid
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

import pytest
from distributed import Client, LocalCluster
from lagrange_xval.cli import main
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.core.parallel import named_executor, parse_executor
from lagrange_xval.studies import bench, stress

DP = "double_pendulum_point"
PLAN = replace(bench.FULL, repeats=2, budget=60.0, min_timed=0.0)  # a short sweep
# what a run computes (its time aside): identical whatever executes it
SAME = ("status", "message", "error_2s", "error_10s", "error_horizon", "t_exceeds_tolerance", "nfev", "steps")


@pytest.fixture(scope="module")
def cluster_executor():
    with named_executor("dask", workers=2, processes=False) as executor:
        yield executor


def _specs():
    specs = [
        bench.taylor_spec(1e-9),
        bench.scipy_spec("hand", "solve_ivp", "DOP853", 1e-6, atol_factor=bench.FULL.atol_factor),
        bench.scipy_spec("hand", "odeint", "LSODA", 1e-8, atol_factor=bench.FULL.atol_factor),
        bench.step_spec("mujoco", "mujoco", "RK4", 1e-2),
        bench.step_spec("hand", "compiled_rk4", "RK4", 1e-2),
    ]
    for s in specs:
        s["method"] = bench.method_name(s)
    return specs


def test_a_bench_sweep_on_a_local_dask_cluster_equals_the_process_pool(cluster_executor):
    prepared = {DP: bench.prepare(DP, bench.FULL)}
    on_dask, _ = bench.sweep(prepared, _specs(), plan=PLAN, executor=cluster_executor)
    with ProcessPoolExecutor(max_workers=2) as pool:
        local, _ = bench.sweep(prepared, _specs(), plan=PLAN, executor=pool)
    assert [(r["method"], r["value"]) for r in on_dask] == [(r["method"], r["value"]) for r in local]
    for a, b in zip(on_dask, local, strict=True):
        assert a["status"] == "ok", a
        assert {k: a[k] for k in SAME} == {k: b[k] for k in SAME}, a["method"]
        assert len(a["cpu_s_repeats"]) == 2 and a["deterministic"], a["method"]


def test_a_stress_run_on_a_local_dask_cluster_equals_the_in_process_run(cluster_executor):
    tiny = replace(
        stress.QUICK, drift_horizons=(2.0,), speeds=(50.0,), stability_t_end=0.5, sections=("drift", "stability")
    )
    here = stress.run_stress(["simple_pendulum"], settings=tiny)
    there = stress.run_stress(["simple_pendulum"], settings=tiny, executor=cluster_executor)
    for key in ("drift", "stability", "skipped", "systems"):  # a search's range is no wall time: equal under load
        assert there[key] == here[key], key
    assert here["drift"] and here["stability"]
    assert set(there["timing"]) == set(here["timing"])


def test_repeated_tasks_are_run_again_not_served_from_dasks_cache(cluster_executor):
    """pure=False: two submissions of one call are two runs (a timing repeat must be measured again)."""
    a, b = (cluster_executor.submit(uuid.uuid4) for _ in range(2))
    assert a.result() != b.result()


def test_an_address_reaches_a_running_scheduler():
    with LocalCluster(n_workers=1, processes=False, dashboard_address="127.0.0.1:0") as cluster:
        with named_executor(f"dask:{cluster.scheduler_address}") as executor:
            assert executor is not None
            assert list(executor.map(abs, [-1, -2])) == [1, 2]
        with Client(cluster) as client:  # the harness's client is closed, the cluster still serves others
            assert client.submit(abs, -3).result() == 3


@pytest.mark.parametrize(
    ("text", "parsed"),
    [("local", ("local", None)), ("dask", ("dask", None)), ("dask:tcp://h:8786", ("dask", "tcp://h:8786"))],
)
def test_executor_names(text, parsed):
    assert parse_executor(text) == parsed


@pytest.mark.parametrize("text", ["", "dask:", "ray", "local:x", "dask :"])
def test_bad_executor_names_are_refused(text):
    with pytest.raises(HarnessError, match="valid: local, dask"):
        parse_executor(text)


def test_local_names_no_executor():
    with named_executor("local") as executor:
        assert executor is None


@pytest.mark.parametrize("command", ["run", "bench", "stress"])
def test_the_commands_refuse_a_bad_executor_before_any_work(command, capsys, tmp_path):
    with pytest.raises(SystemExit) as exc:
        main([command, "--executor", "spark", "--out", str(tmp_path)])
    assert exc.value.code == 2
    assert "--executor" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_the_scaling_study_on_a_local_dask_cluster_equals_the_in_process_run(cluster_executor):
    """The planar and spatial chains as two tasks on the cluster: the same models, the same agreement
    and the same sizes as one after the other in this process (times per state aside)."""
    from lagrange_xval.studies import chains

    def measured(result):
        return [
            (r["kind"], r["n"], r["worst_scaled"], r["all_within_tiers"], r["cond_M_max"], r["symbolic"]["ops_M_Cv"])
            for r in result["rows"]
        ]

    here = chains.run_chains(ns=(2, 3), n_states=20, repeats=1)
    lines: list[str] = []
    there = chains.run_chains(ns=(2, 3), n_states=20, repeats=1, executor=cluster_executor, progress=lines.append)
    assert measured(there) == measured(here)
    assert [(r["kind"], r["n"]) for r in there["rows"]] == [(k, n) for k in ("planar", "spatial") for n in (2, 3)]
    assert all(set(r["per_state_s"]) == {"mujoco", "pinocchio", "symbolic"} for r in there["rows"])
    assert there["symbolic_stopped_at"] == here["symbolic_stopped_at"] == {}
    assert len(lines) == 4 and lines[0].startswith("planar n=2: agree")

"""`simulate` writes files that describe themselves (system, files, source, method, initial state,
input, duration, output step, units, harness version, every adjustment of the request), compactly,
says each adjustment on stdout too, and refuses up front a request whose arrays would not fit the
memory limit."""

from __future__ import annotations

import json
import tracemalloc
from importlib import metadata

import numpy as np
import pytest
from lagrange_xval.cli import main
from lagrange_xval.cli import simulate as sim
from lagrange_xval.dynamics import integrate


def _simulate(out, *, source="hand", t_end="0.5", dt_out="0.01", system="double_pendulum_point", **state):
    """A valid `simulate` command line; `state` changes q0, v0 or tau."""
    q0, v0, tau = state.get("q0", "0,3"), state.get("v0", "0,0"), state.get("tau", "0.5,0")
    return ["simulate", system, "--source", source, "--q0", q0, "--v0", v0, "--tau", tau,
            "--t-end", t_end, "--dt-out", dt_out, "--out", str(out)]  # fmt: skip


def test_a_changed_mujoco_timestep_is_said_on_stdout_and_in_the_file(tmp_path, capsys):
    out = tmp_path / "x.json"
    assert main(_simulate(out, source="mujoco", t_end="0.1", dt_out="0.0125")) == 0
    stdout = capsys.readouterr().out
    note = "MuJoCo's timestep set to 0.00104167 s instead of the model's 0.001 s, so that 12 steps make one --dt-out"
    assert f"adjusted: {note}" in stdout, stdout
    data = json.loads(out.read_text())
    assert data["mujoco_timestep"] == pytest.approx(0.0125 / 12, rel=1e-15)
    assert len(data["adjustments"]) == 1 and note in data["adjustments"][0]
    assert main(_simulate(tmp_path / "y.csv", source="mujoco", t_end="0.1", dt_out="0.01")) == 0
    assert "adjusted" not in capsys.readouterr().out
    assert "# adjustment" not in (tmp_path / "y.csv").read_text()


def test_simulate_json_is_compact_and_records_the_request(tmp_path):
    out = tmp_path / "x.json"
    assert main(_simulate(out, t_end="10", dt_out="0.01")) == 0
    text = out.read_text()
    data = json.loads(text)
    assert np.shape(data["rows"]) == (1001, 5)
    assert len(text.splitlines()) < 1001 + 30, "one sample per line"
    assert len(text) < 1001 * 5 * 25 + 2000, f"{len(text)} bytes for 1001 rows"
    assert data["system"] == "double_pendulum_point" and data["source"] == "hand"
    assert data["method"].startswith("scipy odeint")
    assert data["model"] == "models/double_pendulum_point.xml"
    assert (data["q0"], data["v0"], data["tau"]) == ([0.0, 3.0], [0.0, 0.0], [0.5, 0.0])
    assert (data["t_end"], data["dt_out"]) == (10.0, 0.01)
    assert data["harness_version"] == metadata.version("lagrange-xval")
    assert data["columns"] == ["t", "theta", "phi", "dtheta", "dphi"]
    assert data["units"] == {
        "t": "s", "theta": "rad", "phi": "rad", "dtheta": "rad/s", "dphi": "rad/s",
        "q0": ["rad", "rad"], "v0": ["rad/s", "rad/s"], "tau": ["N m", "N m"],
        "t_end": "s", "dt_out": "s", "mujoco_timestep": "s",
    }  # fmt: skip
    assert data["rows"][0] == [0.0, 0.0, 3.0, 0.0, 0.0]


def test_simulate_csv_has_a_commented_header_with_the_same_facts(tmp_path):
    out = tmp_path / "x.csv"
    assert main(_simulate(out, source="mujoco")) == 0
    lines = out.read_text().splitlines()
    header = {k: v for k, _, v in (line[2:].partition(": ") for line in lines if line.startswith("# "))}
    assert lines[0] == f"# lagrange-xval {metadata.version('lagrange-xval')} simulate"
    assert header["system"].startswith("double_pendulum_point (model models/double_pendulum_point.xml")
    assert header["source"] == "mujoco" and header["method"] == "MuJoCo RK4 dt 0.001"
    assert header["q0"] == "0.0 rad, 3.0 rad" and header["v0"] == "0.0 rad/s, 0.0 rad/s"
    assert header["tau"] == "0.5 N m, 0.0 N m (constant)"
    assert header["t_end"] == "0.5 s" and header["dt_out"] == "0.01 s" and header["mujoco_timestep"] == "0.001 s"
    assert header["units"] == "t [s], theta [rad], phi [rad], dtheta [rad/s], dphi [rad/s]"
    data = [line for line in lines if not line.startswith("#")]
    assert data[0] == "t,theta,phi,dtheta,dphi" and len(data) == 52
    assert np.loadtxt(out, delimiter=",", comments="#", skiprows=len(lines) - 52 + 1).shape == (51, 5)


def test_a_slide_coordinate_is_in_metres(tmp_path):
    from lagrange_xval.systems import PACKAGE_ROOT

    out = tmp_path / "cart.json"
    files = ["--model", str(PACKAGE_ROOT / "examples/cart_pole.xml"), "--equations",
             str(PACKAGE_ROOT / "examples/cart_pole.py")]  # fmt: skip
    args = ["simulate", *files, "--source", "hand", "--q0", "0,0.1", "--v0", "0,0", "--t-end", "0.1",
            "--dt-out", "0.05", "--out", str(out)]  # fmt: skip
    assert main(args) == 0
    units = json.loads(out.read_text())["units"]
    assert (units["q0"], units["v0"], units["tau"]) == (["m", "rad"], ["m/s", "rad/s"], ["N", "N m"])


def test_a_request_too_large_for_memory_is_refused_before_any_work(tmp_path, capsys, monkeypatch):
    def no_work(*args, **kwargs):
        raise AssertionError("integrated a request that should have been refused")

    monkeypatch.setattr(integrate, "scipy_trajectory", no_work)
    out = tmp_path / "x.json"
    assert main(_simulate(out, t_end="1e6", dt_out="1e-4")) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "1e+10 samples of 5 numbers" in err[0] and "TiB in memory" in err[0], err[0]
    assert (
        f"the limit is 1 GiB in memory ({sim.MAX_SIMULATE_BYTES // (5 * sim.MEMORY_BYTES_PER_NUMBER):,} samples"
        in err[0]
    )
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_the_limit_is_where_the_message_says():
    fits = sim.MAX_SIMULATE_BYTES // (5 * sim.MEMORY_BYTES_PER_NUMBER)
    sim.refuse_if_too_large(fits - 1, 1.0, 5)  # fits samples: t = 0 .. fits - 1
    with pytest.raises(sim.HarnessError, match="samples of 5 numbers"):
        sim.refuse_if_too_large(fits + 1, 1.0, 5)


def test_memory_grows_no_faster_than_the_estimate(tmp_path):
    """The refusal's numbers are honest: the peak memory of `simulate` grows by at most
    MEMORY_BYTES_PER_NUMBER per number it writes (tracemalloc sees numpy's arrays too)."""

    def peak(source: str, t_end: str) -> int:
        args = _simulate(tmp_path / "x.csv", source=source, t_end=t_end, dt_out="0.001", system="simple_pendulum",
                         q0="0.3", v0="0", tau="0")  # fmt: skip
        tracemalloc.start()
        try:
            assert main(args) == 0
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    for source in ("hand", "mujoco"):
        peak(source, "1")  # compiled and cached before anything is measured
        small, large = peak(source, "20"), peak(source, "60")
        per_number = (large - small) / (40_000 * 3)
        assert per_number <= sim.MEMORY_BYTES_PER_NUMBER, f"{source}: {per_number:.1f} bytes per number"

"""The rerun recordings: what an .rrd holds, read back with rerun's own reader (`rerun.chunk.RrdReader`)."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import numpy as np
import pytest
from lagrange_xval import replay, systems
from lagrange_xval.cli import main
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.results import dumps
from lagrange_xval.stages.pipeline import run

SYSTEM = "double_pendulum_point"
ROW_ID = "rerun.controls.RowId"


@pytest.fixture(scope="module")
def results():
    return run([SYSTEM], n_states=20, seed=0, drake_run=True)  # every source's run, Drake's too


@pytest.fixture(scope="module")
def rrd(results, tmp_path_factory) -> Path:
    files = replay.render_replays(results)
    path = tmp_path_factory.mktemp("replay") / f"{SYSTEM}.rrd"
    path.write_bytes(files[f"{SYSTEM}.rrd"])
    return path


def read(path: Path, *, blueprint: bool = False) -> list:
    """The chunks of the file's recording store (or of its blueprint store)."""
    from rerun.chunk import RrdReader

    reader = RrdReader(path)
    stores = reader.blueprints() if blueprint else reader.recordings()
    kind = "blueprint" if blueprint else "recording"
    assert len(stores) == 1, f"{path.name}: expected one {kind} store, got {stores}"
    return list(reader.stream(store=stores[0]).to_chunks())


def temporal(chunks: list, entity: str):
    """The record batch of `entity`'s time-varying data (exactly one chunk expected)."""
    found = [c for c in chunks if c.entity_path == entity and not c.is_static]
    assert len(found) == 1, f"{entity}: expected one temporal chunk, got {len(found)}"
    return found[0]


def static(chunks: list, entity: str):
    found = [c for c in chunks if c.entity_path == entity and c.is_static]
    assert len(found) == 1, f"{entity}: expected one static chunk, got {len(found)}"
    return found[0].to_record_batch()


def column(chunk, name: str) -> list:
    batch = chunk.to_record_batch()
    return batch.column(batch.schema.get_field_index(name)).to_pylist()


def nanoseconds(chunk) -> np.ndarray:
    batch = chunk.to_record_batch()
    return batch.column(batch.schema.get_field_index(replay.TIMELINE)).cast("int64").to_numpy()


def ns(seconds) -> np.ndarray:
    return np.rint(np.asarray(seconds, dtype=float) * 1e9).astype(np.int64)


def content(chunks: list) -> list:
    """The chunks' data without row ids (which rerun draws at random), in a stable order."""
    out = []
    for c in chunks:
        batch = c.to_record_batch()
        out.append((c.entity_path, c.is_static, batch.drop_columns([ROW_ID])))
    return sorted(out, key=lambda x: (x[0], x[1], tuple(x[2].schema.names)))


def test_one_rrd_per_system(results):
    """render_replays returns the bytes of <system>.rrd for every system in the results, and nothing else."""
    files = replay.render_replays(results)
    assert set(files) == {f"{name}.rrd" for name in results["systems"]}
    assert all(isinstance(b, bytes) and b.startswith(b"RRF") for b in files.values())


def test_bodies_of_every_run_follow_the_equations_kinematics(results, rrd):
    """Each run's bodies sit where the equations module's body_positions puts them at that run's q."""
    s = systems.load(SYSTEM)
    traj = results["systems"][SYSTEM]["trajectories"]
    chunks = read(rrd)
    assert {r["source"] for r in traj["runs"]} == {"hand", "mujoco", "pinocchio", "drake", "symbolic"}
    for key, run_ in zip(replay.run_keys(traj["runs"]), traj["runs"], strict=True):
        run_ = {**run_, "source": key}  # the run's entity path
        expected = s.equations.body_positions(s.params, np.asarray(run_["q"]))
        for body in s.bodies:
            chunk = temporal(chunks, f"/{SYSTEM}/{run_['source']}/bodies/{body}")
            assert chunk.timeline_names == [replay.TIMELINE]
            positions = np.array([row[0] for row in column(chunk, "Points3D:positions")])
            assert positions.shape == (len(traj["t"]), 3)
            # rerun stores positions as float32
            np.testing.assert_allclose(
                positions, expected[body], rtol=0.0, atol=1e-6, err_msg=f"{run_['source']}/{body}"
            )
            assert static(chunks, f"/{SYSTEM}/{run_['source']}/bodies/{body}").num_rows == 1  # colour, radius
            temporal(chunks, f"/{SYSTEM}/{run_['source']}/links/{body}")
        trail = temporal(chunks, f"/{SYSTEM}/{run_['source']}/trail/{s.bodies[-1]}")
        strips = column(trail, "LineStrips3D:strips")
        assert len(strips) == len(traj["t"]) and all(len(row) == 1 for row in strips)
        # the trail ends at the tip: its last point is the tip's position at that sample
        np.testing.assert_allclose(strips[-1][0][-1], expected[s.bodies[-1]][-1], rtol=0.0, atol=1e-6)


def test_series_hold_one_row_per_sample_on_the_time_timeline(results, rrd):
    """q per coordinate, log10 error (zeros clipped) and E - E(0) per run: whole series, one row per sample."""
    traj = results["systems"][SYSTEM]["trajectories"]
    coordinates = results["systems"][SYSTEM]["coordinates"]
    t = np.asarray(traj["t"])
    chunks = read(rrd)
    for key, run_ in zip(replay.run_keys(traj["runs"]), traj["runs"], strict=True):
        base = f"/{SYSTEM}/{key}"
        q = np.asarray(run_["q"])
        error = np.asarray(run_["error_vs_hand"])
        energy = np.asarray(run_["energy"])
        expected = {f"{base}/q/{c}": q[:, i] for i, c in enumerate(coordinates)}
        expected[f"{base}/log10_error"] = np.log10(np.maximum(error, replay.ERROR_FLOOR))
        expected[f"{base}/energy_change"] = energy - energy[0]
        for entity, values in expected.items():
            chunk = temporal(chunks, entity)
            assert chunk.num_rows == len(t), entity
            np.testing.assert_array_equal(nanoseconds(chunk), ns(t), err_msg=entity)
            got = np.array([row[0] for row in column(chunk, "Scalars:scalars")])
            np.testing.assert_array_equal(got, values, err_msg=entity)
            assert "SeriesLines:colors" in static(chunks, entity).schema.names, f"{entity}: styling not static"
    # the reference agrees with itself exactly: its whole error series sits at the floor
    # the hand run starts on the reference: its error at t = 0 is exactly zero, drawn at the floor
    hand = temporal(chunks, f"/{SYSTEM}/hand/log10_error")
    assert column(hand, "Scalars:scalars")[0] == [np.log10(replay.ERROR_FLOOR)]


def test_every_temporal_chunk_is_on_the_one_timeline(rrd):
    """Nothing is logged on log_time or log_tick: only the "time" timeline, in seconds."""
    for chunk in read(rrd):
        assert chunk.is_static or chunk.timeline_names == [replay.TIMELINE], chunk.entity_path


def test_text_document_describes_system_and_runs(results, rrd):
    """A static markdown document names the system, its coordinates, parameters, runs, threshold and the clipping."""
    s = results["systems"][SYSTEM]
    batch = static(read(rrd), f"/{SYSTEM}/description")
    text = batch.column(batch.schema.get_field_index("TextDocument:text")).to_pylist()[0][0]
    media = batch.column(batch.schema.get_field_index("TextDocument:media_type")).to_pylist()[0][0]
    assert media == "text/markdown"
    for needle in [
        s["description"],
        *s["coordinates"],
        *s["parameters"],
        f"{replay.ERROR_FLOOR:g}",
        f"{s['trajectories']['threshold']:g}",
        *(r["method"] for r in s["trajectories"]["runs"]),
    ]:
        assert needle in text, f"the description lacks {needle!r}"


def test_default_blueprint_is_stored_beside_the_recording(results, rrd):
    """The file holds a blueprint store: a 3D view, one plot per coordinate plus error and energy, text views."""
    from rerun.chunk import RrdReader

    reader = RrdReader(rrd)
    assert reader.blueprints()[0].application_id == reader.recordings()[0].application_id == replay.APPLICATION_ID
    kinds: dict[str, int] = {}
    for chunk in read(rrd, blueprint=True):
        batch = chunk.to_record_batch()
        if "ViewBlueprint:class_identifier" in batch.schema.names:
            kind = batch.column(batch.schema.get_field_index("ViewBlueprint:class_identifier")).to_pylist()[0][0]
            kinds[kind] = kinds.get(kind, 0) + 1
    n = len(results["systems"][SYSTEM]["coordinates"])
    assert kinds == {"3D": 1, "TimeSeries": n + 2, "TextDocument": 1, "TextLog": 1}


def test_first_exceedance_is_marked(results, tmp_path):
    """A run whose error crosses the threshold gets a point at that sample and a text log entry; others get none."""
    sys_results = copy.deepcopy(results["systems"][SYSTEM])
    traj = sys_results["trajectories"]
    mujoco = next(r for r in traj["runs"] if r["source"] == "mujoco")
    for other in traj["runs"]:  # only the doctored run crosses the threshold
        other["first_exceeds_threshold"] = None
    k = len(traj["t"]) // 2
    mujoco["error_vs_hand"] = np.where(np.arange(len(traj["t"])) >= k, 1e-3, 1e-9)
    mujoco["first_exceeds_threshold"] = float(traj["t"][k])
    path = tmp_path / "x.rrd"
    path.write_bytes(replay.render_system(SYSTEM, sys_results))
    chunks = read(path)
    marker = temporal(chunks, f"/{SYSTEM}/mujoco/exceeds_threshold")
    np.testing.assert_array_equal(nanoseconds(marker), ns([traj["t"][k]]))
    assert column(marker, "Scalars:scalars") == [[-3.0]]
    assert "SeriesPoints:markers" in static(chunks, f"/{SYSTEM}/mujoco/exceeds_threshold").schema.names
    events = temporal(chunks, f"/{SYSTEM}/events")
    assert [row[0].split(":")[0] for row in column(events, "TextLog:text")] == ["mujoco"]
    assert not [c for c in chunks if c.entity_path.endswith("exceeds_threshold") and "/mujoco/" not in c.entity_path]


def test_extra_runs_get_their_own_paths_and_colours(results, tmp_path):
    """Runs beyond the three sources (a perturbed start, another integrator) get unique paths and distinct colours."""
    sys_results = copy.deepcopy(results["systems"][SYSTEM])
    runs = sys_results["trajectories"]["runs"]
    perturbed = copy.deepcopy(runs[0])
    perturbed["method"] = "scipy DOP853 rtol 1e-12, phi0 = 3.01"
    perturbed["q"] = np.asarray(perturbed["q"]) + 0.01
    runs += [perturbed, copy.deepcopy(perturbed), copy.deepcopy(runs[1])]
    keys, colours = replay.run_keys(runs), replay.run_colours(runs)
    assert keys[:3] == ["hand", "mujoco", "pinocchio"]
    assert len(set(keys)) == len(keys) and len(set(colours)) == len(colours)
    path = tmp_path / "x.rrd"
    path.write_bytes(replay.render_system(SYSTEM, sys_results))
    chunks = read(path)
    for key in keys:
        assert temporal(chunks, f"/{SYSTEM}/{key}/bodies/link2").num_rows == len(sys_results["trajectories"]["t"])


def test_bodies_turning_in_place_show_their_axes(results, tmp_path, monkeypatch):
    """A body whose centre of mass never moves (a gimbal) is drawn by its three axes, turning with it."""
    s = systems.load(SYSTEM)
    monkeypatch.setattr(
        s.equations, "body_positions", lambda p, q: {b: np.zeros((*np.shape(q)[:-1], 3)) for b in s.bodies}
    )
    path = tmp_path / "x.rrd"
    path.write_bytes(replay.render_system(SYSTEM, results["systems"][SYSTEM]))
    chunks = read(path)
    q = np.asarray(results["systems"][SYSTEM]["trajectories"]["runs"][0]["q"])
    rotations = s.equations.body_rotations(s.params, q)
    for body in s.bodies:
        axes = column(temporal(chunks, f"/{SYSTEM}/hand/axes/{body}"), "LineStrips3D:strips")
        assert all(len(row) == 3 for row in axes), f"{body}: three axes per sample"
        # each axis runs from the centre along a column of the body's rotation
        ends = np.array([[strip[1] for strip in row] for row in axes])  # (K, 3 axes, 3)
        directions = ends / np.linalg.norm(ends, axis=-1, keepdims=True)
        np.testing.assert_allclose(directions, np.swapaxes(rotations[body], 1, 2), rtol=0.0, atol=1e-6)
    # the tip's trail follows the end of its x axis (the line of sight) instead of its still centre
    trail = column(temporal(chunks, f"/{SYSTEM}/hand/trail/{s.bodies[-1]}"), "LineStrips3D:strips")
    tip_x = np.array([row[0] for row in axes])[:, 1]
    np.testing.assert_allclose([row[0][-1] for row in trail], tip_x, rtol=0.0, atol=1e-6)


def test_json_results_render_the_same_recording(results, rrd, tmp_path):
    """Rendering is deterministic and reads results.json as well as the in-memory results."""
    path = tmp_path / "from_json.rrd"
    path.write_bytes(replay.render_replays(json.loads(dumps(results)))[f"{SYSTEM}.rrd"])
    from rerun.chunk import RrdReader

    assert RrdReader(rrd).recordings()[0].recording_id == RrdReader(path).recordings()[0].recording_id
    a, b = content(read(rrd)), content(read(path))
    assert [(p, s, batch.schema.names) for p, s, batch in a] == [(p, s, batch.schema.names) for p, s, batch in b]
    for (entity, _, x), (_, _, y) in zip(a, b, strict=True):
        assert x.equals(y), f"{entity} differs"


def test_diverged_run_leaves_gaps(results, tmp_path):
    """A run that blows up (inf and nan from some sample on, as results.json stores them) still renders; its
    non-finite samples are NaN, which the plots leave as gaps."""
    sys_results = json.loads(dumps({"s": results["systems"][SYSTEM]}))["s"]
    traj = sys_results["trajectories"]
    mujoco = next(r for r in traj["runs"] if r["source"] == "mujoco")
    for other in traj["runs"]:  # only the doctored run crosses the threshold
        other["first_exceeds_threshold"] = None
    k = len(traj["t"]) // 2
    for i in range(k, len(traj["t"])):
        mujoco["q"][i] = ["nan", "inf"]
        mujoco["energy"][i] = "inf"
        mujoco["error_vs_hand"][i] = "nan"
    path = tmp_path / "x.rrd"
    path.write_bytes(replay.render_system(SYSTEM, sys_results))
    chunks = read(path)
    for entity in ("q/theta", "q/phi", "energy_change", "log10_error"):
        got = np.array([row[0] for row in column(temporal(chunks, f"/{SYSTEM}/mujoco/{entity}"), "Scalars:scalars")])
        assert np.isfinite(got[:k]).all() and np.isnan(got[k:]).all(), entity


@pytest.fixture(scope="module")
def results_file(results, tmp_path_factory) -> Path:
    """The results as `run` writes them (results.json), for the command that reads them."""
    path = tmp_path_factory.mktemp("results") / "results.json"
    path.write_text(dumps(results))
    return path


def test_replay_command_saves_a_readable_file(tmp_path, capsys, results_file, monkeypatch):
    """`replay SYSTEM --save FILE` writes an .rrd from the run's results that rerun reads back, with
    every source's bodies, and runs nothing."""
    monkeypatch.setattr("lagrange_xval.stages.pipeline.run", lambda *a, **k: pytest.fail("ran the pipeline"))
    path = tmp_path / "x.rrd"
    assert replay.replay_command(SYSTEM, save=path, results_path=results_file) == 0
    assert str(path) in capsys.readouterr().out
    entities = {c.entity_path for c in read(path)}
    for source in ("hand", "mujoco", "pinocchio"):
        assert f"/{SYSTEM}/{source}/bodies/link1" in entities
    assert read(path, blueprint=True)
    assert [p.name for p in tmp_path.iterdir()] == ["x.rrd"], "temporary files left behind"


def test_a_system_not_in_the_results_names_those_held(tmp_path, results_file):
    """A system the results do not hold: one line naming the systems they hold and what to run."""
    with pytest.raises(HarnessError) as info:
        replay.replay_command("dbl_pendulum", save=tmp_path / "x.rrd", results_path=results_file)
    message = str(info.value)
    assert "dbl_pendulum" in message and SYSTEM in message and "lagrange-xval run dbl_pendulum" in message
    assert not list(tmp_path.iterdir())


def test_missing_results_say_what_to_run(tmp_path):
    with pytest.raises(HarnessError, match="lagrange-xval run"):
        replay.replay_command(SYSTEM, save=tmp_path / "x.rrd", results_path=tmp_path / "none.json")
    assert not list(tmp_path.iterdir())


def test_cli_replay_errors_are_one_line(tmp_path, capsys, results_file):
    """The CLI turns replay errors into one stderr line and exit status 2."""
    assert main(["replay", "dbl_pendulum", "--save", str(tmp_path / "x.rrd"), "--results", str(results_file)]) == 2
    assert main(["replay", SYSTEM, "--save", str(tmp_path / "x.txt"), "--results", str(results_file)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "holds no system" in err[0] and ".rrd" in err[1]
    assert not list(tmp_path.iterdir())


def test_no_display_says_to_save(monkeypatch, tmp_path, results_file):
    """Without a display (Linux), replay without --save says so and suggests --save, before running anything."""
    monkeypatch.setattr(replay.sys, "platform", "linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("lagrange_xval.stages.pipeline.run", lambda *a, **k: pytest.fail("ran the pipeline"))
    with pytest.raises(HarnessError, match="--save"):
        replay.replay_command(SYSTEM, save=None, results_path=results_file)


def test_wrong_printed_forms_run_beside_the_engines(results, rrd):
    """Issue 17: the recording holds the runs of the wrong printed forms from the same start (the
    notes' experiment at its tightest tolerance, on its own time grid), beside the engines' runs."""
    s = results["systems"][SYSTEM]
    wrong = [v["name"] for v in s["variants"] if v["verdict"] == "disagrees"]
    ex = s["experiments"]
    dynamic = {r["form"] for r in ex["runs"]}
    expected = [f for f in wrong if f in dynamic]
    assert expected, "explicit (35)-(36) and the Matlab form are wrong and integrated"
    chunks = read(rrd)
    for form in expected:
        key = "printed_" + re.sub(r"[^a-z0-9]+", "_", form.lower()).strip("_")
        rows = temporal(chunks, f"/{SYSTEM}/{key}/bodies/link2").to_record_batch().num_rows
        assert rows == len(ex["t"]), (form, rows)
    batch = static(chunks, f"/{SYSTEM}/description")
    text = batch.column(batch.schema.get_field_index("TextDocument:text")).to_pylist()[0][0]
    assert "wrong printed forms of the notes from the same start" in " ".join(text.split())


def test_replay_of_ones_own_system_works_from_another_folder(tmp_path, monkeypatch, capsys):
    """Issue 26: `run --model --equations` with relative paths, then `replay` and `report` from
    another folder: the results name the files absolutely."""
    import shutil

    from lagrange_xval.cli import main
    from lagrange_xval.systems import load

    source = load("simple_pendulum")
    (tmp_path / "mine").mkdir()
    shutil.copy(source.mjcf, tmp_path / "mine" / "pend.xml")
    shutil.copy(source.equations.__file__, tmp_path / "mine" / "pend.py")
    monkeypatch.chdir(tmp_path)
    args = ["run", "--model", "mine/pend.xml", "--equations", "mine/pend.py", "--out", "out"]
    assert main([*args, "--states", "10", "--probes", "0", "--no-replay", "--no-cache"]) == 0
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    saved = elsewhere / "pend.rrd"
    assert replay.replay_command("pend", save=saved, results_path=tmp_path / "out" / "results.json") == 0
    assert saved.stat().st_size > 0
    assert main(["report", "--out", str(tmp_path / "out")]) == 0
    capsys.readouterr()

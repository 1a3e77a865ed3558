"""The whole end-to-end jobs (marker `long`) of handwritten/; their helpers stay with the unit tests in
tests/unit/handwritten/."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import urllib.parse

import pytest
from lagrange_xval.core import cache

from tests.unit.handwritten.test_expression import _named_system
from tests.unit.handwritten.test_minimal_contract import GYM_ACROBOT, _system


@pytest.mark.long
def test_gym_acrobot_passes_every_stage_of_run(tmp_path):
    """The whole job on explicit accelerations with u and joint damping: MuJoCo's damped Euler cannot be
    mirrored without M, so that one mirror is not judged (said), and nothing fails a right derivation."""
    import json
    import subprocess
    import sys

    system = _system(tmp_path, "acrobot", GYM_ACROBOT)
    cmd = [sys.executable, "-m", "lagrange_xval.cli", "run", "--model", str(system.mjcf)]
    cmd += ["--equations", str(tmp_path / "mine.py"), "--out", str(tmp_path / "out"), "--states", "60"]
    run = subprocess.run([*cmd, "--probes", "1", "--no-replay"], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout[-1500:] + run.stderr[-1500:]
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    mirror = results["systems"]["mine"]["chaos"]["integrators"]["Euler"]["mirrors"]["mujoco~hand"]
    assert mirror["judged"] is False and "cannot be mirrored" in mirror["why_not_judged"]


@pytest.mark.long
def test_without_home_run_says_so_once(tmp_path):
    """With HOME unset there is no cache key to keep: `run` says so on one warning line, and heyoka's
    JIT cache is off instead of warning on every compilation (37 lines before)."""
    env = {k: v for k, v in os.environ.items() if k not in ("HOME", "XDG_CACHE_HOME", cache.CACHE_ENV)}
    env.pop(cache.PROCESS_KEY_ENV, None)
    done = subprocess.run(
        [sys.executable, "-m", "lagrange_xval.cli", "run", "simple_pendulum", "--no-replay"]
        + ["--out", str(tmp_path / "out")],
        env=env,
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    warnings = [line for line in done.stderr.splitlines() if "warn" in line.lower()]
    assert len(warnings) == 1 and "no private cache key" in warnings[0], warnings[:5]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


@pytest.mark.long
def test_run_writes_every_report_of_a_system_with_such_names(tmp_path):
    """`run --systems DIR` of a system named `my arm: θ` whose joints and bodies hold `/`, `:`, spaces and
    Unicode: status 0, the reports, the recording (no rerun path warnings) and markdown image links that
    resolve."""
    folder = tmp_path / "systems"
    folder.mkdir()
    model, equations = _named_system(tmp_path)
    stem = "my arm: \u03b8"
    model.rename(folder / f"{stem}.xml")
    equations.rename(folder / f"{stem}.py")
    out = tmp_path / "out"
    done = subprocess.run(
        [sys.executable, "-m", "lagrange_xval.cli", "run", "--systems", str(folder), "--out", str(out)]
        + ["--states", "50", "--probes", "1"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "WARN" not in done.stderr, done.stderr[-2000:]
    assert stem in json.loads((out / "results.json").read_text())["systems"]
    assert (out / f"{stem}.rrd").stat().st_size > 0
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", (out / "report.md").read_text())
    assert links and all((out / urllib.parse.unquote(link)).is_file() for link in links), links

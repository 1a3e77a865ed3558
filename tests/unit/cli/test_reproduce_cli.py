"""`check --reproduce DIR`, `check --json`'s reproducers, and `run`'s: each disagreement's script written,
listed with its pair, quantity, state and numbers, and linked from the report (verdict/reproduce.py)."""

from __future__ import annotations

import json

from lagrange_xval.cli import main
from lagrange_xval.core.package import EQUATIONS_DIR, MODELS_DIR
from lagrange_xval.verdict.reproduce import run_reproducer

from ..verdict.test_reproduce import AGREED, CLASS_MASS


def test_check_reproduce_writes_a_script_per_disagreement_and_json_lists_them(tmp_path, capsys):
    model = tmp_path / "classmass.xml"
    model.write_text(CLASS_MASS)
    proofs = tmp_path / "proofs"
    main(["check", "--model", str(model), "--states", "3", "--probes", "0", "--reproduce", str(proofs), "--json"])
    listed = {(r["quantity"], r["pair"]): r for r in json.loads(capsys.readouterr().out)["reproducers"]}
    r = listed["M", "mujoco~pinocchio"]
    assert r["path"] == str(proofs / "classmass_M_mujoco_vs_pinocchio.py")
    assert {"state_index", "state", "entry", "numbers", "tolerance"} <= set(r) and "script" not in r
    assert sorted(p.name for p in proofs.iterdir()) == sorted(x["file"] for x in listed.values() if "path" in x)
    assert run_reproducer(r["path"]).shows
    # the text form names each file before the verdict line, which stays last
    main(["check", "--model", str(model), "--states", "3", "--probes", "0", "--reproduce", str(proofs)])
    lines = capsys.readouterr().out.strip().splitlines()
    assert f"reproducer: M mujoco~pinocchio: {r['path']}" in lines
    assert lines[-1].startswith("verdict: classmass:")


def test_check_without_reproduce_writes_nothing_and_an_agreeing_model_has_none(tmp_path, capsys):
    model = tmp_path / "agreed.xml"
    model.write_text(AGREED)
    assert main(["check", "--model", str(model), "--states", "3", "--probes", "0", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["reproducers"] == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["agreed.xml"]


def test_a_wrong_derivation_gets_its_reproducer_from_check(tmp_path, capsys):
    source = (EQUATIONS_DIR / "simple_pendulum.py").read_text()
    wrong = tmp_path / "simple_pendulum.py"
    wrong.write_text(source.replace("g = p.m * p.g * p.l * np.sin", "g = 0.5 * p.m * p.g * p.l * np.sin"))
    args = ["check", "--model", str(MODELS_DIR / "simple_pendulum.xml"), "--equations", str(wrong)]
    assert main([*args, "--states", "4", "--probes", "0", "--reproduce", str(tmp_path / "p")]) == 1
    shown = run_reproducer(tmp_path / "p" / "simple_pendulum_bias_hand_vs_mujoco.py")
    assert shown.shows, shown.output


def test_run_writes_the_reproducers_beside_results_and_the_report_links_them(tmp_path, capsys):
    model = tmp_path / "classmass.xml"
    model.write_text(CLASS_MASS)
    out = tmp_path / "out"
    main(["run", "--model", str(model), "--out", str(out), "--no-replay", "--states", "3", "--probes", "0"])
    results = json.loads((out / "results.json").read_text())
    records = results["systems"]["classmass"]["reproducers"]
    r = next(x for x in records if x["pair"] == "mujoco~pinocchio" and x["quantity"] == "M")
    assert r["path"] == "reproducers/classmass_M_mujoco_vs_pinocchio.py" and "script" not in r
    assert run_reproducer(out / r["path"]).shows
    assert f"]({r['path']})" in (out / "report.md").read_text()
    assert f'href="{r["path"]}"' in (out / "report.html").read_text()

"""Issue 17: the report and the console lead with what is wrong and why, and say only what is true of
the system they describe. Rendered for a chaotic system of the notes with wrong printed forms
(double_pendulum_point), a damped one (gimbal), a non-chaotic one (simple_pendulum) and a user's
own system (examples/cart_pole.py copied to a temporary folder)."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from lagrange_xval import report
from lagrange_xval.model.urdf import robots_folder
from lagrange_xval.report import findings
from lagrange_xval.report.document import to_plain
from lagrange_xval.results.schema import SCALED_DEFINITION
from lagrange_xval.systems import PACKAGE_ROOT

EXAMPLES = PACKAGE_ROOT / "examples"
NOTES = ["double_pendulum_point", "gimbal", "simple_pendulum"]


@pytest.fixture(scope="module")
def user_folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("mine")
    for suffix in (".xml", ".py"):
        shutil.copy(EXAMPLES / f"cart_pole{suffix}", folder / f"my_cart_pole{suffix}")
    return folder


@pytest.fixture(scope="module")
def results(user_folder) -> dict[str, Any]:
    from lagrange_xval.stages.pipeline import run

    files = [(user_folder / "my_cart_pole.xml", user_folder / "my_cart_pole.py")]
    return run(NOTES, n_states=50, seed=0, files=files)


@pytest.fixture(scope="module")
def files(results) -> dict[str, bytes]:
    return report.render(results)


def md_of(files: dict[str, bytes]) -> str:
    return files["report.md"].decode()


def system_part(md: str, name: str) -> str:
    """The markdown of one system's section."""
    start = md.index(f"## System {name}\n")
    end = md.find("\n## ", start + 5)
    return md[start : end if end > 0 else None]


def first_screen(html: str) -> str:
    return html[: html.index("<main")]


# ----------------------------------------------------------------------------------------------
# 1. Lead with the findings


def wrong_variants(results):
    return [(n, v) for n, s in sorted(results["systems"].items()) for v in s["variants"] if v["verdict"] == "disagrees"]


def test_the_first_screen_lists_every_wrong_form_with_its_term_and_reason(results, files):
    html = files["report.html"].decode()
    head = first_screen(html)
    wrong = wrong_variants(results)
    assert len(wrong) >= 4, "double_pendulum_point and gimbal print wrong forms"
    items = re.findall(r'<li class="finding">(.*?)</li>', head, flags=re.S)
    assert len(items) == len(wrong), items
    for (name, v), item in zip(wrong, items, strict=True):
        assert name in item and v["name"].replace("&", "&amp;") in item.replace("&#39;", "'"), item
        term = re.search(r'<code class="term">(.*?)</code>', item).group(1)
        assert term not in findings.GENERIC_TERMS, f"{v['name']}: term {term!r}"
        explained = [e for e in v.get("explanations", []) if e.get("explained")]
        if explained:
            said = findings.whose(findings.one_line_statement(explained[0]["statement"]), "the notes' form")
            assert said.replace("'", "&#39;") in item or said in item.replace("&#39;", "'"), (said, item)
        else:
            assert "no single slip reproduces it" in item, item
        # issue 26: the transcription note is not the reason; nothing is cut; the notes' form is not "yours"
        assert "transcription note" not in item and "…" not in item and "yours" not in item, item
        anchor = re.search(r'href="#([^"]+)"', item).group(1)
        assert f'id="{anchor}"' in html, f"the link {anchor} leads nowhere"
    # the verdict on each derivation comes before the wrong forms, and each derivation is named
    assert head.index('aria-label="Derivations"') < head.index('aria-label="Wrong printed forms"')
    for name in results["systems"]:
        assert f'href="#system-{findings.slug(name)}"' in head


def test_a_derivation_steps_term_is_the_quantity_and_entry_not_value(results):
    """bob 2 position (9)-(10) is judged as a whole ("value"): its term is the entry that disagrees."""
    v = next(v for _, v in wrong_variants(results) if v["name"].startswith("bob 2 position"))
    assert v["first_disagreeing_term"] == "value"
    assert findings.form_term(v) == "bob 2 position[x]"
    assert findings.form_reason(v) == "the notes' form lacks the factor l_link2 in l_link2*sin(theta)"


def test_the_reason_is_kept_apart_from_the_transcription_note():
    v = {
        "name": "explicit (1)-(2)",
        "kind": "explicit",
        "first_disagreeing_term": "acceleration",
        "terms": [{"term": "friction", "passed": False}, {"term": "acceleration", "passed": False}],
        "note": "Eq (2) prints k where k2 belongs.",
        "explanations": [{"entry": "x", "explained": False, "statement": "no simple form reproduces your numbers"}],
    }
    assert findings.form_term(v) == "friction"
    assert findings.form_reason(v) == "no single slip reproduces it"
    assert findings.form_note(v) == "Eq (2) prints k where k2 belongs."


def test_passing_forms_are_folded(results, files):
    html = files["report.html"].decode()
    head = first_screen(html)
    agreeing = [
        (n, v["name"]) for n, s in results["systems"].items() for v in s["variants"] if v["verdict"] == "agrees"
    ]
    assert agreeing
    folded = re.search(r'<details class="passing">(.*?)</details>', head, flags=re.S).group(1)
    for _name, form in agreeing:
        assert form in folded.replace("&#39;", "'"), form
    assert "<details open" not in html, "folded content must be closed by default"
    # in the summary, agreeing forms are in a closed <details> too
    summary = html[html.index('id="summary"') : html.index('id="errata-of-the-notes"')]
    table, fold = summary.split('<details class="fold">', 1)
    assert not any(f"<td>{form}</td>" in table for _, form in agreeing if "<" not in form)


def test_the_console_ends_with_the_derivations_then_every_wrong_form(results):
    lines = findings.console_lines(results, "out/report.html")
    names = sorted(results["systems"])
    assert lines[0].startswith("derivations")
    assert [line.split(":")[0].split()[-1] for line in lines[1 : 1 + len(names)]] == names
    wrong = [line for line in lines if line.startswith("  wrong ")]
    assert len(wrong) == len(wrong_variants(results))
    for line, (name, v) in zip(wrong, wrong_variants(results), strict=True):
        assert line.startswith(f"  wrong {name}, {v['name']}: {findings.form_term(v)}: "), line
        assert not re.search(r": (value|acceleration): ", line), line


# ----------------------------------------------------------------------------------------------
# 2. Only true text


def test_the_damped_gimbal_is_not_called_conservative_or_chaotic(files):
    part = system_part(md_of(files), "gimbal")
    assert "friction dissipates energy" in part
    assert "conservative" not in part
    assert "amplified by the chaos" not in part and "### Chaos" not in part
    assert "### Error growth" in part and "gimbal is not chaotic from its initial state" in part
    assert "the notes report about" not in part, "the notes' 7 s concern the double pendulum"
    assert "energy change (friction)" in part


def test_the_simple_pendulum_gets_no_chaos_and_no_notes_experiment(files):
    part = system_part(md_of(files), "simple_pendulum")
    assert "### Chaos" not in part and "### Error growth" in part
    assert "simple_pendulum is not chaotic" in part and "amplified by the chaos" not in part
    assert "The notes' experiment" not in part and "A perturbation experiment:" in part
    assert "the notes report about" not in part
    assert "the system is conservative" in part


def test_the_chaotic_double_pendulum_keeps_the_notes_claim(files):
    part = system_part(md_of(files), "double_pendulum_point")
    assert "### Chaos" in part and "moves chaotically from its initial state" in part
    assert "The notes' experiment (section 1" in part and "the notes report about 7 s" in part
    assert "the system is conservative" in part


def test_a_user_system_gets_no_notes_wording(files):
    part = system_part(md_of(files), "my_cart_pole")
    assert "your derivation" in part
    assert "notes" not in part.lower(), [line for line in part.splitlines() if "notes" in line.lower()][:5]
    assert "friction dissipates energy" in part  # the cart's damper


def test_a_run_of_user_systems_alone_says_nothing_of_the_notes(tmp_path, user_folder):
    """`run --model --equations` on a wrong copy of the cart-pole: the headline and the console name the
    failing term and pair; neither report nor console speaks of the notes; the replay hint names the real
    output folder and a viewer that runs."""
    source = (user_folder / "my_cart_pole.py").read_text()
    old = "- p.mp * p.g * lc * s - tau[..., 1]"
    assert source.count(old) == 1
    (tmp_path / "my_cart.py").write_text(source.replace(old, "- p.mp * p.g * p.l * s - tau[..., 1]"))
    shutil.copy(user_folder / "my_cart_pole.xml", tmp_path / "my_cart.xml")
    out = tmp_path / "deep" / "out"
    run = subprocess.run(
        [sys.executable, "-m", "lagrange_xval.cli", "run", "--model", "my_cart.xml"]
        + ["--equations", "my_cart.py", "--out", "deep/out", "--states", "60", "--probes", "2"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 1, run.stderr[-2000:]
    assert "my_cart: FAIL; your derivation: gravity disagrees at the model's parameters" in run.stderr
    last = run.stdout.splitlines()
    assert last[-1].startswith("  FAIL my_cart: your derivation: gravity disagrees at the model's parameters"), last
    assert "notes" not in run.stdout + run.stderr
    md = (out / "report.md").read_text()
    assert f"**✗ my_cart fails: {last[-1].removeprefix('  FAIL my_cart: ')}" in md, md[:500]
    assert "G[theta]: yours has the term" in md.split("## Summary")[0], "the headline says why"
    assert "notes" not in md.lower(), [line for line in md.splitlines() if "notes" in line.lower()][:5]
    # the replay hint: the folder where run wrote the recording, and a viewer command that works
    code = md[md.index("## How to replay") :].split("```sh\n")[1].split("\n```")[0].splitlines()
    viewer, path = code[0].rsplit(" ", 1)
    assert path == "deep/out/my_cart.rrd" and (tmp_path / path).is_file(), code
    assert "rerun" in viewer
    version = subprocess.run([*viewer.split(), "--version"], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert version.returncode == 0 and "rerun" in version.stdout, version.stderr[-500:]
    assert f"replays: {viewer} deep/out/<system>.rrd" in run.stdout


# ----------------------------------------------------------------------------------------------
# 3. Verdicts that say what was judged


def test_verdicts_say_what_was_judged(results, files):
    md = md_of(files)
    part = system_part(md, "double_pendulum_point")
    euler = next(line for line in part.splitlines() if line.startswith("| Euler |"))
    assert "not judged beyond" in euler and "✓ pass" not in euler, euler
    assert re.search(r"MuJoCo Euler: .* reaches 1e-6 rad at [\d.]+ s, so its free run is judged only until then", part)
    perturbed = next(line for line in part.splitlines() if "(phi0 + 0.01)" in line and line.startswith("| hand"))
    assert "(starts elsewhere: phi0 + 0.01)" in perturbed, perturbed
    for line in md.splitlines():
        assert "status" not in line or not line.startswith("| hand |"), line  # the cost column holds costs
    for name, v in wrong_variants(results):
        for line in system_part(md, name).splitlines():
            if line.startswith(f"| {v['name']} |"):
                assert "✗ disagrees" in line and "| ok |" not in line, line


# ----------------------------------------------------------------------------------------------
# 4. One definition of `scaled`


def test_scaled_has_one_definition_in_code_readme_and_report(files):
    from lagrange_xval.verdict.pointwise import States, error_row

    readme = " ".join((PACKAGE_ROOT / "README.md").read_text().split())
    assert SCALED_DEFINITION in readme
    md = " ".join(md_of(files).split())
    assert SCALED_DEFINITION in md
    for text in (readme, md):
        assert "range over the states" not in text and "quantity's range" not in text
    # the code computes exactly that: largest |a - b| over the largest magnitude of either, not the range
    a = np.array([[3.0, -1.0], [2.5, -0.5], [2.0, 0.0]])
    b = a + np.array([[0.0, 0.1], [0.0, 0.0], [0.3, 0.0]])
    z = np.zeros((3, 2))
    row = error_row("x", "a~b", a, b, States(z, z, z), tier="algebraic")
    assert row["scaled"] == pytest.approx(0.3 / 3.0)
    assert row["scaled"] != pytest.approx(0.3 / (np.ptp(a)))


# ----------------------------------------------------------------------------------------------
# 6. Readable figures and tables


def test_parameter_tables_carry_units(files):
    md = md_of(files)
    for name, rows in (
        ("double_pendulum_point", {"l1": "m", "m1": "kg", "I1": "kg m^2", "g": "m/s^2"}),
        ("gimbal", {"kpsi": "N m s/rad", "I2xx": "kg m^2"}),
        ("my_cart_pole", {"kx": "N s/m", "mp": "kg", "l": "m"}),
    ):
        part = system_part(md, name)
        assert "| parameter | value | unit | model keys it sets |" in part
        for key, unit in rows.items():
            assert re.search(rf"^\| {re.escape(key)} \| [^|]+ \| {re.escape(unit)} \|", part, flags=re.M), (name, key)


def legend_problems(fig: Any) -> list[str]:
    """Legends that leave the figure or lie over a plotting area."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    whole = fig.bbox
    out = []
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is None:
            continue
        box = legend.get_window_extent(renderer)
        if box.x0 < whole.x0 - 1 or box.x1 > whole.x1 + 1 or box.y0 < whole.y0 - 1 or box.y1 > whole.y1 + 1:
            out.append(f"{ax.get_title()}: legend leaves the figure")
        for other in fig.axes:
            if box.overlaps(other.get_window_extent(renderer)):
                out.append(f"{ax.get_title()}: legend over the plot {other.get_title()!r}")
    return out


def test_legends_lie_inside_their_figures_and_off_the_data(results, monkeypatch):
    from lagrange_xval.report import figures, studies, system_parts

    problems: list[str] = []
    real = figures.png

    def checked(fig: Any) -> bytes:
        data = real(fig)  # lays the figure out (a legend too long for its margin widens the figure)
        problems.extend(legend_problems(fig))
        return data

    for module in (figures, studies, system_parts):
        monkeypatch.setattr(module, "png", checked)
    report.build(to_plain(results))
    stress = {
        "drift": [
            {
                "system": "s",
                "integrator": i,
                "engine": "mujoco",
                "horizon": 100.0,
                "series": {"t": [0, 1], "dE": [0, 1]},
            }
            for i in ("Euler", "implicit", "implicitfast", "RK4")
        ],
        "conditioning": [{"quantity": "qacc", "cond_max": 10.0, "scaled": 1e-14}],
        "conditioning_summary": [{"system": "s", "quantity": "qacc"}],
    }
    doc = report.Document()
    studies.section_stress(doc, stress)
    assert not problems, problems


def test_long_and_developer_tables_stay_out_of_the_way():
    from lagrange_xval.report import studies

    stiff = [
        {
            "damping_factor": f,
            "integrator": i,
            "engine": "mujoco",
            "timestep": dt,
            "stable": dt < 0.01,
            "max_error": 1e-3,
        }
        for f in (1, 10, 100, 1000)
        for i in ("Euler", "implicit", "implicitfast", "RK4")
        for dt in (0.001, 0.002, 0.005, 0.01, 0.02, 0.05)
    ]
    doc = report.Document()
    studies.section_stress(doc, {"stiff_friction": stiff})
    tables = [b for b in doc.blocks if type(b).__name__ == "Table"]
    assert len(tables) == 1 and len(tables[0].rows) == 4, "a compact grid: one row per integrator"
    folds = [b for b in doc.blocks if type(b).__name__ == "Fold"]
    assert len(folds) == 1 and len(folds[0].blocks[0].rows) == len(stiff), "every run folded below"
    doc = report.Document()
    studies.section_bench(doc, {"ratios": {"rhs_fast_path_vs_hand_math": {"value": 1.2, "target": 1.5}}, "rows": []})
    text = " ".join(getattr(b, "title", "") + getattr(b, "text", "") for b in doc.blocks)
    assert "ratio" not in " ".join(getattr(b, "title", "") for b in doc.blocks), "no ratio table in the report"
    assert "bench.json" in text


# ----------------------------------------------------------------------------------------------
# Issue 26: every sentence conditioned on what was checked, for robots and people's own systems too


SENTENCE = re.compile(r"(?<=[.!?:])\s+(?=[A-Z✓✗])|\n+")


def sentences(md: str) -> list[str]:
    """The report's prose and table cells, a sentence (or a line) each; figures' file names left out."""
    text = re.sub(r"!\[[^\]]*\]\([^)]*\)", "", md)
    text = re.sub(r"```.*?```", "", text, flags=re.S)  # the derived equations and the viewer commands
    return [x.strip() for x in SENTENCE.split(text) if x.strip()]


def facts_of(s: dict[str, Any]) -> dict[str, bool]:
    return {
        "derivation": findings.has_derivation(s),
        "forms": bool(s.get("variants")),
        "damped": findings.is_damped(s),
        "actuated": findings.has_actuators(s),
        "driven": findings.is_driven(s),
        "user": findings.is_user(s),
        "chaotic": findings.is_chaotic(s),
    }


# (pattern, the fact that must hold for a sentence to say it)
CLAIMS = [
    (
        r"\bhand (derivation|equations)\b|\byour derivation\b|\byours\b|derivation agrees|derivation's terms",
        "derivation",
    ),
    (r"\bprinted forms?\b", "forms"),
    (r"friction dissipates|energy change \(friction\)", "damped"),
    (r"\bmotors?\b", "actuated"),
    (r"inputs (also )?do work", "driven"),
    (r"moves chaotically|amplified by the chaos", "chaotic"),
]
NEGATED = [
    (r"\bconservative\b", "damped"),
    (r"\bthe notes\b|\bnotes'", "user"),
]


def false_sentences(md: str, s: dict[str, Any]) -> list[str]:
    """Sentences of `md` that state something the system's facts contradict."""
    facts = facts_of(to_plain(s))
    out = []
    for line in sentences(md):
        plain = line.lower()
        if "no derivation given" in plain or "no derivation was given" in plain:
            continue  # the one sentence that names the derivation is the one that says there is none
        plain = re.sub(r"\bno printed forms? (was judged|of its own)", "", plain)  # says there is none
        out += [f"[{fact}] {line}" for pattern, fact in CLAIMS if re.search(pattern, plain) and not facts[fact]]
        out += [f"[not {fact}] {line}" for pattern, fact in NEGATED if re.search(pattern, plain) and facts[fact]]
    return out


def one_verdict_per_run(md: str) -> list[str]:
    """A run judged until a time is said so wherever it appears (never "whole run" elsewhere), and no
    run judged part-way whose whole-run error is past its tolerance carries a pass mark."""
    out = []
    for line in md.splitlines():
        if "✓" in line and "not judged beyond" in line:
            cells = [c.strip() for c in line.split("|")]
            errors = [float(c.split()[0]) for c in cells if re.fullmatch(r"[\d.]+e[+-]\d+( rad)?", c)]
            if errors and max(errors) > 1e-6:
                out.append(line)
    return out


@pytest.fixture(scope="module")
def model_alone() -> dict[str, Any]:
    """A repository MJCF run as a model alone (no derivation), and the UR5 where it is installed."""
    from lagrange_xval.stages.pipeline import run

    files: list[tuple[Path, Path | None]] = [(PACKAGE_ROOT / "models" / "double_pendulum_point.xml", None)]
    robots = robots_folder()
    if robots is not None:
        files.append((robots / "ur_description/urdf/ur5_robot.urdf", None))
    return run(None, n_states=40, seed=0, files=files, n_probes=0)


def test_a_model_alone_says_so_and_never_speaks_of_a_derivation(model_alone):
    files = report.render(model_alone)
    md = md_of(files)
    html = files["report.html"].decode()
    head = md.split("## Summary")[0]
    assert "No derivation given: the engines' readings of the model and their dynamics compared" in head
    assert "agrees with the engines" not in md and "hand" not in head.lower()
    assert "your derivation ``" not in md and "| parameter | value |" not in md, "no empty parameter table"
    assert "Derivations, each judged" not in html
    for name, s in model_alone["systems"].items():
        assert not findings.has_derivation(s)
        wrong = false_sentences(system_part(md, name), s)
        assert not wrong, "\n".join(wrong)
    wrong = false_sentences(md[: md.index("## System")], next(iter(model_alone["systems"].values())))
    assert not wrong, "\n".join(wrong)
    lines = findings.console_lines(model_alone)
    assert lines[0].startswith("models alone (no derivation given)")
    assert all("derivation agrees" not in line for line in lines)


def test_the_notes_and_a_users_systems_say_only_what_is_true_of_them(results, files):
    md = md_of(files)
    for name, s in results["systems"].items():
        wrong = false_sentences(system_part(md, name), s)
        assert not wrong, f"{name}:\n" + "\n".join(wrong)
    assert not one_verdict_per_run(md), one_verdict_per_run(md)


def test_a_wrong_user_module_gets_a_reason_and_no_notes_wording(tmp_path, user_folder):
    """A user's module with a slip in gravity: the headline names the term and why; "yours" is the
    person's; no sentence speaks of the notes or of printed forms."""
    from lagrange_xval.stages.pipeline import run

    source = (user_folder / "my_cart_pole.py").read_text()
    old = "- p.mp * p.g * lc * s - tau[..., 1]"
    (tmp_path / "slip.py").write_text(source.replace(old, "- p.mp * p.g * p.l * s - tau[..., 1]"))
    shutil.copy(user_folder / "my_cart_pole.xml", tmp_path / "slip.xml")
    results = run(None, n_states=40, seed=0, files=[(tmp_path / "slip.xml", tmp_path / "slip.py")], n_probes=2)
    md = md_of(report.render(results))
    s = results["systems"]["slip"]
    assert "gravity disagrees" in md.split("## Summary")[0] and "yours has the term" in md.split("## Summary")[0]
    wrong = false_sentences(system_part(md, "slip"), s)
    assert not wrong, "\n".join(wrong)


def test_differences_no_single_slip_reproduces_are_said_once():
    """An energies-only module with a mistake: not "(not explained)" once per entry, one plain sentence."""
    from lagrange_xval.report.system_parts import system_derivation

    s = {
        "origin": "user",
        "derivation": {
            "kind": "energies",
            "verdict": "disagrees",
            "statement": "mass matrix disagrees",
            "explanations": [
                {"entry": f"M[{i}, {j}]", "explained": False, "statement": "no simple form reproduces your numbers"}
                for i in range(2)
                for j in range(2)
            ],
        },
    }
    doc = report.Document()
    system_derivation(doc, "mine", s)
    text = " ".join(getattr(b, "text", "") for b in doc.blocks)
    assert "No single slip reproduces the differences of 4 entries" in text
    assert "(not explained)" not in text, "the rows are folded, not the lead"

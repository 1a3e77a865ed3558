"""The corpus of published models (issue 42 item 5): every MJCF and URDF file that three packages of the
`test` extra ship (dm_control, gymnasium-robotics and rtb-data, pinned in requirements.lock, nothing
vendored), each judged model-only by `lagrange-xval check` from its own folder, in a process of its own.

`python -m tests.corpus [--jsonl FILE]` (from the repository) prints one row per model and the figures
(models, verdicts, FAILs with their reproducers and how many of them show their difference, refusals by
reason); `python -m tests.corpus --timing` times `lagrange-xval survey` on each package against the shell
loop of single `check --model` and `audit` runs it replaces;
tests/e2e/test_corpus.py holds each model's expected outcome and fails where one differs.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
import tempfile
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

# The packages of the corpus: import name -> distribution (requirements.lock pins each).
PACKAGES = {"dm_control": "dm-control", "gymnasium_robotics": "gymnasium-robotics", "rtbdata": "rtb-data"}
TIMEOUT = 300.0  # s for one model's check: a model that takes longer is one row, "crash: timed out"
STATES = "20"


def package_folder(name: str) -> Path | None:
    """The installed folder of a corpus package, None where it is not installed."""
    spec = importlib.util.find_spec(name)
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations)))


def installed() -> bool:
    """Whether every corpus package is installed."""
    return all(package_folder(name) is not None for name in PACKAGES)


def marks() -> list[object]:
    """The marks of a corpus test module: `long`, and skipped where the packages are missing outside CI
    (under CI the lock installs them: a missing one fails)."""
    import pytest

    reason = "the corpus packages are not installed (pip install -r requirements.lock)"
    return [pytest.mark.long, pytest.mark.skipif(not installed() and os.environ.get("CI") != "true", reason=reason)]


def models() -> list[tuple[str, Path]]:
    """(key, path) of every model file of the installed corpus packages, as `lagrange-xval survey` finds
    them (studies/survey.py `model_files`: root <mujoco> or <robot>; include fragments are not models),
    sorted; the key is the path below the package's folder's parent ("dm_control/suite/acrobot.xml")."""
    from lagrange_xval.studies.survey import model_files

    out = []
    for name in PACKAGES:
        folder = package_folder(name)
        if folder is not None:
            out += [(path.relative_to(folder.parent).as_posix(), path) for path, _, _ in model_files(folder)]
    return out


@dataclass
class Outcome:
    """What `check --model` said of one model: pass, FAIL, refused or crash, and why (its last line)."""

    kind: str
    why: str
    seconds: float = 0.0
    reproducers: list[dict[str, object]] = field(default_factory=list)


def _kind(code: int) -> str:
    return {0: "pass", 1: "FAIL", 2: "refused"}.get(code, "crash")


def judge(path: Path, reproduce: Path) -> Outcome:
    """`lagrange-xval check --model PATH --json --reproduce DIR` in a fresh process, from PATH's folder."""
    import time

    command = [sys.executable, "-m", "lagrange_xval.cli", "check", "--model", str(path), "--states", STATES]
    command += ["--probes", "0", "--json", "--reproduce", str(reproduce)]
    start = time.perf_counter()
    try:
        done = subprocess.run(command, cwd=path.parent, capture_output=True, text=True, timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        return Outcome("crash", f"timed out after {TIMEOUT:.0f} s", TIMEOUT)
    seconds = time.perf_counter() - start
    kind = _kind(done.returncode)
    if kind in ("pass", "FAIL"):
        document = json.loads(done.stdout)
        verdict = document["verdict"]
        return Outcome(kind, verdict["statement"], seconds, list(document.get("reproducers", [])))
    lines = (done.stderr or done.stdout).strip().splitlines()
    return Outcome(kind, lines[-1] if lines else f"exit {done.returncode}, nothing said", seconds)


def shows(script: Path) -> str:
    """What a reproducer, run alone in a fresh process (`run_reproducer`), says: "shows" (the disagreement
    shows), "silent" (exit 0: it does not) or "broken: ..." (it could not run: its status, last line)."""
    from lagrange_xval.verdict.reproduce import run_reproducer

    run = run_reproducer(script, timeout=TIMEOUT)
    if run.shows or run.status == 0:
        return "shows" if run.shows else "silent"
    lines = run.output.strip().splitlines()
    return f"broken: status {run.status}: {lines[-1] if lines else 'nothing said'}"


def expect(key: str, path: Path, expected: tuple[str, tuple[str, ...]], folder: Path) -> None:
    """Asserts that the model gets its expected outcome (kind, phrases its line holds), that a FAIL has
    reproducers, and that every reproducer written shows its difference when run alone."""
    kind, phrases = expected
    outcome = judge(path, folder)
    missing = [p for p in phrases if p not in outcome.why]
    assert (outcome.kind, missing) == (kind, []), f"{key}: {outcome.kind} (expected {kind}): {outcome.why}"
    if outcome.kind == "FAIL":
        assert outcome.reproducers, f"{key}: a FAIL without a reproducer: {outcome.why}"
    unwritten = [str(r["skipped"]) for r in outcome.reproducers if "could not be written" in str(r.get("skipped", ""))]
    assert not unwritten, f"{key}: the harness could not write its reproducers: {unwritten}"
    said = {str(r["path"]): shows(Path(str(r["path"]))) for r in outcome.reproducers if r.get("path")}
    unshown = {script: what for script, what in said.items() if what != "shows"}
    assert not unshown, f"{key}: reproducers that show no difference (the harness's own misreading): {unshown}"


def reason(outcome: Outcome) -> str:
    """A refusal's reason as a class (the text after the file's name, numbers and quotes left out)."""
    text = re.sub(r"^lagrange-xval: error: [^:]+: ", "", outcome.why)
    text = re.sub(r"'[^']*'", "'…'", text)
    return re.sub(r"\d[\d.e+-]*", "N", text)[:90]


def _one(key: str, path: Path, folder: Path) -> tuple[str, Outcome, list[str]]:
    outcome = judge(path, folder)
    return key, outcome, [shows(Path(str(r["path"]))) for r in outcome.reproducers if r.get("path")]


def survey(workers: int = 2) -> Iterator[tuple[str, Outcome, list[str]]]:
    """Every model's outcome (in the corpus's order, `workers` at a time) and what each of its
    reproducers says."""
    from concurrent.futures import ThreadPoolExecutor

    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(workers) as pool:
        jobs = [pool.submit(_one, key, path, Path(tmp) / str(i)) for i, (key, path) in enumerate(models())]
        for job in jobs:
            yield job.result()


def _timed(command: list[str], cwd: Path) -> float:
    import time

    start = time.perf_counter()
    subprocess.run(command, cwd=cwd, capture_output=True, timeout=TIMEOUT)
    return time.perf_counter() - start


def timing() -> int:
    """`--timing`: `lagrange-xval survey` over each package's folder (2 workers) against the shell loop it
    replaces (`check --model FILE` then `audit FILE`, one process each, one model after the other), on
    the same files; prints the seconds of each and their ratio."""
    cli = [sys.executable, "-m", "lagrange_xval.cli"]
    totals = {"survey": 0.0, "check": 0.0, "audit": 0.0}
    for name in PACKAGES:
        folder = package_folder(name)
        if folder is None:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            survey_s = _timed(
                [*cli, "survey", str(folder), "--out", f"{tmp}/s", "--states", STATES, "--workers", "2"], folder
            )
        files = [path for key, path in models() if key.startswith(f"{name}/")]
        check_s = sum(
            _timed([*cli, "check", "--model", str(p), "--states", STATES, "--probes", "0", "--json"], p.parent)
            for p in files
        )
        audit_s = sum(_timed([*cli, "audit", str(p), "--json"], p.parent) for p in files)
        print(
            f"{name}: {len(files)} models; survey {survey_s:.1f} s; loop: check {check_s:.1f} s + audit {audit_s:.1f} s"
        )
        totals = {
            "survey": totals["survey"] + survey_s,
            "check": totals["check"] + check_s,
            "audit": totals["audit"] + audit_s,
        }
    loop = totals["check"] + totals["audit"]
    print(
        f"total: survey {totals['survey']:.1f} s against the loop's {loop:.1f} s (check {totals['check']:.1f} s, "
        f"audit {totals['audit']:.1f} s): survey / sum of single checks = {totals['survey'] / totals['check']:.2f}, "
        f"survey / loop = {totals['survey'] / loop:.2f} ({os.cpu_count()} cores)"
    )
    return 0


def main(argv: list[str]) -> int:
    """Prints a row per model and the figures; `--jsonl FILE` also writes each row as a JSON line;
    `--timing` times the survey command against the shell loop instead (`timing`)."""
    if "--timing" in argv:
        return timing()
    lines = open(argv[argv.index("--jsonl") + 1], "w") if "--jsonl" in argv else None  # noqa: SIM115
    rows = []
    for key, outcome, shown in survey():
        rows.append((key, outcome, shown))
        if lines is not None:
            record = {"key": key, "kind": outcome.kind, "why": outcome.why, "seconds": outcome.seconds}
            lines.write(json.dumps({**record, "reproducers": shown}) + "\n")
            lines.flush()
        proof = f" [reproducers: {', '.join(shown)}]" if shown else ""
        print(f"{outcome.kind:8} {outcome.seconds:6.1f} s  {key}: {outcome.why[:160]}{proof}", flush=True)
    kinds = Counter(o.kind for _, o, _ in rows)
    scripts = [s for _, o, shown in rows for s in shown]
    print(f"\n{len(rows)} models: " + ", ".join(f"{kinds[k]} {k}" for k in ("pass", "FAIL", "refused", "crash")))
    print(f"FAILs with a reproducer: {sum(1 for _, o, s in rows if o.kind == 'FAIL' and s)} of {kinds['FAIL']}; ")
    print(f"reproducers that show their difference: {scripts.count('shows')} of {len(scripts)}", end="")
    print(f" ({scripts.count('silent')} silent, {sum(s.startswith('broken') for s in scripts)} broken)")
    for why, n in Counter(reason(o) for _, o, _ in rows if o.kind == "refused").most_common():
        print(f"  refused {n:3}: {why}")
    print(f"packages: {', '.join(f'{d}=={_version(d)}' for d in PACKAGES.values())}")
    return 0


def _version(distribution: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(distribution)
    except PackageNotFoundError:
        return "not installed"


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    sys.exit(main(sys.argv[1:]))

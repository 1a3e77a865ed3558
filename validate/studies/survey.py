"""A whole folder of models judged at once (issue 43): `lagrange-xval survey DIR`.

Every MJCF and URDF file under DIR (a file whose root element is <mujoco> or <robot>; an included
fragment, <mujocoinclude>, is part of the models that include it) is judged model-only, as `check
--model FILE` judges it, from the file's own folder and in a process of its own (`judge`): the verdict,
the reproducer of every disagreement (verdict/reproduce.py, written under the survey's folder) and the
audit's findings (audit/audit.py), one `SurveyRow` each. A process that takes longer than `timeout`
seconds is ended with everything it started (its own session, killed as a group) and is one row,
"crash: timed out"; one that dies is one row too. Nothing a model does ends the survey.

The processes run `workers` at a time on this machine (threads waiting on child processes), or as the
tasks of any `concurrent.futures.Executor` (a dask.distributed client's: `--executor dask[:ADDRESS]`;
on a remote cluster the folder must be at the same path on every worker). The rows come back in the
order of the files, whatever the order they finished in, so two surveys of one folder compare line by
line.

Files of one robot (the same name in <robot name> and <mujoco model>, or given as pairs) are compared
with the two-file audit (audit/twofiles.py), one `SurveyPair` each.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import Executor, Future, ThreadPoolExecutor
from pathlib import Path

from ..core.errors import HarnessError
from ..core.parallel import completed, parent_death_signal
from ..results.schema import SurveyPair, SurveyResults, SurveyRow

ROOTS = {"mujoco": "mjcf", "robot": "urdf"}  # a model file's root element -> its format
SUFFIXES = (".xml", ".urdf", ".mjcf")
TIMEOUT = 300.0  # s for one model's check and audit
STATES = 20  # random states each model is compared at
OUTCOMES = ("FAIL", "crash", "refused", "pass")  # the table's order: what needs a look first
MAX_PAIRS_PER_ROBOT = 3  # files of one name beyond the first compared with it
GENERIC_NAMES = {"", "mujoco model", "robot", "model", "scene"}  # names that say nothing of the robot
HEAD_BYTES = 1_000_000  # what is read of a file to find its root element and name


def _head(path: Path) -> tuple[str, str] | None:
    """(format, robot name) of a model file, None for any other file (an include, a mesh's XML)."""
    try:
        text = path.read_bytes()[:HEAD_BYTES].decode("utf-8", "replace")
    except OSError:
        return None
    text = re.sub(r"<\?.*?\?>|<!--.*?-->|<!DOCTYPE[^>]*>", "", text, flags=re.S)
    match = re.search(r"<\s*([A-Za-z_][\w.:-]*)([^>]*)>", text)
    if match is None or match[1] not in ROOTS:
        return None
    attribute = "name" if match[1] == "robot" else "model"
    name = re.search(rf'\b{attribute}\s*=\s*["\']([^"\']*)["\']', match[2])
    return ROOTS[match[1]], (name[1].strip() if name else "")


def model_files(folder: Path) -> list[tuple[Path, str, str]]:
    """(path, format, robot name) of every model file under `folder`, sorted by path; symbolic links to
    folders are not followed (a link back up would survey for ever)."""
    if not folder.is_dir():
        raise HarnessError(f"survey: {folder} is not a folder; give a folder of MJCF (.xml) and URDF (.urdf) files.")
    out = []
    for root, dirs, files in os.walk(folder):
        dirs.sort()
        for name in sorted(files):
            path = Path(root) / name
            if path.suffix.lower() in SUFFIXES and path.is_file():
                head = _head(path)
                if head is not None:
                    out.append((path, *head))
    return sorted(out)


_MOVES = {
    "urdf": re.compile(r"""\btype\s*=\s*["'](revolute|continuous|prismatic)["']"""),
    "mjcf": re.compile(r"<\s*joint\b"),
}


def _moves(path: Path, fmt: str) -> bool:
    """Whether the file has a joint that moves (a cheap look: a URDF joint of a moving type, an MJCF
    <joint>): a two-file audit compares moving joints, so files without are no pair."""
    try:
        return bool(_MOVES[fmt].search(path.read_bytes()[:HEAD_BYTES].decode("utf-8", "replace")))
    except OSError:
        return False


def same_robot(files: Sequence[tuple[Path, str, str]]) -> list[tuple[Path, Path, str]]:
    """Pairs of files that give the robot the same (non-generic) name and both move a joint, the first
    file of each name against each of the next MAX_PAIRS_PER_ROBOT."""
    by_name: dict[str, list[Path]] = {}
    for path, fmt, name in files:
        if name.lower() not in GENERIC_NAMES and _moves(path, fmt):
            by_name.setdefault(name.lower(), []).append(path)
    return [
        (paths[0], other, name)
        for name, paths in sorted(by_name.items())
        for other in paths[1 : 1 + MAX_PAIRS_PER_ROBOT]
    ]


def given_pairs(text: str, folder: Path) -> list[tuple[Path, Path, str]]:
    """`--pairs A:B,C:D` (paths relative to the folder, or absolute) as pairs; a bad entry is one error."""
    out = []
    for entry in (e.strip() for e in text.split(",") if e.strip()):
        a, sep, b = entry.partition(":")
        if not sep or not a or not b:
            raise HarnessError(f"--pairs entry {entry!r}: give A:B, two model files (comma-separated pairs).")
        paths = [p if p.is_absolute() else folder / p for p in (Path(a), Path(b))]
        missing = [str(p) for p in paths if not p.is_file()]
        if missing:
            raise HarnessError(f"--pairs entry {entry!r}: no model file {', '.join(missing)}.")
        out.append((paths[0], paths[1], "given"))
    return out


# --- one process per model ---------------------------------------------------------------------------

_RUNNING: set[subprocess.Popen[bytes]] = set()  # the children running now: ended on Ctrl-C
_LOCK = threading.Lock()


def _end(process: subprocess.Popen[bytes]) -> None:
    """Ends the process and every process it started (its session: start_new_session)."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def end_all() -> None:
    """Ends every child the survey started (Ctrl-C, SIGTERM)."""
    with _LOCK:
        running = list(_RUNNING)
    for process in running:
        _end(process)


def run_child(command: list[str], cwd: str, timeout: float) -> tuple[int | None, str, str, float]:
    """(status, stdout, stderr, seconds) of `command` run in `cwd`, in a session of its own; status None
    where it ran past `timeout` seconds (it and all it started are then killed)."""
    start = time.perf_counter()
    env = {**os.environ, "PYTHONHASHSEED": "0"}
    process = subprocess.Popen(
        command,
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
        env=env,
        # killed when the thread that started it ends: a model's process does not outlive a survey whose
        # worker was killed (a dask worker's session is not the child's: start_new_session)
        preexec_fn=parent_death_signal(),  # noqa: PLW1509 - one prctl call, no lock taken in the child
    )
    with _LOCK:
        _RUNNING.add(process)
    try:
        out, err = process.communicate(timeout=timeout)
        status: int | None = process.returncode
    except subprocess.TimeoutExpired:
        _end(process)
        out, err = process.communicate()
        status = None
    finally:
        _end(process)  # whatever it left running (a reader's child) goes with it
        with _LOCK:
            _RUNNING.discard(process)
    return status, out.decode("utf-8", "replace"), err.decode("utf-8", "replace"), time.perf_counter() - start


def _last_line(*texts: str) -> str:
    for text in texts:
        lines = [x for x in text.strip().splitlines() if x.strip()]
        if lines:
            return lines[-1].removeprefix("lagrange-xval: error: ")
    return "nothing said"


def _crash(status: int | None, err: str, timeout: float) -> str:
    if status is None:
        return f"timed out after {timeout:g} s (the check and everything it started were ended)"
    if status < 0:
        return f"the check's process died of signal {signal.Signals(-status).name}: {_last_line(err)}"
    return f"the check's process ended with status {status}: {_last_line(err)}"


def judge(path: str, key: str, folder: str, fmt: str, robot: str, states: int, timeout: float) -> SurveyRow:
    """The row of one model: `lagrange-xval survey --one` in a process of its own, from the model's folder
    (module docstring). Runs where the executor puts it (a thread here, a dask worker)."""
    reproduce = Path(folder) / "reproducers" / re.sub(r"[^A-Za-z0-9_.-]+", "_", key)
    command = [sys.executable, "-m", "lagrange_xval.cli", "survey", "--one", path, "--reproduce", str(reproduce)]
    status, out, err, seconds = run_child([*command, "--states", str(states)], str(Path(path).parent), timeout)
    row: SurveyRow = {
        "model": key,
        "format": fmt,
        "robot": robot,
        "outcome": "crash",
        "why": "",
        "seconds": round(seconds, 3),
        "reproducers": [],
        "audit": "not run",
        "findings": [],
    }
    if status != 0:
        return {**row, "why": _crash(status, err, timeout)}
    try:
        one = json.loads(out)
    except json.JSONDecodeError:
        return {**row, "why": f"the check wrote no result: {_last_line(err, out)}"}
    shown = [os.path.relpath(p, folder) for p in one.get("reproducers", [])]
    row["outcome"], row["why"], row["audit"] = str(one["outcome"]), str(one["why"]), str(one["audit"])
    return {**row, "reproducers": shown, "findings": [str(f) for f in one["findings"]]}


def compare_pair(a: str, b: str, keys: tuple[str, str], robot: str, timeout: float) -> SurveyPair:
    """The two-file audit of a pair (`lagrange-xval audit A B --json`) in a process of its own."""
    command = [sys.executable, "-m", "lagrange_xval.cli", "audit", a, b, "--json"]
    status, out, err, seconds = run_child(command, str(Path(a).parent), timeout)
    row: SurveyPair = {
        "a": keys[0],
        "b": keys[1],
        "robot": robot,
        "outcome": "crash",
        "why": "",
        "findings": [],
        "seconds": round(seconds, 3),
    }
    if status in (0, 1):
        try:
            findings = [str(f) for f in json.loads(out).get("findings", [])]
        except json.JSONDecodeError:
            return {**row, "why": f"the audit wrote no result: {_last_line(err, out)}"}
        why = "the two files describe the same robot" if status == 0 else "; ".join(findings[:2])
        return {**row, "outcome": "same robot" if status == 0 else "differ", "why": why, "findings": findings}
    if status == 2:
        return {**row, "outcome": "refused", "why": _last_line(err, out)}
    return {**row, "why": _crash(status, err, timeout)}


# --- the survey --------------------------------------------------------------------------------------


def _in_order(
    jobs: list[Future[SurveyRow]], keys: list[str], on_row: Callable[[SurveyRow, int, int], None]
) -> list[SurveyRow]:
    """The jobs' rows in the files' order, `on_row(row, done, total)` called as each finishes."""
    rows: dict[int, SurveyRow] = {}
    index = {id(job): i for i, job in enumerate(jobs)}
    for job in completed(jobs):
        i = index[id(job)]
        try:
            rows[i] = job.result()
        except Exception as exc:  # noqa: BLE001 - a worker lost (a dask worker killed): that model's row
            rows[i] = _lost(keys[i], exc)
        on_row(rows[i], len(rows), len(jobs))
    return [rows[i] for i in range(len(jobs))]


def _lost(key: str, exc: BaseException) -> SurveyRow:
    why = f"the executor lost the task: {type(exc).__name__}: {exc}"
    return {
        "model": key,
        "format": "",
        "robot": "",
        "outcome": "crash",
        "why": why,
        "seconds": 0.0,
        "reproducers": [],
        "audit": "not run",
        "findings": [],
    }


def survey(
    folder: Path,
    out: Path,
    *,
    executor: Executor | None = None,
    workers: int = 2,
    states: int = STATES,
    timeout: float = TIMEOUT,
    pairs: Iterable[tuple[Path, Path, str]] = (),
    on_row: Callable[[SurveyRow, int, int], None] = lambda row, done, total: None,
) -> SurveyResults:
    """Every model under `folder` judged (module docstring), reproducers written under `out`; the
    files' pairs compared after the models."""
    start = time.perf_counter()
    files = model_files(folder)
    if not files:
        raise HarnessError(f"survey: no MJCF or URDF model file under {folder} (a .xml with <mujoco> or a <robot>).")
    keys = [p.relative_to(folder).as_posix() for p, _, _ in files]
    pool = executor or ThreadPoolExecutor(max(1, workers))
    try:
        jobs = [
            pool.submit(judge, str(p), k, str(out), fmt, name, states, timeout)
            for (p, fmt, name), k in zip(files, keys, strict=True)
        ]
        rows = _in_order(jobs, keys, on_row)
        pair_jobs = [
            pool.submit(compare_pair, str(a), str(b), (_key(a, folder), _key(b, folder)), name, timeout)
            for a, b, name in pairs
        ]
        compared = [job.result() for job in pair_jobs]
    finally:
        if executor is None:
            pool.shutdown(wait=True, cancel_futures=True)
    where = "local" if executor is None else type(executor).__name__
    return {
        "folder": str(folder),
        "executor": f"{where} ({workers} workers)" if executor is None else where,
        "seconds": round(time.perf_counter() - start, 3),
        "rows": rows,
        "pairs": compared,
        "counts": counts(rows),
    }


def _key(path: Path, folder: Path) -> str:
    try:
        return path.resolve().relative_to(folder.resolve()).as_posix()
    except ValueError:
        return str(path)


def counts(rows: Iterable[SurveyRow]) -> dict[str, int]:
    """outcome -> models, every outcome listed (0 included), in OUTCOMES' order."""
    seen = Counter(r["outcome"] for r in rows)
    return {k: seen.get(k, 0) for k in OUTCOMES}

"""`lagrange-xval survey DIR`: every model under a folder judged at once (validate/studies/survey.py runs
them; validate/report/survey.py writes the table and the pages).

Each model runs in a process of its own, `survey --one FILE` (hidden), which gives `check --model FILE
--json --reproduce DIR` and `audit FILE --json` in that one process and prints one JSON object: the
verdict, its reproducers and the audit's findings. The table, survey.json (the whole survey: models,
pairs, counts), survey.jsonl (a line per model), survey.html and survey.md
and the reproducers are written into --out as one set when the survey is complete (cli/outputs.py): an
interrupted survey leaves the previous set whole."""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from ..core.errors import HarnessError, console
from ..core.parallel import named_executor
from ..results.schema import SurveyResults, SurveyRow
from ..studies import survey as surveying
from ..verdict.reproduce import FOLDER as REPRODUCERS

Command = Callable[[argparse.Namespace], int]  # a command of this command line (cli/commands.py COMMANDS)


def _captured(command: Command, argv: list[str]) -> tuple[int, str, str]:
    """(status, stdout, stderr) of one command of this command line, run in this process; a HarnessError
    is its one error line and status 2, as `main` gives it (anything else ends the model's process: a
    crash, its row says so)."""
    from .parser import build_parser, one_line

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = command(build_parser().parse_args(argv))
        except HarnessError as exc:
            print(f"lagrange-xval: error: {one_line(exc)}", file=sys.stderr)
            status = 2
    return status, out.getvalue(), err.getvalue()


def _last(text: str) -> str:
    lines = [x for x in text.strip().splitlines() if x.strip()]
    return lines[-1].removeprefix("lagrange-xval: error: ") if lines else "nothing said"


def _audit(audit: Command, path: Path) -> tuple[str, list[str]]:
    """The audit's word on the file ("agrees", "N finding(s)", or why it could not run) and its findings."""
    status, out, err = _captured(audit, ["audit", str(path), "--json"])
    if status not in (0, 1):
        return f"could not run: {_last(err or out)}", []
    document = json.loads(out)
    findings = [str(f) for f in document.get("findings", [])]
    if status == 0 or findings:
        return ("agrees" if status == 0 else f"{len(findings)} finding(s)"), findings
    skipped = [str(why) for why in dict(document.get("skipped") or {}).values()]
    return f"not judged: {skipped[0] if skipped else 'fewer than two readers'}", findings


def one(path: Path, reproduce: Path, states: int, *, check: Command, audit: Command) -> dict[str, Any]:
    """What `survey --one` prints: the verdict on one model (`check`), its reproducers and the audit."""
    command = ["check", "--model", str(path), "--states", str(states), "--probes", "0", "--json"]
    status, out, err = _captured(check, [*command, "--reproduce", str(reproduce)])
    if status in (0, 1):
        document = json.loads(out)
        outcome, why = ("pass" if status == 0 else "FAIL"), str(document["verdict"]["statement"])
        reproducers = [str(r["path"]) for r in document.get("reproducers", []) if r.get("path")]
    else:
        outcome, why, reproducers = ("refused" if status == 2 else "crash"), _last(err or out), []
        why = why.removeprefix(f"{path.name}: ")  # the row names the file already
    said, findings = _audit(audit, path)
    return {"outcome": outcome, "why": why, "reproducers": reproducers, "audit": said, "findings": findings}


def _line(row: SurveyRow, done: int, total: int) -> str:
    return console([f"[{done}/{total}] {row['outcome']:7} {row['seconds']:6.1f} s  {row['model']}"])


@contextlib.contextmanager
def _progress() -> Iterator[Callable[[SurveyRow, int, int], None]]:
    """A live bar of the models judged so far in a terminal (each finished model's line above it); one
    line per model elsewhere (CI, a file)."""
    if not sys.stderr.isatty():
        yield lambda row, done, total: print(_line(row, done, total), file=sys.stderr, flush=True)
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    columns = (TextColumn("surveying"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with Progress(*columns, console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task("models", total=None)

        def live(row: SurveyRow, done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)
            bar.console.print(_line(row, done, total), markup=False, highlight=False, emoji=False)

        yield live


def _pairs(args: argparse.Namespace, folder: Path) -> list[tuple[Path, Path, str]]:
    given = surveying.given_pairs(args.pairs, folder) if args.pairs else []
    named = surveying.same_robot(surveying.model_files(folder))
    seen = {(a.resolve(), b.resolve()) for a, b, _ in given}
    return given + [(a, b, n) for a, b, n in named if (a.resolve(), b.resolve()) not in seen]


def _files(result: SurveyResults, scratch: Path) -> dict[str, bytes]:
    """Every file of the set: the pages, a JSON line per model, the reproducers the models wrote."""
    from ..report.survey import render_survey  # jinja2 and the report: loaded by the survey, not by every command

    lines = "".join(json.dumps(row, sort_keys=True) + "\n" for row in result["rows"])
    whole = json.dumps(result, indent=1, sort_keys=True) + "\n"
    files = {"survey.json": whole.encode(), "survey.jsonl": lines.encode(), **render_survey(result)}
    for path in sorted(scratch.rglob("*")):
        if path.is_file():
            files[path.relative_to(scratch).as_posix()] = path.read_bytes()
    return files


def cmd_survey(args: argparse.Namespace, *, check: Command, audit: Command) -> int:
    """Judges every model under DIR with `check` and `audit` (cli/commands.py's); status 1 when one FAILs
    or crashes (a refusal is said, not a failure)."""
    from .outputs import SURVEY_FILES, replace_set  # the report's renderers: loaded by the survey alone

    if args.one is not None:
        reproduce = args.reproduce or Path(tempfile.mkdtemp())
        print(json.dumps(one(args.one, reproduce, args.states, check=check, audit=audit)))
        return 0
    if args.folder is None:
        raise HarnessError("survey: give a folder of models (lagrange-xval survey DIR).")
    folder = Path(args.folder).absolute()
    pairs = _pairs(args, folder)
    workers = args.workers or os.cpu_count() or 1
    with (
        tempfile.TemporaryDirectory(prefix="lagrange-xval-survey-") as scratch,
        named_executor(args.executor, workers=workers) as executor,
        _progress() as progress,
    ):
        try:
            result = surveying.survey(
                folder,
                Path(scratch),
                executor=executor,
                workers=workers,
                states=args.states,
                timeout=args.timeout,
                pairs=pairs,
                on_row=progress,
            )
        except BaseException:
            surveying.end_all()  # Ctrl-C, SIGTERM: no model's process outlives the command
            raise
        result["executor"] = f"{args.executor or 'local'} ({workers} workers)"
        replace_set(args.out, _files(result, Path(scratch)), replaces=lambda name: name in (*SURVEY_FILES, REPRODUCERS))
    from ..report.survey import table_lines

    if args.json:
        print("\n".join(json.dumps(row, sort_keys=True) for row in result["rows"]))
    else:
        print(console([*table_lines(result), f"written: {args.out}/survey.html, survey.md, survey.json, survey.jsonl"]))
    return 1 if result["counts"]["FAIL"] or result["counts"]["crash"] else 0

"""The command line says what it is: one option name per meaning, help with units and the valid
system names, `--version`, a top-level help about the tool, a broken or unpaired system reported
rather than hiding the others, and a README table that names options that exist.
(`simulate`'s adjustments and files: tests/unit/cli/test_simulate.py.)"""

from __future__ import annotations

import argparse
import json
import shutil
import types
from importlib import metadata

import pytest
from lagrange_xval import systems
from lagrange_xval.cli import main, parser


def _commands() -> dict[str, argparse.ArgumentParser]:
    top = parser.build_parser()
    (sub,) = (a for a in top._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _options(command: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in command._actions if not isinstance(a, (argparse._HelpAction, argparse._VersionAction))]


def _help(command: str, option: str) -> str:
    for action in _options(_commands()[command]):
        if option in action.option_strings or option == action.dest:
            return str(action.help)
    raise AssertionError(f"{command} has no {option}")


def test_an_option_name_means_one_thing_on_every_command():
    """The same option string takes the same kind of value wherever it appears (`--states` was a count
    on `run` and a file on `check`)."""
    kinds: dict[str, dict[str, str]] = {}
    for name, command in _commands().items():
        for action in _options(command):
            for option in action.option_strings:
                kind = getattr(action.type, "__name__", type(action).__name__)
                kinds.setdefault(option, {})[name] = kind
    mixed = {option: by for option, by in kinds.items() if len(set(by.values())) > 1}
    assert not mixed, f"one option, several meanings: {mixed}"
    assert kinds["--states"] == {
        "run": "state_count",
        "check": "state_count",
        "watch": "state_count",
        "survey": "state_count",
    }


def test_check_states_is_a_count_and_the_file_is_states_file(tmp_path, capsys):
    assert main(["check", "simple_pendulum", "--states", "3", "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)["states"]) == 3
    path = tmp_path / "s.json"
    path.write_text('[{"q": [0.1], "v": [0.0]}, {"q": [0.2], "v": [1.0]}]')
    assert main(["check", "simple_pendulum", "--states-file", str(path), "--json"]) == 0
    assert [s["q"] for s in json.loads(capsys.readouterr().out)["states"]] == [[0.1], [0.2]]
    with pytest.raises(SystemExit) as exit_:
        main(["check", "simple_pendulum", "--states", str(path)])  # the old spelling of the file
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "is not a whole number" in err and "--states-file FILE" in err, err
    with pytest.raises(SystemExit):
        main(["check", "simple_pendulum", "--states", "3", "--states-file", str(path)])
    assert "not allowed with argument" in capsys.readouterr().err


def test_the_old_count_spelling_works_with_a_deprecation_line(capsys):
    assert main(["check", "simple_pendulum", "--n", "4", "--json"]) == 0
    captured = capsys.readouterr()
    assert len(json.loads(captured.out)["states"]) == 4
    assert captured.err.strip() == "lagrange-xval: warning: --n is deprecated; use --states N.", captured.err


def test_every_option_has_help_and_says_its_unit():
    missing = [
        f"{name} {action.option_strings or action.dest}"
        for name, command in _commands().items()
        for action in _options(command)
        if not action.help or action.help == argparse.SUPPRESS
    ]
    assert not missing, f"options without help: {missing}"
    for option in ("--t-end", "--dt-out"):
        assert "(s)" in _help("simulate", option), option
    assert "rad" in _help("simulate", "--q0") and "rad/s" in _help("simulate", "--v0")
    assert "N m" in _help("simulate", "--tau")
    assert "2**63 - 1" in _help("run", "--seed") and "2**63 - 1" in _help("check", "--seed")
    assert "results.json" in _help("report", "--out")


@pytest.mark.parametrize("command", ["run", "check", "simulate", "bench", "stress", "replay"])
def test_system_help_lists_the_valid_names(command):
    dest = "systems" if command in ("run", "bench", "stress") else "system"
    text = _help(command, dest)
    for name in systems.system_names():
        assert name in text, f"{command} SYSTEM help does not name {name}: {text}"


def test_version_prints_the_installed_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"lagrange-xval {metadata.version('lagrange-xval')}"


def test_the_top_level_help_says_what_the_tool_does(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "hand-derived Lagrangian equations of motion against MuJoCo, Pinocchio and Drake" in out, out
    assert "Heavy imports" not in out and "subcommands" not in out


def _without(module_name: str, attribute: str, monkeypatch):
    """`import_module` returning the equations module `module_name` without `attribute`."""
    real = systems.loader.importlib.import_module
    original = real(f"{systems.EQUATIONS_PACKAGE}.{module_name}")
    broken = types.ModuleType(original.__name__)
    broken.__dict__.update({k: v for k, v in vars(original).items() if k != attribute})

    def import_module(name, *args):
        return broken if name == f"{systems.EQUATIONS_PACKAGE}.{module_name}" else real(name, *args)

    monkeypatch.setattr(systems.loader.importlib, "import_module", import_module)


def test_list_names_a_module_missing_an_attribute_as_broken_and_lists_the_others(capsys, monkeypatch):
    names = systems.system_names()
    _without(names[-1], "parameters", monkeypatch)
    systems.loader.repository_module.cache_clear()
    try:
        status = main(["list"])
    finally:
        systems.loader.repository_module.cache_clear()
    out = capsys.readouterr().out
    assert status == 1
    assert f"{names[-1]}: BROKEN: equations/{names[-1]}.py lacks parameters(model)" in out, out
    for name in names[:-1]:
        assert f"{name}: " in out and f"{name}: BROKEN" not in out


@pytest.fixture
def lonely_models(tmp_path, monkeypatch):
    """models/ with an MJCF no module pairs (lonely.xml) and without one module's MJCF."""
    names = systems.system_names()
    models = tmp_path / "models"
    models.mkdir()
    for name in names:
        if name != "double_pendulum_bars":
            shutil.copy(systems.MODELS_DIR / f"{name}.xml", models / f"{name}.xml")
    shutil.copy(systems.MODELS_DIR / "simple_pendulum.xml", models / "lonely.xml")
    monkeypatch.setattr(systems.registry, "MODELS_DIR", models)
    return tmp_path


UNPAIRED = [
    "lonely: not checked: models/lonely.xml has no equations/lonely.py",
    "double_pendulum_bars: not checked: equations/double_pendulum_bars.py has no models/double_pendulum_bars.xml",
]


def test_list_and_run_report_unpaired_files(lonely_models, capsys):
    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line for line in lines if "not checked" in line] == UNPAIRED
    out = lonely_models / "reports"
    args = ["run", "simple_pendulum", "--states", "10", "--probes", "0", "--no-replay", "--no-cache"]
    assert main([*args, "--out", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    # the unpaired files, the tally, then the verdict on each derivation (issue 17: the findings last)
    assert lines[:2] == UNPAIRED and lines[2].startswith("all systems pass"), lines
    assert lines[-2:] == ["derivations, each judged term by term against the engines:", lines[-1]], lines
    assert lines[-1].startswith("  pass simple_pendulum: ") and "agrees with MuJoCo, Pinocchio" in lines[-1]


def test_naming_an_unpaired_system_says_what_is_missing(lonely_models, capsys):
    assert main(["check", "lonely"]) == 2
    assert "models/lonely.xml has no equations/lonely.py" in capsys.readouterr().err


def test_the_readme_command_table_uses_the_options_that_exist():
    """Every option the README's command table writes is an option of that command (a renamed option
    left in the README fails here)."""
    import re

    from lagrange_xval.systems import PACKAGE_ROOT

    commands = _commands()
    rows = [
        line for line in (PACKAGE_ROOT / "README.md").read_text().splitlines() if line.startswith("| `lagrange-xval ")
    ]
    assert len(rows) >= len(commands), "one row per command at least"
    wrong = []
    for row in rows:
        usage = row.split("`")[1]
        name = usage.split()[1]
        known = {o for a in commands[name]._actions for o in a.option_strings}
        wrong += [f"{name} {option}" for option in re.findall(r"--[a-z][a-z0-9-]*", usage) if option not in known]
    assert not wrong, f"README options no command has: {wrong}"


# ----------------------------------------------------------------------------------------------
# Issue 26: the command line's loose ends


def _all_help() -> str:
    top = parser.build_parser()
    return " ".join([top.format_help(), *(c.format_help() for c in _commands().values())])


def test_every_example_in_the_help_runs_as_written(capsys):
    """Each command line the help shows is in the help verbatim and runs: `list` runs; `run` parses;
    a `stress --set` example's overrides apply to every system it names (or to every system when it
    names none), exactly as `stress` applies them before any work."""
    from lagrange_xval.model.overrides import parse

    text = " ".join(_all_help().split())
    for example in parser.HELP_EXAMPLES:
        assert example in text, f"{example!r} is not in the help"
        args = parser.build_parser().parse_args(example.split()[1:])
        if args.command == "list":
            assert main(["list"]) == 0
        elif args.command == "stress":
            overrides = parse(args.set)
            for name in args.systems or systems.system_names():
                systems.load(name, overrides)  # an override the system lacks raises, naming it
    capsys.readouterr()


def test_the_help_and_the_readme_say_the_same_durations_and_sources():
    from lagrange_xval.systems import PACKAGE_ROOT

    readme = (PACKAGE_ROOT / "README.md").read_text()
    rows = {line.split("`")[1]: line for line in readme.splitlines() if line.startswith("| `lagrange-xval ")}
    for command, duration in parser.QUICK_DURATION.items():
        row = next(
            r
            for usage, r in rows.items()
            if usage.startswith(f"lagrange-xval {command.split()[0]}")
            and ("--chains" in usage) == ("--chains" in command)
        )
        assert duration in row, f"README's {command} row does not say {duration!r}: {row}"
        assert duration in " ".join(_all_help().split()), f"the help does not say {duration!r}"
    assert "three sources" not in _all_help() and "five sources" in _all_help() and "five sources" in readme


def test_list_takes_a_folder_and_run_goes_on_past_an_unpaired_file(tmp_path, capsys):
    """`list --systems DIR` lists a person's systems; `run --systems DIR` names a file without its
    partner and validates the rest; the results name the files absolutely (replay from anywhere)."""
    source = systems.load("simple_pendulum")
    mine = tmp_path / "mine"
    mine.mkdir()
    shutil.copy(source.mjcf, mine / "pendulum.xml")
    shutil.copy(source.equations.__file__, mine / "pendulum.py")
    (mine / "lonely.xml").write_text("<mujoco/>")
    assert main(["list", "--systems", str(mine)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("pendulum: 1 dof, coordinates (theta)"), out
    assert out[-1] == f"lonely: not checked: {mine / 'lonely.xml'} has no lonely.py or lonely.toml beside it", out
    args = ["run", "--systems", str(mine), "--states", "10", "--probes", "0", "--no-replay", "--no-cache"]
    assert main([*args, "--out", str(tmp_path / "out")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert f"lonely: not checked: {mine / 'lonely.xml'} has no lonely.py or lonely.toml beside it" in lines, lines
    held = json.loads((tmp_path / "out" / "results.json").read_text())["systems"]["pendulum"]
    assert held["mjcf"] == str((mine / "pendulum.xml").absolute()) and held["equations"].startswith("/"), held


def test_simulate_refuses_a_folder_that_does_not_exist(tmp_path, capsys):
    out = tmp_path / "nope" / "x.csv"
    args = ["simulate", "simple_pendulum", "--source", "hand", "--q0", "0.1", "--v0", "0"]
    assert main([*args, "--t-end", "0.1", "--dt-out", "0.05", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"the folder {out.parent} does not exist" in err and len(err.strip().splitlines()) == 1, err
    assert not out.parent.exists()

"""Item 5 of issue 10, "a CLI people trust": --version, help and units on every
option, clock names in any case, `show`, `plan --kind`, messages in option/field
terms, progress bars on a terminal only."""

from __future__ import annotations

import argparse
import re
import sys
from importlib.metadata import version

import pytest

from profiles.ppmc312.table import load_table
from tests.support.cli import arguments, parsers, run
from tests.support.paths import ROOT
from verify import cli

MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


def test_version_is_the_package_metadata(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "--version")
    assert code == 0 and out == f"stepramp {version('stepramp')}\n"


def test_every_option_and_argument_has_help() -> None:
    missing = [f"{name} {a.option_strings or a.dest}" for name, a in arguments()
               if not a.help or a.help == argparse.SUPPRESS]
    assert not missing, f"arguments without help: {missing}"
    assert len(arguments()) > 60  # the walk found the sub-commands' options


def test_units_are_spelled_one_way_in_help() -> None:
    text = " ".join(a.help or "" for _, a in arguments())
    for wrong in ("pps/s", "pps/s²", "pps^2", "a_pps2]", " sec"):
        assert wrong not in text


def test_show_accel_time_is_what_the_chip_runs() -> None:
    from profiles.ppmc312.execution import simulate_move
    from profiles.ppmc312.listing import list_stages

    table = load_table(ROOT / "examples" / "free-curve-nema17.json")
    run_ = simulate_move(table, 100_000)  # long enough to cruise: full ramps
    accel_ticks = sum(s.end_tick - s.start_tick for s in run_.segments if s.phase == "accel")
    assert list_stages(table).accel_s == pytest.approx(accel_ticks / table.clock.hz,
                                                       rel=1e-12)


T = str(ROOT / "examples" / "free-curve-nema17.json")


READ = str(ROOT / "examples" / "free-curve-nema17.read.hex")


@pytest.mark.parametrize(("argv", "option"), [
    (["mc200", "stream", "--vmax", "-1", "--amax", "1", "--jmax", "1", "--pulses", "100",
      "--period-us", "1000"], "--vmax"),
    (["mc200", "stream", "--vmax", "1e3", "--amax", "1e4", "--jmax", "1e5", "--pulses", "100",
      "--period-us", "1"], "--period-us"),
    (["mc200", "stream", "--vmax", "1e3", "--amax", "1e4", "--jmax", "1e5", "--pulses", "100",
      "--period-us", "1000", "--driver-id", "99"], "--driver-id"),
    (["move", "--pulses", "0"], "--pulses"),
    (["move", "--pulses", "5", "--to", "ascii", "--address", "99"], "--address"),
    (["export", T, "--max-block-data", "99"], "--max-block-data"),
    (["simulate", T, "--pulses", "100", "--high-rate", "3"], "--high-rate"),
    (["simulate", T, "--pulses", "0"], "--pulses"),
    (["plan", "--motor", str(MOTOR), "--max-stages", "1"], "--max-stages"),
    (["alink", "settings", "--start-pps", "0", "--high-pps", "100",
      "--accel-ms-per-kpps", "1"], "--start-pps"),
    (["alink", "settings", "--start-pps", "100", "--high-pps", "1000",
      "--accel-ms-per-kpps", "-1"], "--accel-ms-per-kpps"),
    (["alink", "settings", "--motor", str(MOTOR), "--address", "99"], "--address"),
    (["decode", READ, "--table-read", "--clock", "EXTCK", "--extck-hz", "-5"], "--extck-hz"),
])
def test_range_errors_name_the_option_typed(capsys: pytest.CaptureFixture[str],
                                            argv: list[str], option: str) -> None:
    code, _, err = run(capsys, *argv)
    assert code == 2
    [line] = err.strip().splitlines()
    assert line.startswith(f"stepramp {argv[0]}: {option}") and "allowed range" in line


def test_every_command_module_is_registered_and_imports_no_sibling() -> None:
    package = ROOT / "verify" / "cli"
    modules = {f.stem for f in package.glob("*.py") if not f.stem.startswith("_")}
    assert set(cli.COMMANDS) == modules
    for name in modules:
        source = (package / f"{name}.py").read_text(encoding="utf-8")
        siblings = re.findall(r"from (?:verify\.cli)?\.(\w+) import|from verify\.cli import",
                              source)
        assert all(s == "_common" for s in siblings), (name, siblings)
        assert "def add_subparser(sub" in source


def test_dev_install_opens_notebooks() -> None:
    import tomllib

    dev = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["dev"]
    assert any(d.startswith(("jupyterlab", "notebook")) for d in dev)
    assert "jupyter lab notebooks/" in (ROOT / "README.md").read_text(encoding="utf-8")
    import importlib.util

    assert importlib.util.find_spec("jupyterlab") is not None  # installed by the [dev] extra


def _shape(parser: argparse.ArgumentParser) -> list[tuple[str, tuple[str, ...], str | None]]:
    return [(name, tuple(a.option_strings) or (a.dest,), a.help)
            for name, p in parsers(parser) for a in p._actions]


@pytest.mark.parametrize("command", cli.COMMANDS)
def test_one_commands_parser_is_its_branch_of_the_whole(command: str) -> None:
    # main() builds only the branch its command line names (a cold start pays for one
    # command's imports); that branch must be the whole parser's, option for option
    whole = [row for row in _shape(cli.build_parser())
             if row[0].startswith(f"stepramp {command}")]
    alone = _shape(cli.build_parser(command))
    assert [row for row in alone if row[0] != "stepramp"] == whole
    assert len(whole) > 1


def test_an_unknown_or_missing_command_builds_every_branch() -> None:
    for named in (None, "no-such-command", "--version"):
        [sub] = [a for a in cli.build_parser(named)._actions
                 if isinstance(a, argparse._SubParsersAction)]
        assert tuple(sub.choices) == cli.COMMANDS
    assert cli._command_named(["--debug", "check"]) is None
    assert cli._command_named(["check", "--motor", "x"]) == "check"


@pytest.mark.parametrize(("given", "expected"), [(None, "1"), ("4", "4")])
def test_the_command_starts_openblas_with_one_thread_unless_told(given: str | None,
                                                                 expected: str) -> None:
    import os
    import subprocess

    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if given is not None:
        env["OPENBLAS_NUM_THREADS"] = given
    probe = ("import sys, os; import verify.cli; loaded = 'numpy' in sys.modules; "
             "print(os.environ['OPENBLAS_NUM_THREADS'], loaded)")
    out = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    assert out == [expected, "False"]  # set before any command loads numpy


@pytest.mark.parametrize("debug", [False, True])
def test_an_internal_error_is_one_line_unless_debug_shows_the_traceback(
        capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch,
        debug: bool) -> None:
    """A bug (an unexpected exception) is exit 2 and one line naming it, never exit 1;
    `--debug`, anywhere on the command line, adds the Python traceback."""
    from verify.cli import check

    def broken(args: object) -> int:
        raise RuntimeError("a bug")

    real = check.add_subparser

    def add(sub: object) -> None:
        real(sub)
        sub.choices["check"].set_defaults(func=broken)  # type: ignore[attr-defined]

    monkeypatch.setattr(check, "add_subparser", add)
    argv = ["check", str(ROOT / "examples" / "free-curve-nema17.json")]
    code = cli.main([*argv, "--debug"] if debug else argv)
    err = capsys.readouterr().err
    assert code == 2 and "internal error (RuntimeError: a bug)" in err
    assert ("Traceback (most recent call last)" in err) == debug


def test_main_reads_the_command_line_after_the_program_name(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """`stepramp` (the console script) calls main() with no arguments: sys.argv[1:]."""
    monkeypatch.setattr(sys, "argv", ["stepramp", "--version"])
    assert cli.main() == 0
    assert capsys.readouterr().out.strip() == f"stepramp {version('stepramp')}"


def test_top_level_help_lists_debug(capsys: pytest.CaptureFixture[str]) -> None:
    """--debug works anywhere on the line (it is taken out before parsing), and the help
    says it exists."""
    assert cli.main(["--help"]) == 0
    assert "--debug" in capsys.readouterr().out

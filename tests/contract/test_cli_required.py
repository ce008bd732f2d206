"""What each command cannot run without: its required arguments, as a user meets them.

Written from the commands' help, not read back from the parser: a command that stopped
requiring an argument would run on without it (and fail later, less clearly)."""

from __future__ import annotations

import pytest

from verify import cli

REQUIRED = {
    "check": "FILE",
    "show": "TABLE",
    "export": "TABLE",
    "decode": "UPLOAD",
    "move": "--pulses",
    "expand": "TABLE",
    "plan": "--motor",
    "compare": "TABLE, --motor, --pulses",
    "sync": "AXES.json, -o/--output",
    "design": "--motor",
    "sweep": "--motors, --pulses, -o/--output",
    "alink": "COMMAND",
    "mc200": "COMMAND",
    "motor": "SUBCOMMAND",
    "link": "--port, --address, COMMAND",
}


def test_every_command_is_listed() -> None:
    """simulate, answer and emulate have their own rules (TABLE and --pulses, or --axes;
    HEX bytes or --file; --pty or --bus SCRIPT)."""
    assert set(REQUIRED) | {"simulate", "answer", "emulate"} == set(cli.COMMANDS)


@pytest.mark.parametrize("command", sorted(REQUIRED))
def test_a_command_without_its_required_arguments_names_them(
        command: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main([command]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [f"stepramp {command}: the following arguments are required: "
                   f"{REQUIRED[command]} (see stepramp {command} --help)"]


def test_simulate_says_what_it_needs(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["simulate"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        "stepramp simulate: give TABLE and --pulses, a program file, or --axes AXES.json"]


def test_emulate_says_what_it_needs(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["emulate"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        "stepramp emulate: give --pty (a serial slave on a pseudo-terminal) or --bus SCRIPT "
        "(a bus script run through the chip)"]


def test_answer_says_what_it_needs(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["answer"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        "stepramp answer: give the answer's bytes as HEX (e.g. 03 01 00) or --file PATH"]

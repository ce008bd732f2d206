"""`stepramp design` (verify/cli/design.py): its refusals and options, in-process."""

from __future__ import annotations

import sys

import pytest

from profiles.motor import bundled_motor_paths
from verify.cli import main

NEMA17_PATH = next(p for p in bundled_motor_paths() if "nema17" in p.name)


def test_help_names_every_option(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["design", "--help"]) == 0
    out = capsys.readouterr().out
    for option in ("--motor", "--port", "--pulses", "--no-browser"):
        assert option in out


def test_a_missing_extra_is_one_line_naming_it(monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "panel", None)  # `import panel` raises ImportError
    assert main(["design", "--motor", str(NEMA17_PATH), "--no-browser"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pip install 'stepramp[design]'" in err, err


@pytest.mark.parametrize(("argv", "says"), [
    (["--port", "70000"], "--port"),
    (["--pulses", "5"], "--pulses"),
])
def test_unusable_options_exit_2_naming_the_option(argv: list[str], says: str,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["design", "--motor", str(NEMA17_PATH), "--no-browser", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and says in err, err


@pytest.mark.slow  # ~2.5 s (a Panel server); CI runs it
def test_a_port_in_use_exits_2_naming_it(capsys: pytest.CaptureFixture[str]) -> None:
    import socket

    pytest.importorskip("panel")
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        assert main(["design", "--motor", str(NEMA17_PATH), "--no-browser",
                     "--port", str(port)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--port {port}" in err, err


def test_the_page_opens_with_the_designers_move_length() -> None:
    """`stepramp design` without --pulses opens on the notebook designer's move
    (verify.designer.OPENING_PULSES; the command keeps its own literal so that building
    the parser never imports the designer), and its help says so."""
    from verify import cli
    from verify.designer import OPENING_PULSES, Settings

    parser = cli.build_parser("design")
    args = parser.parse_args(["design", "--motor", "nema17-1600"])
    assert args.pulses == OPENING_PULSES == Settings().pulses
    (pulses,) = [a for a in parser._subparsers._group_actions[0].choices["design"]._actions
                 if a.dest == "pulses"]
    assert pulses.help is not None and pulses.help.endswith(f"(default {OPENING_PULSES})")

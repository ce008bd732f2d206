"""The `stepramp` command run in-process, as the CLI tests call it, and its parsers' every
option and argument, as the tests of its help read them."""

from __future__ import annotations

import argparse

import pytest

from verify.cli import build_parser, main


def run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    """`stepramp ARGV...` (each argument str()-ed): (exit code, stdout, stderr)."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def exits(argv: list[str], codes: tuple[int, ...] = (0,)) -> None:
    """`stepramp ARGV` exits with one of `codes` (its output left to the test)."""
    assert main(argv) in codes, argv


def parsers(parser: argparse.ArgumentParser, name: str = "stepramp"
            ) -> list[tuple[str, argparse.ArgumentParser]]:
    """`parser` and every sub-command's parser below it, each with its command line
    (`stepramp motor new`)."""
    out = [(name, parser)]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                out += parsers(sub, f"{name} {sub_name}")
    return out


def arguments() -> list[tuple[str, argparse.Action]]:
    """Every option and argument of every `stepramp` command (--help and the sub-command
    choices aside), with its command line."""
    return [(name, a) for name, p in parsers(build_parser()) for a in p._actions
            if not isinstance(a, argparse._SubParsersAction | argparse._HelpAction)]

"""What every `stepramp` command module shares: exit codes, argument types and
option helpers. Command modules import from here, never from each other."""

from __future__ import annotations

import argparse
from typing import Any

EXIT_OK, EXIT_FINDINGS, EXIT_UNUSABLE = 0, 1, 2


def positive_int(text: str) -> int:
    """A non-negative integer, decimal or with a 0x/0o/0b prefix."""
    try:
        value = int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} is negative")
    return value


def number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None


def add_output(p: argparse.ArgumentParser, metavar: str = "OUT",
               help: str | None = None) -> None:
    """The `-o/--output` option every writing command has."""
    p.add_argument("-o", "--output", metavar=metavar, help=help)


def load_motor(path: str) -> Any:
    from profiles.motor import load_motor as load

    return load(path)

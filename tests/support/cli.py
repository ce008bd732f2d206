"""The `stepramp` command run in-process, as the CLI tests call it."""

from __future__ import annotations

import pytest

from verify.cli import main


def run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    """`stepramp ARGV...` (each argument str()-ed): (exit code, stdout, stderr)."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err

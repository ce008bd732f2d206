"""The `stepramp` command: exit codes, output shapes, bad input, no half-written files."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.support.paths import ROOT
from verify.cli import main

GOOD = ROOT / "examples" / "free-curve-nema17.json"


def test_console_script_cold_imports_nothing_heavy() -> None:
    # numpy too: a table's checks are plain Python over at most 127 stages; numpy's
    # import is 0.12 s, most of what a cold start would otherwise cost
    code = ("import sys; from verify import cli; "
            "rc = cli.main(['check', sys.argv[1]]); "
            "heavy = [m for m in ('toppra', 'casadi', 'matplotlib', 'ruckig', 'numba', "
            "'numpy') "
            "if m in sys.modules]; print(rc, heavy)")
    res = subprocess.run([sys.executable, "-c", code, str(GOOD)], capture_output=True,
                         text=True, cwd=ROOT, check=False)
    assert res.stdout.strip().splitlines()[-1] == "0 []", res.stdout + res.stderr


@pytest.mark.parametrize("argv, named", [
    (["answer", "03", "01", "-inf"], "stepramp answer:"),
    (["check", "x.json", "--no-such-option"], "stepramp check:"),
    (["alink", "decode", "0", "0", "0", "-1e9"], "stepramp alink:"),
])
def test_unrecognized_arguments_name_the_command(argv: list[str], named: str,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(named) and "unrecognized arguments" in err and err.count("\n") == 1

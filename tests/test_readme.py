"""The README's examples run, and CI runs the README's test command."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")


def fenced(lang: str) -> list[str]:
    return re.findall(rf"^```{lang}\n(.*?)^```", README, flags=re.S | re.M)


def test_ci_runs_the_readme_test_command() -> None:
    quick = fenced("sh")
    assert len(quick) == 2, "the quick start is exactly two commands"
    test_command = quick[1].strip()
    assert "pytest" in test_command and "\n" not in test_command
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert test_command in ci, ".ci/run must run the README's test command verbatim"
    assert ci.index(test_command) == len(ci) - 1, "and close on it (the runner's summary)"


def test_ci_fails_on_a_lint_or_type_finding() -> None:
    # `set -e` does not stop at a failing command inside an && list: ruff and mypy stand
    # on lines of their own, so a finding fails CI.
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert "set -euo pipefail" in ci
    assert "ruff check ." in ci and "mypy" in ci


@pytest.mark.slow
def test_python_example_runs(monkeypatch: pytest.MonkeyPatch,
                             capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setenv("MPLBACKEND", os.environ.get("MPLBACKEND", "Agg"))
    [code] = fenced("python")
    exec(compile(code, "README.md", "exec"), {})  # the README's own example
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("worst load angle ")  # the load angle over every move
    assert out[1].startswith("02 ")  # then the upload, its command block first

"""The README's examples run, and CI runs the README's test command."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pytest

from tests.support.bench_readme import bench_readme
from tests.support.paths import ROOT

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
    assert out[0].startswith("SAFE over every move length; worst load angle ")  # the verdict
    assert json.loads(out[1])["safe"] is True  # its JSON object
    assert out[2].startswith("02 ")  # then the upload, its command block first


def command_table() -> list[tuple[str, str, str]]:
    """(command, does, example) of every row of the README's command table."""
    start = README.index("| command | does | example |")
    rows = []
    for line in README[start:].splitlines()[2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
        assert len(cells) == 3, line
        rows.append((cells[0], cells[1], cells[2]))
    return rows


def sub_commands() -> dict[str, list[str]]:
    """Every command of `stepramp --help`, with its sub-commands (alink, mc200, motor, link)."""
    from verify import cli

    [top] = [a for a in cli.build_parser()._actions
             if a.__class__.__name__ == "_SubParsersAction"]
    out = {}
    for name, parser in top.choices.items():  # type: ignore[union-attr]
        nested = [a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction"]
        out[name] = sorted(nested[0].choices) if nested else []
    return out


def examples(cell: str) -> list[list[str]]:
    import shlex

    return [shlex.split(code) for code in re.findall(r"`(stepramp [^`]+)`", cell)]


def test_every_command_is_in_the_table_with_an_example() -> None:
    rows = command_table()
    commands = sub_commands()
    assert {"check", "sync", "motor", "sweep"} <= set(commands)
    shown = {argv[1] for _, _, example in rows for argv in examples(example)}
    assert set(commands) - shown == set(), "commands without an example in the README table"
    for name, subs in commands.items():
        [row] = [r for r in rows if f"`stepramp {name} " in r[0] or f"`stepramp {name}`" in r[0]]
        for sub in subs:
            assert f"stepramp {name} {sub}" in row[0] or f"{sub} " in row[0] \
                or f"| {sub}" in row[0], f"stepramp {name} {sub} is not in the table"
        if name != "link":  # link's sub-commands are one example's alternatives
            ran = {argv[2] for argv in examples(row[2]) if len(argv) > 2}
            assert set(subs) <= ran, f"stepramp {name}: sub-commands without an example"


def test_every_example_in_the_table_parses(capsys: pytest.CaptureFixture[str]) -> None:
    from verify import cli

    parser = cli.build_parser()
    for _, _, example in command_table():
        for argv in examples(example):
            if argv[1:] and argv[-1] == "--help":
                continue
            try:
                parser.parse_args(argv[1:])
            except SystemExit:
                pytest.fail(f"README example does not parse: {' '.join(argv)}: "
                            f"{capsys.readouterr().err}")
            for arg in argv:   # the example files it names exist
                if arg.startswith("examples/"):
                    assert (ROOT / arg).is_file(), arg


def test_the_readme_agrees_with_the_committed_bench_results() -> None:
    """Every `<!-- bench:… -->` block is its results file's section as the generator
    renders it, and every bench figure was drawn from the committed data."""
    assert bench_readme().problems() == [], \
        "the README disagrees with bench/results: run python bench/readme.py"


def test_the_performance_section_is_generated() -> None:
    """No hand-typed table is left in "How good, how fast": every table there sits
    inside a generated block."""
    start = README.index("## How good, how fast")
    section = README[start:README.index("\n## ", start + 1)]
    outside = re.sub(r"<!-- bench:[\w.-]+:[\w.-]+ -->\n.*?<!-- /bench -->", "", section,
                     flags=re.S)
    assert "|---" not in outside
    assert section.count("<!-- bench:") >= 10


def test_the_quick_start_plans_checks_and_exports(tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    # The first quick-start command does the main job: plan, check with the motor, export.
    from verify import cli

    steps = [c.split()[1:] for c in fenced("sh")[0].strip().split(" && ")
             if c.startswith("stepramp ")]
    assert [s[0] for s in steps] == ["plan", "check", "export"]
    monkeypatch.chdir(tmp_path)
    for args in steps:
        assert cli.main(args) == 0, args
    out = capsys.readouterr().out
    assert "verdict: SAFE for every move length" in out and "0 failed" in out
    header = (tmp_path / steps[-1][-1]).read_text(encoding="utf-8")
    assert header.startswith("/* PPMC-312 upload generated by stepramp")

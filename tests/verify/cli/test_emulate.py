"""`stepramp emulate` (verify/cli/emulate.py): the chip emulated on its bus and its link."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support.bus_scripts import header_lines, read_groups
from tests.support.paths import ROOT
from verify import cli

# --- the command: `stepramp emulate --bus SCRIPT` ------------------------------------------------
EXAMPLE = str(ROOT / "examples" / "free-curve-nema17.json")


def emulate_bus(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = cli.main(["emulate", *argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def exported(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    """Our own upload of the example table, `export --format bus` as a user writes it."""
    script = tmp_path / "x.bus"
    assert cli.main(["export", EXAMPLE, "--format", "bus", "-o", str(script)]) == 0
    capsys.readouterr()
    return script


def test_emulate_bus_passes_our_own_export(exported: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    lines = exported.read_text(encoding="utf-8").splitlines()
    blocks = sum(line == "WCR 20" for line in lines)
    assert blocks > 2
    assert emulate_bus(capsys, "--bus", str(exported)) == (
        0, f"{exported}: {blocks} blocks written, {blocks} answers read, every expected read "
           "matched\n", "")


def test_emulate_bus_names_the_line_and_f4_01_when_an_answer_is_not_read(
        exported: Path, capsys: pytest.CaptureFixture[str]) -> None:
    lines = exported.read_text(encoding="utf-8").splitlines()
    start = read_groups(lines)[0]            # block 0's answer: its MREF wait …
    end = start + 3 + 0x40 - int(lines[start + 2].split()[1], 16)  # … to its last DRR read
    answer = lines[start].partition(": ")[2]
    skipped = lines[:start] + lines[end:]
    exported.write_text("\n".join(skipped) + "\n", encoding="utf-8")
    line = header_lines(skipped)[1]          # block 1's header, which issues it
    assert emulate_bus(capsys, "--bus", str(exported)) == (
        1, f"{exported}: line {line}: block 1 is issued while block 0's answer {answer} is "
           "still unread: the chip raises alarm F4 01 (§5-4, §11-9: 命令の多重書込み), stops "
           "pulse output and answers 23 02 F4 01 instead\n", "")


def test_emulate_bus_a_read_that_differs_is_a_finding(exported: Path,
                                                      capsys: pytest.CaptureFixture[str]
                                                      ) -> None:
    lines = exported.read_text(encoding="utf-8").splitlines()
    k = read_groups(lines)[0] + 2
    lines[k] = "RAR 30"
    exported.write_text("\n".join(lines), encoding="utf-8")
    code, out, err = emulate_bus(capsys, "--bus", str(exported))
    assert (code, err) == (1, "")
    assert out.startswith(f"{exported}: line {k + 1}: RAR reads ") and out.endswith(
        ", the script expects 30\n")


@pytest.mark.parametrize(("text", "argv", "says"), [
    ("WCR 20\nFOO 1\n", [], "{script}: line 2: expected 'WCR|WAR|DWR XX', 'RCR --', "
                            "'RAR|DRR XX' or 'WAIT CSR.MWEF|MREF 0', got 'FOO 1'"),
    ("WCR 20\nRCR 00\n", [], "{script}: line 2: RCR is a dummy read, written 'RCR --'"),
    ("  # nothing\n", [], "{script}: the bus script holds no register access (only "
                          "comments or blank lines)"),
    ("", [], "{script}: the file is empty"),
    ("WCR 20\n", ["--log"], "--log: for --pty (the serial slave); --bus runs the chip on its "
                            "parallel bus"),
    ("WCR 20\n", ["--address", "3", "--link", "t"],
     "--address, --link: for --pty (the serial slave); --bus runs the chip on its parallel "
     "bus"),
])
def test_emulate_bus_unusable_input_is_one_line_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, argv: list[str],
        says: str) -> None:
    script = tmp_path / "s.bus"
    script.write_text(text, encoding="utf-8")
    assert emulate_bus(capsys, "--bus", str(script), *argv) == (
        2, "", f"stepramp emulate: {says.format(script=script)}\n")


def test_emulate_says_what_it_needs(capsys: pytest.CaptureFixture[str]) -> None:
    assert emulate_bus(capsys) == (2, "", "stepramp emulate: give --pty (a serial slave on a "
                                          "pseudo-terminal) or --bus SCRIPT (a bus script run "
                                          "through the chip)\n")
    code, _, err = emulate_bus(capsys, "--pty", "--bus", "x.bus")
    assert code == 2 and err.count("\n") == 1 and "not allowed with" in err


def run_cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    from verify.cli import main

    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_emulate_input_options_are_for_the_pty(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_cli(["emulate", "--bus", "x.bus", "--event-at", "0:5"], capsys)
    assert (code, out) == (2, "") and "--event-at: for --pty" in err
    code, out, err = run_cli(["emulate", "--pty", "--event-at", "2:5"], capsys)
    assert (code, out) == (2, "") and "NAME one of 0, 1" in err
    code, out, err = run_cli(["emulate", "--bus", "x.bus", "--limit-at", "fl:5"], capsys)
    assert (code, out) == (2, "") and "--limit-at: for --pty" in err
    code, out, err = run_cli(["emulate", "--pty", "--limit-at", "XL:5"], capsys)
    assert (code, out) == (2, "") and "NAME one of FL, BL, FHL, BHL" in err

"""`stepramp move --command NAME` (every PPMC-312 motion command, verify/cli/move.py) and
`stepramp check` on the files it writes (verify/command_rules.py): the figures' bytes
from the command line, every format, options a command does not take refused naming
them, and the chip's parameter errors as findings with its codes."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.ppmc312.motion import COMMANDS, encode_command
from profiles.ppmc312.upload import encode_move
from tests.support.ascii_frames import FIGURES, by_hand
from verify.cli import main

OPTION = {"rate": "--rate", "pulses": "--pulses", "override_at": "--override-at",
          "on": "--on"}
FLAG = {"ccw": "--ccw", "index": "--index"}


def run(capsys: pytest.CaptureFixture[str], *argv: str | Path) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def argv(name: str, params: dict[str, Any]) -> list[str]:
    out = ["move", "--command", name]
    for key, value in params.items():
        out += [FLAG[key]] if key in FLAG else [OPTION[key], str(value)]
    return out


@pytest.mark.parametrize(("name", "params", "block", "serial"), FIGURES)
def test_move_writes_every_figure(capsys: pytest.CaptureFixture[str], name: str,
                                  params: dict[str, Any], block: str, serial: str | None
                                  ) -> None:
    code, out, err = run(capsys, *argv(name, params))
    assert (code, err) == (0, "")
    assert bytes.fromhex(out.splitlines()[0]) == bytes.fromhex(block)
    code, out, err = run(capsys, *argv(name, params), "--to", "ascii", "--address", "5")
    if serial is None:
        assert code == 2 and err.count("\n") == 1 and "no serial form" in err
    else:
        assert (code, err) == (0, "")
        assert bytes.fromhex(out.splitlines()[0]) == by_hand(5, serial)


def test_the_default_is_todays_accel_move(capsys: pytest.CaptureFixture[str]) -> None:
    for extra, kw in (([], {}), (["--high-rate", "300"], {"high_rate": 300}),
                      (["--override", "3"], {"override": True, "trigger": 3}),
                      (["--rate", "300", "--on", "evt1"],
                       {"high_rate": 300, "override": True, "trigger": 1})):
        code, out, _ = run(capsys, "move", "--pulses", "0x12345678", "--ccw", *extra)
        assert code == 0
        assert bytes.fromhex(out.splitlines()[0]) == encode_move(0x12345678, ccw=True, **kw)
        assert run(capsys, "move", "--command", "accel", "--pulses", "0x12345678", "--ccw",
                   *extra)[1] == out


@pytest.mark.parametrize(("args", "line"), [
    ([], "the following arguments are required: --pulses (see stepramp move --help)"),
    (["--command", "constant"],
     "the following arguments are required by --command constant: --pulses (see stepramp "
     "move --help)"),
    (["--command", "origin-search"],
     "the following arguments are required by --command origin-search: --rate (see "
     "stepramp move --help)"),
    (["--command", "stop", "--pulses", "5"],
     "--pulses: stop (80) does not take it (it takes --override-at, --on)"),
    (["--command", "step", "--rate", "5"], "--rate: step (84) does not take it (it takes "
                                           "--ccw)"),
    (["--command", "high-speed-limit", "--rate", "5", "--ccw"],
     "--ccw: high-speed-limit (05) does not take it (it takes --rate)"),
    (["--command", "accel", "--pulses", "5", "--index"],
     "--index: accel (82) does not take it (it takes --rate, --pulses, --ccw, --on)"),
    (["--command", "accel", "--pulses", "5", "--override-at", "9"],
     "--override-at: accel (82) does not take it (it takes --rate, --pulses, --ccw, --on)"),
    (["--command", "continuous", "--high-rate", "5"],
     "--high-rate: continuous (85) does not take it (it takes --rate, --ccw, --on)"),
    (["--pulses", "5", "--rate", "3", "--high-rate", "4"],
     "--high-rate: give --rate or --high-rate, not both"),
    (["--command", "stop", "--override-at", "4", "--on", "evt1"],
     "--on: give --override-at or --on, not both"),
    (["--command", "change-speed", "--rate", "0"],
     "--rate: 0 is outside the allowed range 2..65535 (0xFFFF)"),
    (["--command", "continuous-constant", "--rate", "9"],
     "--rate: 9 is outside the allowed range 10 (0xA)..65535 (0xFFFF), or 0 (the table's "
     "high rate)"),
    (["--pulses", "5", "--high-rate", "1"],
     "--high-rate: 1 is outside the allowed range 2..65535 (0xFFFF), or 0 (the table's high "
     "rate)"),
    (["--command", "set-speed", "--rate", "9", "--override-at", "9"],
     "--override-at: 9 is outside the allowed range 10 (0xA)..4294967295 (0xFFFFFFFF)"),
    (["--command", "stop", "--to", "ascii", "--address", "16"],
     "--address: 16 (0x10) is outside the allowed range 0..15 (0xF)"),
    (["--pulses", "0x100000000"],
     "--pulses: 4294967296 (0x100000000) is outside the allowed range 1..4294967295 "
     "(0xFFFFFFFF)"),
    (["--command", "continuous", "--on", "evt2", "--to", "ascii"],
     "continuous (85) has no serial form started by an event (evt2) (§16-6: no OV/TRG); "
     "the parallel bus only"),
])
def test_refusals_are_one_line_naming_the_option(capsys: pytest.CaptureFixture[str],
                                                 args: list[str], line: str) -> None:
    code, out, err = run(capsys, "move", *args)
    assert (code, out) == (2, "")
    assert err.splitlines() == [f"stepramp move: {line}"]


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_in_every_format_is_judged_ok(capsys: pytest.CaptureFixture[str],
                                                   tmp_path: Path, name: str) -> None:
    from profiles.ppmc312.formats import FORMATS

    params = next(p for n, p, _b, s in FIGURES if n == name and s is not None)
    for fmt in FORMATS.names:
        for to in ("parallel", "ascii"):
            if to == "ascii" and fmt == "bus":
                continue  # the bus is parallel only
            out = tmp_path / f"{name}.{to}.{fmt}"
            code, _, err = run(capsys, *argv(name, params), "--to", to, "--format", fmt,
                               "-o", out)
            assert (code, err) == (0, ""), (fmt, to)
            code, text, err = run(capsys, "check", out)
            assert code == 0, (fmt, to, text, err)
            assert f"note: {COMMANDS[name].label if name != 'accel' else 'move'}" in text


def judge(tmp_path: Path, items: list[bytes]) -> Any:
    from profiles.ppmc312.formats import render
    from verify.check_file import check_file

    path = tmp_path / "cmd.hex"
    path.write_bytes(render(items, "text"))
    result = check_file(str(path))
    assert result.error is None
    return result


# Every rule on a command of each family: (block hex, rule, chip code, severity)
RULES = [
    ("03 08 83 00 00 00 00 00 00 00", "move-pulses", 0x23, "error"),
    ("03 08 83 04 00 00 00 00 00 01", "move-trigger", 0x21, "error"),
    ("03 04 85 06 00 00", "move-trigger", 0x21, "error"),
    ("03 04 86 04 00 0A", "move-trigger", 0x21, "error"),
    ("03 04 86 00 00 09", "move-rate", 0x20, "error"),
    ("03 04 87 00 00 00", "move-rate", 0x20, "error"),
    ("03 04 10 00 00 01", "move-rate", 0x20, "error"),
    ("03 03 05 00 00", "move-rate", 0x20, "error"),
    ("03 08 82 00 00 01 00 00 00 05", "move-high-rate", 0x20, "error"),
    ("03 02 80 04", "move-position", None, "error"),
    ("03 08 88 06 00 02 00 00 00 09", "move-position", None, "error"),
    ("03 06 81 00 00 00 00 05", "move-position-ignored", None, "warning"),
    ("03 06 81 05 00 00 00 05", "move-position-ignored", None, "warning"),
    ("03 04 87 01 00 02", "move-trigger-ignored", None, "warning"),
    ("03 02 84 80", "move-mode-bits", None, "warning"),
    ("03 04 11 02 00 00", "move-mode-bits", None, "warning"),
    ("03 02 80 F8", "move-mode-bits", None, "warning"),
    ("03 03 80 00 00", "move-block", None, "error"),
    ("02 02 81 00", "move-block", None, "error"),
]


@pytest.mark.parametrize(("data", "rule", "code", "severity"), RULES)
def test_the_chips_parameter_errors_are_findings(tmp_path: Path, data: str, rule: str,
                                                 code: int | None, severity: str) -> None:
    result = judge(tmp_path, [bytes.fromhex(data)])
    found = [f for f in result.findings if f.rule == rule]
    assert len(found) == 1 and found[0].chip_code == code and found[0].severity == severity
    assert result.ok == (severity == "warning")
    assert not [f for f in result.findings if f.rule not in (rule, "upload-unchecked")]


@pytest.mark.parametrize(("payload", "rule", "code"), [
    ("84 0190 00000000", "move-pulses", 0x23),
    ("A5 0009", "move-rate", 0x20),
    ("89 0000", "move-rate", 0x20),
    ("47 0001", "move-rate", 0x20),
    ("83 0001 00000005", "move-high-rate", 0x20),
    ("8E 0002 00000009", "move-position", None),
    ("9D 0002 00", "move-block", None),
    ("82 00", "move-block", None),
])
def test_serial_frames_get_the_same_findings(tmp_path: Path, payload: str, rule: str,
                                             code: int | None) -> None:
    result = judge(tmp_path, [by_hand(4, payload)])
    assert [(f.rule, f.chip_code) for f in result.findings] == [(rule, code)]


def test_a_file_of_commands_is_described_and_the_table_it_needs_named(tmp_path: Path
                                                                      ) -> None:
    blocks = [encode_command("continuous", rate=0, ccw=True),
              encode_command("change-speed", rate=200, override_at=10_000),
              encode_command("decel-stop", on="evt2"),
              encode_command("origin-search", rate=4000, index=True),
              encode_command("high-speed-limit", rate=500),
              encode_command("accel", pulses=16, rate=300)]
    result = judge(tmp_path, blocks)
    assert result.ok and result.findings == []
    assert result.notes == [
        "continuous (85): CCW at the table's high rate, at once",
        "change-speed (87): at rate 200, when the position counter reaches 10000 (OV, TRG 00)",
        "decel-stop (81): held until event input 2 goes low (OV, TRG 11)",
        "origin-search (10): CW on /ORG and /INDEX at rate 4000",
        "high-speed-limit (05): at rate 500",
        "move: 16 pulses CW at high-rate override 300, at once",
        "change-speed (87) rate 200: the chip refuses it (0x20) unless it lies within the "
        "rates of the table it holds; check that table",
        "origin-search (10) rate 4000: the chip refuses it (0x20) unless it lies between the "
        "table's high rate and the faster of its start and stop rates; check that table",
        "high-rate override 300: the chip refuses it (0x20) unless it lies within the rates "
        "of the table it holds; check that table",
    ]
    serial = judge(tmp_path, [encode_command("stop", to="ascii", on="evt1"),
                              encode_command("set-speed", to="ascii", rate=9, override_at=99)])
    assert serial.notes[:2] == ["stop (80): held until event input 1 goes low",
                                "set-speed (88): at rate 9, when the position counter "
                                "reaches 99"]


@settings(max_examples=300, deadline=None)
@given(st.sampled_from([(c, f) for c in COMMANDS.values() for f in c.forms]),
       st.binary(min_size=11, max_size=11))
def test_any_block_of_a_motion_command_is_judged_never_unusable(case: Any,
                                                                noise: bytes) -> None:
    from verify.command_rules import move_block_findings, move_notes

    command, frame = case
    assert frame.size is not None
    block = bytes([0x03, frame.size - 2, command.code]) + noise[:frame.size - 3]
    findings = move_block_findings(block, 0)
    notes = move_notes([block])
    assert len(notes) >= 1
    assert all(f.rule.startswith("move-") for f in findings)

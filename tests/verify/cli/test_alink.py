"""`stepramp alink`: what its options refuse, and where the words' range ends."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings

from profiles import alink as A
from profiles.alink.commands import COMMANDS, decode_command, encode_command
from tests.support.alink_figures import BY_HAND
from tests.support.cli import run
from tests.support.datasheet_motor import datasheet_motor_file
from tests.support.file_checks import alink_file, rules_of
from tests.support.strategies import alink_commands
from verify import cli
from verify.cli import main

SETTINGS_COMMANDS = A.settings_commands(A.quantise_settings(500, 10000, 20))


@pytest.mark.parametrize(("word", "code"), [("0xFFFF", 0), ("65535", 0), ("0x10000", 2),
                                            ("-1", 2)])
def test_decode_takes_16_bit_words(word: str, code: int,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["alink", "decode", word, "0", "0"]) == code
    err = capsys.readouterr().err
    if code:
        assert err.startswith(f"stepramp alink: word 0: {int(word, 0)}")
        assert err.rstrip().endswith("is outside the allowed range 0..65535 (0xFFFF)")
    else:
        assert err == ""


@pytest.mark.parametrize("explicit", [["--start-pps", "100"], ["--high-pps", "5000"],
                                      ["--accel-ms-per-kpps", "10"]])
def test_settings_take_a_motor_or_the_speeds_never_both(
        explicit: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    """One given speed beside --motor would be ignored by the plan: refused instead."""
    assert cli.main(["alink", "settings", "--motor", "nema17-1600", "--pulses", "1000",
                     *explicit]) == 2
    assert capsys.readouterr().err == ("stepramp alink: give either --motor or "
                                       "--start-pps/--high-pps/--accel-ms-per-kpps\n")


@pytest.mark.parametrize(("name", "nn", "value", "words"), BY_HAND)
def test_words_are_the_figures_and_decode_names_the_command(
        name: str, nn: int, value: int, words: tuple[int, int, int],
        capsys: pytest.CaptureFixture[str]) -> None:
    c = encode_command(name, value if COMMANDS[name].forms[nn].value.takes else None, nn)
    assert c.words == words and c.pair == 1
    d = decode_command(*words)
    assert (d.command.name, d.nn, d.value, d.pair, d.problems) == (name, nn, value, 1, ())
    # and through the CLI: `alink command` writes them, `alink decode --command` names them
    argv = ["alink", "command", name, "--nn", str(nn), "--format", "hex"]
    if COMMANDS[name].forms[nn].value.takes:
        argv += ["--value", str(value)]
    assert cli.main(argv) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == " ".join(f"{w:04X}" for w in words) and out[1].startswith("# crc32 ")
    assert cli.main(["alink", "decode", "--command", *(f"0x{w:04X}" for w in words),
                     "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert (doc["name"], doc["symbol"], doc["nn"], doc["value"], doc["problems"]) == \
        (name, COMMANDS[name].cmd.name, nn, value, [])


def _cli(argv: list[str]) -> Any:
    """`stepramp ARGV --format json`'s document (exit 0), in-process."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert cli.main([*argv, "--format", "json"]) == 0
    return json.loads(out.getvalue())


@settings(max_examples=100, deadline=None)
@given(alink_commands())
def test_every_command_round_trips_through_the_cli(case: tuple[str, int, int, int]) -> None:
    """`alink command` writes the words, `alink decode --command` names them back."""
    name, nn, value, pair = case
    argv = ["alink", "command", name, "--nn", str(nn), "--pair", str(pair)]
    if COMMANDS[name].forms[nn].value.takes:
        argv += ["--value", str(value)]
    [row] = _cli(argv)["commands"]
    doc = _cli(["alink", "decode", "--command", *row["words"]])
    assert (doc["name"], doc["nn"], doc["value"], doc["pair"], doc["problems"]) == \
        (name, nn, value, pair, [])


@pytest.mark.parametrize(("argv", "line"), [
    (["l-speed", "--value", "0"],
     "--value (l-speed nn 1: speed): 0 is outside the allowed range 1..100000 (0x186A0)"),
    (["move-a", "--value", "0x8000000"],
     "--value (move-a nn 28: pulse): 134217728 (0x8000000) is outside the allowed range "
     "-134217728..134217727 (0x7FFFFFF)"),
    (["out-m", "--value", "2"], "--value (out-m nn 28: out): 2 is not one of 0 (off), 1 (on)"),
    (["home", "--nn", "5"], "--nn: 5 is not an nn of home (1: search CW, stop at the "
                            "origin's CCW edge; 2: …"),
    (["setting", "--nn", "30", "--value", "0"],
     "--value (setting nn 30: pulse): 0: a soft limit is 1..134217727 (+) or "
     "-134217728..-1 (-)"),
    (["change-speed", "--value", "100001"],
     "--value (change-speed nn 1: speed): 100001 (0x186A1) is outside the allowed range "
     "1..100000 (0x186A0)"),
    (["read-stat", "--value", "0x3FFF"], "--value (read-stat nn 0: type): READ_STAT type "
                                         "0x3FFF: the factory A-Link check: …"),
    (["stop", "--value", "3"], "--value: stop nn 28 takes no value (stop at once (the "
                               "position is not kept): its para is 0)"),
    (["move-a"], "--value: move-a nn 28 needs one: pulse, -134217728..134217727 pulses"),
    (["move-a", "--value", "1", "--pair", "4"], "--pair: 4 is outside the allowed range 1..3"),
    (["logic", "--value", "3"], "--value (logic nn 0: logic): 0x3 sets bits outside the "
                                "word's (0x3); it is a bit word: …"),
])
def test_bad_values_are_one_line_naming_the_flag_value_and_range(
        argv: list[str], line: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["alink", "command", *argv]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1
    err = err.removeprefix("stepramp alink: ").rstrip("\n")
    assert err.startswith(line.removesuffix("…")) if line.endswith("…") else err == line


def test_decode_refuses_answer_options_with_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["alink", "decode", "--command", "0x5C22", "0x4006", "0x46A0",
                     "--read-back"]) == 2
    assert capsys.readouterr().err == ("stepramp alink: --read-back: an answer's; a command's "
                                       "words carry their own pair code\n")
    assert cli.main(["alink", "decode", "--command", "0x5C22", "0x4006", "0x46A0"]) == 0
    assert capsys.readouterr().out == (
        "MOVE_A (move-a, §11-3 (2) absolute move) nn 28: move to pulse (absolute; needs the "
        "origin); pulse 100000 pulses, pair 1\n")
    assert cli.main(["alink", "decode", "--command", "0x7D00", "0", "0"]) == 2  # no command


def test_alink_homing_writes_a_checked_file(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "home.json"
    assert cli.main(["alink", "homing", "--motor", "nema17-1600", "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["homing"]["oh_pps"] == 800 and doc["homing"]["ol_pps"] == 200
    assert [c["name"] for c in doc["commands"]] == ["OL_SPEED", "OH_SPEED", "O_UPTIME"]
    assert cli.main(["check", str(out)]) == 0
    assert cli.main(["alink", "read", str(out)]) == 0
    capsys.readouterr()
    assert cli.main(["alink", "homing", "--motor", "nema17-1600", "--max-pps", "-1"]) == 2
    assert capsys.readouterr().err.startswith("stepramp alink: --max-pps: -1.0 is outside")


def test_alink_read_and_corrupted_settings(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["alink", "settings", "--start-pps", "500", "--high-pps", "10000",
                 "--accel-ms-per-kpps", "20", "--address", "3", "--format", "json", "-o",
                 str(tmp_path / "a.json")]) == 0
    capsys.readouterr()
    assert main(["alink", "read", str(tmp_path / "a.json"), "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["start_pps"] == 500 and doc["commands"][0]["address"] == "0x086"
    path = alink_file(tmp_path, "a.h", SETTINGS_COMMANDS, "c")
    path.write_text(path.read_text().replace("0x4112", "0x4113"))  # L_SPEED → H_SPEED
    assert rules_of(path) == [("error", "alink-corrupted")]
    assert main(["alink", "read", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("stepramp alink: corrupted: STEPRAMP_ALINK_CRC32 says CRC-32")


@pytest.fixture(scope="module")
def datasheet_motor(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The datasheet NEMA17 on its lead screw (tests/support/datasheet_motor.py)."""
    return datasheet_motor_file(tmp_path_factory.mktemp("motor") / "m.json")


@pytest.mark.parametrize(("name", "extra"), [
    ("nema17-1600", ()), ("nema23-heavy", ()), ("pk566-5phase-half", ()), ("datasheet", ()),
    ("datasheet", ("--s-curve",)), ("datasheet", ("--pulses", "400"))])
def test_planned_settings_within_the_aim_at_every_length(
        name: str, extra: tuple[str, ...], datasheet_motor: Path, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    motor = str(datasheet_motor) if name == "datasheet" else name
    out = tmp_path / "s.json"
    code, _, _ = run(capsys, "alink", "settings", "--motor", motor, "--format", "json",
                     "-o", str(out), *extra)
    assert code == 0
    code, report, _ = run(capsys, "check", str(out), "--motor", motor, "--format", "json")
    assert code == 0, report
    safety = json.loads(report)["files"][0]["safety"] if "files" in json.loads(report) \
        else json.loads(report)[0]["safety"]
    assert safety["moves"] == "every" and safety["safe"] and safety["within_aim"]
    assert safety["worst_load_angle_deg"] <= 75.0
    assert "decel-stop" in safety["commands"]


def test_datasheet_settings_lower_the_start_and_say_the_price(
        datasheet_motor: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The issue's case: the untightened start (5 540 pps) leaves short moves past 75°."""
    out = tmp_path / "s.txt"
    code, _, _ = run(capsys, "alink", "settings", "--motor", str(datasheet_motor),
                     "-o", str(out))
    assert code == 0
    text = out.read_text()
    assert "start speed lowered to" in text and "within 75°" in text
    assert "a move of 100 pulses takes" in text

"""Program files (`stepramp.program/1`, profiles/ppmc312/program.py): the reader's one-line
refusals naming the key, the schema beside the others, `stepramp simulate PROGRAM` and
`stepramp check PROGRAM --motor M` through the one verdict
(profiles/ppmc312/program_verdict.py) on clear cases, and the load angle through a
motion with a reversal against the plain-Python oracle (profiles/ppmc312/command_angles.py)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest

from tests.support.cli import run
from tests.support.paths import ROOT

EXAMPLE = ROOT / "examples" / "program-home-and-jog.json"


TABLE = ROOT / "examples" / "free-curve-nema17.json"


NEMA17 = "nema17-1600"   # start speed 800 pps: the example table's start rate 10000


def program(folder: Path, commands: list[Any], **top: Any) -> Path:
    """A program in `folder` beside a copy of the example table."""
    shutil.copy(TABLE, folder / "t.json")
    path = folder / "p.json"
    path.write_text(json.dumps({"format": "stepramp.program/1", "table": "t.json",
                                "commands": commands, **top}))
    return path


@pytest.mark.parametrize(("commands", "words"), [
    ([{"command": "jump"}], "commands[0].command: 'jump' is not one of stop, decel-stop"),
    ([{"command": "accel", "pulses": 5, "rate": 500}],
     "commands[0].rate: accel (82) takes no 'rate' (it takes ccw, high_rate, pulses)"),
    ([{"command": "constant", "pulses": 5, "rate": 50}],
     "commands[0].rate (within the table's rates): 50 (0x32) is outside the allowed range "
     "400 (0x190)..10000 (0x2710) (the chip answers F0 20)"),
    ([{"command": "origin-search", "rate": 20000, "at": 3}],
     "(between the table's high rate and the faster of its start and stop rates)"),
    ([{"command": "constant", "pulses": 0}], "commands[0].pulses: 0 is outside the allowed "
                                             "range 1..4294967295"),
    ([{"command": "accel", "pulses": 200}, {"command": "stop", "at": 300}],
     "commands[1].at: stop (80): 300 is past the motion's end: it runs 200 pulses"),
    ([{"command": "continuous"}], "commands: the program ends while the motion started by "
                                  "commands[0] still runs"),
    ([{"command": "stop"}], "commands[0]: needs \"at\""),
    ([{"command": "constant", "pulses": 5, "at": 2}], "commands[0].at: constant (83) takes "
                                                      "no 'at'"),
    ([{"command": "step", "signal": "FL"}], "commands[0]: give one of \"command\""),
    ([{"signal": "XL", "at": 3}], "commands[0].signal: 'XL' is not one of FL, BL, FHL, BHL"),
    ([{"command": "change-speed", "at": 3}], "commands[0]: change-speed (87) needs rate"),
    ([{"command": "constant", "pulses": 5, "ccw": 1}], "commands[0].ccw: expected true or "
                                                       "false"),
])
def test_a_bad_program_is_one_line_naming_the_key(capsys: pytest.CaptureFixture[str],
                                                  tmp_path: Path, commands: list[Any],
                                                  words: str) -> None:
    path = program(tmp_path, commands)
    for argv in (["simulate", path], ["check", path, "--motor", NEMA17]):
        code, _, err = run(capsys, *argv)
        assert code == 2 and err.count("\n") == 1, err
        assert words in err, err


def test_duplicate_keys_unknown_keys_and_a_missing_table_are_refused(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = program(tmp_path, [{"command": "step"}])
    path.write_text(path.read_text().replace('"step"}', '"step", "ccw": true, "ccw": false}'))
    assert "key 'ccw' appears twice" in run(capsys, "simulate", path)[2]
    path = program(tmp_path, [{"command": "step"}], extra=1)
    assert "'extra': not a key of a program file" in run(capsys, "simulate", path)[2]
    path = program(tmp_path, [{"command": "step"}], table="missing.json")
    code, _, err = run(capsys, "simulate", path)
    assert code == 2 and "table: " in err and "missing.json: no such file" in err


def test_simulate_gives_each_motion_its_timeline_and_files(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, out, err = run(capsys, "simulate", EXAMPLE, "--csv", tmp_path / "p.csv",
                         "--pulse-times", tmp_path / "t.csv")
    assert (code, err) == (0, "")
    assert out.startswith("program: 5 commands, table ")
    assert "motion 3: commands[3] accel (82) CW, 20000 pulses" in out
    assert "pulses 19715–20000  commands[3] accel: decel 20000 → 18223.2 pps" in out
    rows = (tmp_path / "t.csv").read_text().splitlines()
    doc = json.loads(run(capsys, "simulate", EXAMPLE, "--format", "json")[1])
    assert rows[0] == "motion,pulse,time_s"
    assert len(rows) - 1 == sum(m["pulses"] for m in doc["motions"])
    assert rows[-1].startswith("3,20000,1.673")
    pieces = (tmp_path / "p.csv").read_text().splitlines()
    assert len(pieces) - 1 == sum(len(m["pieces"]) for m in doc["motions"])
    assert doc["motions"][0]["pieces"][-1]["ccw"] is False   # the origin return's way back
    code, _, err = run(capsys, "simulate", EXAMPLE, "--samples", tmp_path / "s.csv")
    assert code == 2 and "--samples" in err


def test_simulate_shows_each_reading_of_a_stop_on_the_ramp(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = program(tmp_path, [{"command": "continuous"}, {"command": "decel-stop", "at": 1234}])
    totals = {r: json.loads(run(capsys, "simulate", path, "--format", "json", "--reading",
                                r)[1])["motions"][0]["pulses"] for r in "abc"}
    assert totals == {"a": 2500, "b": 2430, "c": 2398}


@pytest.mark.parametrize(("commands", "code", "words"), [
    ([{"command": "constant", "rate": 0, "pulses": 1000}], 1,
     "commands[0] constant (83) starts at once at 20000 pps, above the motor's start speed"),
    ([{"command": "constant", "rate": 10000, "pulses": 1000}], 0, "motion 1: commands[0] "
                                                                  "constant (83) CW"),
    ([{"command": "accel", "pulses": 20000, "high_rate": 900},
      {"command": "change-speed", "rate": 400, "at": 10000}], 1,
     "the speed change at pulse 10000 (commands[1] change-speed (87)) leaves the chip "
     "stopping from 18223.2 pps at pulse 20000: the decel point stays where it was (§8-8)"),
    ([{"command": "accel", "pulses": 20000, "high_rate": 900}], 0, "ends NOS"),
    ([{"command": "continuous", "rate": 2000}, {"signal": "FL", "at": 3000}], 1,
     "commands[1] /FL stops the motion at once from 4000 pps after pulse 3000"),
])
def test_check_judges_what_the_program_runs(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                            commands: list[Any], code: int, words: str
                                            ) -> None:
    got, out, err = run(capsys, "check", program(tmp_path, commands), "--motor", NEMA17)
    assert (got, err) == (code, ""), out
    assert words in out, out
    if code:
        assert "[program-load-angle]" in out or "slips" not in out


def test_check_names_the_readings_a_finding_comes_under(capsys: pytest.CaptureFixture[str],
                                                        tmp_path: Path) -> None:
    path = program(tmp_path, [{"command": "continuous"}, {"command": "decel-stop", "at": 1234}])
    code, out, _ = run(capsys, "check", path, "--motor", "nema23-heavy", "--format", "json")
    found = json.loads(out)["files"][0]["findings"]
    assert code == 1 and found
    assert any("reading" in f["message"] for f in found) or all(
        "reading" not in f["message"] for f in found)
    code, out, _ = run(capsys, "check", path, "--motor", NEMA17, "--pulses", "5")
    assert code == 2

"""The CLI's safety verdicts judge every move length: check --motor, compare, plan."""

from __future__ import annotations

import itertools
import json
import re
from pathlib import Path

import pytest

from profiles.motor import bundled_motor_paths
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.motion import COMMANDS
from profiles.ppmc312.table import FreeCurveTable, dump_table, load_table
from tests.support.ascii_frames import FIGURES, move_argv
from tests.support.cli import run
from tests.support.datasheet_motor import datasheet_motor_file
from tests.support.paths import ROOT
from tests.support.switching_table import switching_table

MOTORS = {p.stem: p for p in bundled_motor_paths()}


NEMA23 = MOTORS["motor-nema23-heavy"]


NEMA17 = MOTORS["motor-nema17-1600"]


def test_check_motor_fails_a_table_unsafe_only_for_some_lengths(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = switching_table(tmp_path)
    code, out, _ = run(capsys, "check", path, "--motor", NEMA23, "--no-physics")
    assert code == 1 and "stall-switch" in out
    shortest = int(re.search(r"shortest move that runs it: (\d+) pulses",  # type: ignore[union-attr]
                             out[out.index("stall-switch"):]).group(1))
    table = load_table(path)
    # the named length really switches down; a trapezoid of the whole table does not
    segs = simulate_move(table, shortest).segments
    assert any(a.phase == "accel" and b.phase == "decel" and b.rate > a.rate
               for a, b in itertools.pairwise(segs))
    whole = table.accel_total + table.decel_total
    code, out, _ = run(capsys, "check", path, "--motor", NEMA23, "--no-physics",
                       "--pulses", f"{whole},{whole + 1000}")
    assert "stall-switch" not in out
    code, out, _ = run(capsys, "check", path, "--motor", NEMA23, "--no-physics",
                       "--pulses", str(shortest))
    assert code == 1 and "stall-switch" in out


def test_check_pulses_needs_a_motor_and_valid_lengths(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = switching_table(tmp_path)
    assert run(capsys, "check", path, "--pulses", "100")[0] == 2
    code, _, err = run(capsys, "check", path, "--motor", NEMA23, "--pulses", "0")
    assert code == 2 and "move length" in err


def test_check_motor_reports_the_load_angle_judge(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # a motor file that vouches for a 21 kpps start (the criterion believes it) while
    # its rotor (ω_n ≈ 1700 rad/s, 0.196 rad per pulse) swings 2.3 rad on a 20 kpps step
    motor = json.loads(NEMA17.read_text())
    motor.update(start_pps=21000, max_jump_pps=21000)
    motor_path = tmp_path / "optimistic.motor.json"
    motor_path.write_text(json.dumps(motor))
    table = FreeCurveTable(Clock.internal("8MHz"), (300, 400), (800, 800))
    path = tmp_path / "t.table.json"
    path.write_text(dump_table(table))
    code, out, _ = run(capsys, "check", path, "--motor", motor_path, "--format", "json")
    rules = {f["rule"] for f in json.loads(out)["files"][0]["findings"]}
    assert code == 1 and "load-angle" in rules
    assert not rules & {"stall-jump", "stall-accel", "stall-decel", "stall-start-speed"}
    message = next(f["message"] for f in json.loads(out)["files"][0]["findings"]
                   if f["rule"] == "load-angle")
    assert "the criterion passes" in message
    assert run(capsys, "check", path, "--motor", motor_path, "--no-physics")[0] == 0


GOOD = ROOT / "examples" / "free-curve-nema17.json"


BAD = ROOT / "examples" / "free-curve-bad.json"


INIT = ROOT / "examples" / "init-linear.json"


def test_check_good_and_bad(capsys: pytest.CaptureFixture[str]) -> None:
    assert run(capsys, "check", GOOD, INIT)[0] == 0
    code, out, _ = run(capsys, "check", GOOD, BAD)
    assert code == 1
    assert "chip 0x18" in out and "chip 0x19" in out


def test_check_json_shape(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "check", GOOD, BAD, "--format", "json")
    assert code == 1
    doc = json.loads(out)
    assert [f["path"] for f in doc["files"]] == [str(GOOD), str(BAD)]
    assert doc["files"][0]["ok"] is True and doc["files"][1]["ok"] is False
    finding = next(f for f in doc["files"][1]["findings"] if f["chip_code"] == "0x18")
    assert set(finding) == {"severity", "rule", "chip_code", "stage", "message"}
    assert finding["severity"] == "error" and finding["stage"] == 0


def test_check_upload_files_by_what_the_chip_answers(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    hexfile = tmp_path / "good.upload.hex"
    assert run(capsys, "export", GOOD, "--format", "hex", "-o", hexfile)[0] == 0
    assert run(capsys, "check", hexfile)[0] == 0
    binfile = tmp_path / "good.upload.bin"
    assert run(capsys, "export", GOOD, "--format", "bin", "-o", binfile)[0] == 0
    assert run(capsys, "check", binfile)[0] == 0
    # an upload whose stage count the chip refuses (0x11): one stage only
    # hand-edited, without the CRC line: judged (with a warning) by what the chip answers
    lines = [line for line in hexfile.read_text().splitlines() if not line.startswith("#")]
    first = lines[0].split()
    first[4] = "01"
    (tmp_path / "bad.upload.hex").write_text(" ".join(first) + "\n" + "\n".join(lines[1:]))
    code, out, _ = run(capsys, "check", tmp_path / "bad.upload.hex", "--format", "json")
    assert code == 1
    codes = {f["chip_code"] for f in json.loads(out)["files"][0]["findings"]}
    assert "0x11" in codes


def test_check_junit_is_xml(capsys: pytest.CaptureFixture[str]) -> None:
    import xml.etree.ElementTree as ET

    code, out, _ = run(capsys, "check", GOOD, BAD, "--format", "junit")
    assert code == 1
    root = ET.fromstring(out)
    assert len(root.findall(".//testcase")) == 2
    assert root.findall(".//failure")


def test_check_with_motor_on_an_init_table_the_chip_refuses(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    # No stages can be built, so there is nothing to judge for stall-safety: the chip's
    # error is the finding (exit 1), not "unusable input".
    path = tmp_path / "init.json"
    path.write_text('{"format": "stepramp.table/1", "device": "ppmc312", "kind": "init", '
                    '"clock": "8MHz", "shape": "linear", "start_rate": 400, '
                    '"high_rate": 400, "accel_pulses": 2000}')
    motor = ROOT / "profiles" / "data" / "motor-nema17-1600.json"
    code, out, _ = run(capsys, "check", path, "--motor", motor, "--format", "json")
    assert code == 1
    assert [f["chip_code"] for f in json.loads(out)["files"][0]["findings"]] == ["0x03"]


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
            code, _, err = run(capsys, *move_argv(name, params), "--to", to, "--format", fmt,
                               "-o", out)
            assert (code, err) == (0, ""), (fmt, to)
            code, text, err = run(capsys, "check", out)
            assert code == 0, (fmt, to, text, err)
            assert f"note: {COMMANDS[name].label if name != 'accel' else 'move'}" in text


@pytest.fixture(scope="module")
def datasheet_motor(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The datasheet NEMA17 on its lead screw (tests/support/datasheet_motor.py)."""
    return datasheet_motor_file(tmp_path_factory.mktemp("motor") / "m.json")


def test_check_motor_exits_1_on_an_unsafe_hand_written_file(
        datasheet_motor: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "hand.txt"
    assert run(capsys, "alink", "settings", "--start-pps", "8000", "--high-pps", "25000",
               "--accel-ms-per-kpps", "0.5", "-o", str(out))[0] == 0
    code, report, _ = run(capsys, "check", str(out), "--motor", str(datasheet_motor))
    assert code == 1
    assert "[stall-start-speed]" in report and "[load-angle]" in report
    code, report, _ = run(capsys, "check", str(out))  # without a motor: the unit's rules only
    assert code == 0 and "load-angle" not in report


def test_check_json_is_the_tables_verdict_shape(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """The same verdict object as a PPMC-312 table's (`--format json`)."""
    path = tmp_path / "s.txt"
    assert run(capsys, "alink", "settings", "--start-pps", "800", "--high-pps", "20000",
               "--accel-ms-per-kpps", "5", "-o", str(path))[0] == 0
    _, report, _ = run(capsys, "check", str(path), "examples/free-curve-nema17.json",
                          "--motor", "nema17-1600", "--format", "json")
    doc = json.loads(report)
    files = doc["files"] if isinstance(doc, dict) else doc
    ramp, table = files[0]["safety"], files[1]["safety"]
    assert set(ramp) == set(table)
    assert ramp["moves"] == "every" and ramp["safe"] in (True, False)


def test_check_motor_judges_the_commands_the_table_was_planned_for(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from profiles.provenance import FileRef, PlanProvenance

    def judged(table: FreeCurveTable, *more: str) -> tuple[list[str], list[str], str]:
        path = tmp_path / "t.json"
        path.write_text(dump_table(table))
        code, out, err = run(capsys, "check", path, "--motor", NEMA17, "--no-physics",
                             "--pulses", "30", "--format", "json", *more)
        assert code in (0, 1), err
        result = json.loads(out)["files"][0]
        _, text, _ = run(capsys, "check", path, "--motor", NEMA17, "--no-physics",
                         "--pulses", "30", *more)
        return (list(result["safety"]["commands"]), [f["rule"] for f in result["findings"]],
                text)

    plain = FreeCurveTable(Clock.internal("8MHz"), (2500, 3000), (10, 20))
    every, rules, text = judged(plain)  # an older table: every command family, as before
    assert len(every) > 1 and "decel-stop" in every and "commands-narrower" not in rules
    prov = PlanProvenance(FileRef("nema17-1600", "0" * 64), "0.1.0", "d",
                          commands=("decel-stop", "accel"))
    planned = FreeCurveTable(Clock.internal("8MHz"), (2500, 3000), (10, 20), provenance=prov)
    families, rules, text = judged(planned)
    assert families == ["decel-stop"] and "commands-narrower" not in rules
    assert "note: judged for the commands it was planned for: 81,82 (provenance); " \
           "--commands to change" in text
    # the command line wins: wider judges more, without a word; narrower is a warning
    assert judged(planned, "--commands", ",".join(f"{c.code:02X}" for c in COMMANDS.values())
                  )[0] == every
    families, rules, text = judged(planned, "--commands", "82")
    assert families == [] and "commands-narrower" in rules
    assert "warning [commands-narrower]: planned for the commands 81,82, judged for 82" in text


def test_check_commands_takes_the_alink_units_names(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]
                                                    ) -> None:
    """An A-Link settings file: --commands names the unit's commands and narrows its
    families (the JSON "commands" object); a name neither device knows is exit 2, naming
    both lists."""
    target = tmp_path / "s.alink.txt"
    assert run(capsys, "alink", "settings", "--start-pps", "800", "--high-pps", "4000",
               "--accel-ms-per-kpps", "50", "-o", target)[0] == 0
    code, out, _ = run(capsys, "check", target, "--motor", "nema17-1600", "--samples", "0",
                       "--commands", "move-a,limit", "--format", "json")
    assert code == 0
    commands = json.loads(out)["files"][0]["safety"]["commands"]
    assert set(commands) == {"limit"}
    assert commands["limit"]["envelope"]["fastest_pps"] >= 800
    code, _, err = run(capsys, "check", target, "--motor", "nema17-1600", "--commands", "jog")
    assert code == 2 and "A-Link commands" in err and "move-a" in err

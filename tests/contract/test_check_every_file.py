"""`stepramp check` judges every file stepramp writes or reads (issue 19, item 1): each
command that writes a file is run, and every file it wrote is passed back to `check`,
which gives a verdict (exit 0 or 1), never "unusable" (exit 2). The chip's own table-read
answer is judged with `--clock` (without it: exit 2, one line naming `--clock`); a file
check does not judge names the command that reads it.

The fast part runs the commands that only encode (move, export, decode, expand, alink,
mc200 from ruckig's limits, motor new); planning ones (plan, sync for both devices,
mc200 --motor) are the slow part (CI runs it).
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from profiles.alink.formats import FORMATS as ALINK_TABLE
from profiles.mc200.formats import FORMATS as MC200_TABLE
from profiles.ppmc312.formats import FORMATS as PPMC_FORMATS
from tests.support.paths import ROOT
from verify import cli

EXAMPLES = ROOT / "examples"


TABLE = str(EXAMPLES / "free-curve-nema17.json")


INIT = str(EXAMPLES / "init-linear.json")


READ = str(EXAMPLES / "free-curve-nema17.read.hex")


# every format of each device's format table (a new format is written and checked too)
UPLOAD_FORMATS = tuple(PPMC_FORMATS.formats)


ALINK_FORMATS = tuple(ALINK_TABLE.formats)


STREAM_FORMATS = tuple(MC200_TABLE.formats)


DATASHEET = ["--holding-torque-nm", "0.45", "--rated-current-a", "1.5", "--resistance-ohm",
             "1.8", "--inductance-mh", "3.2", "--supply-v", "24", "--microstep", "8",
             "--rotor-inertia-gcm2", "57"]


def encoding_commands(out: Path) -> Iterator[list[str]]:
    """Every command that writes a device file without planning, in every format."""
    for fmt in UPLOAD_FORMATS:
        yield ["move", "--pulses", "5000", "--ccw", "--format", fmt, "-o", f"{out}/move.{fmt}"]
        yield ["move", "--pulses", "7", "--override", "3", "--high-rate", "300", "--format",
               fmt, "-o", f"{out}/held.{fmt}"]
        yield ["export", TABLE, "--format", fmt, "-o", f"{out}/free.{fmt}"]
        yield ["export", INIT, "--format", fmt, "-o", f"{out}/init.{fmt}"]
        if fmt != "bus":  # an ASCII frame goes over the serial line, not the parallel bus
            yield ["move", "--pulses", "300", "--to", "ascii", "--address", "3", "--format",
                   fmt, "-o", f"{out}/serial-move.{fmt}"]
            yield ["export", INIT, "--to", "ascii", "--format", fmt, "-o",
                   f"{out}/serial-init.{fmt}"]
    yield ["decode", f"{out}/free.text", "-o", f"{out}/decoded.table.json"]
    yield ["decode", READ, "--table-read", "--clock", "8mhz", "-o", f"{out}/read.table.json"]
    yield ["expand", INIT, "-o", f"{out}/expanded.table.json"]
    for fmt in ALINK_FORMATS:
        yield ["alink", "settings", "--start-pps", "500", "--high-pps", "20000",
               "--accel-ms-per-kpps", "2", "--format", fmt, "-o", f"{out}/alink.{fmt}"]
        yield ["alink", "command", "move-r", "--value", "-1000", "--address", "4", "--format",
               fmt, "-o", f"{out}/alink-command.{fmt}"]
    yield ["alink", "homing", "--motor", "nema17-1600", "-o", f"{out}/homing.alink.txt"]
    for fmt in STREAM_FORMATS:
        yield ["mc200", "stream", "--vmax", "5000", "--amax", "5e4", "--jmax", "5e6",
               "--pulses", "800", "--period-us", "1000", "--format", fmt, "-o",
               f"{out}/stream.{fmt}"]
    # the other control modes (the motor for the current's load, ruckig's move: no plan)
    yield ["mc200", "stream", "--vmax", "5000", "--amax", "5e4", "--jmax", "5e6", "--pulses",
           "800", "--period-us", "1000", "--mode", "velocity", "--magic", "F0F0F0F0", "--din",
           "5", "--spi-error-reset", "-o", f"{out}/velocity.mc200.hex"]
    yield ["mc200", "stream", "--motor", "nema17-1600", "--vmax", "5000", "--amax", "5e4",
           "--jmax", "5e6", "--pulses", "800", "--period-us", "1000", "--mode", "current",
           "--torque-constant-nm-per-a", "0.3", "-o", f"{out}/current.mc200.json"]
    yield ["motor", "new", *DATASHEET, "--name", "axis", "-o", f"{out}/axis.motor.json"]


def planning_commands(out: Path) -> Iterator[list[str]]:
    """Every command that plans before it writes: plan (free curve, init), sync for both
    devices (every file of each folder), an MC-200 stream of a PPMC-312 plan."""
    axes = out / "axes.json"
    axes.write_text(json.dumps({"format": "stepramp.axes/1", "mode": "time", "axes": [
        {"name": "x", "motor": "nema17-1600", "pulses": 3000},
        {"name": "y", "motor": "pk566-5phase-half", "pulses": -1200}]}))
    alink = out / "alink-axes.json"
    alink.write_text(json.dumps({"format": "stepramp.axes/1", "mode": "line", "device":
                                 "alink", "axes": [
        {"name": "a", "motor": "nema17-1600", "pulses": 3000},
        {"name": "b", "motor": "nema17-1600", "pulses": 1000}]}))
    yield ["plan", "--motor", "nema17-1600", "--pulses", "2000", "-o", f"{out}/plan.json"]
    yield ["plan", "--motor", "nema17-1600", "--pulses", "2000", "--kind", "linear",
           "-o", f"{out}/plan-init.json"]
    yield ["sync", str(axes), "-o", f"{out}/xy", "--no-ruckig"]
    yield ["sync", str(alink), "-o", f"{out}/ab", "--no-ruckig"]
    yield ["alink", "settings", "--motor", "nema17-1600", "--pulses", "3000", "-o",
           f"{out}/planned.alink.json"]
    yield ["mc200", "stream", "--motor", "nema17-1600", "--pulses", "600", "--period-us",
           "500", "-o", f"{out}/staircase.mc200.hex"]


def written(out: Path, before: set[Path]) -> list[Path]:
    return sorted(p for p in out.rglob("*") if p.is_file() and p not in before)


def check_exit(path: Path) -> int:
    """`stepramp check PATH`'s exit code, from the function the command calls (the
    command's own mapping is tested below and in tests/contract/test_cli.py): 0 ok, 1 findings,
    2 unusable."""
    from verify.check_file import check_file

    result = check_file(str(path))
    return 2 if result.error is not None else 0 if result.ok else 1


def run_and_check(commands: Iterator[list[str]], out: Path,
                  capsys: pytest.CaptureFixture[str]) -> dict[str, int]:
    """Run each command, then `check` every file it wrote: {file: check's exit code}."""
    verdicts: dict[str, int] = {}
    for argv in commands:
        before = set(out.rglob("*"))
        code = cli.main(argv)
        _, err = capsys.readouterr()
        assert code == 0, (argv, err)
        files = written(out, before)
        assert files, argv
        for f in files:
            if f.suffix == ".json" and f.name.startswith(("axes", "alink-axes")) \
                    and f.parent == out:
                continue  # the test's own inputs
            verdicts[str(f.relative_to(out))] = check_exit(f)
    return verdicts


def test_every_encoded_file_gets_a_verdict(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    verdicts = run_and_check(encoding_commands(tmp_path), tmp_path, capsys)
    unusable = {f: code for f, code in verdicts.items() if code not in (0, 1)}
    assert unusable == {}
    # every format of each kind, and the device files of all three devices
    assert {f"move.{fmt}" for fmt in UPLOAD_FORMATS} <= set(verdicts)
    assert {"stream.hex", "alink.json", "axis.motor.json", "read.table.json"} <= set(verdicts)
    n = len(UPLOAD_FORMATS)
    assert len(verdicts) == 4 * n + 2 * (n - 1) + 3 + 2 * len(ALINK_FORMATS) + 1 + \
        len(STREAM_FORMATS) + 2 + 1
    assert verdicts["velocity.mc200.hex"] == 0 and verdicts["current.mc200.json"] == 0
    # a command the unit takes from power on and the homing speeds: no finding
    assert verdicts["alink-command.hex"] == 0 and verdicts["homing.alink.txt"] == 0
    # what the chip would refuse is a verdict, never "unusable": the held 7-pulse move with
    # an override rate of 300 is legal (exit 0)
    assert verdicts["held.text"] == 0 and verdicts["move.bin"] == 0
    # and through the command itself, for a sample of every kind
    for name in ("move.text", "serial-move.json", "free.c", "alink.hex", "stream.ihex",
                 "axis.motor.json"):
        assert cli.main(["check", str(tmp_path / name)]) == verdicts[name]
        assert capsys.readouterr().err == ""


@pytest.mark.slow  # plans (sync for both devices, plan, an MC-200 stream of a plan)
def test_every_planned_file_gets_a_verdict(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    verdicts = run_and_check(planning_commands(tmp_path), tmp_path, capsys)
    assert {f: c for f, c in verdicts.items() if c not in (0, 1)} == {}
    for folder, device_files in (("xy", {"x.table.json", "x.upload.hex", "x.upload.ihex",
                                         "x.move.hex", "axes.h", "axes.json"}),
                                 ("ab", {"a.settings.json", "a.commands.hex", "axes.h"})):
        assert {f"{folder}/{n}" for n in [*device_files, "report.json"]} <= set(verdicts)
    assert verdicts["xy/report.json"] == 0 and verdicts["ab/report.json"] == 0


def test_the_table_read_answer_needs_its_clock(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["check", READ]) == 2
    out, err = capsys.readouterr()
    assert err.count("\n") == 1 and "--clock" in err
    assert cli.main(["check", READ, "--clock", "8mhz", "--format", "json"]) == 0
    out, _ = capsys.readouterr()
    result = json.loads(out)["files"][0]
    assert result["ok"] and "error" not in result
    assert cli.main(["check", READ, "--clock", "EXTCK"]) == 2
    assert "--extck-hz" in capsys.readouterr().err


@pytest.mark.parametrize(("data", "pulses", "rule", "code"), [
    (bytes.fromhex("03 08 82 00 00 00 00 00 00 00"), None, "move-pulses", 0x23),
    (bytes.fromhex("03 08 82 04 00 00 00 00 01 00"), None, "move-trigger", 0x21),
    (bytes.fromhex("03 08 82 02 00 00 00 00 01 00"), None, "move-trigger-ignored", None),
    (bytes.fromhex("03 08 82 00 00 01 00 00 01 00"), None, "move-high-rate", 0x20),
    (bytes.fromhex("03 08 82 80 00 00 00 00 01 00"), None, "move-mode-bits", None),
    (bytes.fromhex("03 07 82 00 00 00 00 00 01"), None, "move-block", None),
])
def test_move_rules_are_findings(tmp_path: Path, data: bytes, pulses: int | None, rule: str,
                                 code: int | None) -> None:
    """A move the chip refuses (or that does what the manual says it should not ask) is a
    finding with the chip's code, never unusable input."""
    from profiles.ppmc312.formats import render
    from verify.check_file import check_file

    path = tmp_path / "move.hex"
    path.write_bytes(render([data], "text"))
    result = check_file(str(path))
    assert result.error is None
    found = [f for f in result.findings if f.rule == rule]
    assert len(found) == 1 and found[0].chip_code == code
    assert result.ok == (found[0].severity == "warning")


def test_a_serial_move_of_no_pulses_is_refused(tmp_path: Path) -> None:
    from profiles.ppmc312.ascii import encode_frame
    from profiles.ppmc312.formats import render
    from verify.check_file import check_file

    frame = encode_frame("command", 3, bytes.fromhex("A3 0000 00000000"))
    path = tmp_path / "serial.hex"
    path.write_bytes(render([frame], "text"))
    result = check_file(str(path))
    assert not result.ok and [f.rule for f in result.findings] == ["move-pulses"]
    good = tmp_path / "good.hex"
    good.write_bytes(render([encode_frame("command", 3, bytes.fromhex("83 0000 00000010"))],
                            "text"))
    result = check_file(str(good))
    assert result.ok and result.notes == ["move: 16 pulses CW at the table's top rate, at "
                                          "once (serial: no override)"]


@pytest.mark.parametrize(("name", "content", "reader"), [
    ("duty.csv", b"pulses,weight\n200,5\n", "plan --moves"),
    ("curve.csv", b"# vendor\nspeed_rpm,torque_ozin\n30,60\n", "motor new --curve"),
    ("fig.png", b"\x89PNG\r\n\x1a\n" + bytes(32), "no stepramp command"),
    ("report.xml", b'<?xml version="1.0"?>\n<testsuite name="stepramp check"/>', "CI"),
])
def test_a_file_check_does_not_judge_names_its_reader(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, content: bytes,
        reader: str) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    assert cli.main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and reader in err


def test_documents_are_judged(tmp_path: Path) -> None:
    """An axes file of tables is judged like sync's output (chip rules, finish spread);
    one mixing motors and tables is a verdict; a sync report's recorded problems are."""
    from verify.check_file import check_file

    axes = tmp_path / "axes.json"
    table = EXAMPLES / "free-curve-nema17.json"
    axes.write_text(json.dumps({"format": "stepramp.axes/1", "axes": [
        {"name": "x", "table": str(table), "pulses": 5000},
        {"name": "y", "table": str(table), "pulses": 500}]}))
    result = check_file(str(axes))
    assert [f.rule for f in result.findings] == ["axes-finish-spread"] and not result.ok
    axes.write_text(json.dumps({"format": "stepramp.axes/1", "axes": [
        {"name": "x", "table": str(table), "pulses": 5000},
        {"name": "y", "motor": "nema17-1600", "pulses": 500}]}))
    assert [f.rule for f in check_file(str(axes)).findings] == ["axes-mixed"]
    report = tmp_path / "report.json"
    report.write_text(json.dumps({"format": "stepramp.sync-report/1", "device": "alink",
                                  "mode": "time", "finish_spread_s": 1e-3,
                                  "finish_spread_tolerance_s": 2e-4, "axes": [
                                      {"name": "a", "safe": False, "stall_safe": False}]}))
    result = check_file(str(report))
    assert [f.rule for f in result.findings] == ["sync-report", "sync-report"]
    report.write_text(json.dumps({"format": "stepramp.sync-report/1"}))
    assert "written by stepramp sync" in (check_file(str(report)).error or "")

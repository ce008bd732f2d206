"""profiles.ppmc312.file_verdict: the PPMC-312 file judge: which files are tables, uploads
and programs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from profiles.errors import FormatError
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.file_verdict import load_checkable, looks_like_table_json, planned_commands
from profiles.ppmc312.formats import render
from profiles.ppmc312.table import FreeCurveTable, load_table
from profiles.ppmc312.upload import encode_table
from profiles.provenance import FileRef, PlanProvenance
from tests.support.paths import ROOT
from verify.check_file import check_file

GOOD = ROOT / "examples" / "free-curve-nema17.json"


def _hex() -> str:
    data = render(encode_table(load_table(GOOD)), "hex")
    return data if isinstance(data, str) else data.decode("ascii")


def test_upload_file_is_decoded_and_judged(tmp_path: Path) -> None:
    path = tmp_path / "good.hex"
    path.write_text(_hex())
    table, findings = load_checkable(str(path))
    assert table == load_table(GOOD) and findings == []
    assert check_file(str(path)).ok


def test_upload_the_chip_refuses_is_one_finding_with_its_code(tmp_path: Path) -> None:
    lines = [line for line in _hex().splitlines() if not line.startswith("#")]
    first = lines[0].split()  # hand-edited, so without the CRC line (a warning, below)
    first[4] = "01"  # one stage: the chip answers parameter error 0x11
    path = tmp_path / "bad.hex"
    path.write_text(" ".join(first) + "\n" + "\n".join(lines[1:]) + "\n")
    table, findings = load_checkable(str(path))
    assert table is None
    assert [(f.rule, f.chip_code) for f in findings] == [("chip-rejects-upload", 0x11),
                                                         ("upload-unchecked", None)]
    result = check_file(str(path))
    assert not result.ok and result.error is None


def test_what_counts_as_a_table_file() -> None:
    assert looks_like_table_json(b'  {"format": "stepramp.table/1", "blocks": []}')
    assert looks_like_table_json(b'{"format": "wrong"}')  # reported as a bad table
    assert not looks_like_table_json(json.dumps({"blocks": ["02 00"]}).encode())
    assert not looks_like_table_json(b"02 00 01")


EXAMPLE = ROOT / "examples" / "program-home-and-jog.json"


TABLE = ROOT / "examples" / "free-curve-nema17.json"


def test_the_judge_tells_programs_by_the_readers_format() -> None:
    from profiles.ppmc312.file_verdict import PROGRAM_FORMAT, is_program
    from profiles.ppmc312.program import FORMAT

    assert PROGRAM_FORMAT == FORMAT
    assert is_program(EXAMPLE.read_bytes()) and not is_program(TABLE.read_bytes())


def _planned_for(commands: tuple[str, ...] | None) -> FreeCurveTable:
    prov = PlanProvenance(FileRef("m", "0" * 64), "0.1.0", "d", commands=commands)
    return FreeCurveTable(Clock.named("8MHz"), (400, 800), (10, 20), provenance=prov)


def test_the_commands_a_table_was_planned_for_are_judged_unless_told() -> None:
    recorded = _planned_for(("decel-stop", "accel"))
    notes: list[str] = []
    assert planned_commands(recorded, None, notes) == (("decel-stop", "accel"), [])
    assert notes == ["judged for the commands it was planned for: 81,82 (provenance); "
                     "--commands to change"]
    # the command line wins; wider than the record: no warning, no note
    notes.clear()
    assert planned_commands(recorded, ("82", "81", "84"), notes) == (("82", "81", "84"), [])
    assert notes == []
    # narrower: the verdict leaves out a command the machine was planned to run
    given, found = planned_commands(recorded, ("accel",), notes)
    assert given == ("accel",) and [(f.severity, f.rule) for f in found] == [
        ("warning", "commands-narrower")]
    assert "planned for the commands 81,82, judged for 82: the verdict leaves out 81" \
        in found[0].message
    # no record (an older table, or planned for every command): as given, all when none
    for table in (_planned_for(None), FreeCurveTable(Clock.named("8MHz"), (400, 800), (10, 20))):
        assert planned_commands(table, None, notes) == (None, [])
        assert planned_commands(table, ("82",), notes) == (("82",), [])
    assert notes == []


def test_a_recorded_command_the_device_does_not_know_names_the_key() -> None:
    with pytest.raises(FormatError, match=r"^provenance\.commands: 'warp' is neither"):
        planned_commands(_planned_for(("accel", "warp")), None, [])

"""`stepramp export` (verify/cli/export.py): upload files in every format, refusals."""

from __future__ import annotations

import json
import zlib
from pathlib import Path

import pytest

from profiles.ppmc312.emulator import expected_answers
from profiles.ppmc312.formats import parse_upload
from profiles.ppmc312.table import load_table
from profiles.ppmc312.upload import decode_upload, encode_table
from tests.support.cli import run
from tests.support.paths import ROOT

GOOD = ROOT / "examples" / "free-curve-nema17.json"


BAD = ROOT / "examples" / "free-curve-bad.json"


INIT = ROOT / "examples" / "init-linear.json"


def test_export_decode_round_trip(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    table = load_table(GOOD)
    for fmt in ("hex", "bin", "json"):
        out = tmp_path / f"t.{fmt}"
        assert run(capsys, "export", GOOD, "--format", fmt, "-o", out)[0] == 0
        back = tmp_path / f"back-{fmt}.json"
        assert run(capsys, "decode", out, "-o", back)[0] == 0
        assert load_table(back) == table
    assert decode_upload(parse_upload((tmp_path / "t.hex").read_bytes())) == table


def test_export_hex_format_is_exact(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "export", GOOD, "--format", "hex")
    assert code == 0
    blocks = encode_table(load_table(GOOD))
    answers = expected_answers(blocks) or []
    payload = b"".join(blocks)
    # each block, then the answer the chip gives to it (the handshake, manual §7-2)
    assert out == "".join(b.hex(" ").upper() + "\n# answer: " + a.hex(" ").upper() + "\n"
                          for b, a in zip(blocks, answers, strict=True)) + (
        f"# crc32 {zlib.crc32(payload):08X}: CRC-32 of the {len(payload)} bytes above\n")
    assert out.splitlines()[0].startswith("02 ")
    assert out.splitlines()[-3].startswith("01 ")
    assert out.splitlines()[-2].startswith("# answer: 03 08 01 0F ")


def test_export_ascii_init_frame(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "export", INIT, "--to", "ascii", "--address", "3",
                       "--format", "hex")
    assert code == 0
    frame = bytes.fromhex(out.splitlines()[0])
    assert frame[0] == 0x93  # command frame to slave 3
    assert all(0x30 <= b < 0x7F for b in frame[1:])


def test_export_refuses_table_with_errors(capsys: pytest.CaptureFixture[str],
                                          tmp_path: Path) -> None:
    out = tmp_path / "bad.hex"
    code, _, err = run(capsys, "export", BAD, "-o", out)
    assert code == 1 and "--force" in err
    assert not out.exists()
    assert run(capsys, "export", BAD, "--force", "-o", out)[0] == 0
    assert out.read_text().startswith("02 ")


@pytest.mark.parametrize("content, match", [
    ("", "empty"),
    ("{not json", "not valid JSON"),
    ('{"format": "stepramp.table/1", "device": "ppmc312", "kind": "free_curve", '
     '"clock": "8MHz", "rates": [400, 70000], "accel_pulses": [10, 10]}', "65535"),
    ('{"format": "stepramp.table/1", "device": "ppmc312", "kind": "free_curve", '
     '"clock": "8MHz", "rates": [400, 800], "accel_pulses": [10, -3]}', "accel_pulses"),
    ('{"format": "stepramp.table/1", "device": "ppmc312", "kind": "free_curve", '
     '"clock": "8MHz", "rates": [400, 800], "accel_pulses": [10, 3], "extra": 1}', "unknown"),
    ('{"format": "stepramp.table/1", "device": "ppmc312", "kind": "free_curve", '
     '"clock": "9MHz", "rates": [400, 800], "accel_pulses": [10, 3]}', "clock"),
])
def test_bad_table_files_exit_2_with_one_line(capsys: pytest.CaptureFixture[str],
                                              tmp_path: Path, content: str, match: str) -> None:
    path = tmp_path / "t.json"
    path.write_text(content)
    out = tmp_path / "out.hex"
    code, _, err = run(capsys, "export", path, "-o", out)
    assert code == 2
    assert match in err and len(err.strip().splitlines()) == 1
    assert "Traceback" not in err
    assert not out.exists() and list(tmp_path.iterdir()) == [path]


def test_missing_file_and_bad_arguments(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "check", "/nonexistent.json", "--format", "json")
    assert code == 2
    assert "no such file" in json.loads(out)["files"][0]["error"]
    assert run(capsys, "export", GOOD, "--address", "-1")[0] == 2
    assert run(capsys, "export", GOOD, "--to", "ascii", "--address", "16")[0] == 2
    assert run(capsys, "frobnicate")[0] == 2


def test_export_c_carries_what_the_table_was_planned_for(capsys: pytest.CaptureFixture[str],
                                                        tmp_path: Path) -> None:
    from dataclasses import replace

    from profiles.ppmc312.table import dump_table
    from profiles.provenance import FileRef, PlanProvenance

    prov = PlanProvenance(FileRef("nema17-1600", "ab" * 32), "0.1.0", "2025-01-31T12:00:00Z",
                          (3200,), None, 75.0, 0.6, "2x,10%", ("decel-stop", "accel"))
    path = tmp_path / "t.json"
    path.write_text(dump_table(replace(load_table(GOOD), provenance=prov)))
    code, header, err = run(capsys, "export", path, "--format", "c")
    assert code == 0, err
    assert (" * planned for motor nema17-1600 (sha256 abababababab), a move of 3200 pulses, "
            "aim 75 deg, safety factor 0.6, cruise reserve 2x,10%, commands decel-stop,accel; "
            "stepramp 0.1.0, 2025-01-31T12:00:00Z\n") in header
    code, header, err = run(capsys, "export", GOOD, "--format", "c")  # no provenance: no line
    assert code == 0 and "planned for" not in header

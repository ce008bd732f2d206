"""`stepramp decode` (verify/cli/decode.py): upload files and table reads decoded, bad input in
one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from profiles import alink as A
from profiles import mc200 as M
from profiles.mc200.formats import render as render_stream
from profiles.ppmc312.table import load_table
from tests.support.cli import run
from tests.support.paths import ROOT
from verify.cli import main

GOOD = ROOT / "examples" / "free-curve-nema17.json"


@pytest.mark.parametrize("content", ["02 03 01 00\n", "zz 01\n", "02 03 01 00 1A\n01 04 01 90",
                                     "\x00\x01\x02"])
def test_corrupt_uploads_exit_2(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                content: str) -> None:
    path = tmp_path / "u.hex"
    path.write_text(content)
    out = tmp_path / "t.json"
    code, _, err = run(capsys, "decode", path, "-o", out)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not out.exists()


def test_decode_table_read_response(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from profiles.ppmc312.formats import render
    from profiles.ppmc312.upload import encode_table_read_response

    table = load_table(GOOD)
    path = tmp_path / "read.hex"
    path.write_bytes(render(encode_table_read_response(table), "hex"))  # type: ignore[arg-type]
    out = tmp_path / "t.json"
    assert run(capsys, "decode", path, "--table-read", "--clock", "8MHz", "-o", out)[0] == 0
    assert load_table(out) == table
    code, _, err = run(capsys, "decode", path, "--table-read")
    assert code == 2 and "--clock" in err


def test_decode_table_read_clock_any_case(capsys: pytest.CaptureFixture[str],
                                          tmp_path: Path) -> None:
    read = ROOT / "examples" / "free-curve-nema17.read.hex"
    code, out, _ = run(capsys, "decode", read, "--table-read", "--clock", "8mhz")
    assert code == 0 and '"8MHz"' in out
    code, _, err = run(capsys, "decode", read, "--table-read", "--clock", "extck")
    assert code == 2 and "--extck-hz" in err


def _packets(data: bytes) -> list[bytes]:
    return [data[i:i + 12] for i in range(0, len(data), 12)]


POSITION_AT, DURATION = M.ruckig_profile(600, 8000.0, 8e4, 8e6)


STREAM = M.stream_bytes(POSITION_AT, DURATION, 600, period_us=2000)


SETTINGS_COMMANDS = A.settings_commands(A.quantise_settings(500, 10000, 20))


def test_decode_names_the_command_that_reads_another_devices_file(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    stream = tmp_path / "move.mc200.hex"
    stream.write_bytes(render_stream(_packets(STREAM), "hex"))
    settings_file = tmp_path / "axis.alink.json"
    settings_file.write_text(A.render_settings(
        A.settings_document(A.quantise_settings(500, 10000, 20), SETTINGS_COMMANDS), "json"))
    for path, command in ((stream, "stepramp mc200 decode"),
                          (settings_file, "stepramp alink read")):
        assert main(["decode", str(path)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("stepramp decode: ") and err.rstrip().endswith(command)
        assert len(err.splitlines()) == 1

"""PPMC-312 upload files: render to hex/bin/c/json/bus and parse back."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles.errors import DecodeError, FormatError, StepRampError
from profiles.ppmc312.ascii import encode_serial_init
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.files import parse_upload, render
from profiles.ppmc312.table import FreeCurveTable, InitTable
from profiles.ppmc312.upload import bus_writes, encode_free_curve

SETTINGS = settings(max_examples=100, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
CLOCK = Clock.internal("8MHz")


@st.composite
def uploads(draw: st.DrawFn) -> list[bytes]:
    """Encoded free curves (parallel) or one or more ASCII init frames."""
    if draw(st.booleans()):
        n = draw(st.integers(2, 40))
        rates = draw(st.lists(st.integers(0, 0xFFFF), min_size=n, max_size=n))
        accel = draw(st.lists(st.integers(0, 0xFFFFFF), min_size=n, max_size=n))
        return encode_free_curve(FreeCurveTable(CLOCK, tuple(rates), tuple(accel)),
                                 max_data=draw(st.integers(3, 30)))
    frames = []
    for _ in range(draw(st.integers(1, 3))):
        table = InitTable(CLOCK, "linear", draw(st.integers(0, 0xFFFF)),
                          draw(st.integers(0, 0xFFFF)), draw(st.integers(0, 0xFFFFFF)))
        frames.append(encode_serial_init(table, draw(st.integers(0, 15))))
    return frames


@SETTINGS
@given(uploads(), st.sampled_from(["hex", "bin", "json"]))
def test_render_parse_round_trip(blocks: list[bytes], fmt: str) -> None:
    assert parse_upload(render(blocks, fmt)) == blocks


BLOCKS = encode_free_curve(FreeCurveTable(CLOCK, (100, 200, 300), (10, 20, 30)), max_data=4)


def test_hex_format() -> None:
    text = render(BLOCKS, "hex").decode()
    assert text.splitlines() == ["02 03 01 00 03", "00 04 00 64 00 C8", "00 02 01 2C",
                                 "00 03 00 00 0A", "00 03 00 00 14", "01 03 00 00 1E"]
    lowered = "# upload\n\n" + text.lower().replace("\n", "  # c\n", 1) + "\n\n"
    assert parse_upload(lowered.encode()) == BLOCKS
    assert parse_upload(b"020301 0003\n0004 0064 00C8\n00 02 01 2C\n00 03 00 00 0A\n"
                        b"0003 00 00 14\n010300001E") == BLOCKS


def test_json_and_bin_formats() -> None:
    assert json.loads(render(BLOCKS, "json")) == {"blocks": [
        "02 03 01 00 03", "00 04 00 64 00 C8", "00 02 01 2C", "00 03 00 00 0A",
        "00 03 00 00 14", "01 03 00 00 1E"]}
    assert render(BLOCKS, "bin") == b"".join(BLOCKS)


def test_bus_format_lists_every_register_write() -> None:
    lines = render(BLOCKS, "bus").decode().splitlines()
    expected = [f"{r} {v:02X}" for b in BLOCKS for r, v in bus_writes(b)]
    assert lines == expected
    assert lines[:5] == ["WCR 20", "WAR 1B", "DWR 03", "DWR 00", "DWR 01"]
    ascii_frame = encode_serial_init(InitTable(CLOCK, "linear", 0x1000, 0x100, 0x200), 1)
    with pytest.raises(StepRampError, match="serial"):
        render([ascii_frame], "bus")


def test_c_header_matches_the_blocks() -> None:
    text = render(BLOCKS, "c").decode()
    assert "#include <stdint.h>" in text and "#ifndef STEPRAMP_UPLOAD_H" in text
    arrays = re.findall(r"const uint8_t stepramp_block_(\d+)\[\] = \{([^}]*)\};", text)
    assert [int(i) for i, _ in arrays] == list(range(len(BLOCKS)))
    assert [bytes(int(x, 16) for x in body.split(", ")) for _, body in arrays] == BLOCKS
    lengths = re.search(r"stepramp_block_lengths\[STEPRAMP_BLOCK_COUNT\] = \{([^}]*)\}", text)
    assert lengths is not None
    assert [int(x) for x in lengths.group(1).split(", ")] == [len(b) for b in BLOCKS]


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_c_header_compiles_and_replays_the_blocks(tmp_path: Path) -> None:
    (tmp_path / "upload.h").write_bytes(render(BLOCKS, "c"))
    (tmp_path / "main.c").write_text(
        '#include <stdio.h>\n#include "upload.h"\n#include "upload.h"\n'
        "int main(void) {\n  for (size_t i = 0; i < STEPRAMP_BLOCK_COUNT; i++) {\n"
        "    for (size_t k = 0; k < stepramp_block_lengths[i]; k++)\n"
        '      printf(k ? " %02X" : "%02X", stepramp_blocks[i][k]);\n'
        '    printf("\\n");\n  }\n  return 0;\n}\n')
    exe = tmp_path / "replay"
    subprocess.run(["cc", "-std=c99", "-Wall", "-Werror", "-o", str(exe),
                    str(tmp_path / "main.c")], check=True, capture_output=True, timeout=60)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True, timeout=10)
    assert out.stdout == render(BLOCKS, "hex").decode()


def test_binary_ascii_frames_split_at_control_bytes() -> None:
    frames = [encode_serial_init(InitTable(CLOCK, "linear", 0x1000 + k, 0x100, 0x200), k)
              for k in range(3)]
    assert parse_upload(b"".join(frames)) == frames


@pytest.mark.parametrize(("data", "words"), [
    (b"", "empty"),
    (b"  \n\n", "empty"),
    (b"# only a comment\n\n", "no blocks"),
    (b"02 03 01 00 03\n00 0\n", "line 2, column 4"),
    (b"02 03 01 00 03\n00 ZZ\n", "line 2, column 4: 'Z'"),
    (b"02 03 01 00 03\n00 04 00 64 00 C8 7", "line 2.*odd"),
    (b"\x02\x05\x01\x00", "byte 1:.*past the end"),
    (b"\x02", "byte 0:.*length byte"),
    (b"\x02\x03\x01\x00\x03\x40\x00", "byte 5:.*neither"),
    (b'{"blocks": ["02 03", 5]}', "blocks\\[1\\]"),
    (b'{"blocks": []}', "no blocks"),
    (b'{"blox": []}', "JSON upload"),
    (b'{"blocks": ["02 0"]}', "blocks\\[0\\].*odd"),
    (b"{not json", "not valid JSON"),
    (b"\x40\xff\xfe", "neither text"),
])
def test_parse_errors(data: bytes, words: str) -> None:
    with pytest.raises(StepRampError, match=words) as err:
        parse_upload(data)
    assert isinstance(err.value, DecodeError | FormatError)
    assert "\n" not in str(err.value)


@SETTINGS
@given(st.binary(max_size=80))
def test_garbage_never_crashes_parse_upload(data: bytes) -> None:
    try:
        blocks = parse_upload(data)
    except StepRampError:
        return
    assert blocks and all(blocks)


def test_render_refusals() -> None:
    with pytest.raises(FormatError, match="format"):
        render(BLOCKS, "srec")
    with pytest.raises(FormatError, match="no blocks"):
        render([], "hex")
    with pytest.raises(DecodeError, match="empty"):
        render([b""], "hex")

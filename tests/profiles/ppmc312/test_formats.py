"""PPMC-312 upload files: every format renders and parses back, carries its check,
and a changed file is reported as corrupted."""

from __future__ import annotations

import io
import json
import re
import zlib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from intelhex import IntelHex

from profiles.errors import CorruptedError, DecodeError, FormatError, StepRampError
from profiles.formats import RenderOptions, c_name, crc32
from profiles.ppmc312.ascii import encode_serial_init
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.formats import (
    FORMATS,
    c_symbols,
    parse,
    parse_c_set,
    parse_upload,
    provenance,
    render,
    render_c_set,
)
from profiles.ppmc312.table import FreeCurveTable, InitTable
from profiles.ppmc312.upload import bus_writes, decode_upload, encode_free_curve, encode_init
from tests.support.file_checks import (
    assert_one_line_error,
    compile_and_run,
    flip_verdicts,
    flips,
    needs_cc,
    parsed_in_any_format,
)

SETTINGS = settings(max_examples=100, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


CLOCK = Clock.internal("8MHz")


ALL = ("text", "bin", "ihex", "c", "json", "bus")


@st.composite
def uploads(draw: st.DrawFn, parallel_only: bool = False) -> list[bytes]:
    """Encoded free curves or init blocks (parallel), or ASCII init frames."""
    kind = draw(st.sampled_from(["free", "init"] + ([] if parallel_only else ["ascii"])))
    if kind == "free":
        n = draw(st.integers(2, 40))
        rates = draw(st.lists(st.integers(0, 0xFFFF), min_size=n, max_size=n))
        accel = draw(st.lists(st.integers(0, 0xFFFFFF), min_size=n, max_size=n))
        return encode_free_curve(FreeCurveTable(CLOCK, tuple(rates), tuple(accel)),
                                 max_data=draw(st.integers(3, 30)))
    table = InitTable(CLOCK, "linear", draw(st.integers(0, 0xFFFF)),
                      draw(st.integers(0, 0xFFFF)), draw(st.integers(0, 0xFFFFFF)))
    if kind == "init":
        return [encode_init(table)]
    return [encode_serial_init(table, draw(st.integers(0, 15)))
            for _ in range(draw(st.integers(1, 3)))]


def formats_for(blocks: list[bytes]) -> tuple[str, ...]:
    # Bus writes exist for parallel blocks only (an ASCII frame goes over the serial line).
    return ALL if blocks[0][0] < 0x80 else tuple(f for f in ALL if f != "bus")


@SETTINGS
@given(uploads(), st.sampled_from(ALL), st.integers(0, 0xFFFF_0000))
def test_every_format_round_trips(blocks: list[bytes], fmt: str, base: int) -> None:
    if fmt not in formats_for(blocks):
        return
    data = render(blocks, fmt, RenderOptions(name="axis", base_address=base))
    parsed = parse(data)  # detected by content
    assert parsed.items == blocks
    assert parsed.format == fmt
    assert parsed.integrity == ("none" if fmt == "bin" else "verified")


BLOCKS = encode_free_curve(FreeCurveTable(CLOCK, (100, 200, 300), (10, 20, 30)), max_data=4)


PAYLOAD = b"".join(BLOCKS)


# CRC-32 of the 30 payload bytes, from zlib (an implementation independent of stepramp's).
CRC = f"{zlib.crc32(PAYLOAD):08X}"


def test_the_uploads_crc32() -> None:
    assert CRC == "423ABBA0"


# What the chip answers to each of BLOCKS (manual §7-2): 3 rates due, 1 left; 3 accel
# counts due, 2, 1; done: accel and decel totals 60 (LE=0: the same counts).
ANSWERS = ["03 03 01 00 03", "03 03 01 00 01", "03 03 01 01 03", "03 03 01 01 02",
           "03 03 01 01 01", "03 08 01 0F 00 00 3C 00 00 3C"]


def test_text_format_golden() -> None:
    assert render(BLOCKS, "text").decode().splitlines() == [
        "02 03 01 00 03", "# answer: 03 03 01 00 03",
        "00 04 00 64 00 C8", "# answer: 03 03 01 00 01",
        "00 02 01 2C", "# answer: 03 03 01 01 03",
        "00 03 00 00 0A", "# answer: 03 03 01 01 02",
        "00 03 00 00 14", "# answer: 03 03 01 01 01",
        "01 03 00 00 1E", "# answer: 03 08 01 0F 00 00 3C 00 00 3C",
        "# crc32 423ABBA0: CRC-32 of the 30 bytes above"]
    assert render(BLOCKS, "hex") == render(BLOCKS, "text")  # the old name is an alias


def test_text_accepts_hand_made_files_without_a_check() -> None:
    lowered = "# upload\n\n" + "\n".join(
        line.lower() + "  # c" for line in render(BLOCKS, "text").decode().splitlines()[:-1])
    parsed = parse(lowered.encode())
    assert parsed.items == BLOCKS and parsed.integrity == "absent"
    assert "no CRC-32" in parsed.detail
    assert parse_upload(b"020301 0003\n0004 0064 00C8\n00 02 01 2C\n00 03 00 00 0A\n"
                        b"0003 00 00 14\n010300001E") == BLOCKS


def test_json_and_bin_golden() -> None:
    assert json.loads(render(BLOCKS, "json")) == {"blocks": [
        "02 03 01 00 03", "00 04 00 64 00 C8", "00 02 01 2C", "00 03 00 00 0A",
        "00 03 00 00 14", "01 03 00 00 1E"], "answers": ANSWERS, "crc32": CRC}
    assert list(json.loads(render(BLOCKS, "json"))) == ["blocks", "answers", "crc32"]
    assert render(BLOCKS, "bin") == PAYLOAD
    assert parse(PAYLOAD).integrity == "none"
    old = json.dumps({"blocks": json.loads(render(BLOCKS, "json"))["blocks"]}).encode()
    assert parse(old).integrity == "absent"  # JSON uploads written before the check


def test_bus_format_lists_every_register_access() -> None:
    """Per block: the MWEF wait and its writes (§5-6), then its answer's reads (§5-8):
    the MREF wait, RCR's dummy read, RAR = 0x40 − size, the bytes last first."""
    lines = render(BLOCKS, "bus").decode().splitlines()
    expected = []
    for block, answer in zip(BLOCKS, ANSWERS, strict=True):
        data = bytes.fromhex(answer)
        expected += ["WAIT CSR.MWEF 0", *(f"{r} {v:02X}" for r, v in bus_writes(block)),
                     "WAIT CSR.MREF 0", "RCR --", f"RAR {0x40 - len(data):02X}",
                     *(f"DRR {b:02X}" for b in reversed(data))]
    assert [line.partition("  #")[0] for line in lines] == [
        *expected, f"# crc32 {CRC}: CRC-32 of the 30 bytes above"]
    assert lines[:14] == ["WAIT CSR.MWEF 0", "WCR 20", "WAR 1B", "DWR 03", "DWR 00", "DWR 01",
                          "DWR 03", "DWR 02", "WAIT CSR.MREF 0  # answer to block 0: "
                          "03 03 01 00 03", "RCR --", "RAR 3B", "DRR 03", "DRR 00", "DRR 01"]
    ascii_frame = encode_serial_init(InitTable(CLOCK, "linear", 0x1000, 0x100, 0x200), 1)
    with pytest.raises(StepRampError, match="serial"):
        render([ascii_frame], "bus")


@pytest.mark.parametrize(("cut", "says"), [
    (["WCR 20"], "line 1: WCR 20 is followed by WAR"),                # nothing after it
    (["WCR 20", "DWR 03"], "line 1: WCR 20 is followed by WAR"),      # data, no size
    (["WCR 20", "WAR 1F"], "line 1: WAR says 1 DWR writes follow; found 0"),  # size, no data
])
def test_a_cut_bus_block_is_refused_at_its_line(cut: list[str], says: str) -> None:
    with pytest.raises(DecodeError, match=says):
        parse(("\n".join(cut) + "\n").encode(), fmt="bus")


# --- Intel HEX, checked against the intelhex package ---------------------------------
def test_ihex_golden() -> None:
    assert render(BLOCKS, "ihex").decode().splitlines() == [
        ":020000040000FA",
        ":1000000002030100030004006400C80002012C0088",  # 88 = −(10+00+00+00+02+03…) mod 256
        ":0E0010000300000A0003000014010300001E9C",
        ":00000001FF"]


@SETTINGS
@given(uploads(), st.integers(0, 0xFFFF_F000))
def test_ihex_is_read_by_intelhex(blocks: list[bytes], base: int) -> None:
    payload = b"".join(blocks)
    ih = IntelHex()
    ih.loadhex(io.StringIO(render(blocks, "ihex", RenderOptions(base_address=base)).decode()))
    assert ih.minaddr() == base and ih.maxaddr() == base + len(payload) - 1
    assert ih.tobinstr() == payload


@SETTINGS
@given(uploads(), st.integers(0, 0xFFFF_F000), st.sampled_from([8, 16, 32]))
def test_ihex_written_by_intelhex_is_read(blocks: list[bytes], base: int, width: int) -> None:
    ih = IntelHex()
    ih.puts(base, b"".join(blocks))
    out = io.StringIO()
    ih.write_hex_file(out, byte_count=width)
    parsed = parse(out.getvalue().encode())
    assert parsed.items == blocks and parsed.format == "ihex"


def test_ihex_base_address_range() -> None:
    with pytest.raises(StepRampError, match="base address"):
        render(BLOCKS, "ihex", RenderOptions(base_address=0xFFFF_FFFF))
    with pytest.raises(StepRampError, match="base address"):
        render(BLOCKS, "ihex", RenderOptions(base_address=-1))


@pytest.mark.parametrize(("text", "words"), [
    (":100000000203010003000400640C80002012C0088\n:00000001FF\n", "odd"),
    (":1000000002030100030004006400C80002012C0089\n:00000001FF\n", "corrupted.*checksum"),
    (":1000000002030100030004006400C80002012C0088\n", "corrupted.*end-of-file"),
    (":0E0010000300000A0003000014010300001E9C\n:00000001FF\n:00000001FF\n", "after"),
    (":1000000002030100030004006400C80002012C0088\n:0E0020000300000A0003000014010300001E8C\n"
     ":00000001FF\n", "gaps"),
    (":00000001FF\n", "no data"),
])
def test_ihex_errors(text: str, words: str) -> None:
    with pytest.raises(StepRampError, match=words):
        parse(text.encode())


# --- C header ----------------------------------------------------------------------------
def test_c_header_matches_the_blocks() -> None:
    prov = provenance(FreeCurveTable(CLOCK, (100, 200, 300), (10, 20, 30)),
                      command="stepramp export t.json --format c", motor="NEMA17")
    text = render(BLOCKS, "c", RenderOptions(name="x_axis", provenance=prov)).decode()
    assert "#ifndef X_AXIS_H" in text and "#define X_AXIS_H" in text
    assert "stepramp" not in re.sub(r"/\*.*?\*/", "", text, flags=re.S)  # every symbol prefixed
    comment = text.split("*/")[0]
    for words in ("stepramp 0.1.0", "command: stepramp export t.json --format c",
                  "motor: NEMA17", "clock 8MHz", "3 stages", "accel 60 pulses",
                  f"CRC-32 {CRC}"):
        assert words in comment
    arrays = re.findall(r"const uint8_t x_axis_block_(\d+)\[\] = \{([^}]*)\};", text)
    assert [int(i) for i, _ in arrays] == list(range(len(BLOCKS)))
    assert [bytes(int(x, 16) for x in body.split(", ")) for _, body in arrays] == BLOCKS
    assert f"#define X_AXIS_CRC32 0x{CRC}UL" in text
    assert parse(text.encode()).items == BLOCKS


@pytest.mark.parametrize("name", ["", "1axis", "x-axis", "int", "x axis", "a" * 41, "ä"])
def test_c_name_must_be_an_identifier(name: str) -> None:
    with pytest.raises(FormatError, match="--name"):
        render(BLOCKS, "c", RenderOptions(name=name))
    with pytest.raises(FormatError, match="--name"):
        c_name(name)


def test_comment_cannot_end_early() -> None:
    prov = provenance(None, command="stepramp export '*/ int x;' -o a.h")
    text = render(BLOCKS, "c", RenderOptions(provenance=prov)).decode()
    assert text.count("*/") == 2  # the header comment's end and the guard's #endif comment


MAIN_C = r"""
#include <stdio.h>
#include "x_axis.h"
#include "y_axis.h"
#include "x_axis.h"

/* The check a firmware runs before it uploads: CRC-32 of the blocks in order. */
static uint32_t crc32_blocks(const uint8_t *const *blocks, const size_t *lengths, size_t n) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; i++)
    for (size_t k = 0; k < lengths[i]; k++) {
      crc ^= blocks[i][k];
      for (int b = 0; b < 8; b++) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
  return ~crc;
}

static void dump(const uint8_t *const *blocks, const size_t *lengths, size_t n) {
  for (size_t i = 0; i < n; i++) {
    for (size_t k = 0; k < lengths[i]; k++) printf(k ? " %02X" : "%02X", blocks[i][k]);
    printf("\n");
  }
}

int main(void) {
  if (crc32_blocks(x_axis_blocks, x_axis_block_lengths, X_AXIS_BLOCK_COUNT) != X_AXIS_CRC32)
    return 3;
  if (crc32_blocks(y_axis_blocks, y_axis_block_lengths, Y_AXIS_BLOCK_COUNT) != Y_AXIS_CRC32)
    return 4;
  dump(x_axis_blocks, x_axis_block_lengths, X_AXIS_BLOCK_COUNT);
  printf("--\n");
  dump(y_axis_blocks, y_axis_block_lengths, Y_AXIS_BLOCK_COUNT);
  return 0;
}
"""


@needs_cc
def test_two_headers_compile_together_and_verify_their_crc(tmp_path: Path) -> None:
    other = [encode_init(InitTable(CLOCK, "s_curve", 0x2710, 0x190, 0x7D0))]
    out = compile_and_run(tmp_path, {"x_axis.h": render(BLOCKS, "c", RenderOptions(name="x_axis")),
                                     "y_axis.h": render(other, "c", RenderOptions(name="y_axis"))},
                          MAIN_C)
    assert out.returncode == 0, out.returncode  # 3/4: a CRC constant the C code disagrees with
    x, y = out.stdout.split("--\n")
    assert x.splitlines() == [b.hex(" ").upper() for b in BLOCKS]
    assert y.splitlines() == [b.hex(" ").upper() for b in other]


# --- detection and errors ------------------------------------------------------------------------
def test_format_table() -> None:
    assert set(FORMATS.names) == {*ALL, "hex"}
    with pytest.raises(FormatError, match="format"):
        render(BLOCKS, "srec")
    with pytest.raises(FormatError, match="no blocks"):
        render([], "text")
    with pytest.raises(DecodeError, match="empty"):
        render([b""], "text")
    assert FORMATS.for_path("a.upload.hex") is FORMATS.get("text")  # .hex stays spaced text
    assert FORMATS.for_path("a.ihex") is FORMATS.get("ihex")
    assert FORMATS.for_path("a.h") is FORMATS.get("c")
    assert FORMATS.for_path("a.weird") is None


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
    (b'{"blocks": ["02 03 01 00 03"], "crc32": 5}', "corrupted.*crc32"),
    (b"{not json", "not valid JSON"),
    (b"\x40\xff\xfe", "not a PPMC-312 upload file"),
    (b"02 03 01 00 03\n# crc32 00000000\n", "corrupted: the crc32 comment says CRC-32 0000"),
    (b"/* x */\nint a;\n", "NAME_block_0"),
    (b"static const uint8_t a_block_1[] = {0x02};\n", "corrupted: a_block_0 is missing"),
    (b"static const uint8_t a_block_0[] = {0x102};\n", "not a byte"),
    (b"WCR 20\nWAR 1F\nDWR 00\nDWR 02\n", "WCR 20"),
    (b"WCR 20\nWAR 00\nDWR 00\n", "32 DWR writes follow; found 1"),
    (b"WCR 20\nWXR 1F\n", "WCR\\|WAR\\|DWR"),
])
def test_parse_errors(data: bytes, words: str) -> None:
    assert_one_line_error(parse_upload, data, words)


@SETTINGS
@given(st.binary(max_size=80))
def test_garbage_never_crashes_the_parsers(data: bytes) -> None:
    for blocks in parsed_in_any_format(parse, data, ALL):
        assert blocks and all(blocks)


# --- integrity: a changed file is never read as a different upload --------------------------
SAMPLE = [
    BLOCKS,
    encode_free_curve(FreeCurveTable(CLOCK, tuple(range(400, 400 + 12 * 7, 7)),
                                     tuple(range(2, 14)), tuple(range(0xFFFFF, 0xFFFF3, -1)))),
    [encode_init(InitTable(CLOCK, "s_curve", 0x2710, 0x190, 0x7D0, 0x3000, 0x900))],
    [encode_serial_init(InitTable(CLOCK, "linear", 0x2710, 0x190, 0x7D0), 3)],
]


# The slowest formats to re-parse flip by flip run in CI only (-m slow).
@pytest.mark.parametrize("fmt", [pytest.param(f, marks=pytest.mark.slow) if f in ("c", "bus")
                                 else f for f in ALL if f != "bin"])
def test_every_single_bit_flip_is_caught(fmt: str) -> None:
    """Flip each bit of each file in turn: the file is refused (corrupted or malformed)
    or reads back as the same blocks (a flip in a comment, a space, a digit's case);
    never as a different upload."""
    caught, same = flip_verdicts(((render(b, fmt, RenderOptions(name="axis")), b)
                                  for b in SAMPLE if fmt in formats_for(b)),
                                 lambda data: parse(data).items)
    assert caught > same / 2  # many flips hit the bytes (C: more hit its comments, syntax)


def test_the_crc_detects_every_single_bit_flip_of_the_payload() -> None:
    for blocks in SAMPLE:
        payload = b"".join(blocks)
        good = crc32(payload)
        assert all(crc32(flipped) != good for flipped in flips(payload))


def test_bin_has_no_check_a_flip_reads_as_another_table() -> None:
    """What the wire (and a bin file) cannot detect: bit 0 of the mode byte turns the
    8 MHz clock into 1 MHz, a legal table 8× slower."""
    data = bytearray(render(BLOCKS, "bin"))
    data[3] ^= 0x01
    table = decode_upload(parse_upload(bytes(data)))
    assert isinstance(table, FreeCurveTable) and table.clock.name == "1MHz"
    assert table.rates == (100, 200, 300)


def test_a_changed_crc_line_is_corrupted_not_absent() -> None:
    text = render(BLOCKS, "text").decode().replace(CRC, "423ABBA1")
    with pytest.raises(CorruptedError, match=r"423ABBA1.*423ABBA0"):
        parse(text.encode())


# --- C headers of several uploads (stepramp sync's axes.h) --------------------------------------
SET = [("x", BLOCKS, "axis x"), ("x_move", [bytes.fromhex("03 08 82 05 00 00 00 00 2E E0")],
                                  "axis x's move"),
       ("y", [encode_init(InitTable(CLOCK, "linear", 0x2710, 0x190, 0x7D0))], "axis y")]


SET_MAIN_C = MAIN_C.replace('#include "x_axis.h"\n#include "y_axis.h"\n#include "x_axis.h"',
                            '#include "axes.h"\n#include "axes.h"').replace(
    "x_axis", "x").replace("X_AXIS", "X").replace("y_axis", "y").replace("Y_AXIS", "Y")


def test_a_set_holds_each_upload_with_its_own_check() -> None:
    text = render_c_set(SET, RenderOptions(name="stepramp_sync"))
    parsed = parse_c_set(text)
    assert list(parsed) == ["x", "x_move", "y"]
    for name, blocks, _ in SET:
        assert parsed[name].items == blocks and parsed[name].integrity == "verified"
        assert f"#define {name.upper()}_CRC32 0x{zlib.crc32(b''.join(blocks)):08X}UL" \
            in text.decode()
    assert text.decode().count("#ifndef") == 1  # one guard for the file
    # the single-upload reader says what it holds instead of reading one of them
    assert_one_line_error(parse, text, "one header holds one upload.*holds 3 \\(x, x_move, y\\)")
    # a changed byte of one upload is caught by that upload's CRC-32
    changed = text.replace(b"static const uint8_t y_block_0[] = {0x03",
                           b"static const uint8_t y_block_0[] = {0x02")
    assert changed != text
    with pytest.raises(CorruptedError, match="Y_CRC32"):
        parse_c_set(changed)


def test_the_single_header_is_the_set_of_one() -> None:
    """`--format c` and a set share the symbols: one renderer (`c_symbols`)."""
    single = render(BLOCKS, "c", RenderOptions(name="x")).decode()
    assert "\n".join(c_symbols(BLOCKS, "x")) in single
    assert "\n".join(c_symbols(BLOCKS, "x")) in render_c_set(SET, RenderOptions()).decode()


@needs_cc
def test_a_set_compiles_and_verifies_each_crc(tmp_path: Path) -> None:
    out = compile_and_run(tmp_path, {"axes.h": render_c_set(SET, RenderOptions(
        name="stepramp_sync"))}, SET_MAIN_C)
    assert out.returncode == 0, out.returncode
    x, y = out.stdout.split("--\n")
    assert x.splitlines() == [b.hex(" ").upper() for b in BLOCKS]
    assert y.splitlines() == [b.hex(" ").upper() for b in SET[2][1]]

"""MC-200 stream files: every format renders (whole or chunk by chunk, the same bytes)
and parses back, carries its check, and a changed file is reported as corrupted."""

from __future__ import annotations

import io
import json
import zlib
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from intelhex import IntelHex

from profiles import mc200 as M
from profiles.errors import CorruptedError, FormatError, StepRampError
from profiles.formats import Provenance, RenderOptions
from profiles.mc200.formats import FORMATS, is_stream_file, parse, render, render_chunks
from tests.support.file_checks import (
    assert_one_line_error,
    compile_and_run,
    flip_verdicts,
    needs_cc,
    parsed_in_any_format,
)

SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


ALL = ("hex", "bin", "json", "c", "ihex")


@st.composite
def host_packets(draw: st.DrawFn, max_size: int = 30) -> list[bytes]:
    """Host packets with any fields (position commands, mode switches, resets)."""
    n = draw(st.integers(1, max_size))
    out = []
    for _ in range(n):
        kind = draw(st.sampled_from(["position", "raw"]))
        value = draw(st.integers(-(2**31), 2**31 - 1) if kind == "position"
                     else st.integers(0, 2**32 - 1))
        out.append(M.HostPacket(draw(st.integers(0, 15)), draw(st.booleans()),
                                draw(st.integers(0, 3)), value, kind, draw(st.booleans()),
                                draw(st.integers(0, 15))).encode())
    return out


def _chunks(packets: list[bytes], sizes: list[int]) -> Iterator[bytes]:
    """The packets in chunks of the given packet counts (cycled), empty chunks included."""
    k = i = 0
    while i < len(packets):
        n = sizes[k % len(sizes)]
        yield b"".join(packets[i:i + n])
        i += n
        k += 1


@SETTINGS
@given(host_packets(), st.sampled_from(ALL), st.integers(0, 0xFFFF_0000),
       st.lists(st.integers(0, 9), min_size=1, max_size=5).filter(any))
def test_every_format_round_trips_whole_and_chunked(packets: list[bytes], fmt: str, base: int,
                                                    sizes: list[int]) -> None:
    options = RenderOptions(name="axis", base_address=base,
                            header={"period_us": 50, "duration_s": 0.5, "pulses": 7})
    data = render(packets, fmt, options)
    # chunk-wise (any chunking, empty chunks too) is the same file, the count known ahead
    assert b"".join(render_chunks(_chunks(packets, sizes), fmt,
                                  replace(options, count=len(packets)))) == data
    parsed = parse(data)  # detected by content
    assert parsed.items == packets
    assert parsed.format == fmt
    assert parsed.integrity == ("none" if fmt == "bin" else "verified")
    assert is_stream_file(data) == all(p[1] == p[2] == 0 for p in packets)


def _stream() -> list[bytes]:
    position_at, duration = M.ruckig_profile(600, 8000.0, 8e4, 8e6)
    data = M.stream_bytes(position_at, duration, 600, period_us=2000)
    return [data[i:i + 12] for i in range(0, len(data), 12)]


PACKETS = _stream()


PAYLOAD = b"".join(PACKETS)


CRC = f"{zlib.crc32(PAYLOAD):08X}"  # zlib's: independent of stepramp's running CRC


def test_hex_is_the_old_text_plus_the_check_line() -> None:
    text = render(PACKETS, "hex").decode()
    assert text == "".join(p.hex(" ").upper() + "\n" for p in PACKETS) + (
        f"# crc32 {CRC}: CRC-32 of the {len(PAYLOAD)} bytes above\n")


def test_json_is_what_json_dumps_writes() -> None:
    header = {"period_us": 2000, "duration_s": 0.25, "pulses": 600}
    data = render(PACKETS, "json", RenderOptions(header=header)).decode()
    assert data == json.dumps({**header, "packets": [p.hex(" ").upper() for p in PACKETS],
                               "crc32": CRC}, indent=1) + "\n"
    bare = json.loads(render(PACKETS, "json"))  # no header: packets and crc32 only
    assert list(bare) == ["packets", "crc32"]


@pytest.mark.parametrize("base", [0, 0x0800_0000, 0xFFF8])
def test_ihex_is_read_by_intelhex(base: int) -> None:
    ih = IntelHex(io.StringIO(render(PACKETS, "ihex", RenderOptions(base_address=base))
                              .decode()))
    assert ih.minaddr() == base and ih.tobinstr(start=base) == PAYLOAD


def test_ihex_streamed_past_the_last_address_fails() -> None:
    from profiles.errors import FieldRangeError

    with pytest.raises(FieldRangeError, match="base address"):
        b"".join(render_chunks(iter([PAYLOAD]), "ihex",
                               RenderOptions(base_address=0xFFFF_FFFF - 100)))


def test_rendering_pulls_chunks_only_as_it_writes() -> None:
    """Memory independent of the stream's length: the renderer asks for the next chunk
    only once it has handed out the file's text for the one before."""
    written = {"pieces": 0}

    def chunks() -> Iterator[bytes]:
        for k in range(200):
            assert k <= written["pieces"] + 1, "the renderer read ahead of its output"
            yield PAYLOAD[:120]

    for fmt in ALL:
        written["pieces"] = 0
        for _ in render_chunks(chunks(), fmt, RenderOptions()):
            written["pieces"] += 1
        assert written["pieces"] >= 200


def test_stream_render_chunks_passes_the_move_and_options() -> None:
    position_at, duration = M.ruckig_profile(600, 8000.0, 8e4, 8e6)
    chunks = M.stream_chunks(position_at, duration, 600, period_us=2000, chunk_packets=7)
    data = b"".join(M.render_chunks(chunks, "c", period_us=2000, duration_s=duration,
                                    pulses=600, options=RenderOptions(name="x")))
    assert parse(data).items == PACKETS and b"static const uint8_t x_packets[][12]" in data
    with pytest.raises(FormatError, match="csv"):
        M.render_chunks(iter([]), "csv", period_us=1, duration_s=1.0, pulses=1)


# --- C --------------------------------------------------------------------------------------
MAIN_C = r"""
#include <stdio.h>
#include "x_axis.h"
#include "y_axis.h"
#include "x_axis.h"

/* The check a firmware runs before it streams: CRC-32 of the packets in order. */
static uint32_t crc32_packets(const uint8_t (*packets)[12], size_t n) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; i++)
    for (size_t k = 0; k < 12; k++) {
      crc ^= packets[i][k];
      for (int b = 0; b < 8; b++) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
  return ~crc;
}

int main(void) {
  if (sizeof x_axis_packets / 12 != X_AXIS_PACKET_COUNT) return 5;
  if (crc32_packets(x_axis_packets, X_AXIS_PACKET_COUNT) != X_AXIS_CRC32) return 3;
  if (crc32_packets(y_axis_packets, Y_AXIS_PACKET_COUNT) != Y_AXIS_CRC32) return 4;
  for (size_t i = 0; i < Y_AXIS_PACKET_COUNT; i++) {
    for (size_t k = 0; k < 12; k++) printf(k ? " %02X" : "%02X", y_axis_packets[i][k]);
    printf("\n");
  }
  return 0;
}
"""


@needs_cc
def test_two_headers_compile_together_and_verify_their_crc(tmp_path: Path) -> None:
    other = [M.HostPacket(1, True, 0, -5, "position").encode(), PACKETS[3]]
    prov = Provenance("stepramp mc200 stream '*/ x' -o x_axis.h", ("profile: µ test",))
    out = compile_and_run(tmp_path, {
        "x_axis.h": render(PACKETS, "c", RenderOptions(name="x_axis", provenance=prov)),
        "y_axis.h": render(other, "c", RenderOptions(name="y_axis"))}, MAIN_C)
    assert out.returncode == 0, out.returncode  # 3/4/5: a constant the C code disagrees with
    assert out.stdout.splitlines() == [p.hex(" ").upper() for p in other]


def test_c_header_names_and_counts() -> None:
    text = render(PACKETS, "c", RenderOptions(name="x_axis")).decode()
    assert "#ifndef X_AXIS_H" in text and f"#define X_AXIS_CRC32 0x{CRC}UL" in text
    assert f"#define X_AXIS_PACKET_COUNT {len(PACKETS)}" in text
    wrong = text.replace(f"X_AXIS_PACKET_COUNT {len(PACKETS)}",
                         f"X_AXIS_PACKET_COUNT {len(PACKETS) + 1}")
    with pytest.raises(CorruptedError, match="PACKET_COUNT"):
        parse(wrong.encode())
    with pytest.raises(FormatError, match="--name"):
        render(PACKETS, "c", RenderOptions(name="int"))


def test_c_array_size_when_the_count_is_known_ahead() -> None:
    whole = render(PACKETS, "c", RenderOptions(name="x")).decode()
    assert (f"#define X_PACKET_COUNT {len(PACKETS)}\n"
            "static const uint8_t x_packets[X_PACKET_COUNT][12] = {") in whole
    streamed = b"".join(render_chunks(iter([PAYLOAD]), "c", RenderOptions(name="x"))).decode()
    assert "x_packets[][12] = {" in streamed and f"X_PACKET_COUNT {len(PACKETS)}" in streamed
    assert parse(whole.encode()).items == parse(streamed.encode()).items == PACKETS
    with pytest.raises(FormatError, match=f"{len(PACKETS)} packets, 5 were announced"):
        b"".join(render_chunks(iter([PAYLOAD]), "c", RenderOptions(count=5)))


# --- detection and errors ---------------------------------------------------------------------
def test_format_table() -> None:
    assert set(FORMATS.names) == {*ALL, "text"}
    assert FORMATS.get("text") is FORMATS.get("hex")
    assert FORMATS.for_path("a.mc200.hex") is FORMATS.get("hex")
    assert FORMATS.for_path("a.h") is FORMATS.get("c")
    with pytest.raises(FormatError, match="no packets"):
        render([], "hex")
    with pytest.raises(FormatError, match="packet 0: expected 12 bytes"):
        render([b"\x00" * 11], "hex")
    with pytest.raises(FormatError, match="not whole"):
        b"".join(render_chunks(iter([b"\x00" * 13]), "bin"))
    with pytest.raises(FormatError, match="no packets"):
        b"".join(render_chunks(iter([b""]), "json"))


@pytest.mark.parametrize(("data", "words"), [
    (b"", "empty"),
    (b"# only a comment\n", "no packets"),
    (b"08 00 00 00 00 00 00 00 00 00 08\n", "line 1: 11 bytes"),
    (b"08 00 00 00 00 00 00 00 00 00 08 8G\n", "line 1, column 35: 'G'"),
    (M.servo_on(0)[0].encode() + b"\x08", "block 1, byte 1: 13 bytes is not a whole number"),
    (b'{"packets": ["08 00"]}', "packets\\[0\\]: 2 bytes"),
    (b'{"packets": [5]}', "packets\\[0\\]: expected a hex string"),
    (b'{"packets": [], "speed": 1}', "JSON stream is"),
    (b'{"packets": ["08 00 00 00 00 00 00 00 00 00 08 80"], "crc32": 7}', "corrupted.*crc32"),
    (b"08 00 00 00 00 00 00 00 00 00 08 80\n# crc32 00000000\n",
     "corrupted: the crc32 comment says CRC-32 00000000"),
    (b"/* x */\nint a;\n", "NAME_packets"),
    (b"static const uint8_t a_packets[][12] = {\n {0x08},\n};\n", "a_packets\\[0\\]: 1 values"),
    (b"static const uint8_t a_packets[][12] = {\n {0x08, 0, 0, 0, 0, 0, 0, 0, 0, 0, 8, 0x180}"
     b",\n};\n", "not a byte"),
    (b"static const uint8_t a_packets[][12] = {\n", "truncated"),
])
def test_parse_errors(data: bytes, words: str) -> None:
    assert_one_line_error(parse, data, words)


@SETTINGS
@given(st.binary(max_size=60))
def test_garbage_never_crashes_the_parsers(data: bytes) -> None:
    for packets in parsed_in_any_format(parse, data, ALL):
        assert packets and all(len(p) == 12 for p in packets)
    is_stream_file(data)  # never raises


def test_hand_made_files_without_a_check_are_read_with_integrity_absent() -> None:
    text = "".join(p.hex(" ") + "\n" for p in PACKETS[:4])  # lower case, no crc line
    parsed = parse(text.encode())
    assert parsed.items == PACKETS[:4] and parsed.integrity == "absent"
    doc = json.dumps({"packets": [p.hex() for p in PACKETS[:4]]})
    assert parse(doc.encode()).integrity == "absent"
    c = render(PACKETS[:4], "c").decode()
    c = "\n".join(line for line in c.splitlines() if "_CRC32 0x" not in line)
    assert parse(c.encode()).integrity == "absent"
    assert parse(render(PACKETS[:4], "bin")).integrity == "none"


# --- integrity: a changed file is never read as a different stream ----------------------------
SAMPLE = [PACKETS[:6], PACKETS[-3:], [M.HostPacket(3, False, 1, 0x0F0F0F0F, "raw").encode()]]


# The slowest format to re-parse flip by flip runs in CI only (-m slow).
@pytest.mark.parametrize("fmt", [pytest.param(f, marks=pytest.mark.slow) if f == "c" else f
                                 for f in ALL if f != "bin"])
def test_every_single_bit_flip_is_caught(fmt: str) -> None:
    """Flip each bit of each file: refused (corrupted or malformed) or read back as the
    same packets (a flip in a comment, a space, a digit's case); never other packets."""
    caught, same = flip_verdicts(((render(p, fmt, RenderOptions(name="axis")), p)
                                  for p in SAMPLE), lambda data: parse(data).items)
    assert caught > same / 2


def test_the_crc_sees_what_the_packet_checksum_cannot() -> None:
    """Bit 7 of byte 3 passes the packet checksum (position ±128): bin reads it as
    another stream, the hex file's CRC-32 refuses it."""
    flipped = bytearray(PAYLOAD)
    flipped[12 * 40 + 3] ^= 0x80
    assert M.decode_stream(bytes(flipped))[40].value != M.decode_stream(PAYLOAD)[40].value
    text = render(PACKETS, "hex").decode().splitlines()
    text[40] = bytes(flipped[480:492]).hex(" ").upper()
    with pytest.raises(CorruptedError, match=f"says CRC-32 {CRC}"):
        parse(("\n".join(text) + "\n").encode())


def test_ppmc312_files_are_not_streams() -> None:
    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.formats import FORMATS as PPMC
    from profiles.ppmc312.table import FreeCurveTable, InitTable
    from profiles.ppmc312.upload import encode_free_curve, encode_init

    clock = Clock.internal("8MHz")
    for blocks in (encode_free_curve(FreeCurveTable(clock, (100, 200, 300), (10, 20, 30))),
                   [encode_init(InitTable(clock, "linear", 0x2710, 0x190, 0x7D0))]):
        for fmt in PPMC.formats:
            assert not is_stream_file(PPMC.render(blocks, fmt)), fmt


def test_a_stream_is_told_by_its_packets() -> None:
    """Reserved bytes set (the Frame does not read them) with the checksum right, or
    a checksum damaged with the reserved bytes clear: still packets. Both at once, or
    bit 7 of byte 11 clear: not a stream of packets."""
    odd = bytearray(PACKETS[5])
    odd[1] = 0x01
    odd[10:12] = M.checksum(bytes(odd)).to_bytes(2, "little")
    damaged = bytearray(PACKETS[6])
    damaged[10] ^= 0x01
    assert is_stream_file(render([*PACKETS[:5], bytes(odd), bytes(damaged)], "hex"))
    both = bytearray(odd)
    both[10] ^= 0x01
    assert not is_stream_file(render([*PACKETS[:5], bytes(both)], "hex"))
    unmarked = bytearray(PACKETS[5])
    unmarked[11] &= 0x7F
    assert not is_stream_file(render([*PACKETS[:5], bytes(unmarked)], "hex"))


# --- long streams: read a chunk at a time, decoded a chunk at a time -------------------------
def test_parsed_packets_are_a_view_of_the_payload() -> None:
    from profiles.mc200.formats import Packets, payload_of_parsed

    packets = [M.HostPacket(0, True, 0, v, "position").encode() for v in range(5)]
    parsed = parse(render(packets, "bin"))
    items = parsed.items
    assert isinstance(items, Packets) and len(items) == 5
    assert items == packets and list(items) == packets and items[-1] == packets[4]
    assert items[1:3] == packets[1:3] and items != packets[:4] and items != packets[::-1]
    with pytest.raises(IndexError):
        items[5]
    assert payload_of_parsed(parsed) is items.payload == b"".join(packets)


@pytest.mark.parametrize("fmt", ["hex", "ihex"])
def test_long_text_files_are_read_in_chunks_with_true_line_numbers(
        fmt: str, monkeypatch: pytest.MonkeyPatch) -> None:
    import profiles.formats as F

    # chunks of ~100 bytes: a few lines each; the answer must not change, and an error
    # deep in the file names its line
    packets = [M.HostPacket(0, True, 0, v, "position").encode() for v in range(40)]
    data = render(packets, fmt)
    whole = parse(data)
    monkeypatch.setattr(F, "TEXT_CHUNK_BYTES", 100)
    monkeypatch.setattr(F.text_chunks, "__defaults__", (100,))
    assert [len(t) for _, t in F.text_chunks(data)][:3] != [len(data.decode())]
    assert parse(data) == whole
    lines = data.decode().splitlines()
    lines[30] = lines[30][:-2] + "zz"
    with pytest.raises(StepRampError, match="line 31"):
        parse(("\n".join(lines) + "\n").encode(), fmt=fmt)


@pytest.mark.parametrize("fmt", ["json", "c"])
def test_json_and_c_streams_past_16_mib_are_refused_in_one_line(
        fmt: str, monkeypatch: pytest.MonkeyPatch) -> None:
    import profiles.mc200.formats as MF

    packets = [M.HostPacket(0, True, 0, v, "position").encode() for v in range(20)]
    data = render(packets, fmt)
    monkeypatch.setattr(MF, "MAX_INPUT_BYTES", len(data) - 1)  # the cap, made small
    assert is_stream_file(data)  # still told apart, by its head
    with pytest.raises(FormatError, match=rf"a {fmt} stream file of {len(data)} bytes: .*"
                                          "write long streams as hex, bin or ihex"):
        parse(data)


@pytest.mark.parametrize("direction", ["host", "driver"])
def test_decoded_lines_are_the_whole_listing_a_chunk_at_a_time(direction: str) -> None:
    from dataclasses import asdict

    from profiles.reading import json_text

    packets = [M.HostPacket(0, True, 0, 5, "position"),
               M.HostPacket(1, True, 2, M.MAGIC_DEFAULT, "raw"),
               M.HostPacket(1, True, 0, float("nan"), "velocity"),
               M.HostPacket(1, True, 0, 2.5, "velocity")]
    raw = M.encode_stream(packets)
    decoded = M.decode_stream(raw, direction)  # type: ignore[arg-type]
    rows = [asdict(p) for p in decoded]
    for size in (1, 2, 4096):
        listing = "".join(M.decoded_lines(raw, direction, "json",  # type: ignore[arg-type]
                                          rows_per_chunk=size))
        assert listing == json_text({"direction": direction, "packets": rows})
        text = "".join(M.decoded_lines(raw, direction, "text",  # type: ignore[arg-type]
                                       rows_per_chunk=size))
        assert text.splitlines()[1].startswith("     1  driver_id=1 ")
        assert len(text.splitlines()) == 4
    assert len(json.loads(listing)["packets"]) == 4


def test_a_bad_last_packet_stops_the_listing_before_its_first_line() -> None:
    good = M.HostPacket(0, True, 0, 5, "position").encode()
    bad = good[:10] + bytes([good[10] ^ 1]) + good[11:]
    raw = good * 3 + bad
    with pytest.raises(StepRampError, match="block 3"):
        M.decoded_lines(raw, "host")  # raises on the call: nothing was listed
    with pytest.raises(StepRampError, match="block 3"):
        M.decoded_lines(raw, "driver")


def test_decoded_lines_report_their_progress() -> None:
    packets = [M.HostPacket(0, True, 0, v, "position") for v in range(10)]
    raw = M.encode_stream(packets)
    calls: list[tuple[int, int]] = []
    lines = M.decoded_lines(raw, "host", rows_per_chunk=4,
                            progress=lambda done, total: calls.append((done, total)))
    assert calls == []  # judged, nothing listed yet
    assert len("".join(lines).splitlines()) == 10
    assert calls == [(0, 10), (4, 10), (8, 10), (10, 10)]


@pytest.mark.parametrize("size", [50, 100, 150, 1 << 20])
def test_a_long_intel_hex_stream_is_told_by_its_first_lines(
        size: int, monkeypatch: pytest.MonkeyPatch) -> None:
    import profiles.mc200.formats as MF

    # the head's 16-byte records end inside a 12-byte packet for most sizes: the packets
    # cut off are left out, the whole ones tell
    packets = [M.HostPacket(0, True, 0, v, "position").encode() for v in range(40)]
    data = render(packets, "ihex")
    monkeypatch.setattr(MF, "TEXT_CHUNK_BYTES", size)
    assert is_stream_file(data)
    # the head needs no end record; the file does, when it is parsed
    cut = data[:data.rindex(b":00000001FF")]
    assert is_stream_file(cut)
    with pytest.raises(CorruptedError, match="no end-of-file record"):
        parse(cut)

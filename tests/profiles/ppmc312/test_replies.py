"""The answer handshake of a PPMC-312 upload (manual §7-2, §5-4, §5-8): the answer the
chip gives to every block, carried by every upload file with room for it, read back and
checked against the chip model."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles.errors import CorruptedError, DecodeError, FormatError
from profiles.formats import RenderOptions
from profiles.ppmc312.answer_kinds import BY_KEY
from profiles.ppmc312.answers import (
    Answer,
)
from profiles.ppmc312.ascii import POSITION_REPLY, encode_frame, encode_serial_init
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.emulator import (
    ChipEmulator,
    accept_upload,
    chip_answers,
    expected_answers,
)
from profiles.ppmc312.formats import (
    parse,
    parse_c_set,
    parse_handshake,
    render,
    render_c_set,
)
from profiles.ppmc312.replies import (
    REPLY_KINDS,
    REPLY_TO,
    decode_replies,
    decode_reply,
    encode_reply,
)
from profiles.ppmc312.table import FreeCurveTable, InitTable
from profiles.ppmc312.upload import (
    encode_free_curve,
    encode_init,
    encode_move,
    encode_table_read_response,
)
from tests.support.file_checks import compile_and_run, needs_cc
from tests.support.strategies import accepted_tables, answer_fields

SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


CLOCK = Clock.internal("8MHz")


WITH_ANSWERS = ("text", "json", "c", "bus")


ALL = (*WITH_ANSWERS, "bin", "ihex")


def answers_by_hand(table: FreeCurveTable, blocks: list[bytes]) -> list[bytes]:
    """§7-2 from the table alone: after each block, the section being written and the
    stages it still needs; after the last, 0F and the two totals."""
    counts = [len(table.rates), len(table.accel_pulses)] + (
        [len(table.decel_pulses)] if table.decel_pulses is not None else [])
    sizes = (2, 3, 3)
    out = [bytes([0x03, 0x03, 0x01, 0x00, counts[0]])]
    section, sent = 0, 0
    for block in blocks[1:-1]:
        sent += (len(block) - 2) // sizes[section]
        if sent == counts[section]:
            section, sent = section + 1, 0
        out.append(bytes([0x03, 0x03, 0x01, section, counts[section] - sent]))
    totals = table.accel_total.to_bytes(3, "big") + table.decel_total.to_bytes(3, "big")
    return [*out, bytes([0x03, 0x08, 0x01, 0x0F]) + totals]


# --- what the chip answers -------------------------------------------------------------------
@SETTINGS
@given(st.data(), st.booleans(), st.integers(3, 30))
def test_expected_answers_are_the_chips_for_both_layouts(data: st.DataObject, le: bool,
                                                          max_data: int) -> None:
    table = data.draw(accepted_tables(separate=le))
    blocks = encode_free_curve(table, max_data=max_data)
    answers = expected_answers(blocks)
    assert answers is not None and len(answers) == len(blocks)
    assert answers == answers_by_hand(table, blocks)
    chip = ChipEmulator()
    assert [chip.feed(b) for b in blocks] == answers == chip_answers(blocks)
    assert answers[-1][4:] == (sum(table.accel_pulses).to_bytes(3, "big")
                               + sum(table.decel).to_bytes(3, "big"))


def test_expected_answers_by_hand() -> None:
    """LE=1, 3 rates, 2 accel and 3 decel counts in blocks of 4 data bytes."""
    table = FreeCurveTable(CLOCK, (100, 200, 300), (500, 400), (300, 300, 200))
    assert [a.hex(" ") for a in expected_answers(encode_free_curve(table, max_data=4)) or []] \
        == ["03 03 01 00 03", "03 03 01 00 01", "03 03 01 01 02", "03 03 01 01 01",
            "03 03 01 02 03", "03 03 01 02 02", "03 03 01 02 01",
            "03 08 01 0f 00 03 84 00 03 20"]
    init = [encode_init(InitTable(CLOCK, "linear", 0x2710, 0x190, 0x7D0))]
    assert expected_answers(init) == [bytes.fromhex("03 01 00")]


@pytest.mark.parametrize("blocks", [
    [encode_move(1000)],                                                  # a move
    encode_table_read_response(FreeCurveTable(CLOCK, (100, 200), (10, 20))),  # a capture
    [encode_serial_init(InitTable(CLOCK, "linear", 0x2710, 0x190, 0x7D0), 3)],  # ASCII
    encode_free_curve(FreeCurveTable(CLOCK, (1, 200), (10, 20))),         # refused: rate 1
    encode_free_curve(FreeCurveTable(CLOCK, (100, 200), (10, 20)))[:-1],  # cut short
    [encode_init(InitTable(CLOCK, "linear", 0x2710, 0x190, 0x7D0)), encode_move(5)],
])
def test_no_expected_answers_but_for_an_accepted_table_upload(blocks: list[bytes]) -> None:
    assert expected_answers(blocks) is None
    for fmt in ("text", "json") + (("bus", "c") if blocks[0][0] < 0x80 else ()):
        data = render(blocks, fmt, RenderOptions(name="x"))
        assert b"answer" not in data.lower()
        assert parse_handshake(data) == (parse(data), None)


def test_a_refused_upload_is_answered_with_its_error_then_f1() -> None:
    blocks = encode_free_curve(FreeCurveTable(CLOCK, (1, 200), (10, 20)))
    assert not accept_upload(blocks).ok
    answers = chip_answers(blocks) or []
    assert [a.hex(" ") for a in answers] == [
        "03 03 01 00 02",             # the command block is taken
        "03 03 f0 18 01",             # rate 1: parameter error 18 for command 01
        "03 04 f1 01 01 00"]          # then a parameter block out of sequence: F1 01, INI


# --- every format carries them ------------------------------------------------------------------
@SETTINGS
@given(accepted_tables(), st.sampled_from(ALL), st.integers(3, 30))
def test_every_format_round_trips_its_answers(table: FreeCurveTable, fmt: str,
                                              max_data: int) -> None:
    blocks = encode_free_curve(table, max_data=max_data)
    data = render(blocks, fmt, RenderOptions(name="axis"))
    parsed, answers = parse_handshake(data)
    assert parsed.items == blocks and parsed.format == fmt
    assert answers == (expected_answers(blocks) if fmt in WITH_ANSWERS else None)
    if fmt in WITH_ANSWERS:
        assert "expected answers agree with the chip model" in parsed.detail


BLOCKS = encode_free_curve(FreeCurveTable(CLOCK, (100, 200, 300), (10, 20, 30)), max_data=4)


def test_a_json_file_with_a_wrong_answer_is_refused() -> None:
    doc = json.loads(render(BLOCKS, "json"))
    doc["answers"][2] = "03 03 01 01 02"  # the chip says 3 accel counts are due, not 2
    with pytest.raises(CorruptedError, match=r"answers\[2\]: the file expects the answer "
                                             r"03 03 01 01 02 to block 2, the chip answers "
                                             r"03 03 01 01 03"):
        parse(json.dumps(doc).encode())
    doc["answers"] = doc["answers"][:-1]
    with pytest.raises(CorruptedError, match="5 expected answers for 6 blocks"):
        parse(json.dumps(doc).encode())
    doc["answers"] = []
    with pytest.raises(CorruptedError, match="answers: the list is empty"):
        parse(json.dumps(doc).encode())
    doc["answers"] = "03 03 01 00 03"
    with pytest.raises(FormatError, match="answers: expected a list"):
        parse(json.dumps(doc).encode())


def test_a_text_file_with_a_changed_or_missing_answer_is_refused() -> None:
    text = render(BLOCKS, "text").decode()
    with pytest.raises(CorruptedError, match="line 6: the file expects the answer "
                                             "03 03 01 01 04 to block 2"):
        parse(text.replace("# answer: 03 03 01 01 03", "# answer: 03 03 01 01 04").encode())
    with pytest.raises(CorruptedError, match="block 2 has no expected answer"):
        parse(text.replace("# answer: 03 03 01 01 03\n", "").encode())
    with pytest.raises(DecodeError, match="line 3: an answer line follows its block's line"):
        parse(text.replace("00 04 00 64 00 C8\n", "").encode())
    # a file written before the handshake reads as it did
    old = "".join(line for line in text.splitlines(keepends=True) if "answer" not in line)
    parsed, answers = parse_handshake(old.encode())
    assert parsed.items == BLOCKS and parsed.integrity == "verified" and answers is None


def test_a_c_header_with_a_changed_answer_is_refused() -> None:
    text = render(BLOCKS, "c", RenderOptions(name="x")).decode()
    changed = text.replace("x_answer_5[] = {0x03, 0x08, 0x01, 0x0F, 0x00, 0x00, 0x3C",
                           "x_answer_5[] = {0x03, 0x08, 0x01, 0x0F, 0x00, 0x00, 0x3D")
    assert changed != text
    with pytest.raises(CorruptedError, match="x_answer_5: the file expects"):
        parse(changed.encode())
    missing = re.sub(r"static const uint8_t x_answer_3\[\] = \{[^}]*\};\n", "", text)
    with pytest.raises(CorruptedError, match="block 3 has no expected answer"):
        parse(missing.encode())
    extra = text.replace("static const uint8_t *const x_answers",
                         "static const uint8_t x_answer_6[] = {0x03};\n"
                         "static const uint8_t *const x_answers")
    with pytest.raises(CorruptedError, match="7 expected answers for 6 blocks"):
        parse(extra.encode())


def test_a_set_checks_each_uploads_answers() -> None:
    move = [encode_move(12000)]
    init = [encode_init(InitTable(CLOCK, "linear", 0x2710, 0x190, 0x7D0))]
    text = render_c_set([("x", BLOCKS, "axis x"), ("x_move", move, "its move"),
                         ("y", init, "axis y")], RenderOptions(name="axes"))
    assert b"x_answer_0[]" in text and b"y_answer_0[] = {0x03, 0x01, 0x00};" in text
    assert b"x_move_answer" not in text  # a move has no expected answer
    assert b"compare them with NAME_answers[i]" in text
    assert {n: list(p.items) for n, p in parse_c_set(text).items()} == {
        "x": BLOCKS, "x_move": move, "y": init}
    with pytest.raises(CorruptedError, match="y_answer_0"):
        parse_c_set(text.replace(b"y_answer_0[] = {0x03, 0x01, 0x00}",
                                 b"y_answer_0[] = {0x03, 0x01, 0x01}"))


def test_the_c_comment_gives_the_read_procedure() -> None:
    comment = render(BLOCKS, "c", RenderOptions(name="x")).decode().split("*/")[0]
    for words in ("wait CSR.MREF = 0", "dummy-read RCR", "read RAR",
                  "read 0x40 - RAR bytes from DRR within 3.625 us a byte",
                  "lowest parameter first", "compare them with x_answers[i]",
                  "x_answer_lengths[i]", "alarm F4 01", "wait CSR.MWEF = 0"):
        assert words in comment
    # no answers, no procedure: a move's header
    assert "MREF" not in render([encode_move(5)], "c", RenderOptions(name="m")).decode()


HANDSHAKE_C = r"""
#include <stdio.h>
#include <string.h>
#include "x.h"
#include "y.h"

/* What a host does after each block: read the answer from DRR, lowest parameter first,
   and compare it with the expected one. Here the "chip" answers the expected bytes in
   that order, so the program replays the read and prints what it compared. */
static int replay(const uint8_t *const *answers, const size_t *lengths, size_t n) {
  for (size_t i = 0; i < n; i++) {
    uint8_t got[64];
    size_t size = lengths[i];
    for (size_t k = 0; k < size; k++) got[size - 1 - k] = answers[i][size - 1 - k];
    if (memcmp(got, answers[i], size) != 0) return 1;
    for (size_t k = 0; k < size; k++) printf(k ? " %02X" : "%02X", got[k]);
    printf("\n");
  }
  return 0;
}

int main(void) {
  if (replay(x_answers, x_answer_lengths, X_BLOCK_COUNT)) return 3;
  printf("--\n");
  if (replay(y_answers, y_answer_lengths, Y_BLOCK_COUNT)) return 4;
  return 0;
}
"""


@needs_cc
def test_a_header_with_answers_compiles(tmp_path: Path) -> None:
    table = FreeCurveTable(CLOCK, (100, 200, 300), (500, 400), (300, 300, 200))
    x_blocks = encode_free_curve(table)
    y_blocks = [encode_init(InitTable(CLOCK, "s_curve", 0x2710, 0x190, 0x7D0))]
    out = compile_and_run(tmp_path, {
        "x.h": render(x_blocks, "c", RenderOptions(name="x")),
        "y.h": render(y_blocks, "c", RenderOptions(name="y"))}, HANDSHAKE_C)
    assert out.returncode == 0, out.returncode
    x, y = out.stdout.split("--\n")
    assert x.splitlines() == [a.hex(" ").upper() for a in expected_answers(x_blocks) or []]
    assert y.splitlines() == ["03 01 00"]


def text(a: Answer) -> str:
    return "\n".join(a.describe())


# --- serial replies (§13, §15–19) -----------------------------------------------------------------
@pytest.mark.parametrize("frame, reply_to, name, fields, line", [
    (encode_frame("busy", 3, b""), None, "pulse output in progress (80+a)", {},
     "control 83: busy reply from slave 3"),
    (encode_frame("ready", 3, b""), "command", "ready (90+a): no pulse output, or the "
                                               "command accepted", {}, "ready reply"),
    (encode_frame("data", 3, b"\x38"), None, "pulse output stopped (A0+a)", {"end_code": 0x38},
     "end code 38: normal stop at the commanded position"),
    (encode_frame("data", 3, b"\x31"), "end-status", "end status read reply (A0+a)",
     {"end_code": 0x31}, "end code 31: stopped by the alarm input"),
    (encode_frame("data", 3, bytes.fromhex("00 FF FF FF 38")), None,
     "position read reply (A0+a)", {"counter": 0, "position": 0xFFFFFF38},
     "position 4294967096 (0xFFFFFF38)"),
    (encode_frame("data", 3, b"\x04"), "inputs", "general input reply (A0+a)",
     {"inputs": 4}, "inputs 04: AUXI2 (1)"),
    (encode_frame("data", 3, b"\xff\x00"), None, "control terminal read reply (A0+a)",
     {"pins": 0xFF, "signals": 0}, "signals 00: EVT1 0 (Low), EVT0 0 (Low), RUN 0 (Low)"),
    (encode_frame("data", 3, b"\x00\x02\x00"), None, "status read reply (A0+a)",
     {"operation": 0, "state": 2, "buffers": 0}, "state 02: NOR (normal state)"),
    (encode_frame("ready", 3, b"\x12"), "version", "version read reply (90+a)",
     {"version": 0x12}, "version 18 (0x12)"),
    (encode_frame("ready", 3, b"\x43"), "error-code", "error code read reply (90+a)",
     {"error_code": 0x43}, "error code 43: state error"),
    (encode_frame("data", 3, b"\x43"), "error-code", "error code read reply (90+a)",
     {"error_code": 0x43}, "control A3: data reply"),
    (encode_frame("ready", 3, b"\x00\x07"), None, "error count read reply (90+a)",
     {"error_count": 7}, "error count 7 (0x0007)"),
    (encode_frame("special", 3, b"\x23"), "poll", "special reply (B0+a)", {"code": 0x23},
     "code 23: held execution started (/RUN)"),
    (encode_frame("special", 3, b"\x42"), "position", "special reply (B0+a)", {"code": 0x42},
     "code 42: parameter error"),
])
def test_serial_replies(frame: bytes, reply_to: str | None, name: str,
                        fields: dict[str, Any], line: str) -> None:
    a = decode_reply(frame, reply_to=reply_to)
    assert (a.name, dict(a.fields)) == (name, fields)
    assert a.header["address"] == 3 and a.raw == frame
    assert any(line in shown for shown in a.describe()), text(a)
    assert a.code == (fields["code"] if "code" in fields else None)


@pytest.mark.parametrize("frame, reply_to, message, byte", [
    (encode_frame("ready", 3, b"\x12"), None, "answers version read (§18-4) or error code "
                                              "read (§18-10): say which", 1),
    (encode_frame("data", 3, b"\x12\x34\x56\x78"), None, "a data reply with 4 data byte(s) "
                                                         "is not a reply of §13–19", 1),
    (encode_frame("data", 3, b"\x38"), "position", "a data reply with 1 data byte(s) is not "
                                                   "an answer to position", 1),
    (encode_frame("special", 3, b"\x99"), None, "code 0x99 is none of the manual's", 1),
    (encode_frame("data", 3, b"\x00"), None, "end code 0x00 is none of the manual's", 1),
    (encode_frame("data", 3, b"\x02\x00\x00\x00\x00"), None,
     "counter 0x02 is none of the manual's", 1),
    (encode_frame("data", 3, b"\x38")[:-1] + b"0", None, "checksum mismatch", 3),
    (b"\xd3" + encode_frame("busy", 3, b"")[1:], None, "0xD3 is no control byte", 0),
])
def test_a_bad_reply_is_one_line(frame: bytes, reply_to: str | None, message: str,
                                 byte: int) -> None:
    with pytest.raises(DecodeError) as e:
        decode_reply(frame, reply_to=reply_to)
    assert message in str(e.value) and e.value.byte == byte


def test_the_serial_position_reply_is_the_links_and_42s() -> None:
    # §18-1's data is §10-2's parameters: the reply kind reads ascii.POSITION_REPLY, the
    # frame the link decodes and the emulator writes, field for field 42's (unsigned).
    assert REPLY_KINDS["position"][0].frame is POSITION_REPLY
    assert POSITION_REPLY.fields == BY_KEY["42"].block.fields[3:]
    top = encode_frame("data", 3, POSITION_REPLY.encode(counter=0, position=0xFFFFFFFF))
    assert decode_reply(top, reply_to="position").fields["position"] == 0xFFFFFFFF


def test_serial_replies_back_to_back() -> None:
    capture = encode_reply("busy", 5) + encode_reply("stop report", 5, end_code=0x37)
    assert [a.kind.key for a in decode_replies(capture, reply_to="poll")] == [
        "busy", "stop report"]
    with pytest.raises(DecodeError, match="checksum mismatch") as e:
        decode_replies(capture[:-1] + (b"1" if capture.endswith(b"0") else b"0"))
    assert e.value.block == 1
    with pytest.raises(DecodeError, match="0x31 is no control byte"):
        decode_replies(b"1" + capture)
    with pytest.raises(FormatError, match="reply_to: 'jog' is not one of poll"):
        decode_reply(capture[:3], reply_to="jog")


@st.composite
def reply_and_values(draw: st.DrawFn) -> tuple[str, dict[str, Any], int]:
    key = draw(st.sampled_from(sorted(REPLY_KINDS)))
    kind = REPLY_KINDS[key][0]
    values = draw(answer_fields(kind)) if kind.frame is not None else {}
    return key, values, draw(st.integers(0, 15))


@given(reply_and_values())
def test_every_serial_reply_round_trips(case: tuple[str, dict[str, Any], int]) -> None:
    key, values, address = case
    frame = encode_reply(key, address, **values)
    reply_to = next(to for to, keys in REPLY_TO.items() if key in keys)
    a = decode_reply(frame, reply_to=reply_to)
    assert (a.kind.key, dict(a.fields), a.header["address"]) == (key, values, address)

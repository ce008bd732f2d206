"""Every answer the PPMC-312 gives, decoded: one test per response figure of the manual
(§7–§11, bytes written header first from the figure), the serial replies (§13, §15–19),
a round trip of every kind, and the bytes that are no answer."""

from __future__ import annotations

from typing import Any

import pytest

from profiles.errors import DecodeError, FieldChoiceError, FormatError
from profiles.ppmc312 import frames as F
from profiles.ppmc312.answers import (
    Answer,
    decode_answer,
    decode_answers,
    decode_read_order,
    encode_answer,
)
from tests.support.paths import ROOT


def answer(hexed: str) -> Answer:
    return decode_answer(bytes.fromhex(hexed))


def text(a: Answer) -> str:
    return "\n".join(a.describe())


# --- one test per figure ----------------------------------------------------------------------
# (figure, bytes header first, kind key, fields, a line describe() must hold)
FIGURES: list[tuple[str, str, str, dict[str, Any], str]] = [
    ("§7-1 init", "03 01 00", "00", {}, "init answer (00), manual §7-1"),
    ("§7-2 rates to send", "03 03 01 00 7E", "01 progress", {"status": 0, "remaining": 0x7E},
     "status 00: rate stages still to send"),
    ("§7-2 accel to send", "03 03 01 01 05", "01 progress", {"status": 1, "remaining": 5},
     "stages to send 5"),
    ("§7-2 decel to send", "03 03 01 02 03", "01 progress", {"status": 2, "remaining": 3},
     "status 02: decel stages still to send"),
    ("§7-2 done", "03 08 01 0F 00 05 71 00 05 71", "01 done",
     {"accel_total": 0x571, "decel_total": 0x571}, "accel total 1393 (0x000571)"),
    ("§7-3 in-position setting", "03 01 02", "02", {}, "in-position setting answer (02)"),
    ("§7-3 in-position change", "23 02 E4 01", "E4", {"in_position": 1},
     "in position 01: outside the range"),
    ("§7-4 encoder setting", "03 01 03", "03", {}, "encoder setting answer (03)"),
    ("§7-4 encoder change", "23 02 E3 00", "E3", {"encoder": 0},
     "encoder 00: inside the range"),
    ("§7-5 interlock position", "03 01 04", "04", {}, "interlock position setting answer"),
    ("§7-5 interlock ended", "23 01 E1", "E1", {}, "interlock ended (E1), manual §7-5"),
    ("§7-6 high-speed limit", "03 01 05", "05", {}, "high-speed limit setting answer (05)"),
    ("§7-7 END terminal", "03 02 06 01", "06", {"monitor": 1}, "monitor 01: monitored"),
    ("§8-1 immediate stop", "03 01 80", "80", {}, "immediate stop answer (80)"),
    ("§8-2 decelerate stop", "03 01 81", "81", {}, "decelerate stop answer (81)"),
    ("§8-3 trapezoid", "03 02 82 00", "82", {"status": 0x00},
     "status 00: trapezoid, pulse output started"),
    ("§8-3 triangle held", "03 02 82 11", "82", {"status": 0x11},
     "status 11: triangle, held (waiting for RUN)"),
    ("§8-3 straight decel", "03 02 82 20", "82", {"status": 0x20},
     "status 20: straight triangle (decel), pulse output started"),
    ("§8-3 straight accel held", "03 02 82 41", "82", {"status": 0x41},
     "status 41: straight triangle (accel), held (waiting for RUN)"),
    ("§8-4 constant", "03 02 83 01", "83", {"status": 1},
     "status 01: pulse output held (waiting for RUN)"),
    ("§8-5 single step", "03 01 84", "84", {}, "single step answer (84)"),
    ("§8-6 continuous high", "03 02 85 00", "85", {"status": 0},
     "status 00: pulse output started"),
    ("§8-7 continuous constant", "03 02 86 00", "86", {"status": 0},
     "status 00: pulse output started"),
    ("§8-8 accel speed change", "03 01 87", "87", {}, "speed change by acceleration answer"),
    ("§8-9 immediate speed change", "03 01 88", "88", {}, "immediate speed change answer"),
    ("§8-10 origin search", "03 02 10 00", "10", {"status": 0},
     "constant-speed origin search answer (10)"),
    ("§8-11 origin return", "03 02 11 01", "11", {"status": 1},
     "high-speed origin return answer (11)"),
    ("§9-1 excitation on", "03 01 20", "20", {}, "excitation on answer (20)"),
    ("§9-2 excitation off", "03 01 21", "21", {}, "excitation off answer (21)"),
    ("§9-3 counter clear", "03 01 22", "22", {}, "counter clear answer (22)"),
    ("§9-4 zero clamp", "03 01 23", "23", {}, "zero clamp answer (23)"),
    ("§9-5 alarm clear", "03 01 24", "24", {}, "alarm clear answer (24)"),
    ("§9-6 general input", "03 02 25 81", "25", {"inputs": 0x81},
     "inputs 81: AUXI7 (1), AUXI0 (1)"),
    ("§9-7 general output", "03 01 26", "26", {}, "general output answer (26)"),
    ("§9-8 control terminals", "03 03 27 7F 40", "27", {"pins": 0x7F, "signals": 0x40},
     "pins 7F: /ALM 0 (Low), /END 1 (High), /INDEX 1 (High), /ORG 1 (High), /FHL 1 (High), "
     "/BHL 1 (High), /FL 1 (High), /BL 1 (High)"),
    ("§9-9 mask setting", "03 01 28", "28", {}, "mask setting answer (28)"),
    ("§10-1 first block", "02 0A 41 03 03 02 00 01 2C 00 00 C8", "41",
     {"rate_stages": 3, "accel_stages": 3, "decel_stages": 2, "accel_total": 300,
      "decel_total": 200}, "NEXT 0 (more blocks follow)"),
    ("§10-1 rate block", "00 05 01 01 90 01 F4", "41 rates", {"items": [400, 500]},
     "rates 400, 500"),
    ("§10-1 accel block", "00 07 02 00 00 64 00 00 C8", "41 accel", {"items": [100, 200]},
     "accel pulses 100, 200"),
    ("§10-1 last decel block", "01 04 03 00 00 C8", "41 decel", {"items": [200]},
     "NEXT 1 (the last block)"),
    ("§10-2 / §5-8 position read", "03 06 42 00 12 34 56 78", "42",
     {"counter": 0, "position": 0x12345678}, "position 305419896 (0x12345678)"),
    ("§10-3 position set", "03 01 43", "43", {}, "position set answer (43)"),
    ("§10-4 interlock", "03 02 44 01", "44", {"interlock": 1}, "interlock 01: control started"),
    ("§10-5 version", "03 02 40 13", "40", {"version": 0x13}, "version 19 (0x13)"),
    ("§10-6 sync monitor", "03 02 45 01", "45", {"run_monitor": 1},
     "run monitor 01: RUN not monitored"),
    ("§10-7 event setting", "03 02 49 05", "49", {"status": 5},
     "status 05: nothing registered to delete"),
    ("§10-8 event read", "03 07 47 04 02 82 83 85 86", "47",
     {"registered": 4, "next_number": 2, "codes": [0x82, 0x83, 0x85, 0x86]},
     "registered commands 82 (accel/decel move), 83 (constant-speed move), "
     "85 (continuous high speed), 86 (continuous constant speed)"),
    ("§10-9 status read", "03 04 4D 12 02 52", "4D",
     {"operation": 0x12, "state": 0x02, "buffers": 0x52},
     "buffers 52: EV0E (an event command in event buffer 0), EV0O (an override command on "
     "event buffer 0), CBCNT 2 (override commands in the command buffer)"),
    ("§10-10 reset", "03 01 FF", "FF", {}, "reset answer (FF)"),
    ("§11-2 held move started", "23 01 E2", "E2", {}, "held move started (E2), manual §11-2"),
    ("§11-3 registered", "03 01 E8", "E8", {}, "registered (E8), manual §11-3"),
    ("§11-4 registration failed", "03 02 F7 01", "F7", {"status": 1},
     "status 01: the /EVT0 or /EVT1 named is in use by an event buffer"),
    ("§11-5 size error", "03 02 F6 20", "F6", {"length_written": 0x20},
     "length byte written 32 (0x20)"),
    ("§11-7 state error", "03 04 F1 00 12 82", "F1", {"status": 0, "state": 0x12,
                                                       "command": 0x82},
     "state 12: ALM (alarm state), NOR (normal state)"),
    ("§11-8 limit error", "03 01 F2", "F2", {}, "limit error (F2), manual §11-8"),
    ("§11-9 alarm input", "23 02 F4 00", "F4", {"status": 0}, "status 00: the alarm input"),
    ("§11-10 command error", "03 02 F5 99", "F5", {"command": 0x99},
     "unknown command code 99 (no command code of the manual)"),
    ("§11-11 override aborted", "1B 02 F8 06", "F8", {"status": 6},
     "status 06: a length byte of 0x20 or more"),
    ("§11-12 event aborted", "0B 02 F9 02", "F9", {"status": 2},
     "status 02: a limit signal is input: cannot move"),
    # §11-13's own example: (0x32 EXOR 0x66) AND 0x24 = 0x04
    ("§11-13 general input changed", "23 03 E9 00 04", "E9", {"overwritten": 0, "inputs": 4},
     "inputs 04: AUXI2 (1)"),
]


@pytest.mark.parametrize("hexed, key, fields, line", [f[1:] for f in FIGURES],
                         ids=[f[0] for f in FIGURES])
def test_every_figure_decodes_and_encodes_back(hexed: str, key: str, fields: dict[str, Any],
                                               line: str) -> None:
    a = answer(hexed)
    assert (a.kind.key, dict(a.fields)) == (key, fields)
    assert a.code == (None if key.startswith("41 ") else int(key[:2], 16))
    assert any(line in shown for shown in a.describe()), text(a)
    head = int(hexed[:2], 16)
    assert encode_answer(key, **fields, source=a.header["source"],
                         **({"next": head & 1} if a.code is None else {})) \
        == bytes.fromhex(hexed)


def test_the_manual_s_read_order_example_is_the_position_answer() -> None:
    # §5-8 draws the position answer as the host reads it, lowest parameter first:
    # 78 56 34 12 00 42 06 03; header first it is 03 06 42 00 12 34 56 78.
    read = bytes.fromhex("78 56 34 12 00 42 06 03")
    a = decode_answer(read[::-1])
    assert decode_read_order(read) == [a]  # as read, pasted as is
    assert a.name == "position read answer (42)"
    assert a.fields == {"counter": 0, "position": 0x12345678}
    assert a.header == {"cmr": 0, "source": "bus", "pal": 1, "next": 1}


STOP_BITS = [("ALS", "stopped by the alarm signal"),
             ("NOS", "normal end at the output stop position"),
             ("ORG", "stopped by the origin input"),
             ("LOW", "stopped at once: at the start of deceleration the pulse rate was below "
                     "the stop rate"),
             ("DEC", "stopped by the decelerate-stop command"),
             ("STP", "stopped by the immediate-stop command"),
             ("DEL", "decelerated to a stop by a limit"),
             ("STL", "stopped at once by a limit")]


@pytest.mark.parametrize("bit", range(8))
def test_e0_names_each_cause_bit(bit: int) -> None:
    # §11-1: ALS NOS ORG LOW DEC STP DEL STL, bit 7 first, each 1 = that cause
    cause = 0x80 >> bit
    a = answer(f"23 06 E0 {cause:02X} 00 00 12 34")
    name, meaning = STOP_BITS[bit]
    assert a.name == "pulse output stopped (E0)" and a.code == 0xE0
    assert a.describe()[2] == f"  cause {cause:02X}: {name} ({meaning})"
    assert a.to_json()["meanings"]["cause"] == [f"{name} ({meaning})"]


def test_e0_of_the_brief_and_several_causes() -> None:
    a = answer("23 06 E0 48 00 00 12 34")
    assert a.describe() == [
        "pulse output stopped (E0), manual §11-1",
        "  header 23: CMR 1 (a report the chip raises itself), from the bus, PAL 1, NEXT 1 "
        "(the last block)",
        "  cause 48: NOS (normal end at the output stop position), DEC (stopped by the "
        "decelerate-stop command)",
        "  position 4660 (0x00001234)"]
    assert answer("23 06 E0 00 00 00 00 00").describe()[2] == "  cause 00: none set"


@pytest.mark.parametrize("hexed, position", [
    ("23 06 E0 40 FF FF FF FF", 0xFFFFFFFF), ("23 06 E0 40 80 00 00 00", 0x80000000),
    ("03 06 42 01 FF FF FF 38", 0xFFFFFF38)])
def test_positions_are_unsigned(hexed: str, position: int) -> None:
    # §2-1.6 / §10-3: the counter runs 0…0xFFFFFFFF; a CCW move past 0 wraps to the top
    a = answer(hexed)
    assert a.fields["position"] == position
    assert f"position {position} (0x{position:08X})" in text(a)


def test_f0_carries_the_command_and_parameters_of_any_length() -> None:
    # §11-6: 「異常と判断された命令とパラメータが返されます」, length 不定
    init = bytes.fromhex("00 10 00 10 00 00 01 00 10 00 00 01 00")  # code 00 + 12 params
    a = decode_answer(bytes([0x03, 2 + len(init), 0xF0, 0x01]) + init)
    assert a.fields == {"error": 0x01, "command": 0x00, "parameters": list(init[1:])}
    assert a.describe()[2:] == ["  error 01: init: a rate is out of range",
                                "  command 00 (init)",
                                "  parameters (12 bytes) 10 00 10 00 00 01 00 10 00 00 01 00"]
    longest = bytes([0x03, 0x3E, 0xF0, 0x23, 0x82]) + bytes(range(59))
    assert len(decode_answer(longest).fields["parameters"]) == 59


def test_the_emulator_s_f0_is_a_valid_f0() -> None:
    # the emulator answers status + command code: a tail of one byte
    a = decode_answer(F.PARAM_ERROR.encode(error=0x19, command=0x01))
    assert a.fields == {"error": 0x19, "command": 0x01, "parameters": []}
    assert a.describe()[2:] == ["  error 19: free curve: a stage pulse count ≤ 1",
                                "  command 01 (free curve)", "  parameters none"]


@pytest.mark.parametrize("status, words", [
    (0, "the alarm input"),
    (1, "a command written twice: the host did not read the answer to the first"),
    (2, "a report raised twice"), (3, "pulse output stopped twice")])
def test_f4_alarm_causes(status: int, words: str) -> None:
    a = answer(f"23 02 F4 {status:02X}")
    assert a.name == "alarm (F4)" and a.header["cmr"] == 1
    assert words in a.describe()[2]


@pytest.mark.parametrize("code", [0x20, 0x21, 0x23, 0x24, 0x25, 0x26, 0x27])
def test_f0_knows_the_move_and_event_error_codes(code: int) -> None:
    a = answer(f"03 03 F0 {code:02X} 82")
    assert a.to_json()["meanings"]["error"] == F.PARAM_ERRORS[code]


def test_answers_from_an_event_or_override_say_so() -> None:
    assert answer("0B 02 82 10").header["source"] == "event"
    assert answer("1B 02 83 00").header["source"] == "override"
    assert answer("2B 06 E0 40 00 00 00 01").header == {"cmr": 1, "source": "event",
                                                         "pal": 1, "next": 1}


def test_a_capture_is_split_by_its_length_bytes() -> None:
    capture = bytes.fromhex("03 02 82 00  23 06 E0 40 00 00 13 88  03 01 00")
    got = decode_answers(capture)
    assert [a.kind.key for a in got] == ["82", "E0", "00"]
    assert got[1].raw == bytes.fromhex("23 06 E0 40 00 00 13 88")


def test_json_of_an_answer() -> None:
    assert answer("03 04 F1 01 01 82").to_json() == {
        "name": "state error (F1)", "key": "F1", "code": 0xF1, "section": "§11-7",
        "bytes": "03 04 F1 01 01 82",
        "header": {"cmr": 0, "source": "bus", "pal": 1, "next": 1},
        "fields": {"status": 1, "state": 1, "command": 0x82},
        "meanings": {"status": "wrong header: data came when a command was due",
                     "state": ["INI (initial state)"], "command": "accel/decel move"}}


# --- what is no answer ------------------------------------------------------------------------
@pytest.mark.parametrize("hexed, message, byte", [
    ("83 01 00", "header 0x83 has bit 7 set: not an answer header", 0),
    ("43 01 00", "header 0x43 has bit 6 set", 0),
    ("07 01 00", "header 0x07 has bit 2 set", 0),
    ("13 01 00", "header 0x13 has RESP = 10, which §5-7.1 says cannot occur", 0),
    ("03 06 42 00 12", "length byte says 6 bytes follow but the block carries 3", 1),
    ("03 01 77", "response code 0x77 is no answer of the manual", 2),
    ("03 02 01 00", "length byte 0x02, the manual's figure (§7-2) gives 0x03 or 0x08", 1),
    ("03 02 F1 00", "length byte 0x02, the manual's figure (§11-7) gives 0x04", 1),
    ("03 02 F0 01", "length byte 0x02, the manual's figure (§11-6) gives 0x03..0x3E", 1),
    ("23 01 00", "header 0x23 has CMR 1, init answer (00)'s figure (§7-1) draws 0", 0),
    ("03 02 F4 01", "header 0x03 has CMR 0, alarm (F4)'s figure (§11-9) draws 1", 0),
    ("03 02 F8 00", "header 0x03 has RESP 00, override aborted (F8)'s figure (§11-11) "
                    "draws 11", 0),
    ("02 01 00", "header 0x02 has NEXT 0, init answer (00)'s figure (§7-1) draws 1", 0),
    ("03 02 82 05", "status 0x05 is none of the manual's (00, 01, 10, 11, 20, 21, 40, 41, "
                    "§8-3)", 3),
    ("23 02 F4 04", "alarm (F4): status = 4 (0x4) is outside 0..3", 3),
    ("03 03 F0 22 00", "error 0x22 is none of the manual's", 3),
    ("00 03 07 00 01", "a PAL=0 block (table read, §10-1) starts with its item kind 01, 02 "
                       "or 03, got 0x07", 2),
    ("00 04 01 00 01 02", "not a whole number of 2-byte items", 5),
    ("03 00", "length byte 0x00: an answer with PAL 1 carries its response code", 1),
    ("03", "an answer is at least a header and a length byte, got 1 byte(s)", 1),
])
def test_what_is_no_answer_is_one_line_naming_the_byte(hexed: str, message: str,
                                                       byte: int) -> None:
    with pytest.raises(DecodeError) as e:
        answer(hexed)
    assert message in str(e.value) and "\n" not in str(e.value)
    assert e.value.byte == byte


@pytest.mark.parametrize("hexed, message, block, byte", [
    ("03 01 00 23 06 E0", "length byte 0x06 says 6 bytes follow, only 1 do", 1, 1),
    ("03 01 00 03", "header 0x03 with no length byte after it", 1, 0),
    ("03 01 00 03 01 77", "response code 0x77", 1, 2),
    ("", "no bytes", None, None),
])
def test_a_bad_capture_names_the_block(hexed: str, message: str, block: int | None,
                                       byte: int | None) -> None:
    with pytest.raises(DecodeError, match=message) as e:
        decode_answers(bytes.fromhex(hexed))
    assert (e.value.block, e.value.byte) == (block, byte)


def test_encoding_refuses_what_no_answer_carries() -> None:
    with pytest.raises(FieldChoiceError, match=r"status: 3 is not one of the allowed"):
        encode_answer("82", status=3)
    with pytest.raises(FormatError, match="source: 'bus' is not one of override"):
        encode_answer("F8", status=0, source="bus")
    with pytest.raises(FormatError, match="no field 'cause'"):
        encode_answer("F4", cause=1, status=1)
    with pytest.raises(FormatError, match="no such answer"):
        encode_answer("ZZ")
    with pytest.raises(FormatError, match="no answer has this response code"):
        encode_answer(0x77)
    assert encode_answer(0x01, accel_total=5, decel_total=6) == bytes.fromhex(
        "03 08 01 0F 00 00 05 00 00 06")
    assert encode_answer(0x01, status=1, remaining=2) == bytes.fromhex("03 03 01 01 02")
    assert encode_answer("pulse output stopped (E0)", cause=1, position=2)[:3] == \
        bytes.fromhex("23 06 E0")


@pytest.mark.parametrize("example", ["free-curve-nema17.json", "init-linear.json",
                                     "free-curve-bad.json"])
def test_every_answer_the_emulator_gives_decodes(example: str) -> None:
    # the chip model's answer to each block of an upload (refusals included) is an answer

    from profiles.ppmc312.emulator import chip_answers
    from profiles.ppmc312.table import load_table
    from profiles.ppmc312.upload import encode_table

    table = load_table(ROOT / "examples" / example)
    answers = chip_answers(encode_table(table))
    assert answers
    decoded = [decode_answer(a) for a in answers]
    assert all(a.header == {"cmr": 0, "source": "bus", "pal": 1, "next": 1} for a in decoded)
    assert decode_answers(b"".join(answers)) == decoded
    assert {a.kind.key for a in decoded} <= {"00", "01 progress", "01 done", "F0", "F1"}

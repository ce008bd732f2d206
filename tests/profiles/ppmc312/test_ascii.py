"""PPMC-312 ASCII serial frames: control byte, checksum, serial init and move."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.errors import DecodeError, FieldRangeError, FormatError, UnsupportedError
from profiles.fields import Frame
from profiles.ppmc312.ascii import (
    KINDS,
    SERIAL_END_STATUS_READ,
    SERIAL_ERROR_CODE_READ,
    SERIAL_ERROR_COUNT_READ,
    SERIAL_POSITION_READ,
    SERIAL_POSITION_SET,
    SERIAL_STOP,
    AsciiFrame,
    checksum,
    decode_frame,
    decode_serial_init,
    decode_serial_move,
    describe_reply,
    encode_frame,
    encode_serial_init,
    encode_serial_move,
)
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.table import InitTable

SETTINGS = settings(max_examples=150, deadline=None)


def test_checksum_manual_example_holds() -> None:
    # §13-4: control 01, data "0102030405" → sum F0 → inverted 0F, bit 7 cleared.
    assert checksum(0x01, b"0102030405") == 0x0F


def test_checksum_manual_second_example_is_an_erratum() -> None:
    printed = b"303031303131323235353636616263646566"
    # Taken as printed, the rule does not give the manual's 1D, whether the string
    # is the characters sent or the hex of the characters sent ("001011225566abcdef").
    assert checksum(0x91, printed) == ~(0x91 + sum(printed)) & 0x7F == 0x34
    assert checksum(0x91, bytes.fromhex(printed.decode())) == 0x3C
    # The printed string has one stray byte ("10"): without it, the 8-byte §15-1
    # layout in lowercase gives exactly 1D, so the rule and the 8-byte table hold.
    assert checksum(0x91, b"0011225566abcdef") == 0x1D
    # We send uppercase, whose checksum differs.
    table = InitTable(Clock.internal("8MHz"), "linear", 0x1122, 0x5566, 0xABCDEF)
    assert encode_serial_init(table, 1) == b"\x910011225566ABCDEF5D"
    # …and a slave sending the manual's lowercase frame is accepted.
    assert decode_serial_init(b"\x910011225566abcdef1D") == table


@SETTINGS
@given(st.sampled_from(list(KINDS)), st.integers(0, 15), st.binary(max_size=20))
def test_frame_round_trip(kind: str, address: int, payload: bytes) -> None:
    frame = encode_frame(kind, address, payload)
    assert frame[0] == 0x80 | KINDS[kind] << 4 | address
    chars = frame[1:-2]
    assert chars == payload.hex().upper().encode()
    assert int(frame[-2:], 16) == checksum(frame[0], chars) <= 0x7F
    slave = kind in ("busy", "ready", "data", "special")
    assert decode_frame(frame, from_slave=slave) == AsciiFrame(kind, address, payload)
    # Either case is accepted (the checksum is over the characters as sent).
    lower = frame[:1] + chars.lower()
    lower += f"{checksum(frame[0], chars.lower()):02x}".encode()
    assert decode_frame(lower, from_slave=slave).payload == payload


def test_control_bytes() -> None:
    assert encode_frame("poll", 3, b"")[0] == 0x83
    assert encode_frame("command", 3, b"")[0] == 0x93
    assert decode_frame(encode_frame("busy", 5, b""), from_slave=True).kind == "busy"
    assert decode_frame(encode_frame("data", 5, b"\x01")).kind == "data"
    assert encode_frame("special", 15, b"")[0] == 0xBF
    with pytest.raises(FieldRangeError, match="address"):
        encode_frame("command", 16, b"")
    with pytest.raises(FormatError, match="kind"):
        encode_frame("shout", 1, b"")


@pytest.mark.parametrize(("frame", "byte", "words"), [
    (b"\x91", 1, "checksum"),
    (b"\x51" + b"0011", 0, "one"),                 # bit 7 clear
    (b"\xd1" + b"0011", 0, "zero"),                # bit 6 set
    (b"\x91" + b"001" + b"00", 4, "whole bytes"),   # odd character count
    (b"\x91" + b"0G" + b"00", 2, "hex"),
    (b"\x91" + b"00" + b"Z0", 3, "hex"),
    # 0x91 + 0x30 + 0x31 = 0xF2 → inverted 0x0D, bit 7 clear.
    (b"\x91" + b"01" + b"00", 3, "expected 0D, got 00"),
])
def test_frame_errors(frame: bytes, byte: int, words: str) -> None:
    with pytest.raises(DecodeError, match=words) as err:
        decode_frame(frame)
    assert err.value.byte == byte
    assert "\n" not in str(err.value)


@SETTINGS
@given(st.binary(max_size=30))
def test_random_bytes_never_crash_decode_frame(data: bytes) -> None:
    try:
        decode_frame(data)
    except DecodeError:
        pass


@SETTINGS
@given(st.sampled_from(["linear", "s_curve"]), st.integers(0, 6), st.integers(0, 0xFFFF),
       st.integers(0, 0xFFFF), st.integers(0, 0xFFFFFF), st.integers(0, 15))
def test_serial_init_round_trip(shape: str, clk: int, start: int, high: int, pulses: int,
                                address: int) -> None:
    clock = Clock.from_code(clk, 3e6)
    table = InitTable(clock, shape, start, high, pulses)  # type: ignore[arg-type]
    frame = encode_serial_init(table, address)
    parsed = decode_frame(frame)
    # 8 data bytes: mode `0000 FO CLK`, start, high, pulses (§15-1 table).
    assert len(parsed.payload) == 8
    assert parsed.payload[0] == (0x08 if shape == "s_curve" else 0) | clk
    assert decode_serial_init(frame, extck_hz=3e6) == table


def test_serial_init_refusals() -> None:
    le1 = InitTable(Clock.internal("8MHz"), "linear", 0x1000, 0x100, 0x200, 0x1000, 0x200)
    with pytest.raises(UnsupportedError, match="LE=1"):
        encode_serial_init(le1, 0)
    falling = InitTable(Clock.extck(1e6, "falling"), "linear", 0x1000, 0x100, 0x200)
    with pytest.raises(UnsupportedError, match="falling"):
        encode_serial_init(falling, 0)
    with pytest.raises(DecodeError, match="clk"):
        decode_serial_init(encode_frame("command", 0, bytes.fromhex("07 1000 0100 000200")),
                           extck_hz=1e6)
    with pytest.raises(DecodeError, match="not a command"):
        decode_serial_init(encode_frame("poll", 0, bytes.fromhex("00 1000 0100 000200")))
    # The manual's 9-byte example frame (an extra 10 byte) is refused, with the
    # offset of the first character past the 8-byte layout's size check.
    with pytest.raises(DecodeError, match="9 bytes, expected 8") as err:
        decode_serial_init(encode_frame("command", 1, bytes.fromhex("001011225566abcdef")))
    assert err.value.byte == 17


@SETTINGS
@given(st.integers(0, 15), st.integers(1, 0xFFFFFFFF), st.booleans(), st.integers(0, 0xFFFF))
def test_serial_move_round_trip(address: int, pulses: int, ccw: bool, high: int) -> None:
    frame = encode_serial_move(address, pulses, ccw=ccw, high_rate=high)
    payload = decode_frame(frame).payload
    # `1 0 DIR 0 0011`: 83 CW, A3 CCW (§16-3), then high rate (2) and pulses (4).
    assert payload[0] == (0xA3 if ccw else 0x83) and len(payload) == 7
    assert decode_serial_move(frame) == {"address": address, "ccw": ccw, "high_rate": high,
                                         "pulses": pulses}


def test_serial_move_refusals() -> None:
    with pytest.raises(FieldRangeError, match="pulses"):
        encode_serial_move(0, 0)
    with pytest.raises(DecodeError, match="low"):
        decode_serial_move(encode_frame("command", 0, bytes.fromhex("84 0000 00000001")))


def test_describe_reply() -> None:
    assert describe_reply(encode_frame("special", 2, b"\x42")) == \
        "slave 2: parameter error (0x42)"
    assert describe_reply(encode_frame("ready", 2, b"")) == "slave 2: ready"
    assert describe_reply(encode_frame("busy", 7, b"")) == "slave 7: busy"
    with pytest.raises(DecodeError, match="one code byte"):
        describe_reply(encode_frame("special", 2, b""))


@pytest.mark.parametrize(("frame", "values", "payload"), [
    (SERIAL_STOP, {}, "80"),                                          # §16-1
    (SERIAL_POSITION_READ, {"encoder": 0}, "42"),                     # §18-1: 0 1 P 0 0010
    (SERIAL_POSITION_READ, {"encoder": 1}, "62"),
    (SERIAL_POSITION_SET, {"encoder": 0, "position": 0x01020304}, "4301020304"),  # §18-2
    (SERIAL_POSITION_SET, {"encoder": 1, "position": 0xFFFFFFFE}, "63FFFFFFFE"),
    (SERIAL_END_STATUS_READ, {}, "40"),                               # §18-6
    (SERIAL_ERROR_CODE_READ, {}, "41"),                               # §18-10
    (SERIAL_ERROR_COUNT_READ, {}, "4C"),                              # §18-11
])
def test_the_link_commands_are_the_manuals_bytes(frame: Frame, values: dict, payload: str
                                                 ) -> None:
    """The command codes of §16–18 as the manual's tables draw them, bit by bit (the
    position high byte first), and back."""
    assert frame.encode(values).hex().upper() == payload
    decoded = frame.decode(bytes.fromhex(payload))
    assert {k: decoded[k] for k in values} == values


def test_the_end_codes_are_the_manuals() -> None:
    """§18-6: why pulse output stopped, 0x31–0x39 (0x35 is not used)."""
    from profiles.ppmc312.ascii import END_CODES

    assert sorted(END_CODES) == [0x31, 0x32, 0x33, 0x34, 0x36, 0x37, 0x38, 0x39]
    assert "normal stop" in END_CODES[0x38] and "immediate-stop" in END_CODES[0x37]
    assert "alarm" in END_CODES[0x31] and "no deceleration" in END_CODES[0x39]


def test_a_special_reply_carries_one_code_byte() -> None:
    """§19: a special reply is the control byte B0 + address and one code byte."""
    from profiles.ppmc312.ascii import SPECIAL_REPLY

    assert SPECIAL_REPLY.size == 1
    assert SPECIAL_REPLY.encode(code=0x42) == b"\x42"
    assert SPECIAL_REPLY.decode(b"\x43")["code"] == 0x43

"""PPMC-312 motion commands (profiles/ppmc312/motion.py): every command's block written
from its figure (manual §8-1…§8-11, §7-6) and its ASCII frame from §16 (§15-5), with
checksums computed here by the §13-4 rule; round trips; bad values refused naming the
field, the value and the range; decode refusing what encode never writes, naming the byte."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.errors import DecodeError, FieldRangeError, FormatError, UnsupportedError
from profiles.ppmc312.ascii import encode_frame, encode_serial_move
from profiles.ppmc312.motion import (
    AT,
    COMMANDS,
    EVENTS,
    NOW,
    SERIAL_BY_CODE,
    decode_command,
    encode_command,
    field_range,
)
from profiles.ppmc312.upload import encode_move
from tests.support.ascii_frames import FIGURES, by_hand, judge

SETTINGS = settings(max_examples=150, deadline=None)


@pytest.mark.parametrize(("name", "params", "block", "serial"), FIGURES)
def test_every_command_is_written_as_its_figure_draws_it(
        name: str, params: dict[str, Any], block: str, serial: str | None) -> None:
    assert encode_command(name, **params) == bytes.fromhex(block)
    if serial is None:
        with pytest.raises(UnsupportedError, match="no serial form"):
            encode_command(name, to="ascii", **params)
        return
    for address in (0, 3, 15):
        assert encode_command(name, to="ascii", address=address, **params) == \
            by_hand(address, serial)


def test_every_command_has_a_figure_test() -> None:
    assert {f[0] for f in FIGURES} == set(COMMANDS)
    codes = {c.code for c in COMMANDS.values()}
    assert codes == {0x80, 0x81, 0x82, 0x83, 0x84, 0x85, 0x86, 0x87, 0x88, 0x10, 0x11, 0x05}


def test_checksums_by_hand() -> None:
    # 0x90 + "80" (0x38 0x30) = 0xF8, inverted 0x07; 0x90 + "4701F4" = 0x1D6 → D6 → 0x29
    assert encode_command("stop", to="ascii") == b"\x908007"
    assert encode_command("high-speed-limit", rate=500, to="ascii") == b"\x904701F429"


def test_accel_is_todays_move() -> None:
    """82 through the registry is exactly encode_move and encode_serial_move."""
    for pulses, ccw, rate, on in ((1, False, 0, None), (0xFFFFFFFF, True, 0xFFFF, "evt1"),
                                  (10_000, False, 300, "evt2")):
        trigger = EVENTS[on] if on else 0
        assert encode_command("accel", pulses=pulses, ccw=ccw, rate=rate, on=on) == \
            encode_move(pulses, ccw=ccw, high_rate=rate, override=on is not None,
                        trigger=trigger)
        if on is None:
            assert encode_command("accel", to="ascii", address=7, pulses=pulses, ccw=ccw,
                                  rate=rate) == encode_serial_move(7, pulses, ccw=ccw,
                                                                   high_rate=rate)


def test_serial_codes_agree_with_the_serial_chips_table() -> None:
    """Two transcriptions of §15/§16 (the emulator's command table and these frames) give
    the same codes and payload sizes."""
    from profiles.ppmc312.serial_chip import COMMANDS as CHIP

    for code, (command, start) in SERIAL_BY_CODE.items():
        size = command.serial[start].size
        matches = [(name, n) for name, mask, value, n in CHIP if code & mask == value]
        assert matches and matches[0][1] == size, (command.name, start, hex(code), matches)
    assert len(SERIAL_BY_CODE) == 35  # 4 + 4 + 2·5 (DIR) + 4 + 4 + 4·2 (DIR, IDX) + 1


# --- round trips --------------------------------------------------------------------
@st.composite
def commands(draw: st.DrawFn, serial: bool = False) -> tuple[str, dict[str, Any]]:
    name = draw(st.sampled_from(sorted(COMMANDS)))
    command = COMMANDS[name]
    params: dict[str, Any] = {}
    if command.rate is not None:
        lo = st.integers(command.rate.lo, 0xFFFF)
        params["rate"] = draw(st.one_of(st.just(0), lo) if command.rate.zero else lo)
    if "pulses" in command.takes:
        params["pulses"] = draw(st.integers(1, 0xFFFFFFFF))
    for flag in ("ccw", "index"):
        if flag in command.takes:
            params[flag] = draw(st.booleans())
    starts = [s for s in (NOW, AT, *EVENTS) if (s in command.serial if serial else
              s == NOW or (s == AT and command.positioned is not None)
              or (s in EVENTS and "on" in command.takes))]
    start = draw(st.sampled_from(starts))
    if "override_at" in command.takes:
        params["override_at"] = None
        if start == AT:
            assert command.positioned is not None
            lo, hi = field_range(command.positioned, "position")
            params["override_at"] = draw(st.integers(lo, hi))
    if "on" in command.takes:
        params["on"] = start if start in EVENTS else None
    return name, params


@SETTINGS
@given(commands())
def test_parallel_round_trip(case: tuple[str, dict[str, Any]]) -> None:
    name, params = case
    block = encode_command(name, **params)
    assert decode_command(block) == {"command": name, **params}
    assert block[0] == 0x03 and block[1] == len(block) - 2 and block[2] == COMMANDS[name].code


@SETTINGS
@given(commands(serial=True), st.integers(0, 15))
def test_ascii_round_trip(case: tuple[str, dict[str, Any]], address: int) -> None:
    name, params = case
    frame = encode_command(name, to="ascii", address=address, **params)
    assert decode_command(frame) == {"command": name, "address": address, **params}
    assert frame[0] == 0x90 + address and frame == by_hand(address, frame[1:-2].decode())


@SETTINGS
@given(st.binary(max_size=14))
def test_decoding_any_bytes_is_a_result_or_one_decode_error(data: bytes) -> None:
    try:
        out = decode_command(data)
    except DecodeError:
        return
    name = out.pop("command")
    assert encode_command(name, **out) == data


# --- refusals -----------------------------------------------------------------------
@pytest.mark.parametrize(("name", "params", "error", "message"), [
    ("change-speed", {"rate": 1}, FieldRangeError,
     "rate: 1 is outside the allowed range 2..65535 (0xFFFF)"),
    ("change-speed", {"rate": 0}, FieldRangeError,
     "rate: 0 is outside the allowed range 2..65535 (0xFFFF)"),
    ("origin-search", {"rate": 0}, FieldRangeError, "rate: 0 is outside"),
    ("high-speed-limit", {"rate": 0x10000}, FieldRangeError,
     "rate: 65536 (0x10000) is outside the allowed range 2..65535 (0xFFFF)"),
    ("continuous-constant", {"rate": 9}, FieldRangeError,
     "rate: 9 is outside the allowed range 10 (0xA)..65535 (0xFFFF), or 0 (the table's "
     "high rate)"),
    ("accel", {"pulses": 5, "rate": 1}, FieldRangeError,
     "rate: 1 is outside the allowed range 2..65535 (0xFFFF), or 0"),
    ("accel", {"pulses": 0}, FieldRangeError,
     "pulses: 0 is outside the allowed range 1..4294967295 (0xFFFFFFFF)"),
    ("constant", {"pulses": 1 << 32}, FieldRangeError, "pulses: 4294967296"),
    ("set-speed", {"rate": 100, "override_at": 9}, FieldRangeError,
     "position: 9 is outside the allowed range 10 (0xA)..4294967295 (0xFFFFFFFF)"),
    ("stop", {"override_at": -1}, FieldRangeError, "position: -1 is outside the allowed "
                                                   "range 0..4294967295"),
    ("stop", {"rate": 5}, FormatError, "stop (80) takes no rate (it takes on, override_at)"),
    ("step", {"on": "evt1"}, FormatError, "step (84) takes no on"),
    ("accel", {"rate": 5}, FormatError, "accel (82) needs pulses"),
    ("set-speed", {}, FormatError, "set-speed (88) needs rate"),
    ("accel", {"pulses": 5, "on": "evt3"}, FormatError, "on: 'evt3' is not one of evt1, evt2"),
    ("stop", {"on": "evt1", "override_at": 5}, FormatError, "give override_at or on"),
    ("nudge", {}, FormatError, "command: 'nudge' is not one of stop, decel-stop, accel"),
])
def test_bad_values_are_refused_naming_field_value_and_range(
        name: str, params: dict[str, Any], error: type[Exception], message: str) -> None:
    with pytest.raises(error) as caught:
        encode_command(name, **params)
    assert message in str(caught.value)
    assert len(str(caught.value).splitlines()) == 1


def test_serial_refusals() -> None:
    with pytest.raises(FieldRangeError, match=r"address: 16 \(0x10\) is outside"):
        encode_command("stop", to="ascii", address=16)
    for name, params in (("accel", {"pulses": 5, "on": "evt1"}),
                         ("constant", {"pulses": 5, "on": "evt2"}),
                         ("continuous", {"on": "evt1"})):
        with pytest.raises(UnsupportedError, match=r"no serial form started by an event"):
            encode_command(name, to="ascii", **params)
    with pytest.raises(FormatError, match="to: 'serial' is not"):
        encode_command("stop", to="serial")


@pytest.mark.parametrize(("data", "byte", "message"), [
    ("03 02 80 04", 3, "TRG 00 with override (OV = 1) but no position: its block with the "
                       "position has length 06"),
    ("03 06 80 00 00 00 00 05", 3, "an override position with OV 0, TRG 00"),
    ("03 06 81 05 00 00 00 05", 3, "an override position with OV 1, TRG 01"),
    ("03 08 83 04 00 00 00 00 00 01", 3, "cannot be position-triggered (§11-6: 0x21)"),
    ("03 08 82 06 00 00 00 00 00 01", 3, "cannot be position-triggered"),
    ("03 02 80 01", 3, "TRG 01 without override (OV = 0)"),
    ("03 04 86 00 00 05", 4, "rate 5 is outside 0 or 10..65535 (0xA..0xFFFF)"),
    ("03 04 87 00 00 00", 4, "rate 0 is outside 2..65535"),
    ("03 03 05 00 01", 3, "rate 1 is outside 2..65535"),
    ("03 08 88 04 00 02 00 00 00 09", 6, "position = 9 (0x9) is outside 10..4294967295"),
    ("03 08 83 00 00 00 00 00 00 00", 6, "pulses = 0 (0x0) is outside 1..4294967295"),
    ("03 03 80 00 00", 1, "length byte 03; its blocks have length 02 or 06"),
    ("02 02 80 00", 0, "header 02; a motion command is one block that executes"),
    ("03 02 99 00", 2, "code 99: not a motion command block"),
    ("03 09 00 00", 2, "code 00: not a motion command block"),
    ("03 02 84 80", 3, "mode has unexpected bits set: 0x80"),
    ("03 04 10 02 00 02", 3, "mode has unexpected bits set: 0x2"),
    ("03", 1, "no command code"),
])
def test_decode_refuses_what_encode_never_writes_naming_the_byte(
        data: str, byte: int, message: str) -> None:
    with pytest.raises(DecodeError) as caught:
        decode_command(bytes.fromhex(data))
    assert caught.value.byte == byte, str(caught.value)
    assert message in str(caught.value)


def test_decode_refuses_bad_frames_naming_the_character() -> None:
    good = by_hand(2, "8D 0002 0000000A")
    with pytest.raises(DecodeError, match="checksum mismatch"):
        decode_command(good[:-1] + b"0")
    with pytest.raises(DecodeError, match="serial code 0x99 is not a motion command") as e:
        decode_command(by_hand(2, "99"))
    assert e.value.byte == 1
    with pytest.raises(DecodeError, match="position = 9") as e:  # payload byte 3: char 7
        decode_command(by_hand(2, "8D 0002 00000009"))
    assert e.value.byte == 7
    with pytest.raises(DecodeError, match="is 2 bytes, expected 3") as e:
        decode_command(by_hand(2, "88 00"))
    with pytest.raises(DecodeError, match="a poll frame"):
        decode_command(encode_frame("poll", 2, b""))
    with pytest.raises(DecodeError, match="expected a block of bytes"):
        decode_command("03 02 80 00")  # type: ignore[arg-type]


def test_a_file_of_commands_is_described_and_the_table_it_needs_named(tmp_path: Path
                                                                      ) -> None:
    blocks = [encode_command("continuous", rate=0, ccw=True),
              encode_command("change-speed", rate=200, override_at=10_000),
              encode_command("decel-stop", on="evt2"),
              encode_command("origin-search", rate=4000, index=True),
              encode_command("high-speed-limit", rate=500),
              encode_command("accel", pulses=16, rate=300)]
    result = judge(tmp_path, blocks)
    assert result.ok and result.findings == []
    assert result.notes == [
        "continuous (85): CCW at the table's high rate, at once",
        "change-speed (87): at rate 200, when the position counter reaches 10000 (OV, TRG 00)",
        "decel-stop (81): held until event input 2 goes low (OV, TRG 11)",
        "origin-search (10): CW on /ORG and /INDEX at rate 4000",
        "high-speed-limit (05): at rate 500",
        "move: 16 pulses CW at high-rate override 300, at once",
        "change-speed (87) rate 200: the chip refuses it (0x20) unless it lies within the "
        "rates of the table it holds; check that table",
        "origin-search (10) rate 4000: the chip refuses it (0x20) unless it lies between the "
        "table's high rate and the faster of its start and stop rates; check that table",
        "high-rate override 300: the chip refuses it (0x20) unless it lies within the rates "
        "of the table it holds; check that table",
    ]
    serial = judge(tmp_path, [encode_command("stop", to="ascii", on="evt1"),
                              encode_command("set-speed", to="ascii", rate=9, override_at=99)])
    assert serial.notes[:2] == ["stop (80): held until event input 1 goes low",
                                "set-speed (88): at rate 9, when the position counter "
                                "reaches 99"]

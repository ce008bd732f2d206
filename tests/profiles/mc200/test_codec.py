"""MC-200 SPI packets: checksum example, codecs, sequences through the driver model, streaming."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import mc200 as M
from profiles.errors import DecodeError, FieldRangeError, FormatError
from profiles.motor import load_motor
from tests.support.paths import ROOT

EXAMPLE = bytes([0x08, 0x00, 0x00, 0x80, 0x00, 0x80, 0x3F, 0x00, 0x00, 0x00])


def test_checksum_worked_example() -> None:
    words = struct.unpack("<5H", EXAMPLE)
    assert sum(words) == 0x10047  # the manual's step 1
    assert M.checksum(EXAMPLE) == 0x8047
    packet = EXAMPLE + bytes([0x47, 0x80])
    as_velocity = M.HostPacket.decode(packet, mode="velocity")
    assert as_velocity.servo and as_velocity.mode_switch == 0 and as_velocity.driver_id == 0
    # bytes 3–6 are 80 00 80 3F = 0x3F800080: 1.0000153, not 1.0
    assert as_velocity.value == struct.unpack("<f", bytes([0x80, 0x00, 0x80, 0x3F]))[0]
    assert as_velocity.value == pytest.approx(1 + 2**-16)
    assert as_velocity.encode() == packet
    assert M.HostPacket.decode(packet).value == 0x3F800080  # as a position: 1065353344
    # 1.0 exactly gives the same checksum: bit 7 of an odd byte is invisible to it
    one = M.HostPacket(servo=True, value=1.0, value_kind="velocity").encode()
    assert one[3:7] == bytes([0, 0, 0x80, 0x3F]) and one[10:] == bytes([0x47, 0x80])


def test_checksum_error_names_byte_10_and_field_errors_their_byte() -> None:
    good = M.HostPacket(driver_id=3, servo=True, value=1234).encode()
    bad = bytearray(good)
    bad[4] ^= 0x01
    with pytest.raises(DecodeError, match="byte 10"):
        M.HostPacket.decode(bytes(bad))
    bad = bytearray(good)
    bad[0] |= 0x07  # mode-switch field 7 (allowed 0..3)
    with pytest.raises(DecodeError, match="byte 0"):
        M.HostPacket.decode(bytes(bad))
    bad = bytearray(good)
    bad[7] |= 0x80  # a reserved bit of byte 7
    with pytest.raises(DecodeError, match="byte 7"):
        M.HostPacket.decode(bytes(bad))
    with pytest.raises(DecodeError, match="11 bytes"):
        M.HostPacket.decode(good[:11])
    answer = M.DriverPacket(encoder_pulses=5).encode()
    bad = bytearray(answer)
    bad[9] |= 0x10
    with pytest.raises(DecodeError, match="byte 9"):
        M.DriverPacket.decode(bytes(bad))


def test_encode_refuses_bad_fields() -> None:
    with pytest.raises(FieldRangeError, match="driver_id"):
        M.HostPacket(driver_id=16).encode()
    with pytest.raises(FieldRangeError, match="value"):
        M.HostPacket(value=1 << 31).encode()
    with pytest.raises(FieldRangeError, match="value"):
        M.HostPacket(value=1.5).encode()  # a position is an integer
    with pytest.raises(FieldRangeError, match="din"):
        M.HostPacket(din=16).encode()
    with pytest.raises(FormatError, match="value_kind"):
        M.HostPacket(value_kind="torque").encode()  # type: ignore[arg-type]
    with pytest.raises(FieldRangeError, match="mode"):
        M.DriverPacket(mode=4).encode()


_f32 = st.floats(width=32, allow_nan=False)


@st.composite
def host_packets(draw: st.DrawFn) -> M.HostPacket:
    kind = draw(st.sampled_from(["position", "velocity", "current"]))
    value = draw(st.integers(-(1 << 31), (1 << 31) - 1) if kind == "position" else _f32)
    return M.HostPacket(draw(st.integers(0, 15)), draw(st.booleans()), 0, value, kind,
                        draw(st.booleans()), draw(st.integers(0, 15)))


@settings(max_examples=200, deadline=None)
@given(packet=host_packets())
def test_host_round_trip(packet: M.HostPacket) -> None:
    data = packet.encode()
    assert len(data) == 12 and data[11] & 0x80
    assert data[1:3] == b"\0\0" and data[8:10] == b"\0\0"
    mode = "position" if packet.value_kind == "position" else packet.value_kind
    assert M.HostPacket.decode(data, mode=mode) == packet  # type: ignore[arg-type]


@settings(max_examples=200, deadline=None)
@given(driver_id=st.integers(0, 15), flags=st.lists(st.booleans(), min_size=5, max_size=5),
       enc=st.integers(-(1 << 31), (1 << 31) - 1), cur=_f32, mode=st.integers(0, 3))
def test_driver_round_trip(driver_id: int, flags: list[bool], enc: int, cur: float,
                           mode: int) -> None:
    p = M.DriverPacket(driver_id, flags[0], flags[1], flags[2], flags[3], enc, cur, flags[4],
                       mode)
    data = p.encode()
    assert data[0] >> 4 == driver_id and data[9] & 0x07 == mode
    assert M.DriverPacket.decode(data) == p


@pytest.mark.parametrize("mode", ["velocity", "current", "position"])
def test_mode_switch_then_commands(mode: M.Mode) -> None:
    model = M.DriverModel(mode="position")
    model.feed(M.servo_on(1) + M.mode_switch(1, mode))
    state = model.state
    assert state.mode == M.MODE_CODE[mode] and not state.spi_error
    value: int | float = 2.5 if mode != "position" else 777
    model.consume(M.HostPacket(1, True, 0, value, mode))
    assert model.state.command == value and model.state.servo_on


def test_render_and_decode_stream() -> None:
    position_at, duration = M.ruckig_profile(5000, 20000.0, 2e5, 2e7)
    packets = M.servo_on(0) + M.mode_switch(0, "velocity") + [
        M.HostPacket(0, True, 0, 12.5, "velocity")] + M.mode_switch(0, "position") + \
        M.stream_move(position_at, duration, 5000, period_us=1000)[5:]
    text = M.render_hex(packets)
    lines = text.splitlines()
    assert len(lines) == len(packets)
    assert all(len(line) == 35 and line == line.upper() for line in lines)
    assert M.decode_stream(text) == packets
    assert M.decode_stream(text.encode()) == packets
    assert M.decode_stream(M.encode_stream(packets)) == packets
    answers = [M.DriverPacket(1, True, encoder_pulses=k, mode=1) for k in range(3)]
    assert M.decode_stream(M.render_hex(answers), "driver") == answers


def test_decode_stream_errors_name_packet_and_byte() -> None:
    packets = M.servo_on(0)
    data = bytearray(M.encode_stream(packets))
    data[12 + 5] ^= 0x01
    with pytest.raises(DecodeError, match="block 1, byte 10"):
        M.decode_stream(bytes(data))
    with pytest.raises(DecodeError, match="block 2, byte 11"):
        M.decode_stream(M.encode_stream(packets)[:-1])
    text = M.render_hex(packets).replace("08", "G8", 3)
    with pytest.raises(DecodeError, match="block 0, byte 0"):
        M.decode_stream(text)
    with pytest.raises(FormatError, match="direction"):
        M.decode_stream(b"", "both")  # type: ignore[arg-type]


@settings(max_examples=200, deadline=None)
@given(driver_id=st.integers(0, 15), servo=st.booleans(), din=st.integers(0, 15),
       reset=st.booleans(),
       values=st.lists(st.integers(-(1 << 31), (1 << 31) - 1), max_size=20))
def test_encode_positions_equals_frame_encoding(driver_id: int, servo: bool, din: int,
                                                reset: bool, values: list[int]) -> None:
    template = M.HostPacket(driver_id, servo, 0, 0, "position", reset, din)
    got = M.encode_positions(template, np.array(values, dtype=np.int64))
    want = b"".join(M.HostPacket(driver_id, servo, 0, v, "position", reset, din).encode()
                    for v in values)
    assert got == want


def test_encode_positions_refuses_what_the_frame_refuses() -> None:
    template = M.HostPacket(0, True, 0, 0, "position")
    with pytest.raises(FieldRangeError, match="value"):
        M.encode_positions(template, np.array([0, 1 << 31]))
    with pytest.raises(FormatError, match="integers"):
        M.encode_positions(template, np.array([0.5]))
    with pytest.raises(FormatError, match="position command"):
        M.encode_positions(M.HostPacket(0, True, 0, 1.0, "velocity"), np.array([1]))


def test_the_mode_switch_magics_are_the_manuals() -> None:
    """SPEC §3: bytes 3–6 of a mode switch are 0F0F0F0F (the position and current pages);
    the velocity page prints F0F0F0F0 (an open question: both are offered)."""
    assert (M.MAGIC_DEFAULT, M.MAGIC_VELOCITY_PAGE) == (0x0F0F0F0F, 0xF0F0F0F0)


def test_a_command_value_is_bytes_3_to_6_little_endian() -> None:
    """The raw value a host packet carries: the int32 position −2 is FE FF FF FF there,
    read back as the unsigned 0xFFFFFFFE; a magic reads as itself."""
    p = M.HostPacket(driver_id=3, servo=True, value=-2)
    assert p.encode()[3:7] == b"\xfe\xff\xff\xff" and p.raw_value == 0xFFFFFFFE
    assert M.HostPacket(value=0x01020304).raw_value == 0x01020304


def test_packets_default_to_driver_0() -> None:
    """A packet built without a driver ID addresses driver 0 (a single driver's bus)."""
    assert M.HostPacket().driver_id == 0 and M.DriverPacket().driver_id == 0
    assert M.HostPacket().encode()[0] >> 4 == 0


MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


POSITION_AT, DURATION = M.ruckig_profile(3200, 20000.0, 2e5, 5e6)


def _words(packet: bytes) -> int:
    """The sheet's checksum step ①: bytes 0–9 as five 16-bit little-endian words, summed."""
    return sum(struct.unpack("<5H", packet[:10]))


# --- packets from the sheet's figures, by hand ----------------------------------------------------
def test_a_velocity_command_by_hand() -> None:
    """Velocity page, host → driver: byte 0 driver ID 2 (bits 7–4) | servo (bit 3) | no
    switch; bytes 3–6 指令速度 float32 LE, 1000.0 = 0x447A0000; byte 7 DIN 0b0101.
    Words 0x0028 + 0x0000 + 0x7A00 + 0x0544 + 0 = 0x7F6C → low 15 bits | 0x8000 = 0xFF6C."""
    want = bytes([0x28, 0, 0, 0x00, 0x00, 0x7A, 0x44, 0x05, 0, 0, 0x6C, 0xFF])
    assert _words(want) == 0x7F6C
    packet = M.HostPacket(2, True, 0, 1000.0, "velocity", False, 0b0101)
    assert packet.encode() == want
    assert M.HostPacket.decode(want, mode="velocity") == packet


def test_a_negative_velocity_to_driver_15_with_every_din_by_hand() -> None:
    """−250.0 pps = 0xC37A0000; byte 0 0xF8, byte 7 0x0F. Words 0x00F8 + 0 + 0x7A00 +
    0x0FC3 + 0 = 0x8ABB → low 15 bits 0x0ABB | 0x8000 = 0x8ABB."""
    want = bytes([0xF8, 0, 0, 0x00, 0x00, 0x7A, 0xC3, 0x0F, 0, 0, 0xBB, 0x8A])
    assert (_words(want) & 0x7FFF) | 0x8000 == 0x8ABB
    assert M.HostPacket(15, True, 0, -250.0, "velocity", False, 15).encode() == want


def test_a_current_command_with_the_spi_error_reset_by_hand() -> None:
    """Current page: 指令電流値 1.5 A = 0x3FC00000; byte 7 the SPI通信エラーリセット bit (6).
    Words 0x0008 + 0 + 0xC000 + 0x403F + 0 = 0x10047: the sheet's own example's sum, so
    its checksum 47 80."""
    want = bytes([0x08, 0, 0, 0x00, 0x00, 0xC0, 0x3F, 0x40, 0, 0, 0x47, 0x80])
    assert _words(want) == 0x10047
    packet = M.HostPacket(0, True, 0, 1.5, "current", True, 0)
    assert packet.encode() == want
    assert M.HostPacket.decode(want, mode="current") == packet


def test_the_velocity_pages_magic_by_hand() -> None:
    """The velocity page's switch: mode 2 in bits 2–0 and F0F0F0F0 in bytes 3–6. Words
    0x000A + 0xF000 + 0xF0F0 + 0x00F0 + 0 = 0x1E1EA → 0x61EA | 0x8000 = 0xE1EA."""
    want = bytes([0x0A, 0, 0, 0xF0, 0xF0, 0xF0, 0xF0, 0, 0, 0, 0xEA, 0xE1])
    assert _words(want) == 0x1E1EA
    assert [p.encode() for p in M.mode_switch(0, "velocity", M.MAGIC_VELOCITY_PAGE)] ==\
        [want, want]
    assert M.HostPacket.decode(want, magic=M.MAGIC_VELOCITY_PAGE).value_kind == "raw"


# --- byte 9 of a reply: the sheet's line ---------------------------------------------------------
def _reply_with_byte9(value: int) -> bytes:
    body = bytearray(M.DriverPacket(servo_on=True, encoder_pulses=7, mode=1).encode()[:10])
    body[9] = value
    return bytes(body) + M.checksum(bytes(body)).to_bytes(2, "little")


def test_byte_9_reads_as_the_sheet_prints_it() -> None:
    """「位置決め完了状態 | 0 | 0 | 0 | 制御モード状態 (1: 位置、2: 速度、3: 電流)」: bit 7 the
    in-position state, three zeros (bits 6–4), the mode state in bits 3–0. A set bit 6, 5
    or 4 is a bit the sheet prints 0; bit 3 belongs to the mode state, whose values 8–11
    the sheet does not define: refused as the mode, not as a reserved bit."""
    for bit in (6, 5, 4):
        with pytest.raises(DecodeError, match=r"byte 9: state has unexpected bits set"):
            M.DriverPacket.decode(_reply_with_byte9(0x81 | 1 << bit))
    with pytest.raises(DecodeError, match=r"byte 9: state\.mode = 9 is outside 0\.\.3"):
        M.DriverPacket.decode(_reply_with_byte9(0x89))
    for mode in range(4):
        p = M.DriverPacket.decode(_reply_with_byte9(0x80 | mode))
        assert p.in_position and p.mode == mode
    rows = np.frombuffer(b"".join(_reply_with_byte9(v) for v in (0x81, 0x91, 0x89, 0x03)),
                         np.uint8).reshape(-1, 12)
    assert M.reply_faults(rows).tolist() == [False, True, True, False]


# --- vectorised values equal the Frame's, packet by packet --------------------------------------
_f32_modes = st.floats(width=32, allow_nan=False, allow_infinity=False)


@settings(max_examples=150, deadline=None)
@given(kind=st.sampled_from(["velocity", "current"]), driver_id=st.integers(0, 15),
       servo=st.booleans(), din=st.integers(0, 15), reset=st.booleans(),
       values=st.lists(_f32_modes, max_size=20))
def test_encode_values_equals_the_frame(kind: M.Mode, driver_id: int, servo: bool, din: int,
                                        reset: bool, values: list[float]) -> None:
    template = M.HostPacket(driver_id, servo, 0, 0.0, kind, reset, din)
    got = M.encode_values(template, np.array(values, dtype=np.float64))
    want = b"".join(M.HostPacket(driver_id, servo, 0, v, kind, reset, din).encode()
                    for v in values)
    assert got == want
    decoded = M.decode_stream(got, mode=kind) if values else []
    assert [p.value for p in decoded] == values  # float32 values survive exactly


def test_encode_values_refuses_what_the_frame_refuses() -> None:
    template = M.HostPacket(0, True, 0, 0.0, "velocity")
    with pytest.raises(FieldRangeError, match=r"mc200\.host\.velocity\.value"):
        M.encode_values(template, np.array([1.0, 1e39]))
    with pytest.raises(FieldRangeError, match="value"):
        M.encode_values(template, np.array([np.nan]))
    with pytest.raises(FormatError, match="template"):
        M.encode_values(M.HostPacket(0, True, 1, 0x0F0F0F0F, "raw"), np.array([1]))


# --- streams in every mode ------------------------------------------------------------------------
def _current_model() -> M.CurrentModel:
    return M.CurrentModel.from_motor(load_motor(MOTOR), 0.3)


def _drive(mode: M.Mode, **kw: object) -> M.Drive:
    return M.Drive(mode, current=_current_model() if mode == "current" else None,
                   **kw)  # type: ignore[arg-type]


@pytest.mark.parametrize("mode", ["velocity", "current"])
@pytest.mark.parametrize("chunk", [1, 7, 1 << 16])
def test_a_stream_in_every_mode_is_its_frame_encoded_packets(mode: M.Mode, chunk: int) -> None:
    kw = dict(period_us=500, driver_id=3, hold_packets=6)
    drive = _drive(mode, din=0b1010, spi_error_reset=True, magic=M.MAGIC_VELOCITY_PAGE)
    packets = M.stream_move(POSITION_AT, DURATION, 3200, drive=drive, **kw)
    data = b"".join(M.stream_chunks(POSITION_AT, DURATION, 3200, chunk_packets=chunk,
                                    drive=drive, **kw))
    assert data == M.encode_stream(packets)
    assert len(packets) == M.packet_count(DURATION, 500, 6, drive)
    decoded = M.decode_stream(data, magic=M.MAGIC_VELOCITY_PAGE)
    # the reset comes before the switch: it decodes in the mode in force (position), its
    # zero bytes the same
    assert decoded[1:] == packets[1:] and decoded[0].encode() == packets[0].encode()
    rows = np.frombuffer(data, np.uint8).reshape(-1, 12)
    assert np.all(rows[:, 7] & 0x0F == 0b1010) and np.all(rows[:, 0] >> 4 == 3)
    assert [bool(r[7] & 0x40) for r in rows[:2]] == [True, False]  # the reset opens it


@pytest.mark.parametrize("mode", ["velocity", "current"])
def test_the_driver_reads_a_stream_in_every_mode(mode: M.Mode) -> None:
    drive = _drive(mode)
    data = M.stream_bytes(POSITION_AT, DURATION, 3200, period_us=1000, drive=drive)
    packets = M.decode_stream(data)
    # the switch comes first with the servo off: the servo-on packets are read in `mode`
    assert [p.servo for p in packets[:5]] == [False, False, True, True, True]
    assert [p.mode_switch for p in packets[:2]] == [M.MODE_CODE[mode]] * 2
    r = M.read_stream(data)
    assert r.mode_switches == ((1, M.MODE_CODE[mode]),) and r.servo_on_at == 4
    assert not r.spi_errors and r.moved_while_off is None and r.hold == 10
    commands = r.commands
    assert np.all(commands.mode[2:] == M.MODE_CODE[mode])
    sent = np.array([p.value for p in packets[2:]])
    assert np.array_equal(commands.values(), sent)
    hold = 0.0 if mode == "velocity" else _current_model().hold_a
    assert r.target == pytest.approx(hold)

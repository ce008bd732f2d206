"""MC-200 SPI packets: checksum example, codecs, sequences through the driver model, streaming."""

from __future__ import annotations

import math
import struct
import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import mc200 as M
from profiles.errors import DecodeError, FieldRangeError, FormatError, StepRampError

EXAMPLE = bytes([0x08, 0x00, 0x00, 0x80, 0x00, 0x80, 0x3F, 0x00, 0x00, 0x00])


# --- checksum and the manual's worked example --------------------------------------------------

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


# --- round trips -------------------------------------------------------------------------------

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


# --- sequences through the driver model --------------------------------------------------------

def test_servo_on_needs_three_and_off_needs_five() -> None:
    model = M.DriverModel()
    model.feed(M.servo_on(0)[:2])
    assert not model.state.servo_on
    assert model.feed(M.servo_on(0)[:1]).servo_on
    model.feed(M.servo_off(0)[:4])
    assert model.state.servo_on
    model.consume(M.servo_on(0)[0])  # an interruption restarts the count
    model.feed(M.servo_off(0)[:4])
    assert model.state.servo_on
    assert not model.feed(M.servo_off(0)).servo_on
    with pytest.raises(FieldRangeError, match=r"servo_on\.n"):
        M.servo_on(0, 2)
    with pytest.raises(FieldRangeError, match=r"servo_off\.n"):
        M.servo_off(0, 4)


@pytest.mark.parametrize("mode", ["velocity", "current", "position"])
def test_mode_switch_then_commands(mode: M.Mode) -> None:
    model = M.DriverModel(mode="position")
    model.feed(M.servo_on(1) + M.mode_switch(1, mode))
    state = model.state
    assert state.mode == M.MODE_CODE[mode] and not state.spi_error
    value: int | float = 2.5 if mode != "position" else 777
    model.consume(M.HostPacket(1, True, 0, value, mode))
    assert model.state.command == value and model.state.servo_on


def test_broken_mode_switch_raises_spi_error_until_reset() -> None:
    model = M.DriverModel()
    model.feed(M.servo_on(0))
    first = M.mode_switch(0, "velocity")[0]
    model.consume(first)
    assert model.state.switching_to == 2
    model.consume(M.HostPacket(0, True, 0, 5, "position"))  # no second magic
    state = model.state
    assert state.spi_error and state.mode == 1 and "broken" in (state.spi_error_cause or "")
    model.consume(M.HostPacket(0, True, 0, 99, "position"))
    assert model.state.command == 0  # still the servo-on value: 99 ignored while raised
    model.feed(M.spi_error_reset(0, value=42))
    assert not model.state.spi_error and model.state.command == 42
    # a mode-switch field without the magic is a broken sequence too
    model.consume(M.HostPacket(0, True, 2, 0, "position"))
    assert model.state.spi_error


def test_velocity_page_magic_is_a_parameter() -> None:
    # the velocity page's F0F0F0F0: a driver expecting it refuses the default magic
    strict = M.DriverModel(magic=M.MAGIC_VELOCITY_PAGE)
    strict.feed(M.mode_switch(0, "velocity"))
    assert strict.state.spi_error
    ok = M.DriverModel(magic=M.MAGIC_VELOCITY_PAGE)
    ok.feed(M.mode_switch(0, "velocity", magic=M.MAGIC_VELOCITY_PAGE))
    assert ok.state.mode == 2 and not ok.state.spi_error
    assert M.mode_switch(0, "velocity")[0].encode()[3:7] == bytes([0x0F] * 4)
    with pytest.raises(FieldRangeError, match="magic"):
        M.mode_switch(0, "velocity", magic=1 << 32)
    with pytest.raises(FormatError, match="mode"):
        M.mode_switch(0, "torque")  # type: ignore[arg-type]


def test_model_ignores_other_drivers_and_replies() -> None:
    model = M.DriverModel(driver_id=2)
    model.feed(M.servo_on(1))
    assert not model.state.servo_on
    model.feed([*M.servo_on(2), M.HostPacket(2, True, 0, 123, "position")])
    reply = model.reply()
    assert reply.servo_on and reply.encoder_pulses == 123 and reply.mode == 1
    assert M.DriverPacket.decode(reply.encode()) == reply


# --- streaming ---------------------------------------------------------------------------------

def test_ruckig_profile_matches_ruckig_and_limits() -> None:
    from ruckig import InputParameter, Ruckig, Trajectory

    pulses, v, a, j = 100000, 50000.0, 4e5, 1e8
    position_at, duration = M.ruckig_profile(pulses, v, a, j)
    # the same move in raw units, sampled by ruckig itself
    inp = InputParameter(1)
    inp.current_position, inp.target_position = [0.0], [float(pulses)]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [v], [a], [j]
    traj = Trajectory(1)
    Ruckig(1).calculate(inp, traj)
    assert duration == pytest.approx(traj.duration, rel=1e-6)
    t = np.linspace(0, duration, 97)
    expect = np.array([traj.at_time(float(x))[0][0] for x in t])
    assert np.allclose(position_at(t), expect, atol=1e-3 * pulses * 1e-3)
    dt = 1e-4
    tt = np.arange(0, duration, dt)
    speed = np.diff(position_at(tt)) / dt
    assert speed.max() <= v * (1 + 1e-6) and np.all(speed >= -1e-6)
    with pytest.raises(FieldRangeError, match="a_max_pps2"):
        M.ruckig_profile(100, 1.0, 0.0, 1.0)


def test_stream_move_structure() -> None:
    position_at, duration = M.ruckig_profile(20000, 30000.0, 3e5, 5e7)
    packets = M.stream_move(position_at, duration, 20000, period_us=500, driver_id=4,
                            start_position=1000)
    assert all(p.driver_id == 4 and p.servo for p in packets)
    assert [p.value_kind for p in packets[3:5]] == ["raw", "raw"]
    assert packets[0].value == 1000
    commands = packets[5:]
    assert len(commands) == math.ceil(duration / 500e-6 - 1e-9) + 10
    assert all(p.value == 21000 for p in commands[-10:])
    state = M.DriverModel().feed(packets)
    assert state.servo_on and state.mode == 1 and state.command == 21000
    assert not state.spi_error
    with pytest.raises(FieldRangeError, match="period_us"):
        M.stream_move(position_at, duration, 20000, period_us=0)
    with pytest.raises(FieldRangeError, match="hold_packets"):
        M.stream_move(position_at, duration, 20000, period_us=500, hold_packets=4)
    with pytest.raises(FormatError, match="position_at"):
        M.stream_move(lambda t: np.zeros(3), duration, 20000, period_us=500)


@settings(max_examples=60, deadline=None)
@given(pulses=st.integers(10, 2_000_000), v_frac=st.floats(0.05, 1.0),
       a=st.floats(1e3, 1e7), j_mult=st.floats(2.0, 1e3), period_us=st.sampled_from([
           100, 250, 1000, 2000]))
def test_stream_never_ahead_and_steps_bounded(pulses: int, v_frac: float, a: float,
                                              j_mult: float, period_us: int) -> None:
    v = max(v_frac * math.sqrt(pulses * a), 1.0)
    position_at, duration = M.ruckig_profile(pulses, v, a, a * j_mult)
    if duration / (period_us * 1e-6) > 400_000:
        return  # keep the test fast
    q = M.sample_positions(position_at, duration, pulses, period_us * 1e-6)
    t = np.minimum(np.arange(len(q)) * period_us * 1e-6, duration)
    p = position_at(t)
    assert q[0] == 0 and q[-1] == pulses
    assert np.all(np.diff(q) >= 0)
    assert np.all(q[:-1] <= p[:-1] + 1e-9)  # never ahead of the profile
    # a period's step ≤ ⌈the profile's advance⌉, the profile ending at `pulses` by contract
    p_end = np.append(p[:-1], pulses)
    assert np.all(np.diff(q) <= np.ceil(np.diff(p_end)))
    # and never further behind than one pulse
    assert np.all(p[:-1] - q[:-1] < 1 + 1e-9)


# --- streams -----------------------------------------------------------------------------------

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


# --- lazy streaming (issue 13: memory independent of the move length) -------------------------

def reference_positions(position_at: M.PositionFn, duration: float, pulses: int,
                        period_s: float) -> np.ndarray:
    """The commands computed at once, straight from their definition."""
    count = max(1, math.ceil(duration / period_s - 1e-9))
    t = np.minimum(np.arange(count + 1) * period_s, duration)
    q = np.maximum.accumulate(np.floor(np.clip(position_at(t), 0, pulses))).astype(np.int64)
    q[0], q[-1] = 0, pulses
    return q


@pytest.mark.parametrize("chunk", [1, 2, 7, 1000, 1 << 16])
def test_chunked_positions_equal_the_whole(chunk: int) -> None:
    position_at, duration = M.ruckig_profile(3000, 20000.0, 2e5, 2e7)
    whole = reference_positions(position_at, duration, 3000, 250e-6)
    parts = list(M.iter_positions(position_at, duration, 3000, 250e-6, chunk=chunk))
    assert all(len(p) <= chunk for p in parts)
    assert np.array_equal(np.concatenate(parts), whole)
    assert np.array_equal(M.sample_positions(position_at, duration, 3000, 250e-6), whole)


@pytest.mark.parametrize("chunk", [1, 3, 64, 1 << 16])
def test_stream_chunks_equal_the_frame_encoded_packets(chunk: int) -> None:
    position_at, duration = M.ruckig_profile(4000, 25000.0, 3e5, 5e7)
    kw = dict(period_us=500, driver_id=5, start_position=-1234, hold_packets=6)
    packets = M.stream_move(position_at, duration, 4000, **kw)
    chunks = list(M.stream_chunks(position_at, duration, 4000, chunk_packets=chunk, **kw))
    assert all(0 < len(c) <= max(chunk, 5) * M.PACKET_SIZE for c in chunks)
    data = b"".join(chunks)
    assert data == M.encode_stream(packets)  # vectorised encoder = the Frame's, per packet
    assert data == M.stream_bytes(position_at, duration, 4000, **kw)
    assert len(packets) == M.packet_count(duration, 500, 6)
    assert M.decode_stream(data) == packets


def test_render_chunks_match_the_whole_file_formats() -> None:
    position_at, duration = M.ruckig_profile(1500, 20000.0, 2e5, 2e7)
    packets = M.stream_move(position_at, duration, 1500, period_us=1000)

    def render(fmt: str) -> bytes:
        chunks = M.stream_chunks(position_at, duration, 1500, period_us=1000, chunk_packets=4)
        return b"".join(M.render_chunks(chunks, fmt, period_us=1000, duration_s=duration,
                                        pulses=1500))

    payload = M.encode_stream(packets)
    crc = f"{zlib.crc32(payload):08X}"  # zlib's, independent of stepramp's running CRC
    assert render("bin") == payload
    # the hex file of before the formats table, plus the check line
    assert render("hex").decode() == M.render_hex(packets) + (
        f"# crc32 {crc}: CRC-32 of the {len(payload)} bytes above\n")
    import json

    want = json.dumps({"period_us": 1000, "duration_s": duration, "pulses": 1500,
                       "packets": [p.encode().hex(" ").upper() for p in packets],
                       "crc32": crc}, indent=1)
    assert render("json").decode() == want + "\n"
    with pytest.raises(FormatError, match="format"):
        list(M.render_chunks([], "csv", period_us=1000, duration_s=1.0, pulses=1))


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


def test_stream_chunks_check_everything_before_the_first_chunk() -> None:
    position_at, duration = M.ruckig_profile(2000, 20000.0, 2e5, 2e7)
    with pytest.raises(FormatError, match="position_at"):  # no iteration needed
        M.stream_chunks(lambda t: np.zeros(3), duration, 2000, period_us=500)
    with pytest.raises(FieldRangeError, match="period_us"):
        M.stream_chunks(position_at, duration, 2000, period_us=5)
    with pytest.raises(FieldRangeError, match=r"^duration_s / period: 500000001 \(0x1DCD6501\) "
                                              r"is outside the allowed range 1\.\.20000000"):
        M.stream_chunks(position_at, 1e4, 2000, period_us=20)  # one packet at least


def test_ruckig_refusal_is_one_line() -> None:
    with pytest.raises(StepRampError, match="ruckig: no move for 3200 pulses") as err:
        M.ruckig_profile(3200, 1e-9, 200000, 5e6)
    assert "\n" not in str(err.value)


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


def test_samples_start_at_0_and_end_at_the_move_whatever_the_profile_says() -> None:
    """The first packet commands position 0 and the last one the move's pulses, even when
    the profile's ends are off by a little (a profile evaluated in floating point)."""
    def position_at(t: np.ndarray) -> np.ndarray:
        return 1.5 + 1000.0 * t  # 1.5 pulses ahead at the start, 998.5 at t = 1 s

    q = M.sample_positions(position_at, 1.0, 1000, 0.01)
    assert q[0] == 0 and q[-1] == 1000 and q[1] == 11 and np.all(np.diff(q) >= 0)


def test_stream_progress_counts_whole_packets_up_to_the_total() -> None:
    position_at, duration = M.ruckig_profile(2000, 20000.0, 2e5, 2e7)
    heard: list[tuple[int, int]] = []
    total = sum(len(c) for c in M.stream_chunks(position_at, duration, 2000, period_us=500,
                                                progress=lambda d, t: heard.append((d, t))))
    assert all(isinstance(d, int) and isinstance(t, int) for d, t in heard)
    assert heard[0][0] == 0 and heard[-1][0] == heard[-1][1] == total // M.PACKET_SIZE

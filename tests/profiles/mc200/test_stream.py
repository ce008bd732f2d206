"""profiles.mc200.stream: MC-200 packet streams along a profile (ruckig), chunked and whole,
in every control mode."""

from __future__ import annotations

import json
import math
import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import mc200 as M
from profiles.errors import FieldRangeError, FormatError, StepRampError


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


def test_plan_stream_from_limits_ends_at_the_target() -> None:
    packets, duration = M.plan_stream(5000, period_us=1000, v_max_pps=20000.0,
                                      a_max_pps2=2e5, j_max_pps3=5e7)
    _, ruckig_duration = M.ruckig_profile(5000, 20000.0, 2e5, 5e7)
    assert duration == ruckig_duration
    assert len(packets) == 5 + math.ceil(duration / 1e-3 - 1e-9) + 10
    state = M.DriverModel().feed(packets)
    assert state.servo_on and state.command == 5000 and not state.spi_error


def test_plan_stream_needs_a_profile_or_all_limits() -> None:
    with pytest.raises(FormatError, match="j_max_pps3"):
        M.plan_stream(100, period_us=1000, v_max_pps=1.0, a_max_pps2=1.0)
    with pytest.raises(FormatError, match="not both"):
        M.plan_stream(100, period_us=1000, profile=M.ruckig_profile(100, 1e3, 1e4, 1e6),
                      v_max_pps=1.0)


def test_render_stream_formats() -> None:
    packets, duration = M.plan_stream(500, period_us=1000, v_max_pps=5000.0,
                                      a_max_pps2=5e4, j_max_pps3=5e6)
    raw = M.render_stream(packets, "bin", period_us=1000, duration_s=duration, pulses=500)
    assert isinstance(raw, bytes) and len(raw) == 12 * len(packets)
    text = M.render_stream(packets, "hex", period_us=1000, duration_s=duration, pulses=500)
    assert text.startswith(M.render_hex(packets)) and text.count("\n# crc32 ") == 1
    assert M.decode_stream(raw) == M.decode_stream(text.partition("#")[0])
    doc = json.loads(M.render_stream(packets, "json", period_us=1000, duration_s=duration,
                                     pulses=500))
    assert (doc["pulses"], doc["period_us"], len(doc["packets"])) == (500, 1000, len(packets))
    assert bytes.fromhex(doc["packets"][0]) == raw[:12]
    with pytest.raises(FormatError, match="format"):
        M.render_stream(packets, "csv", period_us=1000, duration_s=duration, pulses=500)


POSITION_AT, DURATION = M.ruckig_profile(3200, 20000.0, 2e5, 5e6)


def test_the_spi_error_reset_opens_the_stream_for_a_driver_in_error() -> None:
    model = M.DriverModel()
    model.feed(M.servo_on(0) + M.mode_switch(0, "velocity")[:1] +
               [M.HostPacket(0, True, 0, 5, "position")])  # a broken switch: the SPI error
    assert model.state.spi_error
    data = M.stream_bytes(POSITION_AT, DURATION, 3200, period_us=1000,
                          drive=M.Drive(spi_error_reset=True))
    state = model.feed(M.decode_stream(data))
    assert not state.spi_error and state.command == 3200 and state.mode == 1
    stuck = M.DriverModel()
    stuck.feed(M.servo_on(0) + M.mode_switch(0, "velocity")[:1] +
               [M.HostPacket(0, True, 0, 5, "position")])
    without = M.stream_bytes(POSITION_AT, DURATION, 3200, period_us=1000)
    assert stuck.feed(M.decode_stream(without)).spi_error  # without it, every packet ignored

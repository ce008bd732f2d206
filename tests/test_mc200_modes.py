"""MC-200 in every control mode (issue 33 item 4): velocity and current packets from the
sheet's figures by hand, streams of either along a profile (their values, round trips, the
driver's reading, `check`), DIN bits, the SPI-error reset, the velocity page's magic, the
≥ 15 µs CS→CLK bound on the period, and byte 9 of a reply read by the sheet's line."""

from __future__ import annotations

import json
import math
import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import mc200 as M
from profiles.errors import DecodeError, FieldRangeError, FormatError, StepRampError
from profiles.motor import load_motor
from tests.support.paths import ROOT
from verify.check_file import check_file
from verify.cli import main

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
    assert [p.encode() for p in M.mode_switch(0, "velocity", M.MAGIC_VELOCITY_PAGE)] == \
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
_f32 = st.floats(width=32, allow_nan=False, allow_infinity=False)


@settings(max_examples=150, deadline=None)
@given(kind=st.sampled_from(["velocity", "current"]), driver_id=st.integers(0, 15),
       servo=st.booleans(), din=st.integers(0, 15), reset=st.booleans(),
       values=st.lists(_f32, max_size=20))
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


def test_velocities_integrate_to_the_profile() -> None:
    period = 1e-3
    v = M.sample_velocities(POSITION_AT, DURATION, 3200, period)
    x = M.iter_samples(POSITION_AT, DURATION, 3200, period, chunk=1 << 20)
    samples = next(x)
    assert len(v) == len(samples) - 1 == math.ceil(DURATION / period - 1e-9)
    assert np.allclose(np.concatenate(([0.0], np.cumsum(v) * period)), samples, atol=1e-9)
    assert np.sum(v) * period == pytest.approx(3200, abs=1e-9)
    assert v.max() <= 20000 * (1 + 1e-6) and v.min() >= 0
    # float32 on the wire: the sum of what is sent stays within a millionth of the move
    sent = np.array(v, dtype=np.float32).astype(np.float64)
    assert abs(np.sum(sent) * period - 3200) < 1e-6 * 3200


def test_currents_are_the_torque_the_move_needs_over_kt() -> None:
    """I_k = (J·α_k·2π/ppr + friction (moving) + load) / Kt, α_k the central difference of
    the mean speeds: written out in plain Python for every period."""
    motor, kt, period = load_motor(MOTOR), 0.3, 1e-3
    v = M.sample_velocities(POSITION_AT, DURATION, 3200, period).tolist()
    got = M.sample_currents(POSITION_AT, DURATION, 3200, period, _current_model())
    padded = [0.0, *v, 0.0]
    for k, speed in enumerate(v):
        alpha = (padded[k + 2] - padded[k]) / (2 * period) * 2 * math.pi / motor.steps_per_rev
        torque = motor.inertia_kgm2 * alpha + (motor.friction_torque_nm if speed > 0 else 0.0)
        assert got[k] == pytest.approx((torque + motor.load_torque_nm) / kt, rel=1e-12,
                                       abs=1e-15)
    # the accelerations sum to nothing: the move starts and ends at rest
    inertial = got - np.where(np.array(v) > 0, motor.friction_torque_nm / kt, 0.0)
    assert abs(float(np.sum(inertial))) < 1e-9


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


@settings(max_examples=40, deadline=None)
@given(pulses=st.integers(1, 200_000), v=st.floats(100.0, 1e5), a=st.floats(1e3, 1e7),
       period_us=st.sampled_from([15.0, 100.0, 333.0, 1000.0]),
       mode=st.sampled_from(["velocity", "current"]))
def test_stream_round_trips(pulses: int, v: float, a: float, period_us: float,
                            mode: M.Mode) -> None:
    """Any ruckig move: the stream decodes back to its commands (float32 of the values),
    and a velocity stream's commands integrate to the move's length."""
    try:
        position_at, duration = M.ruckig_profile(pulses, v, a, 50 * a)
    except StepRampError:  # a limit ruckig's numerics cannot take: not what is tested here
        return
    if duration / (period_us * 1e-6) > 50_000:
        return  # keep the test fast
    drive = _drive(mode)
    data = M.stream_bytes(position_at, duration, pulses, period_us=period_us, drive=drive)
    values = (M.sample_velocities(position_at, duration, pulses, period_us * 1e-6)
              if mode == "velocity" else
              M.sample_currents(position_at, duration, pulses, period_us * 1e-6,
                                drive.current))  # type: ignore[arg-type]
    packets = M.decode_stream(data)
    commands = [p.value for p in packets[5:5 + len(values)]]
    assert commands == np.asarray(values, np.float32).astype(np.float64).tolist()
    if mode == "velocity":
        assert abs(math.fsum(commands) * period_us * 1e-6 - pulses) <= 1e-6 * pulses + 1e-6


def test_the_drive_refuses_what_the_sheet_does_not_have() -> None:
    with pytest.raises(FieldRangeError, match="magic"):
        M.Drive(magic=0x12345678)
    with pytest.raises(FieldRangeError, match="din"):
        M.Drive(din=16)
    with pytest.raises(FormatError, match="current model"):
        M.Drive("current")
    with pytest.raises(FormatError, match="current model"):
        M.Drive("velocity", current=_current_model())
    with pytest.raises(FormatError, match="mode"):
        M.Drive("torque")  # type: ignore[arg-type]
    with pytest.raises(FieldRangeError, match="torque_constant_nm_per_a"):
        M.CurrentModel(0.0, 1e-5, 200)


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


# --- the period: ≥ 15 µs from CS to CLK -----------------------------------------------------------
def test_the_period_leaves_15_us_from_cs_to_clk() -> None:
    """The wiring page: 「CS信号=ONからCLKを入れるまでのwait時間：15usec以上」."""
    assert M.CS_TO_CLK_US == 15.0 and M.PERIOD_US_RANGE[0] == 15.0
    M.stream_chunks(POSITION_AT, DURATION, 3200, period_us=15.0)
    for period in (14.99, 10.0, 0.0, -1.0, math.nan):
        with pytest.raises(FieldRangeError, match=r"^period_us \(µs; .*15 µs from CS to CLK"):
            M.stream_chunks(POSITION_AT, DURATION, 3200, period_us=period)


# --- the command line -----------------------------------------------------------------------------
RUCKIG = ["--vmax", "20000", "--amax", "200000", "--jmax", "5000000", "--pulses", "3200"]


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize(("argv", "needle"), [
    (["--period-us", "10"], "--period-us (µs; each packet waits ≥ 15 µs from CS to CLK, the "
                            "wiring page): 10.0 is outside the allowed range 15.0..1000000.0"),
    (["--period-us", "1000", "--din", "16"], "--din: 16 (0x10) is outside the allowed range "
                                             "0..15"),
    (["--period-us", "1000", "--magic", "0x12345678"], "argument --magic: '0x12345678' is "
                                                       "not one of the sheet's"),
    (["--period-us", "1000", "--mode", "current"], "--mode current needs --motor"),
    (["--period-us", "1000", "--torque-constant-nm-per-a", "0.3"], "only with --mode current"),
    (["--period-us", "1000", "--mode", "torque"], "argument --mode: invalid choice"),
])
def test_stream_options_refused_in_one_line(capsys: pytest.CaptureFixture[str],
                                            argv: list[str], needle: str) -> None:
    code, out, err = _run(capsys, "mc200", "stream", *RUCKIG, *argv)
    assert code == 2 and out == "" and needle in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_current_needs_its_torque_constant(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run(capsys, "mc200", "stream", "--motor", str(MOTOR), "--pulses", "3200",
                        "--period-us", "1000", "--mode", "current")
    assert code == 2 and "--torque-constant-nm-per-a" in err and err.count("\n") == 1
    code, _, err = _run(capsys, "mc200", "stream", "--motor", str(MOTOR), "--pulses", "3200",
                        "--period-us", "1000", "--mode", "current",
                        "--torque-constant-nm-per-a", "0")
    assert code == 2 and err == ("stepramp mc200: --torque-constant-nm-per-a: 0.0 is outside "
                                 "the allowed range above 0.0 up to 1000.0\n")


@pytest.mark.parametrize("mode", ["velocity", "current"])
def test_stream_files_in_every_mode_check_clean(tmp_path: Path, mode: str,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / f"{mode}.json"
    extra = ["--torque-constant-nm-per-a", "0.3"] if mode == "current" else []
    argv = ["mc200", "stream", "--motor", str(MOTOR), "--pulses", "3200", "--period-us",
            "1000", "--mode", mode, "--din", "0b0011", "--spi-error-reset", "--magic",
            "F0F0F0F0", *extra, "-o", str(out)]
    assert main(argv) == 0
    doc = json.loads(out.read_text())
    assert (doc["mode"], doc["unit"]) == (mode, M.UNITS[mode])
    result = check_file(str(out))
    assert result.error is None and result.findings == []
    code, text, _ = _run(capsys, "mc200", "decode", str(out))
    lines = text.splitlines()
    assert code == 0 and "spi_error_reset=True" in lines[0] and "value_kind=raw" in lines[1]
    assert f"value_kind={mode}" in lines[-1] and lines[-1].endswith("din=3")
    code, text, _ = _run(capsys, "mc200", "decode", str(out), "--magic", "0F0F0F0F")
    assert code == 0 and "value_kind=raw" not in text  # read with the other page's magic


def test_check_says_a_velocity_stream_that_ends_turning(tmp_path: Path) -> None:
    data = M.stream_bytes(POSITION_AT, DURATION, 3200, period_us=1000,
                          drive=M.Drive("velocity"))
    turning = data + M.encode_stream([M.HostPacket(0, True, 0, 100.0, "velocity")] * 6)
    path = tmp_path / "turning.mc200.bin"
    path.write_bytes(turning)
    result = check_file(str(path))
    rules = [(f.severity, f.rule, f.message) for f in result.findings]
    assert ("error", "mc200-hold", "the stream ends commanding velocity 100 pps, not 0: the "
            "motor keeps turning") in rules

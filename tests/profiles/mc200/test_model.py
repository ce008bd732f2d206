"""profiles.mc200.model: the MC-200 driver model, fed packet by packet (servo on/off, mode
switches, the SPI error and its reset)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles import mc200 as M
from profiles.errors import FieldRangeError, FormatError, StepRampError
from profiles.mc200.model import read_stream
from tests.support.mc200_replies import SHORT_STREAM, packets_of


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


SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


# --- the driver's reading of a stream ----------------------------------------------------------
@st.composite
def host_sequences(draw: st.DrawFn) -> bytes:
    """Sequences of servo on/off, mode switches (right, broken, other magic), position
    commands (runs of plain ones), resets, other driver ids and corrupted packets."""
    out: list[bytes] = []
    for _ in range(draw(st.integers(1, 12))):
        kind = draw(st.sampled_from(["on", "off", "switch", "broken", "run", "reset", "other",
                                     "bad"]))
        if kind == "on":
            out += [p.encode() for p in M.servo_on(0, draw(st.integers(3, 4)),
                                                   value=draw(st.integers(-5, 5)))]
        elif kind == "off":
            out += [p.encode() for p in M.servo_off(0, draw(st.integers(1, 6)) + 4)][
                :draw(st.integers(1, 6))]
        elif kind == "switch":
            out += [p.encode() for p in M.mode_switch(0, draw(st.sampled_from(M.MODES)))]
        elif kind == "broken":
            out.append(M.mode_switch(0, "velocity")[0].encode())
        elif kind == "run":
            start = draw(st.integers(-1000, 1000))
            steps = draw(st.lists(st.integers(-3, 5), min_size=1, max_size=20))
            servo = draw(st.booleans())
            out += [M.HostPacket(0, servo, 0, start + int(s), "position").encode()
                    for s in np.cumsum(steps)]
        elif kind == "reset":
            out += [p.encode() for p in M.spi_error_reset(0)]
        elif kind == "other":
            out.append(M.HostPacket(5, True, 0, 77, "position").encode())
        else:
            packet = bytearray(M.HostPacket(0, True, 0, 9, "position").encode())
            packet[draw(st.integers(0, 11))] ^= 1 << draw(st.integers(0, 7))
            out.append(bytes(packet))
    return b"".join(out)


@SETTINGS
@given(host_sequences(), st.none() | st.just(0))
def test_read_stream_is_the_model_fed_packet_by_packet(data: bytes,
                                                       driver_id: int | None) -> None:
    """The run-at-once shortcut changes nothing: the final state equals feeding every
    packet the Frame accepts through DriverModel, one by one."""
    model = M.DriverModel(driver_id=driver_id)
    bad = 0
    for packet in packets_of(data):
        try:
            M.HostPacket.decode(packet, mode="position")
        except StepRampError:
            bad += 1
            continue
        model.consume(packet)
    reading = read_stream(data, driver_id=driver_id)
    assert repr(reading.state) == repr(model.state)  # repr: a velocity command may be NaN
    assert reading.bad_count == bad


def test_read_stream_of_a_planned_stream() -> None:
    r = read_stream(SHORT_STREAM)
    assert (r.servo_on_at, r.mode_switches, r.spi_errors, r.reversal_count) == (2, ((4, 1),),
                                                                                (), 0)
    assert r.target == 600 and r.hold == 11  # the last command and the 10 hold packets


def test_a_stream_of_broken_packets_applies_no_position() -> None:
    """Every packet fails its checksum: the driver applies none, so nothing is held."""
    broken = bytearray(SHORT_STREAM[:12 * 4])
    for k in range(4):
        broken[12 * k + 4] ^= 0x01
    r = read_stream(bytes(broken))
    assert (r.bad_count, r.target, r.hold, r.reversal_count) == (4, None, 0, 0)

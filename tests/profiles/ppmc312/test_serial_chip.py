"""The PPMC-312 ASCII-mode slave model (profiles/ppmc312/serial_chip.py) against manual §13–19.

Replies are checked with the ASCII codec (ascii.decode_frame) and against the
control bytes the manual prints (80/90/A0/B0 + address); moves against the
execution model (execution.simulate_move), on a clock the test sets.
"""

from __future__ import annotations

import random
import time
from typing import Any

import pytest
import serial
from hypothesis import given
from hypothesis import strategies as st

from profiles.errors import FieldRangeError, UnsupportedError
from profiles.ppmc312.ascii import (
    END_CODE_REPLY,
    ERROR_CODE_REPLY,
    ERROR_COUNT_REPLY,
    POSITION_REPLY,
    SERIAL_END_STATUS_READ,
    SERIAL_ERROR_CODE_READ,
    SERIAL_ERROR_COUNT_READ,
    SERIAL_POSITION_READ,
    SERIAL_POSITION_SET,
    SERIAL_STOP,
    SPECIAL_REPLY,
    decode_frame,
    encode_frame,
    encode_serial_init,
    encode_serial_move,
)
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.link import REPLY_TO as LINK_REPLY_TO
from profiles.ppmc312.link import (
    ChipRefused,
    Exchange,
    Link,
    LinkTimeout,
    PollReply,
)
from profiles.ppmc312.replies import REPLY_TO, decode_reply
from profiles.ppmc312.serial_chip import COMMANDS, LoopSerial, SerialChip, command_of
from profiles.ppmc312.table import FreeCurveTable, InitTable
from profiles.ppmc312.timing import motion_window
from tests.support.serial_link import ADDRESS as ADDRESS_LINK
from tests.support.serial_link import FakeTime, SkewedTime, move_s, wait_stopped

ADDRESS = 3


TABLE = InitTable(Clock.internal("8MHz"), "linear", 10_000, 400, 2000)


WINDOW_S = 0.115   # §7-1: a linear LE=0 init's table is ready for moves 115 ms after it


class Clock_:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture
def clock() -> Clock_:
    return Clock_()


@pytest.fixture
def chip(clock: Clock_) -> SerialChip:
    return SerialChip(ADDRESS, clock_s=clock)


def poll(chip: SerialChip) -> bytes:
    return chip.receive(encode_frame("poll", ADDRESS, b""))


def command(chip: SerialChip, payload: bytes) -> bytes:
    return chip.receive(encode_frame("command", ADDRESS, payload))


def init(chip: SerialChip, clock: Clock_, table: InitTable = TABLE) -> None:
    """Send `table` and let the window after it pass (§7-1): moves are taken then."""
    assert chip.receive(encode_serial_init(table, ADDRESS)) == READY
    clock.t += motion_window(table).seconds


READY = bytes([0x90 + ADDRESS]) + b"6C"   # §19-1: 90 + a, checksum ~(0x93) & 0x7F


BUSY = bytes([0x80 + ADDRESS]) + b"7C"    # §19-2: 80 + a


def special(code: int) -> bytes:
    return encode_frame("special", ADDRESS, bytes([code]))


def test_command_codes_are_disjoint_and_cover_the_manuals_examples() -> None:
    for code in range(256):
        matches = [name for name, mask, value, _ in COMMANDS if code & mask == value]
        assert len(matches) <= 1, (hex(code), matches)
    # Payload sizes (code byte included) as the §15–18 tables print them.
    assert command_of(0x0A) == ("init", 8)                     # 0000 FO CLK + 7 bytes
    assert command_of(0x83) == ("accel/decel move", 7)         # 83 CW
    assert command_of(0xA3) == ("accel/decel move", 7)         # A3 CCW
    assert command_of(0x62) == ("position read", 1)            # 0 1 P 0 0010, P = encoder
    assert command_of(0x43) == ("position set", 5)
    assert command_of(0x79) == ("event setting", 10)           # 9 data bytes, fixed
    assert command_of(0x4C) == ("error count read", 1)
    assert command_of(0xBA) == ("high-speed origin return", 3)  # 1 0 DIR IDX 1010
    assert command_of(0x50) is None and command_of(0x01 | 0x60) is None


def test_address_is_range_checked() -> None:
    with pytest.raises(FieldRangeError, match=r"address: 16 \(0x10\) is outside"):
        SerialChip(16)


def test_poll_is_ready_then_busy_during_a_move_then_the_stop_report(chip: SerialChip,
                                                                   clock: Clock_) -> None:
    assert poll(chip) == READY
    assert command(chip, bytes.fromhex("4C")) == encode_frame("ready", ADDRESS, b"\x00\x00")
    init(chip, clock)
    assert chip.receive(encode_serial_move(ADDRESS, 2000)) == READY
    run = simulate_move(TABLE, 2000)
    end = run.first_pulse_latency_s + run.duration_s
    assert poll(chip) == BUSY
    clock.t += end - 1e-6
    assert poll(chip) == BUSY
    clock.t += 2e-6
    # §19-14: A0 + a, end code 38 (normal stop at the commanded position), once.
    report = poll(chip)
    assert report[0] == 0xA0 + ADDRESS
    assert decode_frame(report, from_slave=True).payload == b"\x38"
    assert poll(chip) == READY
    assert chip.position == 2000


def test_position_follows_the_execution_model_and_ccw_counts_down(chip: SerialChip,
                                                                  clock: Clock_) -> None:
    init(chip, clock)
    sent = clock.t
    assert chip.receive(encode_serial_move(ADDRESS, 5000, ccw=True)) == READY
    run = simulate_move(TABLE, 5000)
    for t_s in (0.0, 0.05, 0.2, 0.4):
        clock.t = sent + run.first_pulse_latency_s + t_s
        reply = command(chip, SERIAL_POSITION_READ.encode(encoder=0))
        assert reply[0] == 0xA0 + ADDRESS
        fields = POSITION_REPLY.decode(decode_frame(reply, from_slave=True).payload)
        # the 32-bit counter counts down from 0 and wraps (§2-1.6): 0…0xFFFFFFFF
        assert fields == {"counter": 0, "position": -int(run.position_at(t_s)) % (1 << 32)}
    assert (1 << 32) - 5000 < chip.position < 1 << 32


def test_stop_holds_the_counter_and_reports_immediate_stop(chip: SerialChip,
                                                          clock: Clock_) -> None:
    init(chip, clock)
    assert chip.receive(encode_serial_move(ADDRESS, 20_000)) == READY
    clock.t += 0.3
    held = chip.position
    assert 0 < held < 20_000
    assert command(chip, SERIAL_STOP.encode()) == READY
    clock.t += 1.0
    assert chip.position == held
    assert decode_frame(poll(chip), from_slave=True).payload == b"\x37"
    assert decode_frame(command(chip, b"\x40"), from_slave=True).payload == b"\x37"


def test_position_set_and_encoder_position(chip: SerialChip) -> None:
    assert command(chip, SERIAL_POSITION_SET.encode(encoder=0, position=0xFFFFFB2E)) == READY
    assert chip.position == 0xFFFFFB2E
    assert command(chip, SERIAL_POSITION_READ.encode(encoder=1)) == special(0x47)


def test_the_counter_wraps_both_ways(chip: SerialChip, clock: Clock_) -> None:
    """§2-1.6: positions 0…0xFFFFFFFF, CW counts up, CCW down; the 32-bit counter wraps
    (§10-3 sets it anywhere in 0x0~0xffffffff), never a negative number."""
    init(chip, clock)
    assert command(chip, SERIAL_POSITION_SET.encode(encoder=0, position=0xFFFFFFFF - 9)) \
        == READY
    assert chip.receive(encode_serial_move(ADDRESS, 100)) == READY
    clock.t += 1.0
    assert chip.position == 90  # past 0xFFFFFFFF to 0 and on
    assert chip.receive(encode_serial_move(ADDRESS, 100, ccw=True)) == READY
    clock.t += 1.0
    assert chip.position == 0xFFFFFFF6  # and back down past 0
    reply = command(chip, SERIAL_POSITION_READ.encode(encoder=0))
    assert reply == encode_frame("data", ADDRESS, bytes.fromhex("00 FF FF FF F6"))
    with pytest.raises(FieldRangeError, match="position: -1"):
        SERIAL_POSITION_SET.encode(encoder=0, position=-1)


def test_the_manuals_init_example_is_parsed_and_refused_by_the_rate_rules(
        chip: SerialChip) -> None:
    # §13-4 example: start 0x1122 below high 0x5566 → parameter error (start ≤ high).
    frame = bytes([0x90 + ADDRESS]) + b"0011225566abcdef"
    frame += f"{~(sum(frame)) & 0x7F:02X}".encode()
    assert chip.receive(frame) == special(0x42)
    assert chip.table is None
    assert command(chip, SERIAL_ERROR_CODE_READ.encode()) == encode_frame("ready", ADDRESS,
                                                                          b"\x42")


def test_move_needs_a_table_and_an_idle_chip(chip: SerialChip, clock: Clock_) -> None:
    assert chip.receive(encode_serial_move(ADDRESS, 100)) == special(0x43)
    init(chip, clock)
    assert chip.receive(encode_serial_move(ADDRESS, 100_000)) == READY
    assert chip.receive(encode_serial_move(ADDRESS, 100)) == special(0x43)
    assert chip.receive(encode_serial_init(TABLE, ADDRESS)) == special(0x43)
    # A high rate outside the table's range: the execution model's parameter error.
    chip.receive(SERIAL_STOP_FRAME)
    assert chip.receive(encode_serial_move(ADDRESS, 100, high_rate=20_000)) == special(0x42)


SERIAL_STOP_FRAME = encode_frame("command", ADDRESS, SERIAL_STOP.encode())


def test_the_windows_are_the_manuals() -> None:
    """§7-1: 115 ms linear LE=0, 200 ms linear LE=1, 175 ms S-curve (either LE); a free
    curve: §21-4.4's 100 µs of the 'other commands' (docs/manual-notes.md)."""
    clk = Clock.internal("8MHz")
    windows = {(shape, le): motion_window(InitTable(clk, shape, 10_000, 400, 2000,
                                                    *((9_000, 3000) if le else ())))
               for shape in ("linear", "s_curve") for le in (False, True)}
    assert {key: w.seconds for key, w in windows.items()} == {
        ("linear", False): 0.115, ("linear", True): 0.200,
        ("s_curve", False): 0.175, ("s_curve", True): 0.175}
    assert windows[("linear", True)].why == ("the chip accepts motion commands 200 ms after "
                                             "an init (§7-1)")
    free = motion_window(FreeCurveTable(clk, (400, 800), (100, 100)))
    assert free.seconds == 100e-6
    assert free.why.startswith("the chip accepts motion commands 0.1 ms after a free "
                               "curve's last block (§21-4.4")


@pytest.mark.parametrize(("shape", "window_s"), [("linear", 0.115), ("s_curve", 0.175)])
def test_a_move_inside_the_window_after_an_init_is_a_state_error(
        chip: SerialChip, clock: Clock_, shape: str, window_s: float) -> None:
    table = InitTable(Clock.internal("8MHz"), shape, 10_000, 400, 2000)  # type: ignore[arg-type]
    start = clock.t
    assert chip.receive(encode_serial_init(table, ADDRESS)) == READY
    clock.t = start + 0.010
    # §19-5 state error: B0 + a, "43", checksum ~(0xB3 + 0x34 + 0x33) & 0x7F = 0x65.
    assert chip.receive(encode_serial_move(ADDRESS, 100)) == b"\xB3" + b"4365"
    assert chip.log[-1] == (f"refused 0x43: move 10 ms after the init: the chip accepts "
                            f"motion commands {window_s * 1e3:g} ms after an init (§7-1)")
    assert chip.error_code == 0x43   # §18-10 reads it back
    clock.t = start + window_s - 1e-6
    assert chip.receive(encode_serial_move(ADDRESS, 100)) == special(0x43)
    clock.t = start + window_s
    assert chip.receive(encode_serial_move(ADDRESS, 100)) == READY
    assert chip.log[-1].startswith("move: 100 pulses CW")


def test_inside_the_window_other_commands_are_taken_and_a_new_init_restarts_it(
        chip: SerialChip, clock: Clock_) -> None:
    start = clock.t
    assert chip.receive(encode_serial_init(TABLE, ADDRESS)) == READY
    clock.t = start + 0.1
    assert poll(chip) == READY
    assert command(chip, SERIAL_POSITION_SET.encode(encoder=0, position=5)) == READY
    assert command(chip, SERIAL_POSITION_READ.encode(encoder=0)) == encode_frame(
        "data", ADDRESS, POSITION_REPLY.encode(counter=0, position=5))
    assert command(chip, SERIAL_STOP.encode()) == READY  # nothing runs: nothing to refuse
    assert chip.receive(encode_serial_init(TABLE, ADDRESS)) == READY  # at start + 0.1
    clock.t = start + WINDOW_S   # the first init's window is over, the second's is not
    assert chip.receive(encode_serial_move(ADDRESS, 100)) == special(0x43)
    assert chip.log[-1].startswith("refused 0x43: move 15 ms after the init")
    clock.t = start + 0.1 + WINDOW_S
    assert chip.receive(encode_serial_move(ADDRESS, 100)) == READY


def test_undefined_and_unmodelled_commands_are_command_errors(chip: SerialChip) -> None:
    assert command(chip, b"\x50") == special(0x47)
    assert chip.error_code == 0x47
    assert command(chip, b"\xC0") == special(0x47)   # excitation on: documented, not modelled
    assert chip.log[-1] == "refused 0x47: excitation on (0xC0) is not modelled"
    assert chip.error_count == 0


def test_a_bad_checksum_is_answered_and_counted(chip: SerialChip) -> None:
    frame = bytearray(encode_frame("poll", ADDRESS, b""))
    frame[-1] ^= 0x01
    assert chip.receive(bytes(frame)) == special(0x47)
    assert (chip.checksum_errors, chip.error_count, chip.error_code) == (1, 1, 0)
    assert command(chip, SERIAL_ERROR_COUNT_READ.encode()) == encode_frame("ready", ADDRESS,
                                                                           b"\x00\x01")


def test_lowercase_hex_is_accepted(chip: SerialChip) -> None:
    payload = b"\x43\xff\xff\xff\xfe"
    upper = encode_frame("command", ADDRESS, payload)
    lower = upper[:1] + payload.hex().encode()
    lower += f"{~(lower[0] + sum(lower[1:])) & 0x7F:02X}".encode()
    assert chip.receive(lower) == READY
    assert chip.position == 0xFFFFFFFE


def test_a_frame_cut_short_is_a_framing_error_and_the_next_frame_is_answered(
        chip: SerialChip) -> None:
    frame = encode_frame("command", ADDRESS, SERIAL_POSITION_READ.encode(encoder=0))
    assert chip.receive(frame[:3]) == b""
    assert poll(chip) == READY
    assert (chip.framing_errors, chip.error_count) == (1, 1)


def test_characters_outside_a_frame_count_once_per_run(chip: SerialChip) -> None:
    assert chip.receive(b"0123") == b""
    assert poll(chip) == READY
    assert chip.receive(b"45") == b""
    assert chip.framing_errors == 2


def test_frames_for_other_slaves_are_ignored(chip: SerialChip) -> None:
    assert chip.receive(encode_frame("poll", ADDRESS + 1, b"")) == b""
    assert chip.receive(encode_serial_move(ADDRESS + 1, 100)) == b""
    assert chip.error_count == 0
    assert poll(chip) == READY


def test_slave_types_and_bit6_are_framing_errors(chip: SerialChip) -> None:
    assert chip.receive(encode_frame("special", ADDRESS, b"\x47")) == b""
    assert chip.receive(b"\xC3" + b"6C") == b""
    assert chip.framing_errors == 2
    assert poll(chip) == READY


def test_error_count_saturates(chip: SerialChip) -> None:
    chip.framing_errors, chip.checksum_errors = 0xFFF0, 0x20
    assert command(chip, SERIAL_ERROR_COUNT_READ.encode()) == encode_frame("ready", ADDRESS,
                                                                           b"\xff\xff")


@pytest.mark.slow  # 2–4 s: the quick suite's budget; CI runs it
@given(st.lists(st.integers(1, 9), min_size=1, max_size=40))
def test_any_split_of_the_stream_gives_the_same_replies(cuts: list[int]) -> None:
    stream = (encode_serial_init(TABLE, ADDRESS) + encode_frame("poll", ADDRESS, b"")
              + encode_frame("command", ADDRESS, SERIAL_POSITION_SET.encode(encoder=0,
                                                                            position=77))
              + encode_frame("command", ADDRESS, SERIAL_POSITION_READ.encode(encoder=0)))
    whole = SerialChip(ADDRESS, clock_s=lambda: 0.0).receive(stream)
    pieces = SerialChip(ADDRESS, clock_s=lambda: 0.0)
    out, at = b"", 0
    for cut in cuts * 20:
        out += pieces.receive(stream[at:at + cut])
        at += cut
    out += pieces.receive(stream[at:])
    assert out == whole
    assert whole == READY + READY + READY + encode_frame(
        "data", ADDRESS, POSITION_REPLY.encode(counter=0, position=77))


def test_loop_transport_answers_like_the_chip() -> None:
    port = LoopSerial(SerialChip(ADDRESS), timeout=0.5)
    port.write(encode_frame("poll", ADDRESS, b""))
    assert port.read(3) == READY


@given(st.integers(0, 15), st.integers(0, 1), st.integers(0, 0xFFFFFFFF))
def test_position_frames_round_trip(address: int, encoder: int, position: int) -> None:
    for frame, values, kind in (
            (SERIAL_POSITION_SET, {"encoder": encoder, "position": position}, "command"),
            (POSITION_REPLY, {"counter": encoder, "position": position}, "data")):
        wire = encode_frame(kind, address, frame.encode(values))
        parsed = decode_frame(wire, from_slave=kind == "data")
        assert (parsed.kind, parsed.address) == (kind, address)
        assert frame.decode(parsed.payload) == values


@given(st.integers(0, 15), st.integers(0, 0xFFFF), st.integers(0, 0xFF))
def test_error_and_end_code_replies_round_trip(address: int, count: int, code: int) -> None:
    for frame, values in ((ERROR_COUNT_REPLY, {"error_count": count}),
                          (ERROR_CODE_REPLY, {"error_code": code}),
                          (END_CODE_REPLY, {"end_code": code}),
                          (SPECIAL_REPLY, {"code": code})):
        wire = encode_frame("ready", address, frame.encode(values))
        assert frame.decode(decode_frame(wire, from_slave=True).payload) == values


def test_serial_command_codes_are_the_manuals() -> None:
    # §16-1 stop 80, §18-1 position read 42 / 62 (P), §18-2 set 43 / 63, §18-6 40,
    # §18-10 41, §18-11 4C.
    assert SERIAL_STOP.encode() == b"\x80"
    assert [SERIAL_POSITION_READ.encode(encoder=p) for p in (0, 1)] == [b"\x42", b"\x62"]
    assert SERIAL_POSITION_SET.encode(encoder=1, position=0xFFFFFFFF) == b"\x63\xff\xff\xff\xff"
    assert (SERIAL_END_STATUS_READ.encode(), SERIAL_ERROR_CODE_READ.encode(),
            SERIAL_ERROR_COUNT_READ.encode()) == (b"\x40", b"\x41", b"\x4c")


# Each command's code byte as the manual's tables draw it (x: a bit the command carries,
# DIR, P, FO, …) and its payload bytes with the code (the rows between the control code
# and the checksum), section by section; written from the manual, not from COMMANDS.
MANUAL_CODES = (
    ("15-1", "0000xxxx", 8), ("15-2", "11xx0110", 3), ("15-3", "110x0111", 3),
    ("15-4", "11001000", 5), ("15-5", "01000111", 3), ("15-6", "11001001", 2),
    ("16-1", "10000000", 1), ("16-1", "10001011", 5), ("16-1", "10011011", 1),
    ("16-1", "10111011", 1), ("16-2", "10000001", 1), ("16-2", "10001100", 5),
    ("16-2", "10011100", 1), ("16-2", "10111100", 1), ("16-3", "10x00011", 7),
    ("16-4", "10x00100", 7), ("16-5", "10x00010", 1), ("16-6", "10x00110", 3),
    ("16-7", "10x00101", 3), ("16-8", "10001001", 3), ("16-8", "10001110", 7),
    ("16-8", "10011110", 3), ("16-8", "10111110", 3), ("16-9", "10001000", 3),
    ("16-9", "10001101", 7), ("16-9", "10011101", 3), ("16-9", "10111101", 3),
    ("16-10", "10xx0111", 3), ("16-11", "10xx1010", 3), ("17-1", "11000000", 1),
    ("17-2", "11000001", 1), ("17-3", "11000010", 1), ("17-4", "11000011", 1),
    ("17-5", "11000100", 1), ("17-6", "01000100", 1), ("17-7", "01000101", 2),
    ("17-8", "01000110", 1), ("17-9", "11000101", 2), ("18-1", "01x00010", 1),
    ("18-2", "01x00011", 5), ("18-3", "01001000", 1), ("18-4", "01001010", 1),
    ("18-5", "01001101", 1), ("18-6", "01000000", 1), ("18-7", "01xx1001", 10),
    ("18-9", "01001110", 1), ("18-10", "01000001", 1), ("18-11", "01001100", 1),
    ("18-12", "11111111", 1),
)


def test_every_code_byte_is_read_as_the_manual_draws_it() -> None:
    """All 256 code bytes: a command's frame length is the manual's (§15–18), and a byte
    no section draws is no command (the chip answers it with error 0x47)."""
    def matches(pattern: str, code: int) -> bool:
        return all(p in "x" + str(bit) for p, bit in zip(pattern, f"{code:08b}", strict=True))

    for code in range(256):
        drawn = [(section, size) for section, pattern, size in MANUAL_CODES
                 if matches(pattern, code)]
        assert len(drawn) <= 1, (hex(code), drawn)
        found = command_of(code)
        assert (found[1] if found else None) == (drawn[0][1] if drawn else None), \
            (hex(code), drawn, found)


def send(chip: SerialChip, name: str, **params: object) -> bytes:
    from profiles.ppmc312.motion import encode_command

    return chip.receive(encode_command(name, to="ascii", address=ADDRESS, **params))


def stop_report(code: int) -> bytes:
    return encode_frame("data", ADDRESS, bytes([code]))


def position(chip: SerialChip) -> int:
    reply = command(chip, SERIAL_POSITION_READ.encode(encoder=0))
    return int(POSITION_REPLY.decode(decode_frame(reply, from_slave=True).payload)["position"])


def run_out(chip: SerialChip, clock: Clock_, report: int, step_s: float = 0.01,
            limit_s: float = 30.0) -> None:
    """Poll every `step_s` of emulated time until the stop report comes: it is `report`."""
    for _ in range(int(limit_s / step_s)):
        clock.t += step_s
        got = poll(chip)
        if got != BUSY:
            assert got == stop_report(report), chip.log[-3:]
            assert poll(chip) == READY   # the report comes once (§19-14)
            return
    raise AssertionError("still busy")


@pytest.mark.parametrize(("name", "params"), [
    ("accel", {"pulses": 3000}), ("constant", {"pulses": 200, "rate": 1000}),
    ("step", {}), ("continuous", {"rate": 0}), ("continuous-constant", {"rate": 2000}),
    ("origin-search", {"rate": 1000}), ("origin-return", {"rate": 0}),
])
def test_every_start_command_is_taken_then_runs_busy(chip: SerialChip, clock: Clock_,
                                                     name: str, params: dict[str, int]) -> None:
    init(chip, clock)
    assert send(chip, name, **params) == READY
    assert poll(chip) == BUSY
    assert send(chip, name, **params) == special(0x43)     # a start while moving (§19-5)
    assert chip.log[-1].startswith("refused 0x43:") and "during pulse output" in chip.log[-1]
    assert send(chip, "stop") == READY
    assert poll(chip) == stop_report(0x37)


def test_a_constant_run_advances_the_position_by_its_pulses(chip: SerialChip,
                                                           clock: Clock_) -> None:
    init(chip, clock)
    assert send(chip, "constant", rate=1000, pulses=500, ccw=True) == READY
    clock.t += 400e-6 + 250 / 8000   # §8-4's 400 µs, then 250 pulses at 8000 pps
    assert poll(chip) == BUSY and position(chip) == (-250) % (1 << 32)
    run_out(chip, clock, 0x38)
    assert position(chip) == (-500) % (1 << 32)
    assert send(chip, "constant", rate=1000, pulses=500) == READY   # taken again at rest
    run_out(chip, clock, 0x38)
    assert position(chip) == 0


def test_a_continuous_run_runs_until_a_decel_stop(chip: SerialChip, clock: Clock_) -> None:
    init(chip, clock)
    assert send(chip, "continuous", rate=0) == READY
    for _ in range(5):
        clock.t += 1.0
        assert poll(chip) == BUSY
    before = position(chip)
    assert before > 5 * 8000        # past the ramp, at the high rate (20 000 pps)
    assert send(chip, "decel-stop") == READY
    assert send(chip, "decel-stop") == READY          # ignored while decelerating (§8-2)
    assert "already stopping" in chip.log[-1]
    run_out(chip, clock, 0x36)
    assert position(chip) > before


def test_speed_changes_run_only_during_a_motion(chip: SerialChip, clock: Clock_) -> None:
    init(chip, clock)
    for name in ("change-speed", "set-speed"):
        assert send(chip, name, rate=1000) == special(0x43)
        assert "no pulse output" in chip.log[-1]
    assert send(chip, "continuous-constant", rate=2000) == READY
    clock.t += 0.1
    assert send(chip, "set-speed", rate=1000) == READY   # 4000 → 8000 pps at once
    clock.t += 0.1
    at = position(chip)
    clock.t += 0.1
    assert position(chip) - at == 800
    assert send(chip, "change-speed", rate=500) == READY
    assert send(chip, "stop") == READY
    assert poll(chip) == stop_report(0x37)


@pytest.mark.parametrize(("name", "params"), [
    ("constant", {"rate": 300, "pulses": 10}), ("constant", {"rate": 10_001, "pulses": 10}),
    ("continuous", {"rate": 399}), ("continuous-constant", {"rate": 20_000}),
    ("origin-search", {"rate": 10_001}), ("accel", {"pulses": 10, "rate": 300}),
])
def test_a_rate_outside_the_table_is_a_parameter_error(chip: SerialChip, clock: Clock_,
                                                       name: str, params: dict[str, int]
                                                       ) -> None:
    init(chip, clock)
    assert send(chip, name, **params) == special(0x42)
    assert chip.log[-1].startswith("refused 0x42:") and chip.log[-1].endswith("(§11-6 0x20)")
    assert poll(chip) == READY
    assert command(chip, SERIAL_ERROR_CODE_READ.encode()) == encode_frame(
        "ready", ADDRESS, bytes([0x42]))


def test_a_speed_change_outside_the_table_is_a_parameter_error(chip: SerialChip,
                                                               clock: Clock_) -> None:
    init(chip, clock)
    assert send(chip, "continuous-constant", rate=2000) == READY
    assert send(chip, "change-speed", rate=200) == special(0x42)
    assert chip.log[-1].endswith("(§11-6 0x20)")
    assert poll(chip) == BUSY


@pytest.mark.parametrize(("name", "rate"), [("origin-search", 1000), ("origin-return", 0)])
@pytest.mark.parametrize("ccw", [False, True])
def test_origin_search_and_return_stop_on_org(clock: Clock_, name: str, rate: int,
                                              ccw: bool) -> None:
    chip = SerialChip(ADDRESS, clock_s=clock, origin_at=5000)
    init(chip, clock)
    if ccw:  # /ORG lies the way the search runs
        assert command(chip, SERIAL_POSITION_SET.encode(encoder=0, position=9000)) == READY
    assert send(chip, name, rate=rate, ccw=ccw) == READY
    run_out(chip, clock, 0x32)
    assert position(chip) == 5000
    assert send(chip, name, rate=rate) == READY    # on /ORG: found before a pulse
    assert poll(chip) == stop_report(0x32) and position(chip) == 5000


def test_a_step_outputs_one_pulse_and_05_is_taken_at_rest(chip: SerialChip,
                                                          clock: Clock_) -> None:
    init(chip, clock)
    assert send(chip, "high-speed-limit", rate=1000) == READY and chip.limit_rate == 1000
    assert send(chip, "step", ccw=True) == READY
    run_out(chip, clock, 0x38, step_s=0.001)
    assert position(chip) == 0xFFFFFFFF
    assert send(chip, "continuous", rate=0) == READY
    assert send(chip, "high-speed-limit", rate=1000) == special(0x43)


def test_an_override_at_a_position_takes_effect_there(chip: SerialChip, clock: Clock_) -> None:
    init(chip, clock)
    assert send(chip, "stop", override_at=4000) == special(0x43)   # nothing runs (§19-5)
    assert send(chip, "continuous-constant", rate=2000) == READY   # 4000 pps
    assert send(chip, "set-speed", rate=1000, override_at=2000) == READY   # registered
    assert send(chip, "stop", override_at=6000) == READY                   # behind it
    assert "2 in the override buffer" in chip.log[-1]
    clock.t += 400e-6 + 0.25
    assert poll(chip) == BUSY and position(chip) == 1000   # 400 µs, then 1000 pulses
    clock.t += 0.25 + 0.25  # 1000 more at 4000 pps, then 2000 at 8000 pps (§8-9: a jump)
    assert position(chip) == 4000
    clock.t += 1.0
    assert poll(chip) == special(0x21) and poll(chip) == special(0x21)   # §19-9, each
    assert poll(chip) == stop_report(0x37) and poll(chip) == READY
    assert position(chip) == 6000
    assert [line for line in chip.log if line.startswith("override:")] == [
        "override: set-speed (88) at position 2000 at pulse 2000",
        "override: stop (80) at position 6000 at pulse 6000"]


def test_an_override_the_motion_never_reaches_is_aborted(chip: SerialChip,
                                                         clock: Clock_) -> None:
    init(chip, clock)
    assert send(chip, "constant", rate=1000, pulses=500) == READY
    assert send(chip, "decel-stop", override_at=800) == READY
    clock.t += 1.0
    assert poll(chip) == special(0x49)   # §19-10: dropped when the motion ends first
    assert poll(chip) == stop_report(0x38) and poll(chip) == READY
    assert any(line.startswith("override aborted (1 command(s) dropped): the motion ended "
                               "first") for line in chip.log)
    # One the model refuses where it fires (a speed change while decelerating) aborts it too
    assert send(chip, "accel", pulses=3000) == READY
    assert send(chip, "change-speed", rate=1000, override_at=2900) == READY  # in the decel
    assert send(chip, "change-speed", rate=100, override_at=20) == special(0x42)
    assert chip.log[-1].endswith("(§11-6 0x20)")
    # 8D (88 at a position) at 5: below §16-9's 0xA (encode_command refuses to write it)
    assert command(chip, bytes([0x8D, 0x03, 0xE8, 0, 0, 0, 5])) == special(0x42)
    assert poll(chip) == BUSY
    clock.t += 2.0
    assert poll(chip) == special(0x49) and "decelerating there" in chip.log[-2]
    assert poll(chip) == stop_report(0x38)


def test_an_event_fires_the_head_that_waits_for_it(clock: Clock_) -> None:
    chip = SerialChip(ADDRESS, clock_s=clock, events_at=[(0, 3000)])
    init(chip, clock)
    assert send(chip, "continuous-constant", rate=2000) == READY
    assert send(chip, "decel-stop", on="evt2") == READY    # /EVT1 (code BC)
    assert send(chip, "stop", on="evt1") == READY          # /EVT0, behind it
    clock.t += 1.0
    chip.event(0)                                          # the head waits for /EVT1
    assert chip.log[-1] == "/EVT0: nothing waits for it" and poll(chip) == BUSY
    chip.event(1)
    assert poll(chip) == special(0x21)
    assert chip.log[-2] == "override: decel-stop (81) on /EVT1 at pulse 3998"  # 400 µs late
    clock.t += 1.0   # /EVT0 waits behind it, where the counter does not pass 3000 again
    assert poll(chip) == special(0x49) and poll(chip) == stop_report(0x36)
    # --event-at: /EVT0 fires where the counter passes 3000 + the start
    start = position(chip)
    assert send(chip, "continuous-constant", rate=2000, ccw=True) == READY
    assert send(chip, "stop", on="evt1") == READY
    clock.t += 10.0
    assert poll(chip) == special(0x21) and poll(chip) == stop_report(0x37)
    assert position(chip) == 3000 and start > 3000


def test_fl_and_bl_stop_at_once_where_the_motion_meets_them(clock: Clock_) -> None:
    chip = SerialChip(ADDRESS, clock_s=clock, limits_at=[("FL", 3000), ("BL", 1000)])
    init(chip, clock)
    assert send(chip, "continuous-constant", rate=2000) == READY   # CW: /BL not watched
    assert send(chip, "set-speed", rate=1000, override_at=5000) == READY   # never reached
    clock.t += 2.0
    assert poll(chip) == special(0x49) and poll(chip) == stop_report(0x33)  # §19-14 33
    assert position(chip) == 3000 and "/FL at pulse 3000: STL" in chip.log
    assert send(chip, "constant", rate=1000, pulses=10) == special(0x44)   # §19-6
    assert "/FL is low at 3000" in chip.log[-1]
    assert send(chip, "continuous", rate=0, ccw=True) == READY   # away from it: taken
    run_out(chip, clock, 0x33)
    assert position(chip) == 1000


@pytest.mark.parametrize(("limit", "rate", "report"), [
    (None, 0, 0x34),       # 05 not given: the table's high rate (§7-6): decelerates
    (1000, 0, 0x34),       # faster than 05's 1000: decelerates
    (1000, 2000, None),    # slower than it: ignored, runs on
])
def test_fhl_decelerates_at_or_above_the_05_speed(clock: Clock_, limit: int | None, rate: int,
                                                  report: int | None) -> None:
    chip = SerialChip(ADDRESS, clock_s=clock, limits_at=[("FHL", 12_000)])
    init(chip, clock)
    if limit is not None:
        assert send(chip, "high-speed-limit", rate=limit) == READY
    assert send(chip, "continuous", rate=rate) == READY
    clock.t += 5.0
    if report is None:
        assert poll(chip) == BUSY and "ignored, slower than" in chip.log[-2]
        assert send(chip, "stop") == READY and poll(chip) == stop_report(0x37)
        return
    run_out(chip, clock, report)
    assert position(chip) > 12_000 and any(
        line.startswith("/FHL at pulse 12000: DEL") for line in chip.log)


def test_stop_halts_a_move_midway(link: Link, pty_chip: tuple[SerialChip, str]) -> None:
    link.init(TABLE)
    link.move(100_000)
    time.sleep(0.1)
    link.stop()
    held = link.position()
    assert 0 < held < 100_000
    time.sleep(0.05)
    assert link.position() == held == pty_chip[0].position
    assert (link.poll().code, link.end_status()) == (0x37, 0x37)


def test_errors_reads_the_count_and_the_code(link: Link,
                                             pty_chip: tuple[SerialChip, str]) -> None:
    report = link.errors()
    assert (report.error_count, report.error_code, report.error_text) == (0, 0, "no error")
    with pytest.raises(ChipRefused, match=r"slave 5: move: the chip refused it: state error "
                                          r"\(B5 43\)") as refused:
        link.move(100)  # no table yet
    assert refused.value.code == 0x43
    # the whole message, as the CLI prints it after "stepramp link: "
    assert str(refused.value) == "slave 5: move: the chip refused it: state error (B5 43)"
    pty_chip[0].checksum_errors = 2  # as if two damaged frames had reached it
    report = link.errors()
    assert (report.error_count, report.error_code, report.error_text) == (2, 0x43,
                                                                          "state error")


def test_a_free_curve_has_no_serial_form(link: Link) -> None:
    table = FreeCurveTable(Clock.internal("8MHz"), (400, 800), (100, 100))
    with pytest.raises(UnsupportedError, match="no serial form"):
        link.init(table)  # type: ignore[arg-type]


def test_a_silent_slave_times_out_after_the_retries(pty_chip: tuple[SerialChip, str]) -> None:
    with Link(pty_chip[1], ADDRESS_LINK + 1, timeout_s=0.05, retries=2) as other:
        with pytest.raises(LinkTimeout, match=r"^slave 6: poll: no reply within 0.05 s "
                                              r"\(3 attempts\)$"):
            other.poll()
        assert other.stats["attempts"] == 3


@pytest.mark.parametrize("baud", [19_200, 38_400, 83_333])
def test_every_line_speed_of_the_manual_talks(pty_chip: tuple[SerialChip, str], baud: int
                                             ) -> None:
    """§13: 19 200, 38 400 and 83 333 bit/s (a pty carries any of them)."""
    with Link(pty_chip[1], ADDRESS_LINK, baud=baud, timeout_s=0.5) as opened:
        assert opened.position() == 0


def test_link_over_loop_transport(skewed: SkewedTime) -> None:
    chip = SerialChip(ADDRESS_LINK, clock_s=skewed.now)
    link = Link(LoopSerial(chip), ADDRESS_LINK, timeout_s=0.2, **skewed.timing())
    link.init(TABLE)
    link.move(2000)
    assert chip.busy
    assert wait_stopped(link, 2000).code == 0x38
    assert link.position() == 2000


S_TABLE = InitTable(Clock.internal("8MHz"), "s_curve", 10_000, 400, 2000)


def timed_link(fake: FakeTime, notes: list[str], sleep: Any = None) -> tuple[SerialChip, Link]:
    """The chip and the link on one fake clock, over the in-process loop port."""
    chip = SerialChip(ADDRESS_LINK, clock_s=fake.now)
    return chip, Link(LoopSerial(chip), ADDRESS_LINK, clock_s=fake.now,
                      sleep_s=fake.sleep if sleep is None else sleep, on_note=notes.append)


def test_the_link_waits_out_the_window_before_the_first_move_only() -> None:
    fake, notes = FakeTime(), list[str]()
    chip, link = timed_link(fake, notes)
    link.init(TABLE)
    link.move(100)
    # The fake clock stood still while the frames went: the whole window is waited.
    assert fake.slept == [pytest.approx(0.115, abs=1e-12)]
    assert notes == ["the chip accepts motion commands 115 ms after an init (§7-1): "
                     "waiting 115 ms"]
    assert chip.log[-1].startswith("move: 100 pulses CW")
    fake.t += 1.0       # the move is over
    link.move(100)      # no init since: no wait
    assert len(fake.slept) == 1 and len(notes) == 1
    assert sum(line.startswith("move:") for line in chip.log) == 2


def test_time_already_spent_is_not_waited_again() -> None:
    fake, notes = FakeTime(), list[str]()
    chip, link = timed_link(fake, notes)
    link.init(S_TABLE)
    fake.t += 0.100     # the host did other things
    link.move(100)
    assert fake.slept == [pytest.approx(0.075, abs=1e-12)]
    assert notes == ["the chip accepts motion commands 175 ms after an init (§7-1): "
                     "waiting 75 ms"]
    fake.t += 1.0
    link.init(S_TABLE)
    fake.t += 0.2       # past the window: nothing to wait
    link.move(100)
    assert len(fake.slept) == 1 and len(notes) == 1
    assert sum(line.startswith("move:") for line in chip.log) == 2


def test_a_link_that_did_not_wait_would_be_refused_by_the_chip() -> None:
    fake, notes = FakeTime(), list[str]()
    chip, link = timed_link(fake, notes, sleep=lambda _s: None)  # a sleep that takes no time
    link.init(TABLE)
    with pytest.raises(ChipRefused, match=r"^slave 5: move: the chip refused it: state error "
                                          r"\(B5 43\)$"):
        link.move(100)
    assert chip.log[-1] == ("refused 0x43: move 0 ms after the init: the chip accepts motion "
                            "commands 115 ms after an init (§7-1)")


def test_the_position_is_the_unsigned_counter() -> None:
    """§2-1.6: positions 0…0xFFFFFFFF; a CCW move past 0 reads 0xFFFFFF9C, never −100,
    and a CW move back wraps to 50 (the emulator's counter is 32 bits too)."""
    fake, notes = FakeTime(), list[str]()
    chip, link = timed_link(fake, notes)
    link.init(TABLE)
    link.move(100, ccw=True)
    fake.t += 1.0  # the move is over
    assert link.position() == chip.position == 0xFFFFFF9C
    link.move(150)
    fake.t += 1.0
    assert link.position() == chip.position == 50


def test_a_stop_is_never_delayed_and_waiting_needs_an_init() -> None:
    fake, notes = FakeTime(), list[str]()
    _, link = timed_link(fake, notes)
    link.wait_until_motion_accepted()   # no init yet: nothing to wait for
    link.init(TABLE)
    link.stop()
    assert fake.slept == [] and notes == []
    link.wait_until_motion_accepted()   # what `stepramp link init` does before it ends
    assert fake.slept == [pytest.approx(0.115, abs=1e-12)]
    link.move(100)
    assert len(fake.slept) == 1


def test_every_reply_taken_is_heard_with_the_command_it_answers() -> None:
    fake, heard = FakeTime(), list[Exchange]()
    chip = SerialChip(ADDRESS_LINK, clock_s=fake.now)
    link = Link(LoopSerial(chip), ADDRESS_LINK, clock_s=fake.now, sleep_s=fake.sleep,
                on_reply=heard.append)
    link.init(TABLE)
    link.move(100, ccw=True)     # reads the position first (a lost reply's check)
    assert link.poll().state == "busy"
    fake.t += 1.0
    assert link.poll().code == 0x38
    assert link.errors().error_code == 0
    assert [(e.what, e.reply_to) for e in heard] == [
        ("init", "command"), ("position", "position"), ("move", "command"),
        ("poll", "poll"), ("poll", "poll"), ("error count", "error-count"),
        ("error code", "error-code")]
    decoded = [decode_reply(e.reply, reply_to=e.reply_to) for e in heard]
    assert [a.kind.key for a in decoded] == ["ready", "position", "ready", "busy",
                                             "stop report", "error count", "error code"]
    assert decoded[4].fields == {"end_code": 0x38}
    assert all(e.sent[0] in (0x80 + ADDRESS_LINK, 0x90 + ADDRESS_LINK) and e.attempt == 0
               for e in heard)
    assert set(LINK_REPLY_TO.values()) <= set(REPLY_TO)  # every exchange has its reading


class PassThrough:
    """A port wrapper: everything goes to `port` unless a subclass says otherwise."""

    def __init__(self, port: Any) -> None:
        self.port = port

    @property
    def timeout(self) -> float | None:
        return self.port.timeout  # type: ignore[no-any-return]

    @timeout.setter
    def timeout(self, value: float | None) -> None:
        self.port.timeout = value

    def write(self, data: bytes) -> int:
        return self.port.write(data)  # type: ignore[no-any-return]

    def read(self, size: int = 1) -> bytes:
        return self.port.read(size)  # type: ignore[no-any-return]

    def reset_input_buffer(self) -> None:
        self.port.reset_input_buffer()

    def close(self) -> None:
        self.port.close()


class DropReplies(PassThrough):
    """Drops the chip's reply to chosen writes (counted from 0)."""

    def __init__(self, port: Any, drop: set[int]) -> None:
        super().__init__(port)
        self.drop, self.writes = drop, 0

    def write(self, data: bytes) -> int:
        n = self.port.write(data)
        if self.writes in self.drop:
            # Wait for the reply's first byte however slow the machine, then swallow
            # the rest: the master sees nothing.
            timeout = self.port.timeout
            self.port.timeout = 5.0
            assert self.port.read(1), "the chip did not answer"
            self.port.timeout = 0.05
            while self.port.read(64):
                pass
            self.port.timeout = timeout
        self.writes += 1
        return n  # type: ignore[no-any-return]


def test_a_move_whose_reply_is_lost_is_not_sent_twice(pty_chip: tuple[SerialChip, str],
                                                       skewed: SkewedTime) -> None:
    chip, path = pty_chip
    port = DropReplies(serial.Serial(path, timeout=0.1), drop={2})  # init, position, MOVE
    with Link(port, ADDRESS_LINK, timeout_s=0.3, **skewed.timing()) as link:
        link.init(TABLE)
        link.move(200)
        assert sum(line.startswith("move:") for line in chip.log) == 1
        assert link.stats["timeouts"] >= 1
        assert wait_stopped(link, 200).code == 0x38
        assert link.position() == 200
    port.close()


def test_a_lost_stop_report_is_recovered_from_the_end_status(
        pty_chip: tuple[SerialChip, str], skewed: SkewedTime) -> None:
    chip, path = pty_chip
    port = DropReplies(serial.Serial(path, timeout=0.1), drop={3})  # init, position, move, POLL
    with Link(port, ADDRESS_LINK, timeout_s=0.3, **skewed.timing()) as link:
        link.init(TABLE)
        link.move(100)
        time.sleep(move_s(100) + 0.02)
        stopped = link.poll()   # the chip's A0 38 is lost; the resent poll gets ready
        assert (stopped.state, stopped.code) == ("stopped", 0x38)
        assert "poll: stop report 0x38" in chip.log
        assert link.poll().state == "ready"
    port.close()


class NoisyLine(PassThrough):
    """Between master and chip: each byte, either way, has a bit flipped or is dropped
    with the given probabilities (a seeded generator: the same faults each run)."""

    def __init__(self, port: Any, seed: int, flip: float, drop: float) -> None:
        super().__init__(port)
        self.rng, self.flip, self.drop = random.Random(seed), flip, drop
        self.faults = 0

    def _noise(self, data: bytes) -> bytes:
        out = bytearray()
        for byte in data:
            roll = self.rng.random()
            if roll < self.drop:
                self.faults += 1
                continue
            if roll < self.drop + self.flip:
                self.faults += 1
                byte ^= 1 << self.rng.randrange(8)
            out.append(byte)
        return bytes(out)

    def write(self, data: bytes) -> int:
        self.port.write(self._noise(data))
        return len(data)

    def read(self, size: int = 1) -> bytes:
        return self._noise(self.port.read(size))


@pytest.mark.parametrize("seed", [pytest.param(1, marks=pytest.mark.slow),  # ~6 s each
                                  pytest.param(2, marks=pytest.mark.slow),
                                  pytest.param(3, marks=pytest.mark.slow)])
def test_a_noisy_line_loses_and_misreads_nothing(pty_chip: tuple[SerialChip, str],
                                                 skewed: SkewedTime, seed: int) -> None:
    chip, path = pty_chip
    noisy = NoisyLine(serial.Serial(path, timeout=0.1), seed, flip=0.02, drop=0.02)
    link = Link(noisy, ADDRESS_LINK, timeout_s=0.15, retries=10, **skewed.timing())
    link.init(TABLE)
    assert chip.table == TABLE
    expected = 0
    rng = random.Random(seed)
    for _ in range(6):
        pulses, ccw = rng.randint(20, 150), rng.random() < 0.4
        link.move(pulses, ccw=ccw)
        expected = (expected + (-pulses if ccw else pulses)) % (1 << 32)  # §2-1.6: wraps
        time.sleep(move_s(pulses) + 0.01)
        assert link.poll() == PollReply("stopped", 0x38, "normal stop at the commanded position")
        assert link.position() == expected == chip.position
        assert link.poll().state == "ready"
        before = chip.error_count
        report = link.errors()
        assert before <= report.error_count <= chip.error_count
    assert sum(line.startswith("move:") for line in chip.log) == 6  # no move twice
    assert noisy.faults >= 5 and link.stats["resends"] > 0 and chip.error_count > 0
    noisy.close()


def motion_link(fake: FakeTime, origin_at: int | None = None, on_reply: Any = None
                ) -> tuple[SerialChip, Link]:
    chip = SerialChip(ADDRESS_LINK, clock_s=fake.now, origin_at=origin_at)
    link = Link(LoopSerial(chip), ADDRESS_LINK, clock_s=fake.now, sleep_s=fake.sleep,
                on_reply=on_reply)
    link.init(TABLE)
    return chip, link


def poll_until_stopped(link: Link, fake: FakeTime, step_s: float = 0.05) -> Any:
    for _ in range(2000):
        fake.t += step_s
        reply = link.poll()
        if reply.state != "busy":
            return reply
    raise AssertionError("still busy")


@pytest.mark.parametrize(("name", "params"), [
    ("accel", {"pulses": 3000}), ("constant", {"pulses": 200, "rate": 1000}),
    ("step", {"ccw": True}), ("continuous", {}), ("continuous-constant", {"rate": 2000}),
    ("origin-search", {"rate": 1000, "index": True}), ("origin-return", {"rate": 0}),
])
def test_every_start_command_is_sent_answered_and_stopped(name: str, params: dict[str, Any]
                                                          ) -> None:
    fake = FakeTime()
    heard: list[Exchange] = []
    _, link = motion_link(fake, on_reply=heard.append)
    link.motion(name, **params)     # waits out the window after the init (§7-1)
    assert heard[-1].what == name and heard[-1].reply_to == "command"
    assert fake.slept == [pytest.approx(0.115, abs=1e-12)]
    assert link.poll().state == "busy" or name == "step"
    link.motion("stop")
    reply = poll_until_stopped(link, fake)
    assert reply.state == "stopped" and reply.code in (0x37, 0x38)


def test_a_constant_run_then_poll_until_stopped_advances_by_its_pulses() -> None:
    fake = FakeTime()
    _, link = motion_link(fake)
    link.motion("constant", rate=1000, pulses=4000)   # 8000 pps: half a second
    assert poll_until_stopped(link, fake, 0.1) == PollReply(
        "stopped", 0x38, "normal stop at the commanded position")
    assert link.position() == 4000
    link.motion("constant", rate=1000, pulses=1000, ccw=True)
    poll_until_stopped(link, fake)
    assert link.position() == 3000


def test_continuous_then_decel_stop_and_the_speed_changes_while_it_runs() -> None:
    fake = FakeTime()
    _, link = motion_link(fake)
    link.motion("continuous", rate=0)
    fake.t += 2.0
    assert link.poll().state == "busy"
    link.motion("change-speed", rate=1000)
    link.motion("set-speed", rate=800)
    fake.t += 1.0
    at = link.position()
    link.motion("decel-stop")
    assert poll_until_stopped(link, fake).code == 0x36
    assert link.position() > at


def test_the_chips_refusals_name_the_command() -> None:
    fake = FakeTime()
    chip, link = motion_link(fake)
    link.wait_until_motion_accepted()
    with pytest.raises(ChipRefused, match=r"^slave 5: change-speed: the chip refused it: "
                                          r"state error \(B5 43\)$"):
        link.motion("change-speed", rate=1000)
    with pytest.raises(ChipRefused, match=r"^slave 5: constant: the chip refused it: "
                                          r"parameter error \(B5 42\)$") as refused:
        link.motion("constant", rate=300, pulses=10)   # the table's rates: 400..10 000
    assert refused.value.code == 0x42
    assert chip.log[-1] == ("refused 0x42: constant (83): rate 300 is not within the "
                            "rates of the table it holds (400..10000) (§11-6 0x20)")


def test_origin_search_meets_org_where_the_emulator_puts_it() -> None:
    fake = FakeTime()
    _, link = motion_link(fake, origin_at=1500)
    link.motion("origin-search", rate=1000)
    assert poll_until_stopped(link, fake) == PollReply("stopped", 0x32,
                                                       "stopped at the origin input")
    assert link.position() == 1500


def test_a_registration_whose_reply_is_lost_is_not_resent() -> None:
    from profiles.errors import LinkTimeout

    fake = FakeTime()
    chip = SerialChip(ADDRESS_LINK, clock_s=fake.now)
    chip.table = TABLE

    class Swallow(LoopSerial):  # type: ignore[misc]
        drop = False

        def write(self, data: bytes) -> int:
            replies = self.chip.receive(bytes(data))
            if replies and not self.drop:
                protocol_loop.Serial.write(self, replies)
            return len(data)

    from serial.urlhandler import protocol_loop

    port = Swallow(chip)
    link = Link(port, ADDRESS_LINK, clock_s=fake.now, sleep_s=fake.sleep, timeout_s=0.02)
    link.motion("continuous-constant", rate=2000)
    port.drop = True
    with pytest.raises(LinkTimeout, match="may be registered in the override buffer; not "
                                          "resent"):
        link.motion("stop", override_at=5000)
    assert len(chip._overrides) == 1 and link.stats["resends"] == 0

"""Streaming a move to the MC-200: one command per SPI period, lazily.

`stream_profile` picks the profile (one it is handed, e.g. a PPMC-312 staircase's
positions, or ruckig's jerk-limited move); `stream_chunks` yields the packets of a move as bytes, a
chunk at a time, so a stream of millions of packets never sits in memory (issue
13: a 4 M-pulse stream stays far below 200 MB); `render_chunks` turns them into
a file of the stream's format table (`formats`: hex, bin, json, c, ihex), also a
chunk at a time. `stream_move`,
`plan_stream` (packet objects), `stream_bytes` (all bytes) and `render_stream`
are conveniences for small moves.

Commands follow any monotone profile (e.g. `ruckig_profile`): positions never
ahead of it, ending exactly at the target; velocities and currents (`Drive`, the
values: `commands`) integrating to it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..errors import (
    FieldChoiceError,
    FieldRangeError,
    FormatError,
    echo,
    require_int,
    require_number,
)
from ..formats import RenderOptions
from ..progress import report
from .codec import (
    MAGIC_DEFAULT,
    MAGICS,
    MODES,
    PACKET_SIZE,
    HostPacket,
    Mode,
    encode_stream,
    encode_values,
)
from .commands import (
    UNITS,
    CurrentModel,
    PositionFn,
    iter_currents,
    iter_samples,
    iter_velocities,
)
from .formats import FORMATS
from .model import SEQUENCE_MAX, mode_switch, servo_on

if TYPE_CHECKING:
    from ..progress import Progress

INT32_MAX = (1 << 31) - 1
CS_TO_CLK_US = 15.0  # the wiring page: 「CS信号=ONからCLKを入れるまでのwait時間：15usec以上」
PERIOD_US_RANGE = (CS_TO_CLK_US, 1_000_000.0)
# the note rides along to the option's name (`fields_as_options` keeps it): no dots in it
PERIOD_FIELD = "period_us (µs; each packet waits ≥ 15 µs from CS to CLK, the wiring page)"
MAX_STREAM_PACKETS = 20_000_000
HOLD_PACKETS_MIN = 5
CHUNK_PACKETS = 1 << 16  # 786 kB of packets per chunk: memory is this, not the move
OBJECT_CHUNK_PACKETS = 20_000  # packet objects encoded between progress reports (~0.3 s)
StreamFormat = str  # a name of `formats.FORMATS` (hex, bin, json, c, ihex; text = hex)
STREAM_FORMATS: tuple[str, ...] = FORMATS.names


Profile = tuple[PositionFn, float]  # (position_at(t_s) → pulses, duration_s)


def stream_profile(pulses: int, *, profile: Profile | None = None,
                   v_max_pps: float | None = None, a_max_pps2: float | None = None,
                   j_max_pps3: float | None = None) -> Profile:
    """The profile a stream of `pulses` follows and its duration [s].

    `profile`: one the caller hands (any monotone position_at, e.g. a PPMC-312 staircase's
    `Execution.position_at` with its duration: the stream knows no other device);
    otherwise ruckig's jerk-limited profile with the three limits, which must then all be
    given.
    """
    if profile is not None:
        if any(v is not None for v in (v_max_pps, a_max_pps2, j_max_pps3)):
            raise FormatError("a stream follows a profile it is handed, or ruckig's from "
                              "v_max_pps, a_max_pps2 and j_max_pps3: not both")
        return profile
    if v_max_pps is None or a_max_pps2 is None or j_max_pps3 is None:
        raise FormatError("a stream needs a profile, or all of v_max_pps, a_max_pps2 and "
                          "j_max_pps3")
    return ruckig_profile(pulses, v_max_pps, a_max_pps2, j_max_pps3)


def plan_stream(pulses: int, *, period_us: float, driver_id: int = 0,
                profile: Profile | None = None, v_max_pps: float | None = None,
                a_max_pps2: float | None = None,
                j_max_pps3: float | None = None) -> tuple[list[HostPacket], float]:
    """The packets (objects: small moves) that run a move of `pulses` along
    `stream_profile`, and the move's duration [s]."""
    position_at, duration_s = stream_profile(pulses, profile=profile, v_max_pps=v_max_pps,
                                             a_max_pps2=a_max_pps2, j_max_pps3=j_max_pps3)
    packets = stream_move(position_at, duration_s, pulses, period_us=period_us,
                          driver_id=driver_id)
    return packets, duration_s


@dataclass(frozen=True)
class Drive:
    """How a stream drives the MC-200, besides the profile: the control mode of its
    commands (position [pulses], velocity [pps], current [A]: `commands`), the
    mode-switch magic (the position and current pages' 0F0F0F0F, or the velocity
    page's F0F0F0F0), the DIN0–3 bits every packet carries (the driver's inputs, set
    by its parameters #304–#307), whether the stream opens with the SPI-error reset,
    and for a current stream the motor's `CurrentModel`."""

    mode: Mode = "position"
    magic: int = MAGIC_DEFAULT
    din: int = 0
    spi_error_reset: bool = False
    current: CurrentModel | None = None

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise FormatError(f"mode: {echo(self.mode)} is not one of {', '.join(MODES)}")
        if self.magic not in MAGICS:
            raise FieldChoiceError("magic", self.magic, MAGICS)
        require_int("din", self.din, 0, 15)
        if (self.mode == "current") != (self.current is not None):
            raise FormatError("a current stream needs the motor's current model (its "
                              "inertia, friction, load and torque constant); no other does")


def stream_chunks(position_at: PositionFn, duration_s: float, pulses: int, *,
                  period_us: float, driver_id: int = 0, start_position: int = 0,
                  hold_packets: int = 10, chunk_packets: int = CHUNK_PACKETS,
                  drive: Drive | None = None,
                  progress: Progress | None = None) -> Iterator[bytes]:
    """The packets of a move of `pulses` along `position_at` (pulses, monotone 0 → pulses),
    as bytes, at most `chunk_packets` packets per chunk.

    Position mode (`drive` None or its mode "position"): servo on (3 packets holding
    `start_position`), switch to position mode, one command per SPI period sampled at
    t = k·period, then `hold_packets` (≥ 5) at the target. Commands are ⌊profile⌋
    (never ahead), so a period's step never exceeds ⌈the profile's advance⌉; the last
    one is exactly the target. Velocity and current modes: the switch first with the
    servo off, so the servo-on packets are read as velocity 0 / the holding current
    (in the position mode they would command a position, which may be far from the
    motor), then one command per period (`commands`), then the hold (velocity 0 /
    the holding current). With `drive.spi_error_reset`, a packet with the reset bit
    comes first; `drive.din` is in every packet.

    Arguments and the profile's first chunk are checked before this returns, so a
    bad request fails before anything is written. `progress` hears (packets
    yielded, packets in all) as the chunks go out.
    """
    drive = drive or Drive()
    period_s = _check_stream(duration_s, pulses, period_us, start_position, hold_packets)
    require_int("chunk_packets", chunk_packets, 1, MAX_STREAM_PACKETS)
    template = HostPacket(driver_id, True, 0, start_position if drive.mode == "position"
                          else 0.0, drive.mode, False, drive.din)
    preamble = _preamble(template, drive)
    values, hold = _values(position_at, duration_s, pulses, period_s, chunk_packets,
                           start_position, drive)
    first = next(values)  # evaluates the profile once: a broken one fails here

    def parts() -> Iterator[bytes]:
        yield encode_stream(preamble)
        yield encode_values(template, first)
        for v in values:
            yield encode_values(template, v)
        for n in range(hold_packets, 0, -chunk_packets):
            yield encode_values(template, np.full(min(n, chunk_packets), hold))

    def chunks() -> Iterator[bytes]:
        total = packet_count(duration_s, period_us, hold_packets, drive)
        done = 0
        report(progress, done, total)
        for part in parts():
            if part:
                yield part
            done += len(part) // PACKET_SIZE
            report(progress, done, total)

    return chunks()


def _preamble(template: HostPacket, drive: Drive) -> list[HostPacket]:
    """What comes before the first command: the reset (when asked), the servo and the
    mode switch, in the order `stream_chunks` gives."""
    d, din, mode = template.driver_id, drive.din, drive.mode
    hold = template.value if drive.current is None else float(np.float32(drive.current.hold_a))
    position = mode == "position"
    reset = [HostPacket(d, position, 0, hold, mode, True, din)] if drive.spi_error_reset else []
    on = servo_on(d, value=hold, mode=mode, din=din)
    switch = mode_switch(d, mode, drive.magic, servo=position, din=din)
    return reset + (on + switch if position else switch + on)


def _values(position_at: PositionFn, duration_s: float, pulses: int, period_s: float,
            chunk: int, start_position: int, drive: Drive
            ) -> tuple[Iterator[np.ndarray], int | float]:
    """The command values a chunk at a time (the first chunk at least one value, so it
    can be taken to check the profile) and the value the stream holds at its end."""
    if drive.mode == "position":
        def positions() -> Iterator[np.ndarray]:
            for k, q in enumerate(iter_positions(position_at, duration_s, pulses, period_s,
                                                 chunk=chunk)):
                # the sample at t = 0 is the preamble's hold, not a command
                yield start_position + (q[1:] if k == 0 else q)

        return _non_empty_first(positions()), start_position + pulses
    velocities = iter_velocities(position_at, duration_s, pulses, period_s, chunk=chunk)
    if drive.current is None:
        return _non_empty_first(velocities), 0.0
    return (_non_empty_first(iter_currents(velocities, period_s, drive.current)),
            drive.current.hold_a)


def _non_empty_first(chunks: Iterator[np.ndarray]) -> Iterator[np.ndarray]:
    """`chunks` with any empty ones before the first value dropped (a first chunk of one
    sample gives no command): the first chunk taken evaluates the profile."""
    for c in chunks:
        if len(c):
            yield c
            break
    yield from chunks


def stream_bytes(position_at: PositionFn, duration_s: float, pulses: int, *, period_us: float,
                 driver_id: int = 0, start_position: int = 0, hold_packets: int = 10,
                 drive: Drive | None = None) -> bytes:
    """All the bytes of `stream_chunks` at once (small moves)."""
    return b"".join(stream_chunks(position_at, duration_s, pulses, period_us=period_us,
                                  driver_id=driver_id, start_position=start_position,
                                  hold_packets=hold_packets, drive=drive))


def stream_move(position_at: PositionFn, duration_s: float, pulses: int, *, period_us: float,
                driver_id: int = 0, start_position: int = 0,
                hold_packets: int = 10, drive: Drive | None = None) -> list[HostPacket]:
    """The packets of `stream_chunks` as objects (small moves: one object per packet),
    each encoded by its Frame."""
    drive = drive or Drive()
    period_s = _check_stream(duration_s, pulses, period_us, start_position, hold_packets)
    template = HostPacket(driver_id, True, 0, start_position if drive.mode == "position"
                          else 0.0, drive.mode, False, drive.din)
    values, hold = _values(position_at, duration_s, pulses, period_s, CHUNK_PACKETS,
                           start_position, drive)
    # float commands as float32, what the packet carries: the objects decode back equal
    sent = (np.int64 if drive.mode == "position" else np.float32)
    commands = [replace(template, value=v) for chunk in values
                for v in chunk.astype(sent).tolist()]
    held = sent(hold).item()
    return _preamble(template, drive) + commands + [replace(template, value=held)] * hold_packets


def _check_stream(duration_s: float, pulses: int, period_us: float, start_position: int,
                  hold_packets: int) -> float:
    """The period in seconds, once every argument of a stream is known to be usable."""
    require_int("pulses", pulses, 1, INT32_MAX)
    require_int("start_position", start_position, -INT32_MAX - 1, INT32_MAX - pulses)
    require_int("hold_packets", hold_packets, HOLD_PACKETS_MIN, SEQUENCE_MAX)
    require_number(PERIOD_FIELD, period_us, *PERIOD_US_RANGE)
    require_number("duration_s", duration_s, 0, math.inf, lo_open=True, hi_open=True)
    period_s = period_us * 1e-6
    count = math.ceil(duration_s / period_s - 1e-9)
    if count > MAX_STREAM_PACKETS:
        raise FieldRangeError("duration_s / period", count, 1, MAX_STREAM_PACKETS)
    return period_s


def iter_positions(position_at: PositionFn, duration_s: float, pulses: int, period_s: float,
                   *, chunk: int = CHUNK_PACKETS) -> Iterator[np.ndarray]:
    """`sample_positions`, `chunk` samples at a time (the running maximum carried over)."""
    for q in iter_samples(position_at, duration_s, pulses, period_s, chunk=chunk, floor=True):
        yield q.astype(np.int64)


def sample_positions(position_at: PositionFn, duration_s: float, pulses: int,
                     period_s: float) -> np.ndarray:
    """Integer commands at t = 0, period, 2·period, … (the last at `duration_s`):
    ⌊profile⌋ clipped to [0, pulses] and made monotone; the last equals `pulses`."""
    return np.concatenate(list(iter_positions(position_at, duration_s, pulses, period_s)))


def render_chunks(chunks: Iterable[bytes], fmt: str, *, period_us: float,
                  duration_s: float, pulses: int, options: RenderOptions | None = None,
                  mode: Mode = "position") -> Iterator[bytes]:
    """A stream file, a chunk at a time, in any format of the stream's format table
    (`profiles.mc200.formats`: hex, bin, json, c, ihex), the move's period, duration
    and length in the JSON document (and a velocity or current stream's mode and the
    unit of its commands); `options` names the C symbols, the Intel HEX address and
    the provenance. The format is checked before the first chunk."""
    header: dict[str, object] = {"period_us": period_us, "duration_s": duration_s,
                                 "pulses": pulses}
    if mode != "position":  # a position stream's document stays as it always was
        header |= {"mode": mode, "unit": UNITS[mode]}
    return FORMATS.render_chunks(chunks, fmt, replace(options or RenderOptions(),
                                                      header=header))


def render_stream(packets: Sequence[HostPacket], fmt: str, *, period_us: float,
                  duration_s: float, pulses: int,
                  progress: Progress | None = None) -> str | bytes:
    """`render_chunks` of packet objects, whole (small moves): bytes for `bin`, text for
    the others. `progress` hears (packets encoded, packets)."""
    from ..progress import chunks

    FORMATS.get(fmt)  # a bad format fails before any packet is encoded
    parts = (encode_stream(packets[r.start:r.stop])
             for r in chunks(len(packets), OBJECT_CHUNK_PACKETS, progress))
    data = b"".join(render_chunks(parts, fmt, period_us=period_us, duration_s=duration_s,
                                  pulses=pulses))
    return data if FORMATS.get(fmt).binary else data.decode()


def packet_count(duration_s: float, period_us: float, hold_packets: int = 10,
                 drive: Drive | None = None) -> int:
    """How many packets `stream_chunks` yields (for progress and size estimates): the
    reset (when asked), servo on and the mode switch, a command a period, the hold."""
    count = max(1, math.ceil(duration_s / (period_us * 1e-6) - 1e-9))
    return (6 if drive is not None and drive.spi_error_reset else 5) + count + hold_packets


def ruckig_profile(pulses: int, v_max_pps: float, a_max_pps2: float,
                   j_max_pps3: float) -> tuple[PositionFn, float]:
    """A jerk-limited rest-to-rest profile from ruckig (profiles.ruckig_move), evaluated
    vectorised: (position_at(t_s) → pulses, duration_s)."""
    from ..ruckig_move import solve_move

    require_int("pulses", pulses, 1, INT32_MAX)
    for name, value in (("v_max_pps", v_max_pps), ("a_max_pps2", a_max_pps2),
                        ("j_max_pps3", j_max_pps3)):
        require_number(name, value, 0, 1e15, lo_open=True, hi_open=True)
    move = solve_move(pulses, v_max_pps=v_max_pps, a_up_pps2=a_max_pps2,
                      a_down_pps2=a_max_pps2, j_max_pps3=j_max_pps3)
    return move.position_at, move.duration_s


"""Streaming a move to the MC-200: one position command per SPI period, lazily.

`stream_profile` picks the profile (one it is handed, e.g. a PPMC-312 staircase's
positions, or ruckig's jerk-limited move); `stream_chunks` yields the packets of a move as bytes, a
chunk at a time, so a stream of millions of packets never sits in memory (issue
13: a 4 M-pulse stream stays far below 200 MB); `render_chunks` turns them into
a file of the stream's format table (`formats`: hex, bin, json, c, ihex), also a
chunk at a time. `stream_move`,
`plan_stream` (packet objects), `stream_bytes` (all bytes) and `render_stream`
are conveniences for small moves.

Commands follow any monotone profile (e.g. `ruckig_profile`), never ahead of
it, ending exactly at the target.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..errors import FieldRangeError, FormatError, require_int, require_number
from ..formats import RenderOptions
from ..progress import report
from .codec import PACKET_SIZE, HostPacket, encode_positions, encode_stream
from .formats import FORMATS
from .model import SEQUENCE_MAX, mode_switch, servo_on

if TYPE_CHECKING:
    from ..progress import Progress

PositionFn = Callable[[np.ndarray], np.ndarray]
INT32_MAX = (1 << 31) - 1
PERIOD_US_RANGE = (10.0, 1_000_000.0)
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


def stream_chunks(position_at: PositionFn, duration_s: float, pulses: int, *,
                  period_us: float, driver_id: int = 0, start_position: int = 0,
                  hold_packets: int = 10, chunk_packets: int = CHUNK_PACKETS,
                  progress: Progress | None = None) -> Iterator[bytes]:
    """The packets of a move of `pulses` along `position_at` (pulses, monotone 0 → pulses),
    as bytes, at most `chunk_packets` packets per chunk.

    Servo on (3 packets holding `start_position`), switch to position mode, one
    command per SPI period sampled at t = k·period, then `hold_packets` (≥ 5) at the
    target. Commands are ⌊profile⌋ (never ahead), so a period's step never exceeds
    ⌈the profile's advance⌉; the last one is exactly the target.

    Arguments and the profile's first chunk are checked before this returns, so a
    bad request fails before anything is written. `progress` hears (packets
    yielded, packets in all) as the chunks go out.
    """
    period_s = _check_stream(duration_s, pulses, period_us, start_position, hold_packets)
    require_int("chunk_packets", chunk_packets, 1, MAX_STREAM_PACKETS)
    preamble = servo_on(driver_id, value=start_position) + mode_switch(driver_id, "position")
    template = HostPacket(driver_id, True, 0, start_position, "position")
    positions = iter_positions(position_at, duration_s, pulses, period_s, chunk=chunk_packets)
    first = next(positions)  # evaluates the profile once: a broken one fails here

    def parts() -> Iterator[bytes]:
        yield encode_stream(preamble)
        if len(first) > 1:  # the sample at t = 0 is the preamble's hold, not a command
            yield encode_positions(template, start_position + first[1:])
        for q in positions:
            yield encode_positions(template, start_position + q)
        for n in range(hold_packets, 0, -chunk_packets):
            yield encode_positions(template, np.full(min(n, chunk_packets),
                                                     start_position + pulses))

    def chunks() -> Iterator[bytes]:
        total = packet_count(duration_s, period_us, hold_packets)
        done = 0
        report(progress, done, total)
        for part in parts():
            yield part
            done += len(part) // PACKET_SIZE
            report(progress, done, total)

    return chunks()


def stream_bytes(position_at: PositionFn, duration_s: float, pulses: int, *, period_us: float,
                 driver_id: int = 0, start_position: int = 0, hold_packets: int = 10) -> bytes:
    """All the bytes of `stream_chunks` at once (small moves)."""
    return b"".join(stream_chunks(position_at, duration_s, pulses, period_us=period_us,
                                  driver_id=driver_id, start_position=start_position,
                                  hold_packets=hold_packets))


def stream_move(position_at: PositionFn, duration_s: float, pulses: int, *, period_us: float,
                driver_id: int = 0, start_position: int = 0,
                hold_packets: int = 10) -> list[HostPacket]:
    """The packets of `stream_chunks` as objects (small moves: one object per packet)."""
    period_s = _check_stream(duration_s, pulses, period_us, start_position, hold_packets)
    preamble = servo_on(driver_id, value=start_position) + mode_switch(driver_id, "position")
    positions = sample_positions(position_at, duration_s, pulses, period_s)
    commands = [HostPacket(driver_id, True, 0, start_position + int(p), "position")
                for p in positions[1:]]
    hold = [HostPacket(driver_id, True, 0, start_position + pulses, "position")] * hold_packets
    return preamble + commands + hold


def _check_stream(duration_s: float, pulses: int, period_us: float, start_position: int,
                  hold_packets: int) -> float:
    """The period in seconds, once every argument of a stream is known to be usable."""
    require_int("pulses", pulses, 1, INT32_MAX)
    require_int("start_position", start_position, -INT32_MAX - 1, INT32_MAX - pulses)
    require_int("hold_packets", hold_packets, HOLD_PACKETS_MIN, SEQUENCE_MAX)
    require_number("period_us", period_us, *PERIOD_US_RANGE)
    require_number("duration_s", duration_s, 0, math.inf, lo_open=True, hi_open=True)
    period_s = period_us * 1e-6
    count = math.ceil(duration_s / period_s - 1e-9)
    if count > MAX_STREAM_PACKETS:
        raise FieldRangeError("duration_s / period", count, 1, MAX_STREAM_PACKETS)
    return period_s


def iter_positions(position_at: PositionFn, duration_s: float, pulses: int, period_s: float,
                   *, chunk: int = CHUNK_PACKETS) -> Iterator[np.ndarray]:
    """`sample_positions`, `chunk` samples at a time (the running maximum carried over)."""
    count = max(1, math.ceil(duration_s / period_s - 1e-9))
    floor = 0.0
    for k0 in range(0, count + 1, chunk):
        k = np.arange(k0, min(k0 + chunk, count + 1))
        t = np.minimum(k * period_s, duration_s)
        try:
            p = np.asarray(position_at(t), dtype=float)
        except (TypeError, ValueError) as e:
            raise FormatError(f"position_at: cannot evaluate the profile ({e})") from None
        if p.shape != t.shape or not np.all(np.isfinite(p)):
            raise FormatError(f"position_at: expected {t.size} finite positions, got shape "
                              f"{p.shape}")
        q = np.maximum.accumulate(np.maximum(np.floor(np.clip(p, 0, pulses)), floor))
        floor = float(q[-1])
        q = q.astype(np.int64)
        if k0 == 0:
            q[0] = 0
        if k[-1] == count:
            q[-1] = pulses
        yield q


def sample_positions(position_at: PositionFn, duration_s: float, pulses: int,
                     period_s: float) -> np.ndarray:
    """Integer commands at t = 0, period, 2·period, … (the last at `duration_s`):
    ⌊profile⌋ clipped to [0, pulses] and made monotone; the last equals `pulses`."""
    return np.concatenate(list(iter_positions(position_at, duration_s, pulses, period_s)))


def render_chunks(chunks: Iterable[bytes], fmt: str, *, period_us: float,
                  duration_s: float, pulses: int,
                  options: RenderOptions | None = None) -> Iterator[bytes]:
    """A stream file, a chunk at a time, in any format of the stream's format table
    (`profiles.mc200.formats`: hex, bin, json, c, ihex), the move's period, duration
    and length in the JSON document; `options` names the C symbols, the Intel HEX
    address and the provenance. The format is checked before the first chunk."""
    header = {"period_us": period_us, "duration_s": duration_s, "pulses": pulses}
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


def packet_count(duration_s: float, period_us: float, hold_packets: int = 10) -> int:
    """How many packets `stream_chunks` yields (for progress and size estimates)."""
    count = max(1, math.ceil(duration_s / (period_us * 1e-6) - 1e-9))
    return 5 + count + hold_packets


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


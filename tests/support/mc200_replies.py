"""MC200 streams and replies: the guide's stream (ruckig, 20 000 pps, 200 000 pps², 5e6
pps³, 3 200 pulses, one packet a ms), the examples written from it (examples/move.mc200.hex
and its reply log move.mc200.replies.hex), a short stream (600 pulses at 8 000 pps, one
packet every 2 ms), a stream's packets, and a driver's replies that follow a stream a known
number of packets behind."""

from __future__ import annotations

import numpy as np

from profiles import mc200 as M
from profiles.mc200.follow import commanded_positions
from tests.support.paths import ROOT

EXAMPLE_REPLIES = ROOT / "examples" / "move.mc200.replies.hex"
EXAMPLE_STREAM = ROOT / "examples" / "move.mc200.hex"

POSITION_AT, DURATION = M.ruckig_profile(3200, 20000.0, 2e5, 5e6)
GUIDE_STREAM = M.stream_bytes(POSITION_AT, DURATION, 3200, period_us=1000)

SHORT_STREAM = M.stream_bytes(*M.ruckig_profile(600, 8000.0, 8e4, 8e6), 600, period_us=2000)


def packets_of(data: bytes) -> list[bytes]:
    """A stream's (or a reply log's) 12-byte packets."""
    return [data[i:i + 12] for i in range(0, len(data), 12)]


def lagging_replies(stream: bytes, lag: int, *, period_s: float = 1e-3, origin: int = 0,
                    amps_per_pulse: float = 0.01, alarm_at: int | None = None) -> bytes:
    """A driver `lag` packets behind the command it is given: the encoder at reply k is
    ⌊the command of reply k − lag⌋ (+ `origin`, where the encoder counted from), the
    servo on from the packet after the stream turns it on, in position from `lag`
    replies after the command's end, the current proportional to the error. Written
    straight from the definitions, one reply at a time."""
    reading = M.read_stream(stream)
    n = reading.packets
    commanded = commanded_positions(reading.commands, np.full(n, origin), period_s)
    commanded = np.nan_to_num(commanded, nan=float(origin))
    final = np.flatnonzero(commanded != commanded[-1])
    end = int(final[-1]) + 1 if len(final) else 0
    mode = int(reading.commands.mode[-1])
    out = []
    for k in range(n):
        encoder = int(np.floor(commanded[max(k - lag, 0)]))
        on = reading.servo_on_at is not None and k > reading.servo_on_at
        out.append(M.DriverPacket(
            0, on, k == alarm_at, False, False, encoder,
            amps_per_pulse * float(commanded[k] - encoder), on and k >= end + lag, mode).encode())
    return b"".join(out)

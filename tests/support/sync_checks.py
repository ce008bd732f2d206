"""What the synchronised-axes tests share (tests/profiles/*/sync/, tests/verify/sync/): the
bundled motors by name, and the finish spread and line deviation of PPMC-312 executions
recomputed pulse by pulse, independently of the library."""

from __future__ import annotations

import math

import numpy as np

from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.ppmc312.execution import Execution

MOTORS: list[Motor] = [load_motor(p) for p in bundled_motor_paths()]
NEMA17, NEMA23, PK566 = MOTORS


def pulse_instants(e: Execution) -> list[float]:
    """Every pulse's instant from the segments, one by one (ticks, then seconds)."""
    out = []
    tick = 0
    for s in e.segments:
        for _ in range(s.pulses):
            tick += s.rate
            out.append(tick / e.clock.hz)
    return out


def independent_spread(executions: list[Execution]) -> float:
    """The time between the first and the last axis's last pulse [s]."""
    ends = [pulse_instants(e)[-1] for e in executions]
    return max(ends) - min(ends)


def independent_deviation(a: Execution, b: Execution) -> float:
    """Largest distance of the 2-D joint path from the line, at every pulse instant."""
    t = np.array(sorted(set(pulse_instants(a)) | set(pulse_instants(b))))
    x = np.asarray(a.position_at(t), dtype=float)
    y = np.asarray(b.position_at(t), dtype=float)
    nx, ny = a.pulses, b.pulses
    return float(np.max(np.abs(x * ny - y * nx)) / math.hypot(nx, ny))

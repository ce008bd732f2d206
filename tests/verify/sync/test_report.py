"""verify.sync.report: the line deviation it reports, recomputed here independently."""

from __future__ import annotations

import math

import numpy as np
import pytest

from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.execution import Execution
from profiles.ppmc312.sync import (
    plan_line_sync,
)
from verify.sync import sync_report

MOTORS = [load_motor(p) for p in bundled_motor_paths()]


NEMA17, NEMA23, PK566 = MOTORS


# --------------------------------------------------------------------------- recomputation
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
    ends = [pulse_instants(e)[-1] for e in executions]
    return max(ends) - min(ends)


def independent_deviation(a: Execution, b: Execution) -> float:
    """Largest distance of the 2-D joint path from the line, at every pulse instant."""
    t = np.array(sorted(set(pulse_instants(a)) | set(pulse_instants(b))))
    x = np.asarray(a.position_at(t), dtype=float)
    y = np.asarray(b.position_at(t), dtype=float)
    nx, ny = a.pulses, b.pulses
    return float(np.max(np.abs(x * ny - y * nx)) / math.hypot(nx, ny))


# --------------------------------------------------------------------------- line mode
@pytest.fixture(scope="module")
def line_plan():
    return plan_line_sync([("x", NEMA17, 12_000), ("y", NEMA17, -7_001)])


@pytest.mark.slow  # a line sync (~2 s); CI runs it
def test_line_deviation_recomputed_equals_the_report(line_plan) -> None:
    a, b = (x.execution for x in line_plan.axes)
    ours = independent_deviation(a, b)
    report = sync_report(line_plan, device="ppmc312")
    assert report["max_line_deviation_pulses"] == pytest.approx(ours, rel=1e-9, abs=1e-9)
    assert report["finish_spread_s"] == pytest.approx(independent_spread([a, b]), abs=1e-12)

"""Synchronised axes (issue 11): axes files, time and line synchronisation, ruckig.

Finish spread and line deviation are recomputed here independently of the library:
each axis's pulse instants are rebuilt from its table's execution segments in pure
Python (no pulse_times_s / searchsorted), positions at each instant counted with
Execution.position_at (the segment model), and the distance to the line taken as the
2-D cross product |x·N_y − y·N_x| / |N| (the library projects onto the line).
"""

from __future__ import annotations

import math

import pytest

from profiles.ppmc312.execution import Execution, simulate_move
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.sync import (
    line_deviation,
)
from tests.support.sync_checks import NEMA17


def test_line_deviation_is_zero_for_identical_axes() -> None:
    run = simulate_move(plan_free_curve(NEMA17, pulses=3000).table, 3000)
    assert line_deviation([run, run])[0] == pytest.approx(0.0, abs=1e-9)


def test_line_deviation_of_a_known_path() -> None:
    # x runs all its pulses before y starts: at (Nx, 0) the distance is Nx·Ny/|N|
    fast = simulate_move(plan_free_curve(NEMA17, pulses=400).table, 400)
    late = Execution(shape=fast.shape, status=0, segments=[
        type(fast.segments[0])("cruise", 10_000_000, 1, 0),
        type(fast.segments[0])("cruise", 8000, 299, 10_000_000)],
        pulses=300, clock=fast.clock, high_rate=8000, high_rate_given=False)
    assert line_deviation([fast, late])[0] == pytest.approx(400 * 300 / math.hypot(400, 300),
                                                           rel=1e-12)

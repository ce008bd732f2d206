"""The continuous optimum is a true lower bound of every stall-safe staircase.

This ties the planner, the chip model and the references together: if the
planner ever beat the exact oracle, either the stall criterion, the reference's
limits or the chip model would be wrong.
"""

from __future__ import annotations

import pytest

from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.ppmc312.criterion import check_stall
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.planner import plan_free_curve
from verify.references import exact_optimum

MOTORS = [load_motor(p) for p in bundled_motor_paths()]


@pytest.mark.parametrize("motor", MOTORS, ids=lambda m: m.name[:8])
@pytest.mark.parametrize("pulses", [300, 2_000, 10_000, 100_000, 1_000_000])
def test_planned_table_never_beats_the_optimum(motor: Motor, pulses: int) -> None:
    plan = plan_free_curve(motor, pulses=pulses)
    assert check_stall(plan.table, motor) == []
    run = simulate_move(plan.table, pulses)
    assert run.shape == "trapezoid"
    assert run.duration_s == pytest.approx(plan.duration_s, rel=1e-9)
    assert run.duration_s >= exact_optimum(motor, pulses).duration_s * (1 - 1e-9)

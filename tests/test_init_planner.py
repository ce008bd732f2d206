"""The best stall-safe init tables, the yardstick for what the free curve buys."""

from __future__ import annotations

import pytest

from profiles.errors import InitPlanError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.init_planner import init_candidates, plan_init
from profiles.ppmc312.planner import plan_free_curve
from verify.checks import check_table
from verify.stall import check_stall

MOTORS = [load_motor(p) for p in bundled_motor_paths()]


@pytest.mark.parametrize("motor", MOTORS, ids=lambda m: m.name[:8])
@pytest.mark.parametrize("shape", ["linear", "s_curve"])
def test_init_plans_are_stall_safe_legal_and_best_of_their_candidates(
        motor: Motor, shape: str) -> None:
    cands = init_candidates(motor, shape, highs=8)
    for c in cands:
        assert not [f for f in check_table(c.table) if f.severity == "error"]
        assert check_stall(c.stages, motor) == []
    for pulses in (2_000, 20_000):
        plan = plan_init(motor, shape, pulses, candidates=cands)
        assert plan.duration_s == min(simulate_move(c.stages, pulses).duration_s
                                       for c in cands)
        assert plan.duration_s == simulate_move(plan.extras["stages"], pulses).duration_s
        # The free curve can run any stall-safe staircase, so it is never slower.
        assert plan_free_curve(motor, pulses=pulses).duration_s <= plan.duration_s * 1.0001


def test_counts_are_near_minimal() -> None:
    motor = MOTORS[0]
    cand = init_candidates(motor, "linear", highs=3, separate_decel=False)[0]  # fastest high
    smaller = type(cand.table)(cand.table.clock, "linear", cand.table.start_rate,
                               cand.table.high_rate, int(cand.table.accel_pulses * 0.97))
    from profiles.errors import InitBuildError
    from profiles.ppmc312.init_model import expand_init

    try:
        stages = expand_init(smaller)
    except InitBuildError:
        return  # cannot even be built: certainly not a better candidate
    assert check_stall(stages, motor), "3 % fewer pulses should break the criterion"


def test_bad_shape_is_refused() -> None:
    with pytest.raises(InitPlanError, match="shape"):
        init_candidates(MOTORS[0], "cubic")  # type: ignore[arg-type]

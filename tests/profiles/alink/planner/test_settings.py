"""profiles.alink.planner: the fastest stall-safe A-Link settings for a motor."""

from __future__ import annotations

import pytest

from profiles import alink as A
from profiles.alink.model import quantise_settings
from profiles.alink.planner import Judgement, tighten_settings
from profiles.errors import FieldRangeError, PlanError
from profiles.motor import bundled_motor_paths, load_motor
from profiles.motor.catalogue import resolve

MOTORS = [load_motor(p) for p in bundled_motor_paths()]


def test_plan_long_move_respects_ramp_limit_and_s_curve_is_slower() -> None:
    motor = MOTORS[0]
    long = A.plan_settings(motor, ramp_limit_s=0.1)
    assert long.duration_s is None and long.extras["ramp_time_s"] <= 0.1
    longer = A.plan_settings(motor, ramp_limit_s=1.0)
    assert longer.table.high_pps >= long.table.high_pps
    lin = A.plan_settings(motor, pulses=20000)
    s = A.plan_settings(motor, pulses=20000, s_curve=True)
    assert s.duration_s > lin.duration_s and s.table.s_curve


def test_plan_with_max_speed_uses_one_multiplier() -> None:
    plan = A.plan_settings(MOTORS[1], pulses=5000, max_pps=8000)
    assert plan.table.multiplier == 1 and plan.table.high_pps <= 8000
    with pytest.raises(FieldRangeError, match="pulses"):
        A.plan_settings(MOTORS[0], pulses=0)


def test_plan_ratio_to_optimum() -> None:
    from verify.references import exact_optimum

    for motor in MOTORS:
        plan = A.plan_settings(motor, pulses=20000)
        assert plan.duration_s is not None
        ratio = plan.duration_s / exact_optimum(motor, 20000).duration_s
        # a constant-acceleration unit cannot beat the torque-curve optimum
        assert 1.0 - 1e-3 <= ratio < 3


def test_plan_says_what_binds() -> None:
    motor = MOTORS[0]
    # a move too short to reach any high speed: the ramps meet
    short = A.plan_settings(motor, pulses=2)
    assert short.extras["shape"] == "triangle" and short.binds.startswith("move length")
    # MAX_SPEED below every speed the torque would allow: it is the limit
    capped = A.plan_settings(motor, pulses=100000, max_pps=1000)
    assert capped.table.high_pps == 1000 and capped.binds == "top speed (MAX_SPEED, 1000 pps)"
    # a tight ramp limit holds the long-move setting below the top speed
    long = A.plan_settings(motor, ramp_limit_s=0.01)
    assert long.binds == "ramp time limit (0.01 s)" and long.duration_s is None
    assert long.table.high_pps < A.plan_settings(motor, ramp_limit_s=100).table.high_pps
    # in between, the torque: a higher speed would need a slower ramp
    assert A.plan_settings(motor, pulses=5000).binds.startswith("motor torque")
    assert long.info.startswith(f"×{long.table.multiplier}: start {long.table.start_pps} pps")


def test_nothing_safe_names_what_would_help() -> None:
    motor = load_motor(resolve("nema17-1600"))
    settings = quantise_settings(800, 20000, 5.0)

    def never(_: object) -> Judgement:
        return Judgement(False, 120.0, "start", "a move of 3 pulses")

    with pytest.raises(PlanError, match=r"lower speed limit.*less load inertia.*higher drive"):
        tighten_settings(motor, settings, never, aim_deg=75.0)

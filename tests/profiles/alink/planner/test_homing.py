"""profiles.alink.planner.homing: homing speeds whose every stop is safe for a motor."""

from __future__ import annotations

import dataclasses

import pytest

from profiles import alink as A
from profiles.alink.commands import encode_command
from profiles.alink.planner import Judgement
from profiles.errors import PlanError
from profiles.motor import load_motor
from profiles.motor.catalogue import resolve
from verify.devices.alink import command_findings


# --- homing speeds -----------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["nema17-1600", "nema23-heavy", "pk566-5phase-half"])
def test_homing_speeds_stop_within_the_self_start_speed(name: str) -> None:
    motor = load_motor(name)
    plan = A.plan_homing(motor)
    h = plan.table
    cap = min(motor.start_pps, motor.jump_pps)
    assert 20 <= h.ol_pps <= h.oh_pps <= cap and h.oh_pps > cap - 20
    # run unchanged under every multiplier the unit can pick (speeds and para)
    for m, (lo, hi) in A.PARA_RANGE.items():
        if m <= 20:
            assert h.ol_pps % m == h.oh_pps % m == h.o_uptime_para % m == 0
            assert lo <= h.o_uptime_para <= hi and h.oh_pps // m <= A.STEPS_MAX
    assert "self-start" in plan.binds and plan.extras["model"] in plan.info
    commands = A.homing_commands(h)
    assert [c.name for c in commands] == ["OL_SPEED", "OH_SPEED", "O_UPTIME"]
    assert command_findings([*commands, encode_command("home", nn=1, pair=1)]) == []


def test_homing_under_max_speed_and_refused_without_a_safe_speed() -> None:
    motor = load_motor("nema17-1600")
    low = A.plan_homing(motor, max_pps=333)
    assert low.table.oh_pps == 320 and low.binds == "MAX_SPEED (333 pps)"
    slow = dataclasses.replace(motor, start_pps=39.0, max_jump_pps=None)
    with pytest.raises(PlanError, match=r"up to 39 pps, below 40 pps .*coarser microstep"):
        A.plan_homing(slow)


def test_tighten_homing_lowers_oh_until_the_judge_agrees() -> None:
    from profiles.alink.planner.homing import HomingSettings, tighten_homing

    motor = load_motor(resolve("nema17-1600"))

    def below_500(h: HomingSettings) -> Judgement:
        return Judgement(h.oh_pps <= 500, 80.0 if h.oh_pps > 500 else 60.0, "start", "")

    h, verdict, price = tighten_homing(motor, HomingSettings(200, 800, 200), below_500,
                                       aim_deg=75.0)
    assert h.oh_pps <= 500 and h.oh_pps % 20 == 0 and h.ol_pps <= h.oh_pps
    assert verdict.within_aim and "origin high speed lowered to" in price
    with pytest.raises(PlanError, match="higher drive current"):
        tighten_homing(motor, HomingSettings(200, 800, 200),
                       lambda h: Judgement(False, 99.0, "start", ""), aim_deg=75.0)

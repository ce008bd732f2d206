"""profiles.alink.homing: homing speeds whose every stop is safe for a motor."""

from __future__ import annotations

import dataclasses

import pytest

from profiles import alink as A
from profiles.alink.commands import encode_command
from profiles.errors import PlanError
from profiles.motor import load_motor
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

"""profiles.ppmc312.sync.time_mode: synchronised axes finishing together (time mode)."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles.errors import SyncError
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.sync import (
    plan_time_sync,
    spread_tolerance_s,
)
from profiles.ppmc312.upload import decode_move
from tests.support.sync_checks import NEMA17, NEMA23, PK566, independent_spread, pulse_instants
from verify.criterion import check_stall
from verify.sync import sync_report


# --------------------------------------------------------------------------- time mode
@pytest.fixture(scope="module")
def time_plan():
    return plan_time_sync([("x", NEMA17, 12_000), ("y", PK566, -5_000), ("z", NEMA23, 900)])


@pytest.mark.slow  # a three-axis time sync (~7 s); CI runs it
def test_time_mode_finishes_together(time_plan) -> None:
    exes = [a.execution for a in time_plan.axes]
    spread = independent_spread(exes)
    assert spread == pytest.approx(time_plan.spread_s, abs=1e-12)
    assert spread <= spread_tolerance_s(time_plan.duration_s)
    report = sync_report(time_plan, device="ppmc312")
    assert report["finish_spread_s"] == pytest.approx(spread, abs=1e-12)
    for a, item in zip(time_plan.axes, report["axes"], strict=True):
        assert item["duration_s"] == simulate_move(a.table, abs(a.pulses)).duration_s
        assert item["duration_s"] == pytest.approx(pulse_instants(a.execution)[-1], abs=1e-12)


@pytest.mark.slow  # shares that plan
def test_time_mode_slowest_keeps_its_fastest_table_others_slowed_safely(time_plan) -> None:
    from profiles.motor.angles import AIM_DEG
    from profiles.ppmc312.load_angle import worst_load_angle

    slowest = max(time_plan.axes, key=lambda a: a.fastest_s)
    # the table `stepramp plan` makes: the criterion and the load angle within the aim
    assert slowest.table == plan_free_curve(slowest.motor, pulses=abs(slowest.pulses),
                                            load_angle_deg=AIM_DEG).table
    for a in time_plan.axes:
        assert not check_stall(a.table, a.motor), a.name
        assert worst_load_angle(a.table, a.motor).worst_angle_deg <= AIM_DEG, a.name
        assert a.duration_s >= a.fastest_s - 1e-12
        assert a.execution.shape == "trapezoid"   # same first-pulse latency on every chip
    assert time_plan.duration_s == pytest.approx(time_plan.unsynchronised_s, abs=1e-12)


def test_too_short_an_axis_is_refused() -> None:
    with pytest.raises(SyncError, match="at least 8"):
        plan_time_sync([("x", NEMA17, 1000), ("y", NEMA17, 5)])


def _time_property(nx: int, ratio: float, sign: int) -> None:
    ny = max(8, round(nx * ratio))
    plan = plan_time_sync([("x", NEMA17, nx), ("y", PK566, sign * ny)])
    exes = [a.execution for a in plan.axes]
    assert independent_spread(exes) == pytest.approx(plan.spread_s, abs=1e-12)
    assert plan.spread_s <= spread_tolerance_s(plan.duration_s)
    assert plan.duration_s == pytest.approx(plan.unsynchronised_s, abs=1e-12)
    for a in plan.axes:
        assert not check_stall(a.table, a.motor)


@pytest.mark.slow  # property over planned axes; CI runs it
@settings(max_examples=3, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(nx=st.integers(200, 4_000), ratio=st.floats(0.02, 1.0), sign=st.sampled_from([1, -1]))
def test_time_mode_property_over_pulse_ratios(nx: int, ratio: float, sign: int) -> None:
    _time_property(nx, ratio, sign)


@pytest.mark.slow
@settings(max_examples=10, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(nx=st.integers(200, 40_000), ratio=st.floats(0.005, 1.0), sign=st.sampled_from([1, -1]))
def test_time_mode_property_over_pulse_ratios_wide(nx: int, ratio: float, sign: int) -> None:
    _time_property(nx, ratio, sign)


@pytest.mark.slow  # shares the three-axis time sync
def test_move_commands_carry_the_trigger(time_plan) -> None:
    from profiles.ppmc312.sync import move_command

    for a in time_plan.axes:
        cmd = decode_move(move_command(a))
        assert cmd == {"pulses": abs(a.pulses), "ccw": a.pulses < 0, "high_rate": 0,
                       "override": True, "trigger": 1}

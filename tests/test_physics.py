"""verify.physics: load-angle rotor simulation against the executed staircase."""

from __future__ import annotations

import math

import numpy as np
import pytest

from profiles.errors import FieldRangeError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.table import FreeCurveTable
from verify.physics import STALL_LAG_FULL_STEPS, load_angle_check

MHZ1 = Clock.internal("1MHz")


def nema17() -> Motor:
    return load_motor(next(p for p in bundled_motor_paths() if "nema17" in p.name))


def ramp(lo_pps: float, hi_pps: float, stages: int, pulses_per_stage: int) -> FreeCurveTable:
    speeds = np.linspace(hi_pps, lo_pps, stages)  # fastest first
    rates = tuple(round(float(MHZ1.hz / v)) for v in speeds)
    return FreeCurveTable(MHZ1, rates, (pulses_per_stage,) * stages)


def flat_motor(friction_nm: float, **kw: object) -> Motor:
    # 0.4 N·m up to 2000 pps, falling linearly to 0.05 N·m at 4000 pps.
    return Motor(steps_per_rev=1600, curve_speed_pps=np.array([0.0, 2000.0, 4000.0]),
                 curve_torque_nm=np.array([0.4, 0.4, 0.05]), inertia_kgm2=6.8e-6,
                 safety_factor=1.0, start_pps=500.0, friction_torque_nm=friction_nm,
                 **kw)  # type: ignore[arg-type]


def test_gentle_table_does_not_stall_and_lag_stays_small() -> None:
    e = simulate_move(ramp(400, 4000, 40, 100), 20_000)
    r = load_angle_check(e, nema17())
    assert not r.stalled and r.stall_time_s is None
    assert abs(r.worst_lag_full_steps) < 0.1
    assert np.all(np.abs(r.lag_full_steps) <= abs(r.worst_lag_full_steps))
    assert r.lag_t_s[0] == 0 and np.all(np.diff(r.lag_t_s) > 0)
    assert r.lag_t_s[-1] >= e.duration_s  # followed to the end of the move and beyond


def test_violent_jump_from_rest_stalls_early() -> None:
    e = simulate_move(FreeCurveTable(MHZ1, (50, 60), (100, 100)), 1000)  # 16.7 kpps at once
    r = load_angle_check(e, nema17())
    assert r.stalled and r.stall_time_s is not None
    assert 0 < r.stall_time_s < 0.002
    assert abs(r.lag_full_steps[-1]) > STALL_LAG_FULL_STEPS
    assert r.worst_lag_full_steps > STALL_LAG_FULL_STEPS  # behind the command


def test_lag_sign_behind_when_accelerating_ahead_when_decelerating() -> None:
    # No friction, so only inertia sets the sign: behind the command while it
    # speeds up, ahead of it while it slows down.
    e = simulate_move(ramp(400, 3000, 10, 200), 6000)
    r = load_angle_check(e, flat_motor(0.0))
    accel_end = next(s.end_tick for s in e.segments if s.phase == "cruise") / MHZ1.hz
    decel_start = next(s.start_tick for s in e.segments if s.phase == "decel") / MHZ1.hz
    during_accel = r.lag_full_steps[(r.lag_t_s > 0) & (r.lag_t_s < accel_end * 0.3)]
    during_decel = r.lag_full_steps[(r.lag_t_s > decel_start) & (r.lag_t_s < e.duration_s)]
    assert during_accel.mean() > 0 and during_decel.mean() < 0
    assert not r.stalled


def test_settled_cruise_lag_matches_the_steady_state_law() -> None:
    # At a steady speed the restoring torque balances friction:
    # T_amp(v)·sin δ = T_f with T_amp = T_pullout / sin 45°, δ = lag · 90°.
    motor = flat_motor(0.1)
    e = simulate_move(ramp(400, 3000, 30, 100), 400_000)
    r = load_angle_check(e, motor)
    assert not r.stalled
    cruise = next(s for s in e.segments if s.phase == "cruise")
    t_end = cruise.end_tick / MHZ1.hz
    lag_end = r.lag_full_steps[np.searchsorted(r.lag_t_s, t_end) - 1]
    t_amp = float(motor.torque_nm(MHZ1.hz / cruise.rate)) / math.sin(math.pi / 4)
    expect = math.asin(0.1 / t_amp) / (math.pi / 2)
    assert lag_end == pytest.approx(expect, rel=1e-2)
    # The cruise was skipped once settled: far fewer samples than RK4 steps over it.
    inside = (r.lag_t_s > cruise.start_tick / MHZ1.hz) & (r.lag_t_s < t_end)
    assert inside.sum() < 0.2 * (t_end - cruise.start_tick / MHZ1.hz) / 1e-5


def test_stall_exactly_where_the_load_exceeds_pullout_torque() -> None:
    # Friction 0.1 N·m: the pull-out torque is 0.1 at 3714 pps. A cruise at 3000 pps
    # holds; one at 3900 pps (pull-out 0.0675 N·m) loses the rotor.
    motor = flat_motor(0.1)
    ok = load_angle_check(simulate_move(ramp(400, 3000, 30, 100), 20_000), motor)
    fast = simulate_move(ramp(400, 3900, 40, 100), 20_000)
    bad = load_angle_check(fast, motor)
    assert not ok.stalled and bad.stalled and bad.stall_time_s is not None
    # It slips only once the command is past the speed where pull-out = friction.
    crossing_pps = 2000 + (0.4 - 0.1) / (0.35 / 2000)
    assert fast.speed_at(bad.stall_time_s) > crossing_pps


def test_holding_torque_caps_the_restoring_torque() -> None:
    e = simulate_move(ramp(400, 2000, 10, 100), 3000)
    free = load_angle_check(e, flat_motor(0.1))
    capped = load_angle_check(e, flat_motor(0.1, holding_torque_nm=0.3))
    # A weaker restoring torque needs a larger lag for the same friction.
    assert abs(capped.worst_lag_full_steps) > abs(free.worst_lag_full_steps)


def test_rotor_teeth_changes_the_electrical_scale() -> None:
    e = simulate_move(ramp(400, 2000, 10, 100), 3000)
    fifty = load_angle_check(e, flat_motor(0.1))
    explicit = load_angle_check(e, flat_motor(0.1, rotor_teeth=50))
    assert fifty.worst_lag_full_steps == explicit.worst_lag_full_steps
    other = load_angle_check(e, flat_motor(0.1, rotor_teeth=100))
    assert other.worst_lag_full_steps != fifty.worst_lag_full_steps


def test_deterministic_and_finer_steps_agree() -> None:
    e = simulate_move(ramp(400, 3000, 10, 200), 6000)
    a = load_angle_check(e, nema17())
    b = load_angle_check(e, nema17())
    assert a.worst_lag_full_steps == b.worst_lag_full_steps
    assert np.array_equal(a.lag_full_steps, b.lag_full_steps)
    fine = load_angle_check(e, nema17(), max_step_s=5e-6)
    assert fine.worst_lag_full_steps == pytest.approx(a.worst_lag_full_steps, rel=1e-3)


def test_bad_arguments() -> None:
    e = simulate_move(ramp(400, 2000, 4, 100), 1000)
    with pytest.raises(FieldRangeError, match="max_step_s"):
        load_angle_check(e, nema17(), max_step_s=0.0)
    with pytest.raises(FieldRangeError, match="damping_ratio"):
        load_angle_check(e, nema17(), damping_ratio=-1)

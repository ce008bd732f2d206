"""profiles.ppmc312.load_angle_trace and profiles.motor.rotor: the load angle (electrical
degrees) of executions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from profiles.errors import FieldRangeError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import move_families, simulate_move
from profiles.ppmc312.load_angle import worst_load_angle
from profiles.ppmc312.load_angle_trace import trace_load_angle
from profiles.ppmc312.table import FreeCurveTable

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


def test_gentle_table_stays_far_from_the_peak() -> None:
    e = simulate_move(ramp(400, 4000, 40, 100), 20_000)
    r = trace_load_angle(e, nema17())
    assert not r.slipped and r.slip_time_s is None and r.stable
    assert abs(r.worst_angle_deg) < 10 and r.margin_deg > 80
    assert np.all(np.abs(r.angle_deg) <= abs(r.worst_angle_deg))
    assert r.lag_t_s[0] == 0 and np.all(np.diff(r.lag_t_s) > 0)
    assert r.lag_t_s[-1] >= e.duration_s  # followed to the end of the move and beyond


def test_violent_jump_from_rest_slips_a_pole_early() -> None:
    e = simulate_move(FreeCurveTable(MHZ1, (25, 30), (100, 100)), 1000)  # 33 kpps at once
    r = trace_load_angle(e, nema17())
    assert r.slipped and r.slip_time_s is not None and not r.stable
    assert 0 < r.slip_time_s < 0.002
    assert abs(r.angle_deg[-1]) > 180
    assert r.worst_angle_deg > 180  # behind the command


def test_lag_sign_behind_when_accelerating_ahead_when_decelerating() -> None:
    # No friction, so only inertia sets the sign: behind the command while it
    # speeds up, ahead of it while it slows down.
    e = simulate_move(ramp(400, 3000, 10, 200), 6000)
    r = trace_load_angle(e, flat_motor(0.0))
    accel_end = next(s.end_tick for s in e.segments if s.phase == "cruise") / MHZ1.hz
    decel_start = next(s.start_tick for s in e.segments if s.phase == "decel") / MHZ1.hz
    during_accel = r.angle_deg[(r.lag_t_s > 0) & (r.lag_t_s < accel_end * 0.3)]
    during_decel = r.angle_deg[(r.lag_t_s > decel_start) & (r.lag_t_s < e.duration_s)]
    assert during_accel.mean() > 0 and during_decel.mean() < 0
    assert not r.slipped


def test_settled_cruise_angle_matches_the_steady_state_law() -> None:
    # At a steady speed the restoring torque balances friction: T_pullout(v)·sin δ = T_f,
    # the pull-out torque being the peak of the torque–angle curve (at 90° electrical).
    motor = flat_motor(0.1)
    e = simulate_move(ramp(400, 3000, 30, 100), 400_000)
    r = trace_load_angle(e, motor)
    assert not r.slipped
    cruise = next(s for s in e.segments if s.phase == "cruise")
    t_end = cruise.end_tick / MHZ1.hz
    angle_end = r.angle_deg[np.searchsorted(r.lag_t_s, t_end) - 1]
    t_pullout = 0.4 - 0.35 * (MHZ1.hz / cruise.rate - 2000) / 2000  # the curve, by hand
    assert angle_end == pytest.approx(math.degrees(math.asin(0.1 / t_pullout)), rel=1e-2)
    # The cruise was skipped once settled: far fewer samples than RK4 steps over it.
    inside = (r.lag_t_s > cruise.start_tick / MHZ1.hz) & (r.lag_t_s < t_end)
    assert inside.sum() < 0.2 * (t_end - cruise.start_tick / MHZ1.hz) / 1e-5


def test_slips_exactly_where_the_load_exceeds_pullout_torque() -> None:
    # Friction 0.1 N·m: the pull-out torque is 0.1 at 3714 pps. A cruise at 3000 pps
    # holds; one at 3900 pps (pull-out 0.0675 N·m) loses the rotor.
    motor = flat_motor(0.1)
    ok = trace_load_angle(simulate_move(ramp(400, 3000, 30, 100), 20_000), motor)
    fast = simulate_move(ramp(400, 3900, 40, 100), 20_000)
    bad = trace_load_angle(fast, motor)
    assert not ok.slipped and ok.stable and bad.slipped and bad.slip_time_s is not None
    crossing_pps = 2000 + (0.4 - 0.1) / (0.35 / 2000)
    assert fast.speed_at(bad.slip_time_s) > crossing_pps


def test_holding_torque_caps_the_restoring_torque() -> None:
    e = simulate_move(ramp(400, 2000, 10, 100), 3000)
    free = trace_load_angle(e, flat_motor(0.1))
    capped = trace_load_angle(e, flat_motor(0.1, holding_torque_nm=0.3))
    # A weaker restoring torque needs a larger angle for the same friction.
    assert abs(capped.worst_angle_deg) > abs(free.worst_angle_deg)


def test_electrical_degrees_compare_two_and_five_phase() -> None:
    # The same rotor (50 teeth) and the same mechanical move: the angle in electrical
    # degrees is the same whatever the phase count; in full steps it is 2.5× larger for
    # the 5-phase motor (a full step is 36° there, 90° for 2 phases).
    e = simulate_move(ramp(400, 2000, 10, 100), 3000)
    two = trace_load_angle(e, flat_motor(0.1))
    five = trace_load_angle(e, flat_motor(0.1, phases=5))
    assert five.worst_angle_deg == two.worst_angle_deg
    assert five.worst_lag_full_steps == pytest.approx(2.5 * two.worst_lag_full_steps)
    other = trace_load_angle(e, flat_motor(0.1, rotor_teeth=100))
    assert other.worst_angle_deg != two.worst_angle_deg


def test_load_torque_acts_against_forward_moves_and_with_backward_ones() -> None:
    e = simulate_move(ramp(400, 2000, 10, 100), 3000)
    loaded = flat_motor(0.02, load_torque_nm=0.1)
    fwd = trace_load_angle(e, loaded, direction=1)
    back = trace_load_angle(e, loaded, direction=-1)
    plain = trace_load_angle(e, flat_motor(0.02))
    assert fwd.worst_angle_deg > plain.worst_angle_deg > 0
    # at rest after a backward move the load pulls the rotor ahead: sin δ = −T_L/T_hold
    # minus what static friction holds
    assert back.angle_deg[-1] < 0
    verdict = worst_load_angle(ramp(400, 2000, 10, 100), loaded, pulses=[3000])
    assert verdict.worst_angle_deg == pytest.approx(
        max(abs(fwd.worst_angle_deg), abs(back.worst_angle_deg)), rel=1e-6)


def test_judging_every_family_agrees_with_direct_simulation() -> None:
    # The shared-prefix/rejoin shortcut gives the same worst angle as integrating each
    # execution on its own (within the rejoin tolerance)
    table = FreeCurveTable(MHZ1, (400, 500, 700, 1000, 1600, 2500), (30, 40, 40, 50, 60, 80),
                           (20, 25, 30, 45, 60, 80))
    motor = nema17()
    for fam in move_families(table)[:: 3]:
        run = fam.execution()
        direct = abs(trace_load_angle(run, motor).worst_angle_deg)
        shared = worst_load_angle(table, motor, pulses=[run.pulses]).worst_angle_deg
        assert shared == pytest.approx(direct, abs=0.02)
    every = worst_load_angle(table, motor)
    worst_direct = max(abs(trace_load_angle(f.execution(), motor).worst_angle_deg)
                       for f in move_families(table))
    assert every.worst_angle_deg >= worst_direct - 0.02


def test_deterministic_and_finer_steps_agree() -> None:
    e = simulate_move(ramp(400, 3000, 10, 200), 6000)
    a = trace_load_angle(e, nema17())
    b = trace_load_angle(e, nema17())
    assert a.worst_angle_deg == b.worst_angle_deg
    assert np.array_equal(a.angle_deg, b.angle_deg)
    fine = trace_load_angle(e, nema17(), max_step_s=5e-6)
    assert fine.worst_angle_deg == pytest.approx(a.worst_angle_deg, rel=1e-3)


def test_bad_arguments() -> None:
    e = simulate_move(ramp(400, 2000, 4, 100), 1000)
    with pytest.raises(FieldRangeError, match="max step"):
        trace_load_angle(e, nema17(), max_step_s=0.0)
    with pytest.raises(FieldRangeError, match="damping_ratio"):
        flat_motor(0.1, damping_ratio=-1)


def test_a_verdict_that_would_take_too_long_is_refused_in_one_line(
        monkeypatch: pytest.MonkeyPatch, tmp_path) -> None:  # type: ignore[no-untyped-def]
    # the step budget of one verdict, lowered so that an ordinary table exhausts it: the
    # answer is a one-line refusal (the CLI's exit 2), never a hang
    from profiles.errors import StepRampError
    from profiles.motor import batch_angle
    from profiles.ppmc312.table import dump_table
    from verify.cli import main

    monkeypatch.setattr(batch_angle, "MAX_VERDICT_STEPS", 2_000)
    table = ramp(400, 4000, 40, 100)
    with pytest.raises(StepRampError, match="too stiff, or too lightly damped"):
        worst_load_angle(table, nema17())
    path = tmp_path / "t.table.json"
    path.write_text(dump_table(table))
    motor = next(p for p in bundled_motor_paths() if "nema17" in p.name)
    assert main(["check", str(path), "--motor", str(motor)]) == 2


@pytest.mark.parametrize(("worst_deg", "stable"), [(89.99, True), (90.0, False), (-90.0, False),
                                                   (-45.0, True)])
def test_a_trace_at_the_90_degree_peak_is_not_stable(worst_deg: float, stable: bool) -> None:
    """At 90° the torque is at its peak: any more load and the rotor falls back."""
    from profiles.ppmc312.load_angle_trace import LoadAngleTrace

    none = np.zeros(0)
    trace = LoadAngleTrace(worst_deg, 0.0, False, None, none, none, 90.0)
    assert trace.stable is stable
    assert trace.to_json()["stable"] is stable


def test_a_trace_runs_forward_unless_told_otherwise() -> None:
    """With a load torque the two directions differ; the default is the forward move."""
    from dataclasses import replace

    motor = replace(load_motor(bundled_motor_paths()[0]), load_torque_nm=0.05)
    table = FreeCurveTable(Clock.internal("8MHz"), (4000, 8000), (20, 20), None)
    run = simulate_move(table, 200)
    forward = trace_load_angle(run, motor, direction=1).worst_angle_deg
    assert trace_load_angle(run, motor).worst_angle_deg == forward
    assert trace_load_angle(run, motor, direction=-1).worst_angle_deg != forward

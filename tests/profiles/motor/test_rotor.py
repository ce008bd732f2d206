"""profiles.motor.rotor: the rotor model (load angle in electrical degrees) against the
plain-Python oracle (tests/support/rotor_oracle.py), step by step."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles.motor import Motor
from profiles.motor.rotor import (
    MAX_SETTLE_PERIODS,
    SLIP_DEG,
    STEPS_PER_NATURAL_PERIOD,
    follow,
    rotor_of,
    rotors,
    settle_s,
)
from profiles.motor.tolerance import variant
from profiles.ppmc312.load_angle import worst_load_angle
from profiles.ppmc312.table import FreeCurveTable
from tests.support import rotor_oracle as oracle
from tests.support.oracle_moves import worst_whole_move
from tests.support.stand_ins import plain_motor
from tests.support.strategies import MHZ1
from tests.support.strategies import rotor_motors as motors
from tests.support.strategies import rotor_tables as tables

AGREE_DEG = 0.1   # the kernel and the oracle: the bound (they agree to rounding)


SETTINGS = settings(max_examples=25, suppress_health_check=[HealthCheck.too_slow])


def deg(rotor_c_e: float, lag: float) -> float:
    return math.degrees(rotor_c_e * lag)


@SETTINGS
@given(motors(), st.lists(st.tuples(st.floats(0.01, 3.0), st.floats(0, 30_000)),
                          min_size=1, max_size=12), st.sampled_from([1, -1]))
def test_kernel_is_the_oracle_span_by_span(motor: Motor, periods: list[tuple[float, float]],
                                           direction: int) -> None:
    """Spans of 0.01..3 natural periods at any speed, then rest: the same lag at every
    step as the plain-Python integrator."""
    rotor = rotor_of(motor, direction=direction)
    step = rotor.step_s()
    period = rotor.natural_period_s(0.0)
    spans = [*((n * period, v) for n, v in periods), (settle_s(rotor, step), 0.0)]
    fast = follow(rotor, spans, step_s=step)
    slow = oracle.follow(rotor, spans, step_s=step)
    assert fast.slipped == slow.slipped
    assert len(fast.span_max) == len(slow.span_max)
    for a, b in zip(fast.span_max, slow.span_max, strict=True):
        assert abs(deg(rotor.c_e, a) - deg(rotor.c_e, b)) <= AGREE_DEG
    for (lag, _), fl in zip(slow.boundary, fast.boundary_lag, strict=True):
        assert abs(deg(rotor.c_e, fl) - deg(rotor.c_e, lag)) <= AGREE_DEG
    assert fast.steps == slow.steps
    np.testing.assert_allclose(fast.lag, slow.lag, atol=math.radians(AGREE_DEG) / rotor.c_e)


@pytest.mark.slow
@settings(max_examples=15, suppress_health_check=[HealthCheck.too_slow])
@given(motors(), st.data())
def test_a_move_judged_through_shared_prefixes_is_the_oracles_whole_move(
        motor: Motor, data: st.DataObject) -> None:
    """Moves judged from where they part from the longest one until they rejoin it, as
    the verdict does, against each integrated whole by the oracle."""
    table = data.draw(tables(0.9 * motor.top_curve_pps))
    top = min(table.accel_total + table.decel_total + 30, 80)
    lengths = data.draw(st.lists(st.integers(1, top), min_size=1, max_size=3, unique=True))
    for n in lengths:
        fast = worst_load_angle(table, motor, pulses=[n]).worst_angle_deg
        if fast < SLIP_DEG:
            assert fast == pytest.approx(worst_whole_move(table, motor, n), abs=AGREE_DEG)


def test_the_rotor_slips_a_pole_where_the_lag_first_passes_180_degrees() -> None:
    """Driven at 30 kpps from rest it cannot follow: the slip is reported at the first
    step past 180° electrical (not 360°), and every earlier step is within 180°."""
    rotor = rotor_of(plain_motor())
    step = rotor.step_s()
    trace = follow(rotor, [(3e-3, 30_000.0)], step_s=step)
    assert trace.slipped and trace.slip_time_s is not None
    angle = np.degrees(rotor.c_e * np.abs(trace.lag))
    before = trace.t_s < trace.slip_time_s - 1e-12
    assert angle[before].max() <= SLIP_DEG < angle[-1]
    assert trace.t_s[-1] == pytest.approx(trace.slip_time_s)


@pytest.mark.parametrize("speed_pps", [0.5, 500.0, 5000.0])
def test_friction_makes_the_rotor_lag_at_a_steady_speed(speed_pps: float) -> None:
    """At a constant speed, moving (even at half a pulse per second) the rotor needs
    sin δ = T_f / T_pk(v) to overcome friction: it lags behind the field by that angle."""
    motor = plain_motor(friction_torque_nm=0.08, damping_ratio=0.7)
    rotor = rotor_of(motor)
    step = rotor.step_s()
    long_s = 0.5 + 4 / speed_pps  # the lag it needs is about a pulse: time to build it
    trace = follow(rotor, [(long_s, speed_pps)], step_s=step)
    expected = math.asin(0.08 / float(motor.torque_nm(speed_pps)))
    assert rotor.c_e * trace.boundary_lag[-1] == pytest.approx(expected, abs=1e-3)
    backward = follow(rotor, [(long_s, -speed_pps)], step_s=step)
    assert rotor.c_e * backward.boundary_lag[-1] == pytest.approx(-expected, abs=1e-3)


def test_a_load_torque_pulls_the_rotor_back_forward_and_ahead_backward() -> None:
    motor = plain_motor(load_torque_nm=0.1, damping_ratio=0.7)
    expected = math.asin(0.1 / 0.4)
    for direction, sign in ((1, 1), (-1, -1)):
        rotor = rotor_of(motor, direction=direction)
        trace = follow(rotor, [(0.5, 1000.0)], step_s=rotor.step_s())
        assert rotor.c_e * trace.boundary_lag[-1] == pytest.approx(sign * expected, abs=1e-3)


def test_static_friction_holds_a_small_lag_at_rest() -> None:
    """At rest, a lag whose restoring torque is below the friction stays where it is; a
    larger one is pulled back until friction holds it (never past zero and beyond)."""
    motor = plain_motor(friction_torque_nm=0.1)
    rotor = rotor_of(motor)
    small = math.asin(0.05 / 0.4) / rotor.c_e
    held = follow(rotor, [(0.05, 0.0)], step_s=rotor.step_s(), state=(small, 0.0))
    assert held.boundary_lag[-1] == pytest.approx(small)
    big = math.asin(0.3 / 0.4) / rotor.c_e
    back = follow(rotor, [(0.2, 0.0)], step_s=rotor.step_s(), state=(big, 0.0))
    assert abs(back.boundary_lag[-1]) <= math.asin(0.1 / 0.4) / rotor.c_e + 1e-9


def test_the_start_state_is_lag_then_its_rate() -> None:
    """state=(L, s): released from a lag of 30° with no lag rate the rotor swings through
    zero to about −30° (lightly damped); with (0, s) it starts at zero lag."""
    rotor = rotor_of(plain_motor(damping_ratio=0.0))
    lag0 = math.radians(30.0) / rotor.c_e
    trace = follow(rotor, [(rotor.natural_period_s(0.0), 0.0)], step_s=rotor.step_s(),
                   state=(lag0, 0.0))
    assert trace.lag[0] == pytest.approx(lag0)
    assert np.degrees(rotor.c_e * trace.lag).min() == pytest.approx(-30.0, abs=0.5)
    moving = follow(rotor, [(1e-4, 0.0)], step_s=rotor.step_s(), state=(0.0, 100.0))
    assert moving.lag[0] == 0.0 and moving.lag[-1] > 0.0


def test_after_the_last_pulse_the_rotor_is_followed_long_enough_to_settle() -> None:
    """The rest after a move lasts MAX_SETTLE_PERIODS natural periods (at least as many
    windows of 50 steps), so even a lightly damped rotor has settled by its end."""
    rotor = rotor_of(plain_motor())
    step = rotor.step_s()
    period = rotor.natural_period_s(0.0)
    assert settle_s(rotor, step) == pytest.approx(MAX_SETTLE_PERIODS * period)
    assert settle_s(rotor, step / 10) == pytest.approx(MAX_SETTLE_PERIODS * period)
    coarse = 4 * period / STEPS_PER_NATURAL_PERIOD
    assert settle_s(rotor, coarse) == pytest.approx(MAX_SETTLE_PERIODS * 4 * period)


def test_damping_comes_from_the_stiffness_at_rest_whatever_the_curve_ends_at() -> None:
    """D = 2ζω_n with ω_n the small-signal frequency at rest (the curve's first point),
    also for a curve falling to 0 torque at its last point."""
    motor = plain_motor(curve_torque_nm=np.array([0.4, 0.4, 0.32, 0.0]), damping_ratio=0.3)
    rotor = rotor_of(motor)
    omega_n = 2 * math.pi / rotor.natural_period_s(0.0)
    assert rotor.damping_per_s == pytest.approx(2 * 0.3 * omega_n)
    assert rotor.damping_per_s > 0


def test_box_rows_for_a_motor_with_no_tolerances_are_its_rotor() -> None:
    motor = plain_motor(load_torque_nm=0.02)
    assert rotors(motor, direction=-1).rotor(0) == rotor_of(motor, direction=-1)
    assert rotors(motor, {"torque_scale": [0.8]}).rotor(0) == rotor_of(
        variant(motor, {"torque_scale": 0.8}))


def test_a_slow_rotor_is_followed_at_most_400_seconds_at_a_fine_step() -> None:
    """The rest counts natural periods of at most 1 s: a rotor with a 4 s period at rest,
    followed with a step ten times finer than its own, rests 400 s, not 1 600."""
    rotor = rotor_of(plain_motor())
    slow = replace(rotor, k=rotor.k * (rotor.natural_period_s(0.0) / 4.0) ** 2)
    assert slow.natural_period_s(0.0) == pytest.approx(4.0)
    assert settle_s(slow, slow.step_s() / 10) == pytest.approx(MAX_SETTLE_PERIODS * 1.0)
    assert settle_s(slow, slow.step_s()) == pytest.approx(MAX_SETTLE_PERIODS * 4.0)


def test_the_periods_at_rest_are_each_rotors_own_or_none_off_a_curve_from_rest() -> None:
    """`Rotors.periods_at_rest_s`: every row's `natural_period_s(0.0)` at once when the
    curve starts at 0 pps; None (ask each rotor) when it starts above, or is empty."""
    box = rotors(plain_motor(), {"torque_scale": [0.8, 1.0, 1.2]})
    periods = box.periods_at_rest_s()
    assert periods is not None
    assert periods == pytest.approx([box.rotor(i).natural_period_s(0.0)
                                     for i in range(len(box))], rel=1e-12)
    assert replace(box, curve_v=box.curve_v + 100.0).periods_at_rest_s() is None
    assert replace(box, curve_v=box.curve_v[:0]).periods_at_rest_s() is None


def test_the_rk4_step_is_a_fiftieth_and_the_rest_four_hundred_natural_periods() -> None:
    """The step is 1/50 of the natural period at rest; the rest after a move lasts 400
    natural periods (the module docstring's numbers)."""
    rotor = rotor_of(plain_motor())
    period = rotor.natural_period_s(0.0)
    assert rotor.step_s() == pytest.approx(period / 50, rel=1e-12)
    assert settle_s(rotor, rotor.step_s()) == pytest.approx(400 * period, rel=1e-12)


def test_the_natural_period_at_rest_is_that_of_the_rotor_teeth_stiffness() -> None:
    """Small-signal stiffness at rest Nr·T_pk(0) [N·m/rad] against the inertia J:
    ω_n = √(Nr·T(0)/J), 2- and 5-phase alike (the load angle is Nr × the rotor's angle);
    the damping is 2ζω_n from that same first curve point, not the second."""
    for steps, teeth, phases in ((1600, 50, 2), (1000, 50, 5), (400, 100, 2)):
        motor = plain_motor(steps_per_rev=steps, rotor_teeth=teeth, phases=phases,
                            curve_torque_nm=np.array([0.5, 0.4, 0.32, 0.04]),
                            damping_ratio=0.25)
        rotor = rotor_of(motor)
        omega_n = math.sqrt(teeth * 0.5 / 6.8e-6)
        assert rotor.natural_period_s(0.0) == pytest.approx(2 * math.pi / omega_n, rel=1e-9)
        assert rotor.damping_per_s == pytest.approx(2 * 0.25 * omega_n, rel=1e-9)


def test_a_span_of_no_duration_takes_no_step() -> None:
    rotor = rotor_of(plain_motor())
    step = rotor.step_s()
    plain = follow(rotor, [(2e-3, 500.0)], step_s=step)
    with_empty = follow(rotor, [(0.0, 500.0), (2e-3, 500.0)], step_s=step)
    assert with_empty.steps == plain.steps
    np.testing.assert_array_equal(with_empty.lag, plain.lag)


def test_a_run_past_its_step_budget_is_refused_naming_it() -> None:
    """`max_steps` RK4 steps at most: a run that needs more is refused (a verdict that
    would take minutes)."""
    from profiles.errors import StepRampError

    rotor = rotor_of(plain_motor(damping_ratio=0.0))
    step = rotor.step_s()
    long_span = [(200 * step, 300.0)]  # 200 steps
    assert follow(rotor, long_span, step_s=step, max_steps=201).steps == 200
    for record in (True, False):
        with pytest.raises(StepRampError, match="more than 200 RK4 steps"):
            follow(rotor, long_span, step_s=step, max_steps=200, record=record)

    # more spans than the budget has steps: refused the same way (its recording buffers
    # are sized by the spans and the budget together, never below what it may record)
    many_spans = [(3 * step, 300.0 + i) for i in range(5)]
    with pytest.raises(StepRampError, match="more than 3 RK4 steps"):
        follow(rotor, many_spans, step_s=step, max_steps=3, record=True)
    whole = follow(rotor, many_spans, step_s=step, max_steps=16)
    assert whole.steps == 15 and len(whole.t_s) == 16  # the start and every step


def test_the_default_step_budget_is_two_million_steps() -> None:
    from profiles.errors import StepRampError

    rotor = rotor_of(plain_motor(damping_ratio=0.0))
    step = rotor.step_s()
    period = rotor.natural_period_s(0.0)
    # undamped, each span skipped after 400 windows of a period (20 000 steps)
    many = [(1000 * period, 300.0 * (k % 2)) for k in range(130)]
    assert follow(rotor, many, step_s=step, record=False, max_steps=10**8).steps > 2_000_000
    with pytest.raises(StepRampError, match="more than 2000000 RK4 steps"):
        follow(rotor, many, step_s=step, record=False)


def test_a_coarse_step_settles_by_windows_of_at_least_8_steps_like_the_oracle() -> None:
    """With a step of a quarter natural period the settling window is its floor of 8
    steps; a speed past the curve (no restoring torque) never settles within a span; an
    undamped rotor is skipped after 400 windows. The kernel takes the oracle's steps."""
    damped = rotor_of(plain_motor(damping_ratio=0.7))
    undamped = rotor_of(plain_motor(damping_ratio=0.0))  # skipped after 400 windows
    period = damped.natural_period_s(0.0)
    for rotor, step, spans in (
            (damped, period / 4, [(40 * period, 800.0), (40 * period, 0.0)]),
            (damped, period / 50, [(1e-3, 800.0), (0.02, 60_000.0)]),
            (undamped, period / 20, [(600 * period, 300.0)])):
        fast = follow(rotor, spans, step_s=step)
        slow = oracle.follow(rotor, spans, step_s=step)
        assert fast.steps == slow.steps
        np.testing.assert_allclose(fast.lag, slow.lag, atol=1e-9, rtol=1e-9)


def test_rotor_sets_stack_only_alike_rotors_and_broadcast_their_parameters() -> None:
    """Rotors judged together share their curve speeds and c_e (else refused); a
    parameter array and a scalar give one row per array value."""
    from profiles.motor.rotor import Rotors

    base = rotors(plain_motor())
    other_speeds = rotors(plain_motor(curve_speed_pps=np.array([0.0, 2000.0, 9000.0,
                                                                 48000.0])))
    other_teeth = rotors(plain_motor(rotor_teeth=100))
    for odd in (other_speeds, other_teeth):
        for parts in ([base, odd], [odd, base], [base, base, odd]):
            with pytest.raises(ValueError, match="share their curve speeds and c_e"):
                Rotors.stack(parts)
    assert len(Rotors.stack([base, base, base])) == 3
    rows = rotors(plain_motor(), {"torque_scale": [0.8, 0.9, 1.0], "inertia_kgm2": 1e-5})
    assert len(rows) == 3
    assert rows.rotor(2) == rotor_of(variant(plain_motor(), {"inertia_kgm2": 1e-5}))


def test_rotors_and_traces_are_values() -> None:
    """A rotor is immutable and hashable (a cache key); rotor sets and traces are
    immutable."""
    import dataclasses

    rotor = rotor_of(plain_motor())
    assert hash(rotor) == hash(rotor_of(plain_motor()))
    trace = follow(rotor, [(1e-3, 100.0)], step_s=rotor.step_s())
    for value, attr in ((rotor, "k"), (rotors(plain_motor()), "c_e"), (trace, "steps")):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(value, attr, 1)


def test_a_span_shorter_than_a_step_is_one_step() -> None:
    """Half a step of command is one RK4 step of that length, recorded; a budget of one
    step is already spent by it (refused), whatever is recorded."""
    from profiles.errors import StepRampError

    rotor = rotor_of(plain_motor())
    step = rotor.step_s()
    trace = follow(rotor, [(step / 2, 100.0)], step_s=step)
    assert trace.steps == 1 and len(trace.lag) == 2
    assert trace.t_s[-1] == pytest.approx(step / 2)
    for record in (True, False):
        with pytest.raises(StepRampError, match="more than 1 RK4 steps"):
            follow(rotor, [(step / 2, 100.0)], step_s=step, max_steps=1, record=record)


def test_families_are_sampled_every_eighth_period_and_cruise_ten_periods() -> None:
    """Within a family only partial stages and the cruise change length: lengths are
    taken every 1/8 natural period of dwell at the slowest changing segment's speed, and
    a trapezoid family is judged up to a cruise of 10 natural periods at its top speed
    (1 s at most): longer cruises repeat that settled state."""
    from profiles.ppmc312.execution import move_families
    from profiles.ppmc312.load_angle import samples

    motor = plain_motor(damping_ratio=0.3)
    rotor = rotor_of(motor)
    table = FreeCurveTable(MHZ1, (100, 200, 400, 800), (40, 30, 20, 10))
    lengths, family, spacing = samples(table, [motor])
    fams = move_families(table)
    trapezoid = next(i for i, f in enumerate(fams) if f.shape == "trapezoid" and f.hi > f.lo)
    top = MHZ1.hz / fams[trapezoid].cruise_rate
    cruise = math.ceil(top * 10 * min(rotor.natural_period_s(top), 1.0))
    assert lengths[family == trapezoid].max() == fams[trapezoid].lo + cruise
    # the family whose slowest changing stage is the 800-rate one (1250 pps): 1/8 period
    slow = next(i for i, f in enumerate(fams) if f.hi - f.lo > 20 and f.shape != "trapezoid"
                and f.execution().segments[-1].rate == 800)
    speed = MHZ1.hz / 800
    assert spacing[slow] == max(1, int(rotor.natural_period_s(speed) * speed / 8))
    assert np.all(np.diff(lengths[family == slow]) <= spacing[slow])

"""The compiled load-angle model (profiles.motor.rotor_kernel) against its oracle, the
plain-Python integrator (tests/rotor_oracle.py), and the all-length verdict against
brute force over every move length; then the physics each part of the model states,
as tests a wrong sign or threshold fails."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.motor.rotor import (
    MAX_SETTLE_PERIODS,
    SLIP_DEG,
    STEPS_PER_NATURAL_PERIOD,
    follow,
    rotor_of,
    rotors,
    settle_s,
)
from profiles.motor.tolerance import corners, variant
from profiles.ppmc312.load_angle import worst_load_angle, worst_load_angles
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import FreeCurveTable
from tests.support import rotor_oracle as oracle
from tests.support.oracle_moves import whole_move, worst_whole_move
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


@pytest.mark.slow
@SETTINGS
@given(motors(), st.data())
def test_the_all_length_verdict_is_brute_force_over_every_length(
        motor: Motor, data: st.DataObject) -> None:
    """Every length up to a cruise long enough to settle, each judged on its own, against
    the sampled-and-refined verdict: the same worst angle and shortest unstable move.
    (Tables within the motor's curve: beyond it every move slips at once.)"""
    table = data.draw(tables(0.9 * motor.top_curve_pps))
    rotor = rotor_of(motor)
    top = table.clock.hz / table.rates[0]
    cruise = math.ceil(top * 10 * min(rotor.natural_period_s(top), 1.0)) + 1
    # a barely stable top speed (a period near 1 s) needs tens of thousands of lengths:
    # past the brute force's step budget (and the verdict's: it refuses, saying why), not
    # a question about the sampling
    assume(cruise <= 4000)
    verdict = worst_load_angle(table, motor)
    every = worst_load_angle(table, motor, pulses=range(
        1, table.accel_total + table.decel_total + cruise + 1))
    if every.slipped:  # past a pole slip the angle is no longer a margin: same verdict
        assert verdict.slipped
        return
    assert verdict.worst_angle_deg == pytest.approx(every.worst_angle_deg, abs=AGREE_DEG)
    assert verdict.first_unstable_pulses == every.first_unstable_pulses


def bundled() -> list[Motor]:
    return [load_motor(p) for p in bundled_motor_paths()]


@pytest.mark.parametrize("motor", bundled(), ids=lambda m: m.name[:12])
def test_bundled_plans_agree_with_the_oracle_and_every_length(motor: Motor) -> None:
    table = plan_free_curve(motor, pulses=2000).table
    verdict = worst_load_angle(table, motor)
    for n in sorted({1, 20, verdict.worst_pulses, 2000}):
        assert worst_load_angle(table, motor, pulses=[n]).worst_angle_deg == pytest.approx(
            worst_whole_move(table, motor, n), abs=AGREE_DEG)
    every = worst_load_angle(table, motor,
                             pulses=range(1, table.accel_total + table.decel_total + 2))
    assert verdict.worst_angle_deg >= every.worst_angle_deg - AGREE_DEG


def test_tolerance_corners_in_one_call_are_each_corners_own_verdict() -> None:
    base = load_motor(next(p for p in bundled_motor_paths() if "nema17" in p.name))
    motor = replace(base, load_torque_nm=0.01, tolerances=(
        ("inertia_kgm2", 4.8e-6, 8.8e-6), ("torque_scale", 0.8, 1.0),
        ("load_torque_nm", -0.02, 0.02)))
    table = plan_free_curve(base, pulses=3000).table
    box = corners(motor)
    together = worst_load_angles(table, [c.motor for c in box], pulses=[40, 300, 3000])
    for corner, verdict in zip(box, together, strict=True):
        alone = worst_load_angle(table, corner.motor, pulses=[40, 300, 3000])
        assert verdict == alone
        assert verdict.worst_angle_deg == pytest.approx(
            worst_whole_move(table, corner.motor, verdict.worst_pulses), abs=AGREE_DEG)


# --- the physics, stated so that a wrong sign or threshold fails ----------------------

def plain_motor(**kw: object) -> Motor:
    """0.4 N·m flat to 2000 pps, then falling: a NEMA17 at 1/8 step."""
    args: dict[str, object] = dict(
        steps_per_rev=1600, curve_speed_pps=np.array([0.0, 2000.0, 8000.0, 48000.0]),
        curve_torque_nm=np.array([0.4, 0.4, 0.32, 0.04]), inertia_kgm2=6.8e-6,
        safety_factor=0.6, start_pps=800.0)
    args.update(kw)
    return Motor(**args)  # type: ignore[arg-type]


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


# --- the model's numbers and edges, stated so that an off-by-one fails -------------------

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


def test_a_weak_rotor_still_has_a_finite_natural_period() -> None:
    """Stiffness k·c_e·T = 0.25 /s² (well below 1): the period is 2π/0.5 = 4π s, in the
    model and in its kernel; a rotor with no torque has none."""
    from profiles.motor import rotor_kernel as rk
    from profiles.motor.rotor import Rotor

    weak = Rotor(1.0, 1.0, (0.0, 10.0), (0.25, 0.25), 0.0, 0.0, 0.0)
    assert weak.natural_period_s(0.0) == pytest.approx(4 * math.pi)
    assert rk.natural_period_s(*weak.curve(), weak.row(), 0.0) == pytest.approx(4 * math.pi)
    assert math.isinf(rk.natural_period_s(*weak.curve(), weak.row(), 20.0))


def test_the_peak_torque_is_the_curve_exactly_at_its_points_and_zero_beyond() -> None:
    """T_pk(v) of a 5-point curve: exactly the curve's torque at each point (both
    directions), linear between, 0 past the last point; the kernel agrees bit for bit."""
    from profiles.motor import rotor_kernel as rk

    speeds = (0.0, 1000.0, 3000.0, 6000.0, 12000.0)
    torques = (0.4, 0.1, 0.3, 0.2, 0.05)  # values whose differences do not round back
    motor = plain_motor(curve_speed_pps=np.array(speeds), curve_torque_nm=np.array(torques))
    rotor = rotor_of(motor)
    cv, ct = rotor.curve()
    for v, t in zip(speeds, torques, strict=True):
        for signed in (v, -v):
            assert rotor.t_peak(signed) == t
            assert rk._t_peak(cv, ct, signed) == t
    for v in (500.0, 2000.0, 4500.0, 9000.0, 11999.0):
        expected = float(np.interp(v, speeds, torques))
        assert rotor.t_peak(v) == pytest.approx(expected, rel=1e-12)
        assert rk._t_peak(cv, ct, v) == pytest.approx(expected, rel=1e-12)
    for v in (12000.5, 5e4):
        assert rotor.t_peak(v) == 0.0 and rk._t_peak(cv, ct, v) == 0.0
    # the natural periods at many speeds at once (the verdict's sampling) are the
    # one-speed ones bit for bit: at the points (the last one: its torque, not 0), in the
    # first and the last interval, past the end (no stiffness: infinite), either sign
    many = np.array([0.0, 1.0, 500.0, 999.999, 1000.0, 4500.0, 11999.0, 12000.0, 12000.5,
                     5e4, -500.0, -12000.0])
    periods = rotor.natural_periods_s(many)
    np.testing.assert_array_equal(periods, [rotor.natural_period_s(v) for v in many])
    assert np.isfinite(periods[7]) and np.isinf(periods[8:10]).all()


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


def test_a_few_moves_of_a_tiny_table_are_the_oracles_whole_moves() -> None:
    """Every execution kernel on a 3-stage table (LE=1: the decel side differs), a few
    lengths judged together (each from where it parts from the longest one until it
    rejoins it), both directions under a load: each length's worst angle in each
    direction is the oracle's whole move. Small enough to run as plain Python (the
    kernel's mutation run)."""
    from profiles.ppmc312.load_angle import angles

    motor = plain_motor(load_torque_nm=0.05, friction_torque_nm=0.02, damping_ratio=0.3)
    table = FreeCurveTable(MHZ1, (120, 200, 400), (3, 3, 2), (2, 4))
    lengths = [1, 4, 9, 15, 40]
    found = angles(table, [motor], pulses=lengths)
    assert found.deg.shape == (2, len(lengths)) and list(found.lengths) == lengths
    for row, direction in enumerate(found.direction.tolist()):
        for e, n in enumerate(lengths):
            assert found.deg[row, e] == pytest.approx(
                whole_move(table, motor, n, direction)[0], abs=AGREE_DEG), (direction, n)
    assert not found.slipped.any()


@pytest.mark.parametrize("load_nm, accel, decel, top_rate", [
    (0.0, (6, 5, 4, 3), None, 200),            # LE=0, safe: the worst is sampled right
    (0.03, (6, 5, 4, 3), (3, 8), 200),         # LE=1 under a load: both directions
    (0.0, (3, 3, 3, 3), None, 40),             # too fast: past 90° from some length on
])
def test_the_sampled_verdict_is_brute_force_over_every_length(
        load_nm: float, accel: tuple[int, ...], decel: tuple[int, ...] | None,
        top_rate: int) -> None:
    """The all-length verdict (each move family sampled by the ringing's phase, the
    worst families refined) against every length judged one by one, up to a cruise long
    enough to settle: the same worst angle, the same shortest unstable move."""
    motor = plain_motor(load_torque_nm=load_nm, friction_torque_nm=0.01, damping_ratio=0.2)
    rates = (top_rate, 2 * top_rate, 4 * top_rate, 8 * top_rate)
    table = FreeCurveTable(MHZ1, rates, accel, decel)
    verdict = worst_load_angle(table, motor)
    rotor = rotor_of(motor)
    top = MHZ1.hz / rates[0]
    cruise = math.ceil(top * 10 * min(rotor.natural_period_s(top), 1.0)) + 1
    every = worst_load_angle(table, motor, pulses=range(
        1, table.accel_total + table.decel_total + cruise + 1))
    assert verdict.slipped == every.slipped
    assert verdict.worst_angle_deg == pytest.approx(every.worst_angle_deg, abs=AGREE_DEG)
    assert verdict.first_unstable_pulses == every.first_unstable_pulses
    assert verdict.worst_direction == every.worst_direction


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


# --- the all-length verdict's sampling and its refusals ----------------------------------

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


def test_a_move_at_exactly_the_peak_angle_is_unstable() -> None:
    """90° is the top of the torque–angle curve: a move reaching it has no margin left
    and is the shortest unstable move."""
    from profiles.ppmc312.load_angle import Angles

    found = Angles(np.array([10, 20, 30]), np.array([[40.0, 90.0, 95.0]]),
                   np.zeros((1, 3), bool), np.array([0]), np.array([1]))
    assert found.worst(0).first_unstable_pulses == 20
    assert found.worst(0).worst_pulses == 30


def test_verdicts_are_values() -> None:
    import dataclasses

    motor = plain_motor()
    table = FreeCurveTable(MHZ1, (200, 400), (4, 4))
    verdict = worst_load_angle(table, motor, pulses=[5])
    with pytest.raises(dataclasses.FrozenInstanceError):
        verdict.worst_angle_deg = 0.0  # type: ignore[misc]
    from profiles.ppmc312.load_angle import angles

    with pytest.raises(dataclasses.FrozenInstanceError):
        angles(table, [motor], pulses=[5]).deg = np.zeros(1)  # type: ignore[misc]


def test_a_verdict_refuses_no_lengths_a_bad_step_and_an_endless_run() -> None:
    """No move length to judge, a step outside 1 ns..1 s, or a verdict past its budget
    (here: steps of 1 ns over a 2 ms move): refused, naming the field or the budget."""
    from profiles.errors import FieldRangeError, StepRampError

    motor = plain_motor()
    table = FreeCurveTable(MHZ1, (200, 400), (4, 4))
    with pytest.raises(FieldRangeError) as empty:
        worst_load_angle(table, motor, pulses=[])
    assert (empty.value.field, empty.value.value, empty.value.lo, empty.value.hi) == (
        "move lengths to judge", 0, 1, 0xFFFFFFFF)
    for step in (0.0, 0.99e-9, 1.01, 2.0):
        with pytest.raises(FieldRangeError, match=r"max step \[s\]"):
            worst_load_angle(table, motor, pulses=[5], max_step_s=step)
    assert worst_load_angle(table, motor, pulses=[5], max_step_s=1.0).executions == 1
    with pytest.raises(StepRampError, match="more than 8000000 RK4 steps"):
        worst_load_angle(table, motor, pulses=[10], max_step_s=1e-9)


def test_a_verdict_names_its_direction_and_counts_its_executions() -> None:
    """Without a load a move is judged forward only (direction 1); with one, both ways:
    the executions counted are the lengths judged times the directions, and the worst
    is named by its direction (±1)."""
    table = FreeCurveTable(MHZ1, (200, 400), (4, 4))
    free = worst_load_angle(table, plain_motor(), pulses=[3, 8, 20])
    assert (free.worst_direction, free.executions) == (1, 3)
    loaded = worst_load_angle(table, plain_motor(load_torque_nm=0.1), pulses=[3, 8, 20])
    assert loaded.executions == 6 and loaded.worst_direction in (1, -1)


def test_refine_judges_every_length_around_the_worst_sample_and_before_the_first_unstable(
        ) -> None:
    """`refine`: a family within REFINE_DEG of the worst gets every length within one
    spacing of its worst sample (its ends excluded: they are samples), a family far
    below gets none, and a family whose samples pass 90° gets every length before its
    first unstable sample."""
    from profiles.ppmc312.load_angle import refine

    lengths = np.array([10, 20, 30, 40, 100, 110, 120, 200, 210, 220, 230])
    family = np.array([0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 2])
    spacing = np.array([10, 10, 10])
    # family 0 is the worst (80° at 30), family 2 within 3° of it (78° at 220)
    worst = np.array([40.0, 60.0, 80.0, 70.0, 20.0, 30.0, 25.0, 50.0, 60.0, 78.0, 70.0])
    assert refine(lengths, family, spacing, worst).tolist() == [
        *range(21, 30), *range(31, 40), *range(211, 220), *range(221, 230)]
    # family 2 passes 90° at 220 and is worst at its end (99° at 230): family 0 is now
    # far below; family 2 gets the lengths before 220 and those around 230
    worst = np.array([40.0, 60.0, 80.0, 70.0, 20.0, 30.0, 25.0, 50.0, 60.0, 95.0, 99.0])
    assert refine(lengths, family, spacing, worst).tolist() == [*range(211, 220),
                                                                *range(221, 230)]
    assert not refine(lengths, family, np.array([1, 1, 1]), worst).tolist()  # dense already
    # spacing 2: the one length between samples on each side of the worst; a family at
    # exactly 90° (far below a 99° one) still names its shortest unstable move, and only
    # the lengths before its first unstable sample, not up to a later one
    lengths = np.array([10, 12, 14, 16, 100, 104, 108, 112])
    family = np.array([0, 0, 0, 0, 1, 1, 1, 1])
    worst = np.array([50.0, 99.0, 60.0, 95.0, 40.0, 90.0, 85.0, 88.0])
    assert refine(lengths, family, np.array([2, 4]), worst).tolist() == [
        11, 13, 101, 102, 103]


def test_every_family_is_sampled_by_its_own_slowest_changing_stage() -> None:
    """Each family's spacing comes from the slowest stage whose pulses change within it
    (found here from its shortest and longest moves), and its samples run from its
    shortest move to where that dwell has settled without a gap wider than the
    spacing."""
    from profiles.ppmc312.execution import move_families, moves
    from profiles.ppmc312.load_angle import samples

    motor = plain_motor(damping_ratio=0.3)
    rotor = rotor_of(motor)
    table = FreeCurveTable(MHZ1, (100, 200, 400, 800), (40, 30, 20, 10), (10, 20, 30, 40))
    lengths, family, spacing = samples(table, [motor])
    checked = 0
    for f, fam in enumerate(move_families(table)):
        if fam.shape == "trapezoid" or fam.hi - fam.lo < 2:
            continue
        ends = moves(table, np.array([fam.lo, fam.hi]))
        a, b = ends.runs(0), ends.runs(1)
        changing = [r for (_, r, c), (_, _, d) in zip(a, b, strict=True) if c != d]
        speed = MHZ1.hz / max(changing)
        expected = max(1, min(fam.hi - fam.lo, int(rotor.natural_period_s(speed) * speed / 8)))
        assert spacing[f] == expected, (f, fam.shape)
        mine = lengths[family == f]
        assert mine[0] == fam.lo and np.all(np.diff(mine) <= expected), (f, mine)
        checked += 1
    assert checked >= 3


def test_a_batch_on_threads_judges_every_cell_as_one_at_a_time() -> None:
    """Enough (rotor, execution) cells to be split over threads: every cell gets the
    angle its move gets judged alone (on the calling thread), the first and the last
    included."""
    from profiles.ppmc312.load_angle import PARALLEL_MIN_CELLS, angles

    motor = plain_motor(load_torque_nm=0.05, damping_ratio=0.3)
    table = FreeCurveTable(MHZ1, (120, 200, 400), (3, 3, 2))
    lengths = list(range(1, PARALLEL_MIN_CELLS + 3))
    batch = angles(table, [motor], pulses=lengths)
    assert batch.deg.size >= PARALLEL_MIN_CELLS
    for e, n in enumerate(lengths):
        alone = angles(table, [motor], pulses=[n])
        np.testing.assert_allclose(batch.deg[:, e], alone.deg[:, 0], atol=AGREE_DEG)
    assert batch.deg.min() > 0


def _judge_in_child(lengths: list[int], out: object) -> None:
    from profiles.ppmc312.load_angle import angles

    motor = plain_motor(load_torque_nm=0.05, damping_ratio=0.3)
    table = FreeCurveTable(MHZ1, (120, 200, 400), (3, 3, 2))
    out.put(angles(table, [motor], pulses=lengths).deg.tolist())  # type: ignore[attr-defined]


def test_a_forked_child_judges_on_threads_of_its_own() -> None:
    """The threads are kept between verdicts; a child forked after the parent judged (a
    sweep's worker) does not have them and must start its own, not wait forever."""
    import multiprocessing

    from profiles.ppmc312.load_angle import PARALLEL_MIN_CELLS, angles

    lengths = list(range(1, PARALLEL_MIN_CELLS + 3))
    motor = plain_motor(load_torque_nm=0.05, damping_ratio=0.3)
    table = FreeCurveTable(MHZ1, (120, 200, 400), (3, 3, 2))
    here = angles(table, [motor], pulses=lengths).deg.tolist()  # the parent's threads start
    fork = multiprocessing.get_context("fork")
    out = fork.Queue()
    child = fork.Process(target=_judge_in_child, args=(lengths, out))
    child.start()
    child.join(timeout=60)
    if child.is_alive():
        child.kill()
    assert child.exitcode == 0, "the child hung or failed"
    assert out.get(timeout=5) == here


def test_after_the_last_pulse_a_loaded_rotor_creeping_to_its_held_lag_is_followed() -> None:
    """A heavy, critically damped rotor under a load: after a 1-pulse move its lag peaks
    (7.05°), dips, then creeps up to where the load holds it (7.18°). The verdict follows
    the rest until its ringing fades above that held lag, so it names the oracle's worst,
    not the first peak. (Found by the shared-prefix property.)"""
    motor = plain_motor(steps_per_rev=1600, curve_speed_pps=np.array([0.0, 4000.0]),
                        curve_torque_nm=np.array([1.0, 1.0]), inertia_kgm2=7.8167e-4,
                        start_pps=100.0, friction_torque_nm=0.0625, damping_ratio=1.0,
                        load_torque_nm=0.125)
    table = FreeCurveTable(MHZ1, (4975, 5000), (2, 2))
    fast = worst_load_angle(table, motor, pulses=[1]).worst_angle_deg
    assert fast == pytest.approx(worst_whole_move(table, motor, 1), abs=AGREE_DEG)
    assert fast > 7.1

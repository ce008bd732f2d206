"""The compiled load-angle model (profiles.motor.rotor_kernel) against its oracle, the
plain-Python integrator (tests/support/rotor_oracle.py), and the all-length verdict against
brute force over every move length; then the physics each part of the model states,
as tests a wrong sign or threshold fails."""

from __future__ import annotations

import math

import numpy as np
import pytest

from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.motor.rotor import (
    rotor_of,
)
from profiles.ppmc312.load_angle import worst_load_angle
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import FreeCurveTable
from tests.support.oracle_moves import worst_whole_move
from tests.support.stand_ins import plain_motor
from tests.support.strategies import MHZ1

AGREE_DEG = 0.1   # the kernel and the oracle: the bound (they agree to rounding)


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


def test_every_family_is_sampled_by_its_own_slowest_changing_stage() -> None:
    """Each family's spacing comes from the slowest stage whose pulses change within it
    (found here from its shortest and longest moves), and its samples run from its
    shortest move to where that dwell has settled without a gap wider than the
    spacing."""
    from profiles.ppmc312.execution import move_families
    from profiles.ppmc312.load_angle import samples
    from profiles.ppmc312.move_batch import moves

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


def test_a_worst_exactly_at_the_bound_ends_the_integration() -> None:
    """`_joins`: away from the reference's state, the worst so far bounds the rest once it
    is no less than the reference's worst from there plus `bound` amplitudes of the
    difference (≥: exactly at the bound counts; just below does not)."""
    from profiles.motor import rotor_kernel as rk

    rotor = rotor_of(load_motor(bundled_motor_paths()[0]))
    curve_v, curve_t = rotor.curve()
    row, v, lag, s, ref_rest, bound = rotor.row(), 1000.0, 0.5, 100.0, 2.0, 1.5
    at = ref_rest + bound * rk._amplitude(curve_v, curve_t, row, v, lag, s)

    def joins(worst: float, bound: float = bound) -> bool:
        return bool(rk._joins(curve_v, curve_t, row, v, lag, s, worst, 0.0, 0.0, 1e-9, 1e-9,
                              ref_rest, bound))

    assert joins(at)
    assert not joins(float(np.nextafter(at, -math.inf)))
    assert not joins(math.inf, bound=0.0)  # no bound: only rejoining the reference ends it


def test_a_full_record_stops_the_integration_out_of_room() -> None:
    """`follow_spans` records every step's (t, lag) while its buffers have room; once they
    are full it stops with OUT_OF_ROOM (profiles.motor.rotor.follow then integrates again
    with longer ones), never writing past them."""
    from profiles.motor import rotor_kernel as rk
    from profiles.motor.rotor import SETTLE_TOL_DEG, SLIP_DEG

    rotor = rotor_of(load_motor(bundled_motor_paths()[0]))
    step = rotor.step_s()
    out_max, out_lag, out_s = np.zeros(1), np.zeros(1), np.zeros(1)
    rec_t, rec_lag = np.full(3, np.nan), np.full(3, np.nan)
    _, status, _, _, _, _, recorded = rk.follow_spans(
        *rotor.curve(), rotor.row(), np.array([20 * step]), np.array([500.0]), 0.0, 0.0,
        0.0, 0.0, step, math.radians(SLIP_DEG) / rotor.c_e,
        math.radians(SETTLE_TOL_DEG) / rotor.c_e, 400, 10**6, np.full(1, -1, dtype=np.int64),
        out_lag, out_s, 0.0, 0.0, out_max, out_lag, out_s, True, rec_t, rec_lag, False,
        out_max, 0.0, 0.0)
    assert status == rk.OUT_OF_ROOM and recorded == 3
    assert rec_t == pytest.approx([step, 2 * step, 3 * step])
    assert np.all(np.isfinite(rec_lag))

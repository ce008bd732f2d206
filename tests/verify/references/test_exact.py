"""verify.references.exact: the exact continuous optimum against hand kinematics and brute
force."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.errors import FieldRangeError, FormatError, StepRampError
from tests.support.reference_moves import BUNDLED, flat_motor, hand_trapezoid
from verify.references import exact_optimum, move_limits
from verify.references._common import ZERO_ACCEL_MARGIN, accel_zero_pps, capability_violation


@pytest.mark.parametrize("n", [1, 7, 300, 2000, 123_457, 10_000_000])
def test_exact_matches_hand_kinematics_on_constant_torque(n: int) -> None:
    motor = flat_motor()
    ref = exact_optimum(motor, n)
    expected = hand_trapezoid(0.5, 0.05, 20000.0, 400.0, n)
    assert ref.duration_s == pytest.approx(expected, rel=1e-6)
    # constant acceleration: the samples obey v² = v0² + 2·a·x while speeding up
    up = ref.a_pps2 > 0
    a_up = float(motor.a_acc_pps2(0.0))
    assert np.allclose(ref.v_pps[up] ** 2, 400.0**2 + 2 * a_up * ref.x_pulses[up], rtol=1e-9)


def test_exact_cruises_at_the_cap_on_long_moves() -> None:
    ref = exact_optimum(flat_motor(), 1_000_000)
    assert ref.v_pps.max() == pytest.approx(20000.0, rel=1e-12)
    assert "cruise 0 s" not in ref.info


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(sorted(BUNDLED)), st.floats(1, 1e6), st.floats(1.0001, 3))
def test_exact_is_monotone_in_pulses(name: str, n: float, factor: float) -> None:
    motor = BUNDLED[name]
    assert exact_optimum(motor, n * factor, points=64).duration_s > \
        exact_optimum(motor, n, points=64).duration_s


@pytest.mark.parametrize("name", sorted(BUNDLED))
@pytest.mark.parametrize("n", [1, 2000, 100_000])
def test_exact_against_brute_force_integration(name: str, n: int) -> None:
    motor = BUNDLED[name]
    ref = exact_optimum(motor, n)
    # T = ∫ dx / v over the sampled (exact) speed profile, fine trapezoid
    x = np.linspace(0, n, 400_001)
    v = ref.speed_at_position(x)
    assert np.trapezoid(1 / v, x) == pytest.approx(ref.duration_s, rel=2e-4)
    # and the samples respect t(x) consistency
    assert np.allclose(ref.position_at(ref.t_s), ref.x_pulses)


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_exact_boundary_and_capability(name: str) -> None:
    motor = BUNDLED[name]
    lim = move_limits(motor, 5000)
    ref = exact_optimum(motor, 5000)
    assert ref.v_pps[0] == ref.v_pps[-1] == lim.v0_pps == min(motor.start_pps, motor.jump_pps)
    assert ref.x_pulses[0] == 0 and ref.x_pulses[-1] == 5000
    assert np.all(np.diff(ref.t_s) >= 0) and np.all(np.diff(ref.x_pulses) >= 0)
    assert capability_violation(motor, lim, ref, rel_tol=1e-9) == ""
    assert ref.solve_s < 0.05


def test_speed_limit_stops_short_of_zero_acceleration() -> None:
    motor = BUNDLED["motor-nema23-heavy"]  # a_acc < 0 at its last curve point
    v_zero = accel_zero_pps(motor)
    assert v_zero < motor.top_pps
    assert float(motor.a_acc_pps2(v_zero)) == pytest.approx(0.0, abs=1e-6)
    lim = move_limits(motor, 1e6)
    assert lim.v_lim_pps == pytest.approx(v_zero * (1 - ZERO_ACCEL_MARGIN))
    assert float(motor.a_acc_pps2(lim.v_lim_pps)) > 0
    assert exact_optimum(motor, 1e6).v_pps.max() == pytest.approx(lim.v_lim_pps)
    # a motor that keeps positive a_acc is capped by its curve / max_pps instead
    assert move_limits(flat_motor(max_pps=9000.0), 10).v_lim_pps == 9000.0


def test_start_speed_above_the_cap_runs_the_move_at_the_cap() -> None:
    motor = flat_motor(start_pps=5000.0, max_pps=3000.0)
    ref = exact_optimum(motor, 600)
    assert np.all(ref.v_pps == 3000.0)
    assert ref.duration_s == pytest.approx(0.2)


def test_jump_limit_lowers_the_boundary_speed() -> None:
    motor = flat_motor(max_jump_pps=100.0)
    assert exact_optimum(motor, 50).v_pps[0] == 100.0
    assert exact_optimum(motor, 50).duration_s == pytest.approx(
        hand_trapezoid(0.5, 0.05, 20000.0, 100.0, 50), rel=1e-9)


@pytest.mark.parametrize("bad", [0, -5, 0.5, math.inf, math.nan, 1e11])
def test_bad_pulses_name_the_field(bad: float) -> None:
    with pytest.raises(FieldRangeError, match=r"^pulses: "):
        exact_optimum(flat_motor(), bad)


@pytest.mark.parametrize("bad", ["100", None, True])
def test_non_numeric_pulses(bad: object) -> None:
    with pytest.raises(FormatError, match=r"^pulses: "):
        exact_optimum(flat_motor(), bad)


def test_bad_points() -> None:
    with pytest.raises(StepRampError, match=r"^points: "):
        exact_optimum(flat_motor(), 100, points=2)

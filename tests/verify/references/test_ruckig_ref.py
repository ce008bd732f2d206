"""verify.references.ruckig_ref: the ruckig reference (jerk limits, speed caps)."""

from __future__ import annotations

import numpy as np
import pytest

from profiles.errors import FieldRangeError, FormatError
from profiles.motor import Motor
from tests.support.reference_moves import BUNDLED, assert_move, flat_motor, hand_trapezoid
from verify.references import exact_optimum, move_limits, ruckig_reference
from verify.references._common import capability_violation


@pytest.mark.parametrize("name", sorted(BUNDLED))
@pytest.mark.parametrize("n", [1, 2000, 100_000])
def test_ruckig_brackets_the_exact_optimum(name: str, n: int) -> None:
    motor = BUNDLED[name]
    exact = exact_optimum(motor, n).duration_s
    feasible = ruckig_reference(motor, n)
    optimistic = ruckig_reference(motor, n, bound="optimistic")
    assert feasible.duration_s >= exact >= optimistic.duration_s
    assert_move(motor, n, feasible, rel_tol=1e-9)
    # the optimistic one uses more acceleration than the motor has at speed
    lim = move_limits(motor, n)
    assert capability_violation(motor, lim, optimistic) != "" or n == 1


def test_ruckig_without_jerk_is_the_hand_trapezoid() -> None:
    """Constant torque: the feasible and optimistic brackets collapse onto the optimum."""
    motor = flat_motor()
    for n in (50, 500_000):
        expected = hand_trapezoid(0.5, 0.05, 20000.0, 400.0, n)
        assert ruckig_reference(motor, n).duration_s == pytest.approx(expected, rel=1e-9)
        assert ruckig_reference(motor, n, bound="optimistic").duration_s == \
            pytest.approx(expected, rel=1e-9)


def test_ruckig_jerk_limit_costs_time_and_stays_within_it() -> None:
    motor = BUNDLED["motor-pk566-5phase-half"]
    free = ruckig_reference(motor, 5000)
    jerk = 1e9
    limited = ruckig_reference(motor, 5000, j_max_pps3=jerk)
    assert limited.duration_s > free.duration_s
    assert_move(motor, 5000, limited, rel_tol=1e-9)
    da = np.diff(limited.a_pps2)
    dt = np.diff(limited.t_s)
    assert np.all(np.abs(da) <= jerk * dt * (1 + 1e-6) + 1e-6)
    # the motor's own jerk limit is used by default
    with_jerk = Motor(**{**_motor_kwargs(motor), "max_jerk_pps3": jerk})
    assert ruckig_reference(with_jerk, 5000).duration_s == pytest.approx(limited.duration_s)


def _motor_kwargs(motor: Motor) -> dict[str, object]:
    return {f: getattr(motor, f) for f in motor.__dataclass_fields__}


def test_ruckig_bad_arguments() -> None:
    motor = BUNDLED["motor-nema17-1600"]
    with pytest.raises(FieldRangeError, match=r"^v_max_pps: "):
        ruckig_reference(motor, 100, v_max_pps=1e9)
    with pytest.raises(FieldRangeError, match=r"^a_max_pps2: "):
        ruckig_reference(motor, 100, a_max_pps2=-1.0)
    with pytest.raises(FormatError, match=r"^bound: "):
        ruckig_reference(motor, 100, bound="tight")


def test_ruckig_explicit_limits_are_used() -> None:
    motor = flat_motor()
    ref = ruckig_reference(motor, 1000, v_max_pps=2000.0, a_max_pps2=1e5)
    assert ref.v_pps.max() == pytest.approx(2000.0)
    assert np.max(np.abs(ref.a_pps2)) == pytest.approx(1e5)


def test_ruckig_speed_caps_span_the_start_to_the_limit() -> None:
    """Candidates lie above the start speed up to the limit, the curve's points among
    them; a limit at the start speed (a move that cannot speed up) is its only cap."""
    from verify.references.ruckig_ref import v_max_candidates

    motor = BUNDLED["motor-nema17-1600"]
    caps = v_max_candidates(motor, 1000.0, 20_000.0)
    assert caps[-1] == 20_000.0 and all(1000.0 < c <= 20_000.0 for c in caps)
    inside = motor.curve_speed_pps[(motor.curve_speed_pps > 1000) & (motor.curve_speed_pps < 2e4)]
    assert set(inside.tolist()) <= set(caps)
    assert v_max_candidates(motor, 1000.0, 1000.0) == [1000.0]
    assert v_max_candidates(motor, 1000.0, 1000.0 * (1 + 1e-10)) == [1000.0 * (1 + 1e-10)]

"""verify.references.toppra_ref: the TOPP-RA reference against the exact optimum."""

from __future__ import annotations

import numpy as np
import pytest

from profiles.errors import FieldRangeError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from verify.references import (
    Reference,
    exact_optimum,
    move_limits,
    toppra_reference,
)
from verify.references._common import capability_violation

BUNDLED = {p.stem: load_motor(p) for p in bundled_motor_paths()}


def flat_motor(torque_nm: float = 0.5, friction_nm: float = 0.05, top_pps: float = 20000.0,
               start_pps: float = 400.0, **extra: float) -> Motor:
    """A constant-torque motor: its optimum is a textbook triangle/trapezoid."""
    return Motor(steps_per_rev=200, curve_speed_pps=np.array([0.0, top_pps]),
                 curve_torque_nm=np.array([torque_nm, torque_nm]), inertia_kgm2=1e-5,
                 safety_factor=0.8, start_pps=start_pps, friction_torque_nm=friction_nm,
                 **extra)


def assert_move(motor: Motor, n: float, ref: Reference, rel_tol: float = 1e-6) -> None:
    """Starts and ends at v0, covers exactly 0…N, time runs forward, stays in capability."""
    lim = move_limits(motor, n)
    assert ref.v_pps[0] == pytest.approx(lim.v0_pps, rel=1e-9)
    assert ref.v_pps[-1] == pytest.approx(lim.v0_pps, rel=1e-9)
    assert ref.x_pulses[0] == 0 and ref.x_pulses[-1] == pytest.approx(n, rel=1e-12)
    assert np.all(np.diff(ref.t_s) >= 0)
    assert ref.t_s[-1] == pytest.approx(ref.duration_s, rel=1e-9)
    assert capability_violation(motor, lim, ref, rel_tol=rel_tol) == ""


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(BUNDLED))
@pytest.mark.parametrize("n", [2000, 100_000])
def test_toppra_within_0p2_percent_of_exact(name: str, n: int) -> None:
    motor = BUNDLED[name]
    exact = exact_optimum(motor, n).duration_s
    ref = toppra_reference(motor, n)
    # interpolation discretisation holds the constraint at both interval ends, so the
    # result is feasible and therefore never faster than the exact optimum
    assert exact * (1 - 1e-9) <= ref.duration_s <= exact * 1.002
    assert_move(motor, n, ref)


@pytest.mark.slow  # a toppra solve; CI runs it
def test_toppra_short_move() -> None:
    motor = BUNDLED["motor-nema17-1600"]
    ref = toppra_reference(motor, 10, gridpoints=200)
    assert ref.duration_s == pytest.approx(exact_optimum(motor, 10).duration_s, rel=5e-3)
    assert_move(motor, 10, ref)


def test_toppra_bad_gridpoints() -> None:
    with pytest.raises(FieldRangeError, match=r"^gridpoints: "):
        toppra_reference(flat_motor(), 10, gridpoints=3)

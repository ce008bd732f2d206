"""Motor files and their acceleration capability."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from profiles.errors import FieldRangeError, FormatError
from profiles.motor import Motor, bundled_motor_paths, load_motor

MOTORS = [load_motor(p) for p in bundled_motor_paths()]


def test_three_bundled_motors() -> None:
    assert len(MOTORS) == 3
    assert all(m.name for m in MOTORS)


@pytest.mark.parametrize("motor", MOTORS, ids=lambda m: m.name[:8])
def test_capability_formula(motor: Motor) -> None:
    v = 1234.0
    k = motor.steps_per_rev / (2 * math.pi * motor.inertia_kgm2)
    t = float(np.interp(v, motor.curve_speed_pps, motor.curve_torque_nm))
    assert motor.a_acc_pps2(v) == pytest.approx((motor.safety_factor * t
                                                  - motor.friction_torque_nm) * k)
    assert motor.a_dec_pps2(v) == pytest.approx((motor.safety_factor * t
                                                  + motor.friction_torque_nm) * k)


@pytest.mark.parametrize("motor", MOTORS, ids=lambda m: m.name[:8])
@given(a=st.floats(0, 1), b=st.floats(0, 1))
def test_interval_minimum_is_exact(motor: Motor, a: float, b: float) -> None:
    lo, hi = sorted((a * motor.top_pps, b * motor.top_pps))
    dense = np.linspace(lo, hi, 20001)
    got = motor.min_a_acc_pps2(lo, hi)
    assert got <= motor.a_acc_pps2(dense).min() + 1e-6
    assert got >= motor.a_acc_pps2(np.r_[dense, motor.curve_speed_pps[
        (motor.curve_speed_pps > lo) & (motor.curve_speed_pps < hi)]]).min() - 1e-6


def test_json_round_trip() -> None:
    for m in MOTORS:
        again = Motor.from_json(json.loads(json.dumps(m.to_json())))
        assert again.to_json() == m.to_json()


@pytest.mark.parametrize("patch, error, match", [
    ({"bogus": 1}, FormatError, "unknown key"),
    ({"safety_factor": 1.5}, FieldRangeError, "safety_factor"),
    ({"safety_factor": 0}, FieldRangeError, "safety_factor"),
    ({"inertia_kgm2": -1}, FieldRangeError, "inertia_kgm2"),
    ({"pullout_torque": [[0, 1]]}, FormatError, "two"),
    ({"pullout_torque": [[0, 1], [0, 1]]}, FormatError, "strictly increase"),
    ({"pullout_torque": "x"}, FormatError, "pairs"),
    ({"start_pps": "fast"}, FormatError, "start_pps"),
    ({"friction_torque_nm": 5.0}, FormatError, "cannot accelerate"),
    ({"format": "x"}, FormatError, "format"),
])
def test_bad_motor_files(patch: dict, error: type, match: str) -> None:
    obj = MOTORS[0].to_json() | patch
    with pytest.raises(error, match=match):
        Motor.from_json(obj)

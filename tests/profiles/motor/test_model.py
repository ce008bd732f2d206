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
    ({"pullout_torque": [[0, 1], ["fast", 0.5]]}, FormatError, "pairs"),
    ({"tolerances": {"inertia_kgm2": 1e-5}}, FormatError, r"\[low, high\]"),
    ({"tolerances": {"inertia_kgm2": [1e-5]}}, FormatError, r"\[low, high\]"),
    ({"tolerances": {"inertia_kgm2": [1e-5, "x"]}}, FormatError, r"\[low, high\]"),
    ({"resonance_bands_pps": [[1000, 1100, 1200]]}, FormatError, "pairs"),
    ({"resonance_bands_pps": [[1000, "x"]]}, FormatError, "pairs"),
    ({"friction_torque_nm": 0.01, "tolerances": {"friction_torque_nm": [-0.01, 0.02]}},
     FieldRangeError, r"low: -0\.01 is outside the allowed range 0\.\.0\.02"),
])
def test_bad_motor_files(patch: dict, error: type, match: str) -> None:
    obj = MOTORS[0].to_json() | patch
    with pytest.raises(error, match=match):
        Motor.from_json(obj)


def test_a_load_takes_from_both_sides_and_one_step_a_turn_is_a_motor() -> None:
    """The load opposes one direction and helps the other; the chip runs one table both
    ways, so both capabilities lose |T_L| (a_dec keeps the friction's help)."""
    m = MOTORS[0]
    loaded = Motor.from_json(m.to_json() | {"load_torque_nm": -0.05,
                                            "friction_torque_nm": 0.01})
    k = loaded.steps_per_rev / (2 * math.pi * loaded.inertia_kgm2)
    t = float(np.interp(500.0, loaded.curve_speed_pps, loaded.curve_torque_nm))
    sf = loaded.safety_factor
    assert loaded.a_acc_pps2(500.0) == pytest.approx((sf * t - 0.01 - 0.05) * k)
    assert loaded.a_dec_pps2(500.0) == pytest.approx((sf * t + 0.01 - 0.05) * k)
    assert Motor.from_json(m.to_json() | {"steps_per_rev": 1}).steps_per_rev == 1
    with pytest.raises(FieldRangeError, match="steps_per_rev"):
        Motor.from_json(m.to_json() | {"steps_per_rev": 0})


def test_a_damping_ratio_other_than_the_default_is_written_either_way() -> None:
    """to_json leaves out only the default damping ratio: one above it, or below, is
    written and read back."""
    from dataclasses import replace

    from profiles.motor.model import DEFAULT_DAMPING_RATIO

    base = MOTORS[0]
    for ratio in (DEFAULT_DAMPING_RATIO / 2, DEFAULT_DAMPING_RATIO * 2):
        motor = replace(base, damping_ratio=ratio)
        assert motor.to_json()["damping_ratio"] == ratio
        assert Motor.from_json(json.loads(json.dumps(motor.to_json()))).damping_ratio == ratio
    assert "damping_ratio" not in replace(base, damping_ratio=DEFAULT_DAMPING_RATIO).to_json()


def test_the_curve_may_reach_the_speed_bound_but_not_pass_it() -> None:
    from profiles.motor.model import MAX_SPEED_PPS

    doc = MOTORS[0].to_json()
    for top, ok in ((MAX_SPEED_PPS, True), (MAX_SPEED_PPS * 1.5, False)):
        curve = [[0.0, 0.5], [top, 0.1]]
        if ok:
            assert Motor.from_json({**doc, "pullout_torque": curve}).curve_speed_pps[-1] == top
        else:
            with pytest.raises(FormatError, match="speeds up to"):
                Motor.from_json({**doc, "pullout_torque": curve})

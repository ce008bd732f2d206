"""profiles.ppmc312.tolerance_box: samples of a motor's tolerance box judged."""

from __future__ import annotations

import json

import pytest

from profiles.motor import Motor
from profiles.motor.tolerance import (
    corners,
    worst_case_motor,
)
from profiles.ppmc312.load_angle import worst_load_angle
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.tolerance_box import judge_box
from tests.support.paths import ROOT

DATA = ROOT / "profiles" / "data"


NEMA17 = DATA / "motor-nema17-1600.json"


def motor_with(**extra: object) -> Motor:
    obj = json.loads(NEMA17.read_text())
    obj.update(extra)
    return Motor.from_json(obj)


def test_judge_box_is_reproducible_and_reports_the_worst_case() -> None:
    m = motor_with(tolerances={"inertia_kgm2": [6.8e-6 * 0.7, 6.8e-6 * 1.3],
                               "torque_scale": [0.8, 1.0]})
    table = plan_free_curve(worst_case_motor(m), pulses=5000).table
    a = judge_box(table, m, pulses=[200, 5000], samples=200, seed=4)
    b = judge_box(table, m, pulses=[200, 5000], samples=200, seed=4)
    assert a == b
    assert a.corners == 4 and a.samples == 200 and a.sampled_pulses == (200, 5000)
    # the corner verdict is the scalar model's
    assert a.corner_worst_deg == max(worst_load_angle(table, c.motor, pulses=[200, 5000])
                                     .worst_angle_deg for c in corners(m))
    assert a.worst_angle_deg == max(a.corner_worst_deg, a.sample_worst_deg)
    assert a.worst_direction in (1, -1) and a.worst_pulses in (200, 5000)
    assert ("corner" in a.worst_where) or ("sample" in a.worst_where)
    if a.sample_failures == 0:
        assert a.stall_probability_upper == pytest.approx(1 - 0.05 ** (1 / 200))

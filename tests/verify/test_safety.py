"""verify.safety: the one verdict (unstable moves named, past the aim a warning)."""

from __future__ import annotations

import math

import pytest

from profiles.motor import bundled_motor_paths, load_motor
from profiles.motor.angles import PEAK_DEG
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.load_angle_trace import trace_load_angle
from profiles.ppmc312.table import FreeCurveTable
from tests.support.paths import ROOT
from verify.safety import judge_safety

MHZ1 = Clock.internal("1MHz")


@pytest.mark.parametrize("path", bundled_motor_paths(), ids=lambda p: p.stem)
def test_unstable_verdict_names_the_shortest_unstable_move(path) -> None:  # type: ignore[no-untyped-def]
    # a table that steps from the start speed by 2·ω_n/c_e: in the linear model the lag
    # swings 2 rad (115°) past its mean, beyond the 90° peak
    motor = load_motor(path)
    c_e = math.radians(motor.electrical_deg_per_pulse)
    k = motor.steps_per_rev / (2 * math.pi * motor.inertia_kgm2)
    omega_n = math.sqrt(k * c_e * float(motor.curve_torque_nm[0]))
    fast_pps = motor.start_pps + 2 * omega_n / c_e
    fast = FreeCurveTable(MHZ1, (round(MHZ1.hz / fast_pps), round(MHZ1.hz / motor.start_pps)),
                          (400, 400))
    verdict = judge_safety(fast, motor)
    v = verdict.load_angle
    assert v is not None and not verdict.safe and "load angle" in verdict.failed
    assert v.first_unstable_pulses is not None
    assert v.worst_deg >= PEAK_DEG and v.margin_deg <= 0
    assert not trace_load_angle(simulate_move(fast, v.first_unstable_pulses), motor).stable


def test_past_the_aim_below_the_peak_is_a_warning_naming_the_aim() -> None:
    """A table whose worst angle lies between the aim and 90°: stall-safe, with a
    `load-angle-margin` warning that says what `stepramp plan` aims at."""

    from profiles.ppmc312.table import load_table

    root = ROOT
    table = load_table(root / "examples" / "free-curve-nema17.json")
    motor = load_motor(root / "profiles" / "data" / "motor-nema17-1600.json")
    worst = judge_safety(table, motor).load_angle.worst_deg  # type: ignore[union-attr]
    verdict = judge_safety(table, motor, aim_deg=worst / 2)
    assert verdict.safe and not verdict.within_aim
    (found,) = [f for f in verdict.findings() if f.rule.startswith("load-angle")]
    assert (found.severity, found.rule) == ("warning", "load-angle-margin")
    assert found.message.endswith(f"(stepramp plan aims at ≤ {worst / 2:g}°)")
    assert not [f for f in judge_safety(table, motor).findings()
                if f.rule.startswith("load-angle")]

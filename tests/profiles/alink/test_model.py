"""A-Link ALUM: multiplier tables, unit correction, quantised settings, planner, words."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import alink as A
from profiles.errors import FieldRangeError, FormatError
from profiles.motor import bundled_motor_paths, load_motor

MOTORS = [load_motor(p) for p in bundled_motor_paths()]


MOTOR_IDS = [p.stem for p in bundled_motor_paths()]


@pytest.mark.parametrize(("high", "m"), [(1, 2), (8000, 2), (8001, 5), (16000, 5), (16001, 10),
                                         (40000, 10), (40001, 20), (100000, 20)])
def test_multiplier_by_high_speed(high: int, m: int) -> None:
    assert A.multiplier(high) == m


@pytest.mark.parametrize(("max_pps", "m"), [(1, 1), (8000, 1), (8001, 2), (16000, 2), (16001, 5),
                                            (40000, 5), (40001, 10), (80000, 10), (80001, 20),
                                            (100000, 20)])
def test_multiplier_by_max_speed(max_pps: int, m: int) -> None:
    # with MAX_SPEED set the high speed no longer matters
    assert A.multiplier(1, max_pps) == m
    assert A.multiplier(max_pps, max_pps) == m


@pytest.mark.parametrize(("high", "max_pps"), [(0, 0), (100001, 0), (5, -1), (5, 100001),
                                               (5.0, 0), (True, 0)])
def test_multiplier_refuses_out_of_range(high: object, max_pps: object) -> None:
    with pytest.raises(FieldRangeError, match="pps"):
        A.multiplier(high, max_pps)  # type: ignore[arg-type]


def test_para_ranges_follow_appendix_3() -> None:
    assert A.PARA_RANGE[1] == (1, 8000)
    assert A.PARA_RANGE[20] == (20, 160000)
    assert A.PARA_RANGE[500] == (500, 4000000)
    used = {m for _, m in A.BANDS_BY_HIGH + A.BANDS_BY_MAX}
    assert used == {1, 2, 5, 10, 20}  # ×50…×500 are never selected (notes)


def test_unit_applies_corrects_silently() -> None:
    run = A.unit_applies(301, 12345, 3, max_pps=0)
    assert run.multiplier == 5
    assert (run.start_pps, run.high_pps) == (300, 12345)
    assert run.para == 5  # below the ×5 minimum: raised to it
    assert run.accel_pps2 == pytest.approx(2e7)
    assert run.nak is None
    assert len(run.corrections) == 2
    big = A.unit_applies(300, 12345, 10**6)
    assert big.para == 40000
    cut = A.unit_applies(300, 12345, 1237)
    assert cut.para == 1235  # truncated to a multiple of ×5: the faster reading


def test_unit_applies_naks_and_legacy_rate() -> None:
    assert "MAX_SPEED" in (A.unit_applies(100, 9000, 100, max_pps=8000).nak or "")
    assert "self-start" in (A.unit_applies(900, 800, 100).nak or "")
    legacy = A.unit_applies(100, 800, 2, nn=1)
    assert (legacy.para, legacy.accel_pps2) == (4, None)
    with pytest.raises(FieldRangeError, match="nn"):
        A.unit_applies(100, 800, 100, nn=3)


@settings(max_examples=150, deadline=None)
@given(start=st.floats(1, 100000), high=st.floats(1, 100000),
       ms=st.floats(0.001, 1600), max_pps=st.sampled_from([0, 8000, 16000, 40000, 80000,
                                                            100000]))
def test_quantise_never_exceeds_request_and_unit_runs_it_unchanged(
        start: float, high: float, ms: float, max_pps: int) -> None:
    try:
        s = A.quantise_settings(start, high, ms, max_pps)
    except FieldRangeError:
        return  # refused: the request cannot be met without being more aggressive
    assert s.high_pps <= high
    assert s.start_pps <= start
    assert s.accel_ms_per_kpps >= ms * (1 - 1e-12) or s.accel_para == s.multiplier
    assert s.accel_para >= ms * 100 * (1 - 1e-12)  # never a faster ramp than asked
    m = s.multiplier
    assert s.high_pps % m == 0 and s.start_pps % m == 0 and s.accel_para % m == 0
    run = A.unit_applies(s.start_pps, s.high_pps, s.accel_para, max_pps=s.max_pps)
    assert run.corrections == () and run.nak is None
    # the multiple below-next-step is not lost: within one step of the request
    assert high - s.high_pps < m or high > (s.max_pps or 100000)


def test_quantise_warnings_say_what_changed() -> None:
    s = A.quantise_settings(333, 12345.6, 3.333)
    assert (s.start_pps, s.high_pps, s.accel_para) == (330, 12345, 335)
    text = " | ".join(s.warnings)
    assert "12345.6 → 12345" in text and "333 → 330" in text and "3.35 ms/kpps" in text
    exact = A.quantise_settings(300, 12345, 3.35)
    assert exact.warnings == ()


def test_quantise_band_crossing_and_refusals() -> None:
    # 8003 pps falls in ×5; rounding down lands on 8000, which is ×2 and even
    s = A.quantise_settings(100, 8003, 1.0)
    assert (s.high_pps, s.multiplier) == (8000, 2)
    with pytest.raises(FieldRangeError, match="accel_ms_per_kpps"):
        A.quantise_settings(100, 5000, 200.0)  # slower than 160 ms/kpps at ×2
    with pytest.raises(FieldRangeError, match="high_pps"):
        A.quantise_settings(1, 1, 1.0)  # ×2: 1 pps cannot be set
    with pytest.raises(FieldRangeError, match="high_pps"):
        A.quantise_settings(100, 9000, 1.0, max_pps=8000)
    with pytest.raises(FieldRangeError, match="max_pps"):
        A.quantise_settings(100, 900, 1.0, max_pps=0.5)
    fast = A.quantise_settings(100, 5000, 0.001)
    assert fast.accel_para == 2 and "para 2" in fast.warnings[0]


def test_settings_refuse_what_the_unit_would_change() -> None:
    with pytest.raises(FormatError, match="multiple"):
        A.AlinkSettings(301, 12345, 335)
    with pytest.raises(FieldRangeError, match="accel_para"):
        A.AlinkSettings(300, 12345, 40005)
    assert A.AlinkSettings(300, 12345, 335, s_curve=True).mode_word == 0x0015
    assert A.AlinkSettings(300, 12345, 335, triangle_avoidance=True).mode_word == 0x0025


def test_move_time_trapezoid_triangle_and_avoidance() -> None:
    s = A.AlinkSettings(500, 10000, 1000)  # a = 1e5 pps/s
    a = 1e5
    ramp = (10000**2 - 500**2) / (2 * a)
    long = A.move_time_s(s, 10**5)
    assert long.shape == "trapezoid"
    assert long.duration_s == pytest.approx(2 * 9500 / a + (10**5 - 2 * ramp) / 10000)
    short = A.move_time_s(s, 400)
    assert short.shape == "triangle"
    assert short.peak_pps == pytest.approx(math.sqrt(500**2 + a * 400))
    # simulate the triangle: time = ∫ dx / v over both halves
    x = np.linspace(0, 200, 200001)
    v = np.sqrt(500**2 + 2 * a * x)
    assert short.duration_s == pytest.approx(2 * np.trapezoid(1 / v, x), rel=1e-6)
    avoid = A.move_time_s(A.AlinkSettings(500, 10000, 1000, triangle_avoidance=True), 400)
    assert avoid.shape == "avoided_triangle"
    assert avoid.duration_s > short.duration_s
    assert avoid.ramp_pulses == pytest.approx(400 / 3)


@pytest.mark.parametrize("motor", MOTORS, ids=MOTOR_IDS)
@pytest.mark.parametrize("pulses", [None, 300, 5000, 100000])
@pytest.mark.parametrize("s_curve", [False, True])
def test_plan_is_stall_safe(motor, pulses: int | None, s_curve: bool) -> None:
    plan = A.plan_settings(motor, pulses=pulses, s_curve=s_curve)
    s = plan.table
    peak = s.accel_pps2 * (math.pi / 2 if s_curve else 1)
    assert peak <= motor.min_a_acc_pps2(s.start_pps, s.high_pps) * (1 + 1e-12)
    assert peak <= motor.min_a_dec_pps2(s.start_pps, s.high_pps) * (1 + 1e-12)
    assert s.start_pps <= min(motor.start_pps, motor.jump_pps)
    assert s.high_pps <= motor.top_pps
    run = A.unit_applies(s.start_pps, s.high_pps, s.accel_para, max_pps=s.max_pps)
    assert run.corrections == () and run.nak is None
    # the next faster para (one step of m) would break the stall bound
    faster = 1e8 / (s.accel_para - s.multiplier) * (math.pi / 2 if s_curve else 1)
    if s.accel_para > s.multiplier:
        assert faster > motor.min_a_acc_pps2(s.start_pps, s.high_pps) * (1 - 1e-9)


@pytest.mark.parametrize("motor", MOTORS, ids=MOTOR_IDS)
def test_plan_minimises_time_over_high_speeds(motor) -> None:
    pulses = 20000
    plan = A.plan_settings(motor, pulses=pulses)
    s = plan.table
    assert plan.duration_s == pytest.approx(A.move_time_s(s, pulses).duration_s)
    # every other stall-safe setting on a coarse grid of high speeds is no faster
    for vh in np.linspace(s.start_pps + 100, motor.top_pps, 40):
        m = A.multiplier(int(vh))
        high = int(vh) // m * m
        start = int(min(motor.start_pps, motor.jump_pps)) // m * m
        a_lim = float(motor.min_a_acc_pps2(start, high))
        if a_lim <= 0 or high < start:
            continue
        para = math.ceil(1e8 / a_lim / m) * m
        if para > 8000 * m:
            continue
        other = A.move_time_s(A.AlinkSettings(start, high, max(para, m)), pulses)
        assert plan.duration_s <= other.duration_s * (1 + 1e-9)


def test_settings_commands_sequence() -> None:
    s = A.quantise_settings(500, 12345, 3.35)
    cmds = A.settings_commands(s, slave_address=5, axis=1, duplex="half")
    assert [c.name for c in cmds] == ["MAX_SPEED", "MODE", "H_SPEED", "L_SPEED", "UP_TIME"]
    assert [c.pair for c in cmds] == [1, 2, 3, 1, 2]
    assert [(c.func, c.para) for c in cmds] == [(1, 0), (0, 0x0005), (1, 12345), (1, 500),
                                               (2, 335)]
    for c in cmds:
        assert A.parse_command(*c.words) == (c.cmd, c.func, c.para, c.pair)
        assert c.address == 0x080 + 2 * (5 + 3)
    # the programmed values are what the unit runs
    run = A.unit_applies(cmds[3].para, cmds[2].para, cmds[4].para, max_pps=cmds[0].para)
    assert run.corrections == () and run.nak is None

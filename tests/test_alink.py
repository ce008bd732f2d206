"""A-Link ALUM: multiplier tables, unit correction, quantised settings, planner, words."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import alink as A
from profiles.errors import DecodeError, FieldRangeError, FormatError, StepRampError
from profiles.motor import bundled_motor_paths, load_motor

MOTORS = [load_motor(p) for p in bundled_motor_paths()]
MOTOR_IDS = [p.stem for p in bundled_motor_paths()]


# --- multiplier tables at every boundary (appendix 2) ------------------------------------------

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


# --- what the unit runs ------------------------------------------------------------------------

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


# --- move-time model ---------------------------------------------------------------------------

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


# --- planner -----------------------------------------------------------------------------------

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


def test_plan_long_move_respects_ramp_limit_and_s_curve_is_slower() -> None:
    motor = MOTORS[0]
    long = A.plan_settings(motor, ramp_limit_s=0.1)
    assert long.duration_s is None and long.extras["ramp_time_s"] <= 0.1
    longer = A.plan_settings(motor, ramp_limit_s=1.0)
    assert longer.table.high_pps >= long.table.high_pps
    lin = A.plan_settings(motor, pulses=20000)
    s = A.plan_settings(motor, pulses=20000, s_curve=True)
    assert s.duration_s > lin.duration_s and s.table.s_curve


def test_plan_with_max_speed_uses_one_multiplier() -> None:
    plan = A.plan_settings(MOTORS[1], pulses=5000, max_pps=8000)
    assert plan.table.multiplier == 1 and plan.table.high_pps <= 8000
    with pytest.raises(FieldRangeError, match="pulses"):
        A.plan_settings(MOTORS[0], pulses=0)


def test_plan_ratio_to_optimum() -> None:
    from verify.references import exact_optimum

    for motor in MOTORS:
        plan = A.plan_settings(motor, pulses=20000)
        assert plan.duration_s is not None
        ratio = plan.duration_s / exact_optimum(motor, 20000).duration_s
        # a constant-acceleration unit cannot beat the torque-curve optimum
        assert 1.0 - 1e-3 <= ratio < 3


def test_plan_says_what_binds() -> None:
    motor = MOTORS[0]
    # a move too short to reach any high speed: the ramps meet
    short = A.plan_settings(motor, pulses=2)
    assert short.extras["shape"] == "triangle" and short.binds.startswith("move length")
    # MAX_SPEED below every speed the torque would allow: it is the limit
    capped = A.plan_settings(motor, pulses=100000, max_pps=1000)
    assert capped.table.high_pps == 1000 and capped.binds == "top speed (MAX_SPEED, 1000 pps)"
    # a tight ramp limit holds the long-move setting below the top speed
    long = A.plan_settings(motor, ramp_limit_s=0.01)
    assert long.binds == "ramp time limit (0.01 s)" and long.duration_s is None
    assert long.table.high_pps < A.plan_settings(motor, ramp_limit_s=100).table.high_pps
    # in between, the torque: a higher speed would need a slower ramp
    assert A.plan_settings(motor, pulses=5000).binds.startswith("motor torque")
    assert long.info.startswith(f"×{long.table.multiplier}: start {long.table.start_pps} pps")


# --- command words -----------------------------------------------------------------------------

def test_form_manual_example_and_erratum() -> None:
    # the manual prints form(MOVE_A, 28, 1000000) as 0006/06A0: those encode 100000
    cmd, p1, p2 = A.form(A.Cmd.MOVE_A, 28, 100000)
    assert (cmd, p1, p2) == (0x1C22, 0x0006, 0x06A0)
    assert A.form(A.Cmd.MOVE_A, 28, 1000000) == (0x1C22, 0x003D, 0x0240)
    assert (0x003D << 14) | 0x0240 == 1000000
    assert A.form(A.Cmd.LOGIC, 0, 0x14) == (0x001C, 0x0000, 0x0014)  # the LOGIC example
    assert A.form(A.Cmd.MOVE_R, 28, -1) == (0x1C21, 0x3FFF, 0x3FFF)


def test_form_refuses_bad_input() -> None:
    with pytest.raises(FieldRangeError, match="func"):
        A.form(A.Cmd.MOVE_A, 32, 0)
    with pytest.raises(FieldRangeError, match="para"):
        A.form(A.Cmd.MOVE_A, 28, 1 << 27)
    with pytest.raises(FieldRangeError, match="para"):
        A.form(A.Cmd.MOVE_A, 28, -(1 << 27) - 1)
    with pytest.raises(StepRampError, match="0x7D"):
        A.form(0x7D, 0, 0)  # ROUTINE_WRK: only in a sample #define
    with pytest.raises(StepRampError, match="0x86"):
        A.form(0x86, 0, 0)


@settings(max_examples=200, deadline=None)
@given(cmd=st.sampled_from(list(A.Cmd)), func=st.integers(0, 31),
       para=st.integers(-(1 << 27), (1 << 27) - 1), pairs=st.integers(1, 7))
def test_form_round_trip(cmd: A.Cmd, func: int, para: int, pairs: int) -> None:
    w = A.form(cmd, func, para)
    assert all(x >> 14 == 0 for x in w)  # no pair code before putcmd
    writer = A.CommandWriter()
    for _ in range(pairs):
        c = writer.put(cmd, func, para)
    assert A.parse_command(*c.words) == (cmd, func, para, c.pair)
    assert [x & 0x3FFF for x in c.words] == list(w)  # putcmd only adds bits 15–14


def test_pair_codes_cycle_from_one() -> None:
    writer = A.CommandWriter()
    pairs = [writer.put(A.Cmd.READ, 0, 0).pair for _ in range(7)]
    assert pairs == [1, 2, 3, 1, 2, 3, 1]
    assert [A.next_pair(p) for p in (0, 1, 2, 3)] == [1, 2, 3, 1]
    assert A.PairCode.NOOP.next() is A.PairCode.ONE and A.PairCode.THREE.next() == 1
    with pytest.raises(FieldRangeError, match="pair"):
        A.next_pair(4)
    words = list(A.CommandWriter().stream([(A.Cmd.LOGIC, 0, 0x14), (A.Cmd.MOVE_A, 28, 100000)]))
    assert words == [(0x401C, 0x4000, 0x4014), (0x9C22, 0x8006, 0x86A0)]


def test_parse_command_refuses_mixed_pairs_and_reserved_bit() -> None:
    with pytest.raises(FormatError, match="pair"):
        A.parse_command(0x401C, 0x8000, 0x4014)
    with pytest.raises(DecodeError, match="unexpected bits"):
        A.parse_command(0x201C, 0x0000, 0x0000)
    with pytest.raises(FieldRangeError, match="word"):
        A.parse_command(0x1_0000, 0, 0)


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


# --- memory map (tables 9-3-1, 9-3-2) ----------------------------------------------------------

@pytest.mark.parametrize(("duplex", "axis", "word", "offset"), [
    ("full", 0, 0, 0), ("full", 0, 1, 2), ("full", 0, 2, 4),
    ("full", 1, 0, 6), ("full", 1, 1, 8), ("full", 1, 2, 10),
    ("half", 0, 0, 0), ("half", 0, 1, 1), ("half", 0, 2, 2),
    ("half", 1, 0, 3), ("half", 1, 1, 4), ("half", 1, 2, 5)])
def test_memory_map(duplex: A.Duplex, axis: int, word: int, offset: int) -> None:
    n = 7
    assert A.command_address(n, axis, duplex, word) == 0x080 + (n + offset) * 2
    assert A.status_address(n, axis, duplex, word) == 0x100 + (n + offset) * 2


def test_memory_map_ranges() -> None:
    assert A.command_address(1) == 0x082  # the first D0 word in table 9-2-1
    assert A.status_address(53, 1, "full", 2) == 0x100 + 63 * 2  # last DI word
    assert A.status_address(58, 1, "half", 2) == 0x100 + 63 * 2
    with pytest.raises(FieldRangeError, match="slave_address"):
        A.command_address(54, 0, "full")
    with pytest.raises(FieldRangeError, match="slave_address"):
        A.command_address(0)
    with pytest.raises(FieldRangeError, match="axis"):
        A.command_address(1, 2)
    with pytest.raises(FormatError, match="duplex"):
        A.command_address(1, 0, "simplex")  # type: ignore[arg-type]


# --- responses ---------------------------------------------------------------------------------

def test_decode_response_status_bits_and_value() -> None:
    status = 0x0001 | (2 << 2) | (1 << 5) | (1 << 8) | (1 << 10) | (1 << 15)
    raw = (-5) & 0x0FFFFFFF
    r = A.decode_response(status, (2 << 14) | (raw >> 14), (2 << 14) | (raw & 0x3FFF),
                          expected_pair=2)
    assert r.valid and r.ack and r.value == -5
    assert r.driving and r.origin_set and r.plus_limit and r.abnormal_stop
    assert not (r.inhibit or r.minus_limit or r.eeprom_error or r.extended)
    nak = A.decode_response(0x0008, 0x8000, 0x8000, expected_pair=2)
    assert nak.valid and not nak.ack


def test_decode_response_names_the_pair_that_disagrees() -> None:
    r = A.decode_response(0x0008, 0x8000, 0x4000, expected_pair=2)
    assert not r.valid and r.mismatch is not None and r.mismatch.startswith("DATA2")
    r = A.decode_response(0x0004, 0x8000, 0x8000, expected_pair=2)
    assert r.mismatch is not None and r.mismatch.startswith("status")
    r = A.decode_response(0x0004, 0x8000, 0x4000)
    assert r.mismatch is not None and r.mismatch.startswith("DATA1")
    with pytest.raises(FieldRangeError, match="DATA1 word"):
        A.decode_response(0, -1, 0)


def test_decode_read_back() -> None:
    # H_SPEED_R answer: sub-command 3 echoed, parameter 0 = 1 (×1 pps), 12345 pps
    status = 1 | (3 << 2) | (1 << 4) | (3 << 6) | (1 << 11)
    r = A.decode_response(status, (3 << 14) | (12345 >> 14), (3 << 14) | (12345 & 0x3FFF),
                          expected_pair=3, read_back=True, expected_cmd=A.Cmd.H_SPEED_R)
    assert r.valid and r.value == 12345 and r.subcommand == 3 and r.param0 == 1
    # a read-back's status word has its own layout (extended, sub-command, parameter 0):
    # no drive flag is read from it, so none is claimed
    assert not any((r.driving, r.inhibit, r.origin_set, r.origin_detecting, r.plus_limit,
                    r.minus_limit, r.limit_latched, r.abnormal_stop, r.eeprom_error))
    wrong = A.decode_response(status, 0xC000, 0xC000, read_back=True,
                              expected_cmd=A.Cmd.L_SPEED_R)
    assert not wrong.valid and "sub-command" in (wrong.mismatch or "")
    assert A.decode_nak_cause(0b01010) == ["parameter value not valid",
                                           "self-start speed > high speed"]


_pair = st.integers(0, 3)


@settings(max_examples=200, deadline=None)
@given(pairs=st.tuples(_pair, _pair, _pair), value=st.integers(-(1 << 27), (1 << 27) - 1),
       flags=st.lists(st.booleans(), min_size=11, max_size=11),
       sub=st.integers(0, 15), p0=st.integers(0, 31), read_back=st.booleans())
def test_response_round_trip(pairs: tuple[int, int, int], value: int, flags: list[bool],
                             sub: int, p0: int, read_back: bool) -> None:
    if read_back:
        r = A.AlinkResponse(flags[0], pairs, value, False, read_back=True, extended=flags[1],
                            subcommand=sub, param0=p0)
    else:
        names = ("eeprom_error", "extended", "driving", "inhibit", "origin_set",
                 "origin_detecting", "plus_limit", "minus_limit", "limit_latched",
                 "abnormal_stop")
        r = A.AlinkResponse(flags[0], pairs, value, False,
                            **dict(zip(names, flags[1:], strict=True)))
    back = A.decode_response(*r.words(), read_back=read_back)
    assert back.valid == (len(set(pairs)) == 1)
    assert replace(back, valid=False, mismatch=None) == r
    assert back.words() == r.words()


# The command codes as the manual's §11 headings print them (SPEC §2 lists the same),
# written from the manual, not from Cmd.
MANUAL_CODES = {
    "LOGIC": 0x1C, "MODE": 0x1D, "L_SPEED": 0x12, "H_SPEED": 0x13, "UP_TIME": 0x14,
    "MAX_SPEED": 0x15, "SETTING": 0x17, "OL_SPEED": 0x18, "OH_SPEED": 0x19, "O_UPTIME": 0x1A,
    "MODE_SIG": 0x1E, "MOVE_R": 0x21, "MOVE_A": 0x22, "STOP": 0x2F, "HOME": 0x31,
    "P_SEARCH": 0x3C, "M_SEARCH": 0x3D, "P_ORG": 0x3E, "M_ORG": 0x3F, "READ_STAT": 0x45,
    "READ": 0x46, "OUT_M": 0x4C, "OUT_B": 0x4D, "OUT_S": 0x4E, "OUT_G": 0x4F,
    "CHANGE_SPD": 0x51, "LIMIT": 0x52, "DELAY": 0x58, "OFFSET": 0x5A, "RESET_POS": 0x5B,
    "CLEAR_EL": 0x5C,
    # §11-9, the read-backs (0x86 and 0x8B are not commands)
    "L_SPEED_R": 0x82, "H_SPEED_R": 0x83, "UP_TIME_R": 0x84, "MAX_SPEED_R": 0x85,
    "SETTING_R": 0x87, "OL_SPEED_R": 0x88, "OH_SPEED_R": 0x89, "O_UPTIME_R": 0x8A,
    "LOGIC_R": 0x8C, "MODE_R": 0x8D, "MODE_SIG_R": 0x8E,
}


def test_every_command_code_is_the_manuals() -> None:
    assert {c.name: int(c) for c in A.Cmd} == MANUAL_CODES


@pytest.mark.parametrize("axis", [-1, 2])
def test_an_axis_outside_the_units_two_is_refused_naming_them(axis: int) -> None:
    with pytest.raises(FieldRangeError,
                       match=rf"^axis: {axis} is outside the allowed range 0\.\.1"):
        A.command_address(1, axis)

"""profiles.ppmc312.execution: the chip's accel/decel move model (choices: docs/manual-notes.md)."""

from __future__ import annotations

import csv
import io
import itertools
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import mc200 as M
from profiles.errors import FieldRangeError, MoveParameterError, StepRampError
from profiles.motor import load_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import (
    LATENCY_S,
    STATUS,
    Execution,
    pulse_times_csv,
    samples_csv,
    simulate_move,
    simulate_moves,
    to_csv,
)
from profiles.ppmc312.move_batch import MOVE_PULSES_MAX
from profiles.ppmc312.table import FreeCurveTable, InitTable
from tests.support.paths import ROOT
from tests.support.strategies import MHZ1
from tests.support.strategies import stage_tables as tables

# LE=0, four stages fastest first: 10/20/30/40 pulses at rates 100/200/300/400.
COMMON = FreeCurveTable(MHZ1, (100, 200, 300, 400), (10, 20, 30, 40))


# LE=1, accel 5 stages (start rate 500), decel 3 stages (stop rate 300):
# the rate-difference pulses are accel stages 3 and 4: 40 + 50 = 90.
LONG_ACCEL = FreeCurveTable(MHZ1, (100, 200, 300, 400, 500), (10, 20, 30, 40, 50), (5, 6, 7))


# LE=1, decel longer: start rate 300, stop rate 500; rate-difference = 8 + 9 = 17.
LONG_DECEL = FreeCurveTable(MHZ1, (100, 200, 300, 400, 500), (10, 20, 30), (5, 6, 7, 8, 9))


def runs(e: Execution) -> list[tuple[str, int, int]]:
    return [(s.phase, s.rate, s.pulses) for s in e.segments]


def test_trapezoid_timeline_by_hand() -> None:
    e = simulate_move(COMMON, 1000)
    assert e.shape == "trapezoid" and e.status == 0x00 and e.status_hex == "0x00"
    assert runs(e) == [("accel", 400, 40), ("accel", 300, 30), ("accel", 200, 20),
                       ("accel", 100, 10), ("cruise", 100, 800), ("decel", 100, 10),
                       ("decel", 200, 20), ("decel", 300, 30), ("decel", 400, 40)]
    by_hand = 2 * (40 * 400 + 30 * 300 + 20 * 200 + 10 * 100) + 800 * 100
    assert e.ticks == by_hand == 140_000
    assert e.duration_s == pytest.approx(0.14)
    starts = [s.start_tick for s in e.segments]
    assert starts == [0, 16_000, 25_000, 29_000, 30_000, 110_000, 111_000, 115_000, 124_000]
    assert e.first_pulse_latency_s == pytest.approx(100e-6)


def test_exactly_accel_plus_decel_is_a_trapezoid_without_cruise() -> None:
    e = simulate_move(COMMON, 200)
    assert e.shape == "trapezoid" and e.status == 0x00
    assert all(s.phase != "cruise" for s in e.segments)
    assert sum(s.pulses for s in e.segments) == 200


def test_triangle_common_table_splits_half_and_truncates() -> None:
    e = simulate_move(COMMON, 151)
    assert e.shape == "triangle" and e.status == 0x10
    # ratio 100:100, accel share rounded down: 75 accel, 76 decel.
    assert runs(e) == [("accel", 400, 40), ("accel", 300, 30), ("accel", 200, 5),
                       ("decel", 200, 6), ("decel", 300, 30), ("decel", 400, 40)]
    assert e.first_pulse_latency_s == pytest.approx(700e-6)


def test_triangle_keeps_table_ratio_le1_same_stage_count() -> None:
    table = FreeCurveTable(MHZ1, (100, 200, 300), (30, 30, 30), (10, 10, 10))
    e = simulate_move(table, 80)  # ratio 90:30 → 60 accel, 20 decel
    acc = sum(s.pulses for s in e.segments if s.phase == "accel")
    dec = sum(s.pulses for s in e.segments if s.phase == "decel")
    assert (e.shape, acc, dec) == ("triangle", 60, 20)
    assert runs(e) == [("accel", 300, 30), ("accel", 200, 30),
                       ("decel", 200, 10), ("decel", 300, 10)]


def test_le1_longer_accel_triangle_and_straight_accel() -> None:
    e = simulate_move(LONG_ACCEL, 100)
    # extra 90 accel pulses whole, the other 10 split 60:18 → 7 accel, 3 decel.
    assert e.shape == "triangle" and e.status == 0x10
    assert runs(e) == [("accel", 500, 50), ("accel", 400, 40), ("accel", 300, 7),
                       ("decel", 300, 3)]
    assert simulate_move(LONG_ACCEL, 90).shape == "triangle"  # == rate-difference pulses
    s = simulate_move(LONG_ACCEL, 89)
    assert s.shape == "straight_triangle_accel" and s.status == 0x40
    assert runs(s) == [("accel", 500, 50), ("accel", 400, 39)]
    assert s.first_pulse_latency_s == pytest.approx(700e-6)
    t = simulate_move(LONG_ACCEL, 200)
    assert t.shape == "trapezoid"
    assert runs(t)[-3:] == [("decel", 100, 5), ("decel", 200, 6), ("decel", 300, 7)]


def test_le1_triangle_decel_never_speeds_up_past_the_accel_peak() -> None:
    e = simulate_move(LONG_ACCEL, 150)  # accel peaks at rate 200; decel share 14 would
    peak = min(s.rate for s in e.segments if s.phase == "accel")  # start on stage 0
    assert peak == 200
    assert all(s.rate >= peak for s in e.segments if s.phase == "decel")
    assert sum(s.pulses for s in e.segments) == 150


def test_le1_longer_decel_straight_triangle_decel_runs_the_tail() -> None:
    s = simulate_move(LONG_DECEL, 10)
    assert s.shape == "straight_triangle_decel" and s.status == 0x20
    assert runs(s) == [("decel", 400, 1), ("decel", 500, 9)]  # the last 10 of 8 + 9
    e = simulate_move(LONG_DECEL, 40)
    assert e.shape == "triangle"
    assert runs(e)[-2:] == [("decel", 400, 8), ("decel", 500, 9)]


def test_held_by_run_adds_one() -> None:
    for pulses, shape in ((1000, "trapezoid"), (100, "triangle")):
        e = simulate_move(COMMON, pulses, held_by_run=True)
        assert e.shape == shape and e.status == STATUS[shape] + 1
    assert simulate_move(LONG_DECEL, 5, held_by_run=True).status == 0x21
    assert simulate_move(LONG_ACCEL, 5, held_by_run=True).status == 0x41


def test_manual_latency_table() -> None:
    # Manual §8-3: 100/700 µs without a rate, 900/1400 µs with one.
    assert simulate_move(COMMON, 1000).first_pulse_latency_s == LATENCY_S[(True, False)] == 100e-6
    assert simulate_move(COMMON, 50).first_pulse_latency_s == 700e-6
    assert simulate_move(COMMON, 1000, high_rate=100).first_pulse_latency_s == 900e-6
    assert simulate_move(COMMON, 50, high_rate=100).first_pulse_latency_s == 1400e-6


def test_high_rate_equal_to_fastest_stage_is_the_default_motion() -> None:
    assert runs(simulate_move(COMMON, 1000, high_rate=100)) == runs(simulate_move(COMMON, 1000))


def test_high_rate_between_stages_caps_the_staircase() -> None:
    e = simulate_move(COMMON, 1000, high_rate=250)
    assert e.shape == "trapezoid" and e.high_rate == 250
    assert runs(e) == [("accel", 400, 40), ("accel", 300, 30), ("cruise", 250, 860),
                       ("decel", 300, 30), ("decel", 400, 40)]
    # The cap shrinks accel + decel to 140: 139 pulses is a triangle.
    assert simulate_move(COMMON, 139, high_rate=250).shape == "triangle"
    assert simulate_move(COMMON, 140, high_rate=250).shape == "trapezoid"


def test_high_rate_slower_than_second_stage_gives_straight_triangle() -> None:
    e = simulate_move(COMMON, 500, high_rate=350)  # 2nd stage from the start is 300
    assert e.shape == "straight_triangle_decel" and e.status == 0x20
    assert runs(e) == [("cruise", 400, 500)]  # cannot accelerate: stays at the start rate
    assert e.first_pulse_latency_s == pytest.approx(1400e-6)
    assert simulate_move(COMMON, 500, high_rate=300).shape == "trapezoid"
    # Decel side longer: the no-accel move still decelerates down to the stop rate.
    d = simulate_move(LONG_DECEL, 100, high_rate=250)  # 2nd accel stage is 200
    assert runs(d) == [("cruise", 300, 83), ("decel", 400, 8), ("decel", 500, 9)]


def test_a_move_that_cannot_accelerate_cruises_at_the_high_rate_then_runs_slower_stages() -> None:
    # Rates 10/60/20/30 (not ascending: the execution still follows the chip's rule), high
    # rate 50: slower than the second stage from the start (20), so no acceleration. The
    # level is the slower of the high rate and the start stage's (30): 50. Every decel
    # stage slower than that level is run on the way down: here the one at rate 60 (listed
    # second), which takes all 3 pulses. A level taken from another stage (60) would leave
    # nothing slower to run: 3 pulses of cruise.
    t = FreeCurveTable(MHZ1, (10, 60, 20, 30), (5, 5, 5, 5))
    e = simulate_move(t, 3, high_rate=50)
    assert e.high_rate == 50
    assert runs(e) == [("decel", 60, 3)]


def test_equal_executions_compare_equal() -> None:
    # Executions are values: the same move twice is equal (their cached arrays are left out
    # of the comparison), a different one is not.
    assert simulate_move(COMMON, 1000) == simulate_move(COMMON, 1000)
    assert simulate_move(COMMON, 1000) != simulate_move(COMMON, 999)


@pytest.mark.parametrize("rate", [99, 401, 0xFFFF, -1])
def test_high_rate_outside_table_range_is_refused(rate: int) -> None:
    with pytest.raises(MoveParameterError) as err:
        simulate_move(COMMON, 100, high_rate=rate)
    msg = str(err.value)
    assert "high rate" in msg and "100 (0x64)..400 (0x190)" in msg
    assert "F0 20" in msg and "\n" not in msg


@pytest.mark.parametrize("pulses", [0, -5, MOVE_PULSES_MAX + 1, 1.5, True, "10"])
def test_pulse_count_range(pulses: object) -> None:
    with pytest.raises(FieldRangeError, match=r"pulses: .* 1\.\.4294967295"):
        simulate_move(COMMON, pulses)  # type: ignore[arg-type]


def test_full_range_move_is_a_few_segments() -> None:
    e = simulate_move(COMMON, MOVE_PULSES_MAX)
    assert len(e.segments) == 9
    assert sum(s.pulses for s in e.segments) == MOVE_PULSES_MAX
    assert e.ticks == 2 * 30_000 + (MOVE_PULSES_MAX - 200) * 100
    assert e.position_at(np.array([e.duration_s]))[0] == MOVE_PULSES_MAX
    with pytest.raises(StepRampError, match="limit"):
        e.pulse_times_s()


def test_position_speed_and_pulse_times_agree() -> None:
    e = simulate_move(LONG_ACCEL, 137)
    times = e.pulse_times_s()
    assert len(times) == 137 and np.all(np.diff(times) > 0)
    assert times[-1] == pytest.approx(e.duration_s, abs=0)
    # At each pulse instant exactly k+1 pulses are out; just before, k.
    assert np.array_equal(e.position_at(times), np.arange(1, 138))
    assert np.array_equal(e.position_at(times - 1e-9), np.arange(0, 137))
    assert e.position_at(0.0) == 0 and e.position_at(-1.0) == 0
    t = np.linspace(-0.01, e.duration_s + 0.01, 5001)
    x = e.position_at(t)
    assert np.all(np.diff(x) >= 0) and x[-1] == 137
    lin = e.position_linear_at(t)
    assert np.array_equal(np.floor(lin + 1e-9).astype(np.int64), x)
    # Speed: the stage's clock / rate inside, 0 outside.
    v = e.speed_at(np.array([-1e-6, 0.0, times[49] + 1e-9, e.duration_s]))
    assert v.tolist() == [0.0, 2000.0, 2500.0, 0.0]


def test_sample_accel_is_the_stage_start_difference() -> None:
    e = simulate_move(COMMON, 1000)
    t, x, v, a = e.sample(1001)
    assert t[0] == 0 and t[-1] == pytest.approx(e.duration_s)
    assert x[0] == 0 and x[-1] == 1000 and np.all(np.diff(x) >= 0)
    # First stage: 2500 pps for 16 ms, next stage 3333.3 pps.
    assert a[1] == pytest.approx((1e6 / 300 - 1e6 / 400) / 0.016)
    cruise = (t > 0.031) & (t < 0.109)
    assert np.all(a[cruise] == 0) and np.all(v[cruise] == 10_000)
    assert np.all(a[(t > 0.1101) & (t < 0.1239)] < 0)
    assert np.all(a[t > 0.1241] == 0)  # the last stage has no next stage start: 0
    with pytest.raises(FieldRangeError):
        e.sample(1)


def test_json_and_csv() -> None:
    e = simulate_move(LONG_ACCEL, 100)
    obj = json.loads(json.dumps(e.to_json()))
    assert obj["shape"] == "triangle" and obj["status"] == 16 and obj["status_hex"] == "0x10"
    assert obj["ticks"] == e.ticks == 50 * 500 + 40 * 400 + 10 * 300
    assert obj["pulses"] == 100 and obj["duration_s"] == pytest.approx(0.044)
    assert [s["pulses"] for s in obj["segments"]] == [50, 40, 7, 3]
    rows = list(csv.DictReader(io.StringIO(to_csv(e))))
    assert [r["phase"] for r in rows] == ["accel", "accel", "accel", "decel"]
    assert int(rows[-1]["end_tick"]) == e.ticks
    assert float(rows[0]["speed_pps"]) == 2000.0 and float(rows[1]["start_s"]) == 0.025
    assert all(int(r["end_tick"]) - int(r["start_tick"]) == int(r["pulses"]) * int(r["rate"])
               for r in rows)


def test_bad_tables_are_refused() -> None:
    with pytest.raises(FieldRangeError, match="rates"):
        simulate_move(FreeCurveTable(MHZ1, (0, 10), (5, 5)), 3)
    with pytest.raises(FieldRangeError, match="accel stage count"):
        simulate_move(FreeCurveTable(MHZ1, (10, 20), (), (5, 5)), 3)


def test_init_table_support() -> None:
    from profiles.ppmc312 import init_model

    table = InitTable(MHZ1, "linear", start_rate=1000, high_rate=100, accel_pulses=2000)
    e = simulate_move(table, 10_000)
    expanded = init_model.expand_init(table)
    assert runs(e) == runs(simulate_move(expanded, 10_000))
    assert e.shape == "trapezoid" and e.segments[0].rate == expanded.rates[-1]


@settings(max_examples=200, deadline=None)
@given(table=tables(), pulses=st.integers(1, 3000), pick=st.integers(0, 10**6),
       use_high=st.booleans())
def test_every_shape_emits_exactly_the_requested_pulses(table: FreeCurveTable, pulses: int,
                                                        pick: int, use_high: bool) -> None:
    lo, hi = min(table.rates), max(table.rates)
    high = lo + pick % (hi - lo + 1) if use_high else 0
    e = simulate_move(table, pulses, high_rate=high)
    assert sum(s.pulses for s in e.segments) == pulses == e.pulses
    assert all(s.pulses > 0 for s in e.segments)
    tick = 0
    for s in e.segments:  # contiguous, exact integer ticks
        assert s.start_tick == tick
        tick += s.pulses * s.rate
    assert tick == e.ticks
    assert e.status == STATUS[e.shape]
    phases = [s.phase for s in e.segments]
    assert phases == sorted(phases, key=["accel", "cruise", "decel"].index)
    acc = [s.rate for s in e.segments if s.phase == "accel"]
    dec = [s.rate for s in e.segments if s.phase == "decel"]
    assert acc == sorted(acc, reverse=True) and dec == sorted(dec)  # staircases monotone
    if e.shape == "trapezoid" and high == 0:
        assert e.ticks == (sum(p * r for p, r in zip(table.accel_pulses, table.rates,
                                                      strict=False))
                           + sum(p * r for p, r in zip(table.decel, table.rates, strict=False))
                           + (pulses - table.accel_total - table.decel_total) * table.rates[0])
    if pulses <= 400:
        times = e.pulse_times_s()
        assert np.array_equal(e.position_at(times), np.arange(1, pulses + 1))
        assert e.position_at(0.0) == 0 and e.position_at(e.duration_s) == pulses


def _move_error(table: FreeCurveTable, pulses: object, high_rate: object = 0) -> int | None:
    from profiles.errors import MoveParameterError

    try:
        simulate_move(table, pulses, high_rate=high_rate)  # type: ignore[arg-type]
    except MoveParameterError as e:
        assert str(e).endswith(f"(the chip answers F0 {e.chip_code:02X})")
        return e.chip_code
    return None


PINNED_TABLE = FreeCurveTable(MHZ1, (100, 200, 300), (10, 10, 10))


@pytest.mark.parametrize("pulses, code", [
    (0, 0x23), (1, None), (0xFFFFFFFF, None), (0x100000000, 0x23), (-1, 0x23), (True, 0x23),
])
def test_pulse_count_chip_code_0x23(pulses: object, code: int | None) -> None:
    assert _move_error(PINNED_TABLE, pulses) == code


@pytest.mark.parametrize("high_rate, code", [
    (0, None), (99, 0x20), (100, None), (300, None), (301, 0x20), (1.5, 0x20),
])
def test_high_rate_chip_code_0x20(high_rate: object, code: int | None) -> None:
    assert _move_error(PINNED_TABLE, 100, high_rate) == code


@pytest.mark.parametrize("table, pulses, high_rate, shape, status", [
    (PINNED_TABLE, 60, 0, "trapezoid", 0x00),
    (PINNED_TABLE, 59, 0, "triangle", 0x10),
    # LE=1, accel one stage longer: fewer pulses than its extra stage → straight accel
    (FreeCurveTable(MHZ1, (100, 200, 300), (10, 10, 10), (10, 10)), 9, 0,
     "straight_triangle_accel", 0x40),
    (FreeCurveTable(MHZ1, (100, 200, 300), (10, 10, 10), (10, 10)), 10, 0, "triangle", 0x10),
    # decel one stage longer → straight decel
    (FreeCurveTable(MHZ1, (100, 200, 300), (10, 10), (10, 10, 10)), 9, 0,
     "straight_triangle_decel", 0x20),
    # a high rate slower than the accel side's second stage cannot accelerate
    (PINNED_TABLE, 100, 201, "straight_triangle_decel", 0x20),
    (PINNED_TABLE, 100, 200, "trapezoid", 0x00),
])
def test_shape_status_bytes(table: FreeCurveTable, pulses: int, high_rate: int, shape: str,
                            status: int) -> None:
    e = simulate_move(table, pulses, high_rate=high_rate)
    assert (e.shape, e.status) == (shape, status)


def test_positions_at_and_before_the_start_are_0() -> None:
    e = simulate_move(PINNED_TABLE, 100)
    assert e.position_at(np.array([-1.0, -1e-9, 0.0])).tolist() == [0, 0, 0]
    assert e.position_at(e.duration_s * 2) == 100


def test_segment_accel_by_hand() -> None:
    # 1 MHz, rates 100 and 200, 10 pulses each; 40 pulses: accel 200 (10 000 pps for…)
    e = simulate_move(FreeCurveTable(MHZ1, (100, 200), (10, 10)), 40)
    assert runs(e) == [("accel", 200, 10), ("accel", 100, 10), ("decel", 100, 10),
                       ("decel", 200, 10)]
    # 5 000 pps for 2 ms, then 10 000 pps for 1 ms, 10 000 for 1 ms, 5 000 for 2 ms:
    # slopes (10 000 − 5 000) / 2 ms, 0 / 1 ms, (5 000 − 10 000) / 1 ms, and 0 for the last
    assert e.segment_accel_pps2().tolist() == pytest.approx([2.5e6, 0.0, -5e6, 0.0])


def test_sample_count_limits() -> None:
    e = simulate_move(PINNED_TABLE, 100)
    assert len(e.sample(2)[0]) == 2
    for n in (1, 10**8 + 1):
        with pytest.raises(FieldRangeError, match="sample n"):
            e.sample(n)


def test_an_empty_side_names_its_count_0() -> None:
    with pytest.raises(FieldRangeError) as e:
        simulate_move(FreeCurveTable(MHZ1, (10, 20), (), (5, 5)), 3)
    assert (e.value.value, e.value.lo) == (0, 1)


@pytest.mark.parametrize("table, high_rate, expected", [
    # 2 stages, high rate between them: no acceleration, the move runs at the start rate
    (FreeCurveTable(MHZ1, (100, 200), (10, 10)), 150,
     [("cruise", 200, 30)]),
    # 3 stages, high rate slower than the middle one: start rate, then down the slower ones
    (PINNED_TABLE, 201, [("cruise", 300, 30)]),
])
def test_a_high_rate_that_cannot_accelerate(table: FreeCurveTable, high_rate: int,
                                            expected: list[tuple[str, int, int]]) -> None:
    e = simulate_move(table, 30, high_rate=high_rate)
    assert (e.shape, e.status) == ("straight_triangle_decel", 0x20)
    assert runs(e) == expected


def test_pulse_times_csv_chunks_match_the_cumulative_sum() -> None:
    from profiles.ppmc312.execution import (
        PULSE_TIMES_CSV_MAX,
        pulse_times_csv_chunks,
        samples_csv,
    )

    e = simulate_move(FreeCurveTable(MHZ1, (100, 200, 300), (10, 20, 30)), 200)
    chunks = list(pulse_times_csv_chunks(e, chunk=7))
    assert chunks[0] == "pulse,time_s\n" and max(c.count("\n") for c in chunks[1:]) <= 7
    rows = "".join(chunks).splitlines()[1:]
    times = e.pulse_times_s()  # repeat/cumsum: another way to the same instants
    assert rows == [f"{i},{t:.9f}" for i, t in enumerate(times, start=1)]
    assert len(samples_csv(e).splitlines()) == 1001  # 1000 samples by default
    assert PULSE_TIMES_CSV_MAX == 10_000_000
    big = simulate_move(PINNED_TABLE, PULSE_TIMES_CSV_MAX)
    assert next(pulse_times_csv_chunks(big)) == "pulse,time_s\n"
    with pytest.raises(FieldRangeError, match="one CSV row per pulse"):
        next(pulse_times_csv_chunks(simulate_move(PINNED_TABLE, PULSE_TIMES_CSV_MAX + 1)))


def test_families_of_a_move_that_cannot_accelerate() -> None:
    """LE=1, decel two stages longer, high rate 150 between the accel side's rates: the
    move runs at level max(150, 200) = 200 and then down the decel stages slower than it
    (300 × 7, 400 × 8). Worked by hand: up to 8 pulses only rate 400 runs; from 9 rate 300
    joins (15 is the whole tail, the same rates); from 16 a cruise at 200 comes first."""
    from profiles.ppmc312.execution import move_families

    table = FreeCurveTable(MHZ1, (100, 200, 300, 400), (10, 10), (5, 6, 7, 8))
    fams = move_families(table, high_rate=150)
    assert [f.lo for f in fams] == [1, 9, 16]
    assert fams[-1].hi == 0xFFFFFFFF
    for fam in fams:
        for n in range(fam.lo, min(fam.hi, 40) + 1):
            assert [(s.phase, s.rate) for s in simulate_move(table, n, high_rate=150).segments
                    ] == [(s.phase, s.rate) for s in fam.execution().segments], n
    assert runs(simulate_move(table, 8, high_rate=150)) == [("decel", 400, 8)]
    assert runs(simulate_move(table, 9, high_rate=150)) == [("decel", 300, 1), ("decel", 400, 8)]
    assert runs(simulate_move(table, 16, high_rate=150))[0] == ("cruise", 200, 1)
    assert move_families(table) == move_families(table, high_rate=0)  # 0: the table's
    # the rate the move runs at is reported: the slower of the high rate and the start rate
    assert simulate_move(table, 30, high_rate=150).high_rate == 200
    assert simulate_move(table, 30, high_rate=250).high_rate == 250


@settings(max_examples=150, deadline=None)
@given(st.lists(st.integers(2, 40), min_size=2, max_size=5), st.data())
def test_segments_are_merged_and_contiguous(accel: list[int], data: st.DataObject) -> None:
    """Whatever the shape: no two neighbouring segments share phase and rate (a clamped
    share at the peak rate joins its neighbour), the pulses add up to the move, and each
    segment starts where the previous one ended."""
    n = len(accel)
    decel = data.draw(st.one_of(st.none(), st.lists(st.integers(2, 40), min_size=2,
                                                    max_size=5)))
    rates = tuple(100 + 37 * k for k in range(max(n, len(decel or []))))
    table = FreeCurveTable(MHZ1, rates, tuple(accel), None if decel is None else tuple(decel))
    pulses = data.draw(st.integers(1, sum(accel) + sum(decel or accel) + 3))
    high = data.draw(st.sampled_from([0, *rates]))
    e = simulate_move(table, pulses, high_rate=high)
    keys = [(s.phase, s.rate) for s in e.segments]
    assert all(a != b for a, b in itertools.pairwise(keys)), keys
    assert sum(s.pulses for s in e.segments) == pulses
    assert all(a.end_tick == b.start_tick for a, b in itertools.pairwise(e.segments))


# --- time queries at their exact edges (found by tools/mutation.py) -------------------------
# A 2**20 Hz clock makes every dyadic instant exact in ticks (t · hz = the ticks written).
DYADIC = Clock.extck(2.0**20)


def test_the_snap_window_is_4_ulps_of_the_tick_count() -> None:
    run = simulate_move(FreeCurveTable(DYADIC, (3, 7), (3, 4)), 20)  # first: 4 pulses at rate 7
    ulp = float(np.spacing(21.0))  # the 3rd pulse ends at tick 21
    at = [21.0, 21 - 4 * ulp, 21 - 5 * ulp, 21 + 4 * ulp]
    assert list(run.position_at(np.array(at) / DYADIC.hz)) == [3, 3, 2, 3]


def test_positions_just_after_the_start() -> None:
    # a rate of 1: the first pulse ends at tick 1; the linear position runs from 0
    run = simulate_move(FreeCurveTable(DYADIC, (1,), (3,)), 6)
    assert list(run.position_at(np.array([0.0, 0.5, 1.0]) / DYADIC.hz)) == [0, 0, 1]
    slow = simulate_move(FreeCurveTable(DYADIC, (3, 7), (3, 4)), 20)
    assert list(slow.position_linear_at(np.array([0.0, 0.5, 7.0]) / DYADIC.hz)) == \
        [0.0, 0.5 / 7, 1.0]


def test_an_execution_without_segments_or_with_an_empty_one() -> None:
    from profiles.ppmc312.execution import Segment

    empty = Execution("trapezoid", 0, [], 0, DYADIC, 3, False)
    assert empty.segment_accel_pps2().shape == (0,)
    assert list(empty.position_at([0.0, 1.0])) == [0, 0]
    # a segment of 0 pulses lasts no time: no slope from it (not a division by 0)
    hollow = Execution("trapezoid", 0, [Segment("accel", 7, 0, 0), Segment("cruise", 3, 2, 0),
                                        Segment("decel", 7, 1, 6)], 3, DYADIC, 3, False)
    slopes = hollow.segment_accel_pps2()
    assert slopes[0] == 0.0 and np.all(np.isfinite(slopes))


def test_sample_edges_and_pulse_time_limits() -> None:
    e = simulate_move(COMMON, 1000)
    a = e.sample(1001)[3]
    assert a[0] == pytest.approx((1e6 / 300 - 1e6 / 400) / 0.016)  # t = 0 is in the move
    with pytest.raises(FieldRangeError) as err:
        e.sample(10**8 + 1)
    assert (err.value.lo, err.value.hi) == (2, 10**8)
    # edges: each segment start plus the end, the last speed repeated (400 pps … 2500 pps)
    t, x, v = e.edges()
    assert t[0] == 0.0 and t[-1] == e.duration_s
    assert list(x[-2:]) == [960.0, 1000.0] and list(v[-2:]) == [2500.0, 2500.0]
    assert v[-3] == pytest.approx(1e6 / 300)
    # pulse times: up to `limit` pulses, the limit named when refused
    assert len(e.pulse_times_s(limit=1000)) == 1000
    with pytest.raises(FieldRangeError) as err:
        e.pulse_times_s(limit=999)
    assert (err.value.value, err.value.lo, err.value.hi) == (1000, 0, 999)
    with pytest.raises(FieldRangeError) as err:
        simulate_move(COMMON, 10_000_001).pulse_times_s()
    assert err.value.hi == 10_000_000


def _rates(plan: list[tuple[str, int, int]]) -> list[tuple[str, int]]:
    return [(phase, rate) for phase, rate, _ in plan]


# LE=1, accel extra stages (fastest first) 2 then 30 pulses: the rate-difference is 32 and
# the straight accel triangle enters its second extra stage at 31 = rate-difference − 1.
EDGE_EXTRA = FreeCurveTable(MHZ1, (100, 200, 300, 400), (10, 20, 2, 30), (5, 6))


@pytest.mark.parametrize("table", [COMMON, LONG_ACCEL, LONG_DECEL, EDGE_EXTRA],
                         ids=["common", "long accel", "long decel", "edge extra"])
def test_families_by_brute_force_on_pinned_tables(table: FreeCurveTable) -> None:
    from profiles.ppmc312.execution import move_families

    fams = move_families(table)
    assert fams[0].lo == 1 and fams[-1].hi == MOVE_PULSES_MAX
    top = table.accel_total + table.decel_total + 2
    for fam in fams:
        first = fam.execution()
        assert fam.runs() == fam.runs(fam.lo) == runs(first)
        for n in range(fam.lo, min(fam.hi, top) + 1):
            assert _rates(runs(simulate_move(table, n))) == _rates(runs(first)), n
        n = min(fam.hi, top)
        assert fam.runs(n) == runs(simulate_move(table, n))
    if table is EDGE_EXTRA:
        assert 31 in [f.lo for f in fams]
    # a boundary of no effect is merged: neighbours differ in their rates or their shape
    for a, b in itertools.pairwise(fams):
        assert _rates(a.runs()) != _rates(b.runs()) or a.shape != b.shape
    # membership: whole numbers lo..hi only
    fam = fams[1]
    assert fam.lo in fam and fam.hi in fam and fam.lo - 1 not in fam and fam.hi + 1 not in fam
    assert float(fam.lo) not in fam and "1" not in fam


def test_a_rate_below_1_is_refused_naming_the_range() -> None:
    with pytest.raises(FieldRangeError) as err:
        simulate_move(FreeCurveTable(MHZ1, (0, 5), (2, 2)), 4)
    assert (err.value.field, err.value.lo) == ("rates[0]", 1)


def test_a_move_that_cannot_accelerate_cruises_at_the_start_rate() -> None:
    # high rate 250 is slower than the 2nd slowest stage (200): no acceleration; the move
    # cruises at the slowest rate 300, whatever that stage's pulse count (1000 here)
    table = FreeCurveTable(MHZ1, (100, 200, 300), (10, 20, 1000), (10, 20, 5))
    for n in (50, 2000):
        assert runs(simulate_move(table, n, high_rate=250)) == [("cruise", 300, n)]


def test_pulse_times_csv_by_hand_and_its_limit() -> None:
    from profiles.ppmc312.execution import pulse_times_csv

    # 4 pulses, a triangle on the slower stage: 2 up and 2 down at rate 200 on 1 MHz
    run = simulate_move(FreeCurveTable(MHZ1, (100, 200), (2, 2)), 4)
    assert pulse_times_csv(run) == ("pulse,time_s\n1,0.000200000\n2,0.000400000\n"
                                    "3,0.000600000\n4,0.000800000\n")
    with pytest.raises(FieldRangeError) as err:
        pulse_times_csv(simulate_move(COMMON, 10_000_001))
    assert (err.value.lo, err.value.hi) == (1, 10_000_000)


def test_edges_repeat_the_last_speed_not_the_first() -> None:
    # LE=1, start at rate 300 (3333 pps), stop at rate 500 (2000 pps)
    t, x, v = simulate_move(LONG_DECEL, 1000).edges()
    assert v[0] == pytest.approx(1e6 / 300) and list(v[-2:]) == [2000.0, 2000.0]
    assert x[-1] == 1000 and len(t) == len(x) == len(v)


@settings(max_examples=100, deadline=None)
@given(table=tables(), lengths=st.lists(st.integers(1, 3000), min_size=1, max_size=8),
       pick=st.integers(0, 10**6), use_high=st.booleans())
def test_several_moves_at_once_are_each_move_alone(table: FreeCurveTable, lengths: list[int],
                                                   pick: int, use_high: bool) -> None:
    lo, hi = min(table.rates), max(table.rates)
    high = lo + pick % (hi - lo + 1) if use_high else 0
    assert simulate_moves(table, lengths, high_rate=high) == [
        simulate_move(table, n, high_rate=high) for n in lengths]


def test_several_moves_refuse_a_bad_length() -> None:
    with pytest.raises(MoveParameterError, match="pulses"):
        simulate_moves(COMMON, [10, 0])


MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


TABLE = FreeCurveTable(MHZ1, (100, 200, 300, 400), (10, 20, 30, 40))


def test_plan_stream_from_motor_follows_the_chip_staircase() -> None:
    from profiles.ppmc312.planner import plan_free_curve

    motor = load_motor(MOTOR)
    run = simulate_move(plan_free_curve(motor, pulses=3000).table, 3000)
    packets, duration = M.plan_stream(3000, period_us=500,
                                      profile=(run.position_at, run.duration_s))
    assert duration == run.duration_s
    commands = [p.value for p in packets[5:-10]]
    t = np.minimum(np.arange(1, len(commands) + 1) * 500e-6, duration)
    assert commands == [int(x) for x in run.position_at(t)]


def test_pulse_times_csv_from_the_segments() -> None:
    run = simulate_move(TABLE, 150)
    expected = []  # every pulse ends one rate after the previous, segment by segment
    for s in run.segments:
        expected += [(s.start_tick + s.rate * (k + 1)) / 1e6 for k in range(s.pulses)]
    rows = pulse_times_csv(run).splitlines()
    assert rows[0] == "pulse,time_s" and len(rows) == 151
    for i, row in enumerate(rows[1:], start=1):
        n, t = row.split(",")
        assert int(n) == i and float(t) == pytest.approx(expected[i - 1], abs=1e-9)


def test_samples_csv_rows() -> None:
    run = simulate_move(TABLE, 150)
    rows = [r.split(",") for r in samples_csv(run, 11).splitlines()]
    assert rows[0] == ["t_s", "x_pulses", "v_pps", "a_pps2"] and len(rows) == 12
    assert float(rows[1][0]) == 0 and float(rows[-1][0]) == pytest.approx(run.duration_s)
    assert float(rows[-1][1]) == 150
    # a speed inside the move is 1 MHz over the running segment's rate
    t_mid, v_mid = float(rows[6][0]), float(rows[6][2])
    tick = t_mid * 1e6
    seg = next(s for s in run.segments if s.start_tick <= tick < s.end_tick)
    assert v_mid == pytest.approx(1e6 / seg.rate)

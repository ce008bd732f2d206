"""Decel stops (81) from any pulse of the ramp (profiles/ppmc312/stops.py): what the chip
runs under each reading the manual leaves open, by hand on small LE=0 and LE=1 tables
(LOW included); the batch of every stop against `stop_runs`; the compiled verdict against
the plain-Python oracle; the all-stop verdict against every dwell judged."""

from __future__ import annotations

import math

import numpy as np
import pytest
import rotor_oracle as oracle
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_rotor_kernel import motors, tables

from profiles.errors import FieldRangeError, FormatError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.motor.rotor import SLIP_DEG, rotor_of
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.load_angle import directions, spans_of
from profiles.ppmc312.stops import (
    describe_readings,
    dwell_ranges,
    is_low,
    locate,
    ramp_pulse,
    readings_of,
    stop_angles,
    stop_batch,
    stop_execution,
    stop_problems,
    stop_runs,
    stop_runs_at,
)
from profiles.ppmc312.table import FreeCurveTable

MHZ1 = Clock.internal("1MHz")
AGREE_DEG = 0.1
# fastest first: rates 100 < 200 < 400 (10 000, 5 000, 2 500 pps)
LE0 = FreeCurveTable(MHZ1, (100, 200, 400), (5, 3, 2))
# LE=1, two decel stages: accel stages 2 and 3 are slower than the stop rate (LOW)
LE1 = FreeCurveTable(MHZ1, (100, 200, 400, 800), (5, 3, 2, 2), (4, 6))
MOTORS = {p.stem.removeprefix("motor-"): load_motor(p) for p in bundled_motor_paths()}


def test_every_reading_by_hand_le0() -> None:
    """2 pulses into stage 1 (200) of the LE=0 table, after stage 2 (400 × 2)."""
    head = [("accel", 400, 2), ("accel", 200, 2)]
    assert stop_runs(LE0, 1, 2, "a") == [*head, ("decel", 200, 3), ("decel", 400, 2)]
    assert stop_runs(LE0, 1, 2, "b") == [*head, ("decel", 200, 1), ("decel", 400, 2)]
    assert stop_runs(LE0, 1, 2, "c") == [*head, ("decel", 400, 2)]
    # (b) at the stage's last pulse is (c) there: nothing left of the stage
    assert stop_runs(LE0, 1, 3, "b") == stop_runs(LE0, 1, 3, "c") == [
        ("accel", 400, 2), ("accel", 200, 3), ("decel", 400, 2)]
    # the slowest stage: nothing to walk down, the stop ends at its rate
    assert stop_runs(LE0, 2, 1, "c") == [("accel", 400, 1)]
    assert stop_runs(LE0, 2, 1, "a") == [("accel", 400, 1), ("decel", 400, 2)]
    # the top stage: (a) is a trapezoid's decel after p pulses of it
    assert stop_runs(LE0, 0, 4, "a") == [("accel", 400, 2), ("accel", 200, 3),
                                         ("accel", 100, 4), ("decel", 100, 5),
                                         ("decel", 200, 3), ("decel", 400, 2)]


def test_every_reading_by_hand_le1_and_low() -> None:
    """LE=1: (a) runs the decel side's count of the stage; stages slower than the decel
    side's slowest stop at once under every reading (LOW)."""
    head = [("accel", 800, 2), ("accel", 400, 2), ("accel", 200, 3)]
    assert stop_runs(LE1, 0, 1, "a") == [*head, ("accel", 100, 1), ("decel", 100, 4),
                                         ("decel", 200, 6)]
    assert stop_runs(LE1, 0, 1, "b") == [*head, ("accel", 100, 1), ("decel", 100, 4),
                                         ("decel", 200, 6)]
    assert stop_runs(LE1, 0, 1, "c") == [*head, ("accel", 100, 1), ("decel", 200, 6)]
    # stage 1 is the decel side's slowest: (a) dwells its 6, (c) stops at its rate
    assert stop_runs(LE1, 1, 2, "a") == [("accel", 800, 2), ("accel", 400, 2),
                                         ("accel", 200, 2), ("decel", 200, 6)]
    assert stop_runs(LE1, 1, 2, "c") == [("accel", 800, 2), ("accel", 400, 2),
                                         ("accel", 200, 2)]
    assert not is_low(LE1, 1) and is_low(LE1, 2) and is_low(LE1, 3) and not is_low(LE0, 2)
    for reading in "abc":
        assert stop_runs(LE1, 2, 1, reading) == [("accel", 800, 2), ("accel", 400, 1)]
        assert stop_runs(LE1, 3, 2, reading) == [("accel", 800, 2)]


def test_a_stop_is_found_by_its_pulse_of_the_ramp_and_in_the_cruise_runs_the_decel() -> None:
    assert [locate(LE0, n) for n in (1, 2, 3, 5, 6, 10, 11)] == [
        (2, 1), (2, 2), (1, 1), (1, 3), (0, 1), (0, 5), None]
    assert ramp_pulse(LE0, 1, 3) == 5 and ramp_pulse(LE0, 0, 1) == 6
    assert stop_runs_at(LE0, 4, "a") == stop_runs(LE0, 1, 2, "a")
    for reading in "abc":  # the cruise: the trapezoid's decel under every reading
        assert stop_runs_at(LE0, 13, reading) == [
            ("accel", 400, 2), ("accel", 200, 3), ("accel", 100, 5), ("cruise", 100, 3),
            ("decel", 100, 5), ("decel", 200, 3), ("decel", 400, 2)]


def test_bad_stops_are_refused_in_one_line() -> None:
    for call in (lambda: stop_runs(LE0, 3, 1, "a"), lambda: stop_runs(LE0, 1, 0, "a"),
                 lambda: stop_runs(LE0, 1, 4, "c"), lambda: stop_runs(LE0, -1, 1, "c"),
                 lambda: stop_runs(LE0, True, 1, "c"), lambda: locate(LE0, 0)):
        with pytest.raises(FieldRangeError) as e:
            call()
        assert "\n" not in str(e.value)
    with pytest.raises(FormatError, match="reading: 'd' is not one of a, b, c"):
        stop_runs(LE0, 1, 1, "d")


def test_the_dwells_are_exactly_the_readings_not_the_gap() -> None:
    """(c)/(b): 1..A[i]; (a): D[i]+1..D[i]+A[i]; the gap between them is no stop."""
    r = dwell_ranges(LE1)
    assert list(zip(r.stage.tolist(), r.lo.tolist(), r.hi.tolist(), strict=True)) == [
        (0, 1, 9), (1, 1, 3), (1, 7, 9), (2, 1, 2), (3, 1, 2)]
    assert readings_of(LE1, 1, 3) == [("b", None), ("c", 3)]
    assert readings_of(LE1, 1, 7) == [("a", 1)]
    assert readings_of(LE1, 1, 5) == []  # the gap
    assert readings_of(LE1, 0, 5) == [("a", 1), ("b", None), ("c", 5)]
    assert readings_of(LE1, 2, 2) == [("LOW", 2)]
    assert "reading (a): at once, same stage" in describe_readings(readings_of(LE1, 1, 7))
    assert "E0 cause bit LOW" in describe_readings(readings_of(LE1, 2, 2))


@pytest.mark.parametrize("table", [LE0, LE1], ids=["LE0", "LE1"])
def test_the_batch_of_every_stop_is_stop_runs(table: FreeCurveTable) -> None:
    """Every (stage, dwell) of the table's dwell ranges, built at once in numpy, is the
    stop of its first reading (neighbouring segments of one rate joined)."""
    r = dwell_ranges(table)
    pairs = [(s, d) for s, lo, hi in zip(r.stage.tolist(), r.lo.tolist(), r.hi.tolist(),
                                         strict=True) for d in range(lo, hi + 1)]
    batch = stop_batch(table, np.array([s for s, _ in pairs]), np.array([d for _, d in pairs]))
    for e, (s, d) in enumerate(pairs):
        reading, p = readings_of(table, s, d)[0]
        runs = stop_runs(table, s, table.accel_pulses[s] if p is None else p,
                         "c" if reading == "LOW" else reading)
        joined: list[tuple[int, int]] = []
        for _, rate, count in runs:
            if joined and joined[-1][0] == rate:
                joined[-1] = (rate, joined[-1][1] + count)
            else:
                joined.append((rate, count))
        assert [(rate, count) for _, rate, count in batch.runs(e)] == joined
        assert batch.pulses[e] == sum(c for _, c in joined)
        assert stop_execution(table, s, d).pulses == batch.pulses[e]


def whole_stop(table: FreeCurveTable, motor: Motor, stage: int, dwell: int) -> float:
    """The stop integrated whole from rest until settled by the plain-Python oracle, its
    worst |load angle| over the directions the verdict judges."""
    worst = 0.0
    for direction in directions(motor):
        rotor = rotor_of(motor, direction=direction)
        step = rotor.step_s()
        trace = oracle.follow(rotor, spans_of(stop_execution(table, stage, dwell), rotor, step),
                              step_s=step, trace=oracle.Trace(record=False))
        worst = max(worst, math.degrees(rotor.c_e * max(trace.span_max)))
    return worst


def every_dwell(table: FreeCurveTable) -> list[tuple[int, int]]:
    r = dwell_ranges(table)
    return [(s, d) for s, lo, hi in zip(r.stage.tolist(), r.lo.tolist(), r.hi.tolist(),
                                        strict=True) for d in range(lo, hi + 1)]


def assert_sampled_stops_are_the_oracles(table: FreeCurveTable, motor: Motor,
                                         picks: list[int]) -> None:
    """Stops judged in the all-stop batch (sharing prefixes, family dwells and tails with
    its reference), each against the oracle's whole stop."""
    found = stop_angles(table, [motor])
    per_stop = found.deg.max(axis=0)
    for e in sorted({min(k, len(per_stop) - 1) for k in picks}):
        if per_stop[e] < SLIP_DEG:
            assert per_stop[e] == pytest.approx(
                whole_stop(table, motor, int(found.stage[e]), int(found.dwell[e])),
                abs=AGREE_DEG), (int(found.stage[e]), int(found.dwell[e]))


@pytest.mark.parametrize("name", sorted(MOTORS))
def test_planned_tables_stops_are_the_oracles_and_every_dwell(name: str) -> None:
    """A plan of each bundled motor: the worst stop and a spread of others against the
    oracle, and the sampled verdict against every dwell of every stage judged."""
    from profiles.ppmc312.planner import plan_free_curve

    motor = MOTORS[name]
    table = plan_free_curve(motor, pulses=2000).table
    found = stop_angles(table, [motor])
    worst = int(np.argmax(found.deg.max(axis=0)))
    assert_sampled_stops_are_the_oracles(table, motor, [0, worst, len(found.stage) // 3,
                                                        len(found.stage) - 1])
    every = stop_angles(table, [motor], stops=every_dwell(table))
    assert found.worst_deg() == pytest.approx(every.worst_deg(), abs=AGREE_DEG)


SETTINGS = settings(max_examples=20, suppress_health_check=[HealthCheck.too_slow])


@pytest.mark.slow
@SETTINGS
@given(st.data())
def test_random_tables_stops_are_the_oracles_and_every_dwell(data: st.DataObject) -> None:
    """Random small tables (LE=0 and LE=1, LOW stages too) and motors: stops judged in the
    batch against the oracle, the sampled verdict against every dwell."""
    motor = data.draw(motors())
    table = data.draw(tables(0.9 * motor.top_curve_pps))
    found = stop_angles(table, [motor])
    n = len(found.stage)
    assert_sampled_stops_are_the_oracles(
        table, motor, data.draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=3)))
    every = stop_angles(table, [motor], stops=every_dwell(table))
    if every.slipped.any():
        assert found.slipped.any()
        return
    assert found.worst_deg() == pytest.approx(every.worst_deg(), abs=AGREE_DEG)


def test_the_criterion_on_stops_allows_low_and_finds_what_the_trapezoid_has() -> None:
    """A stop's speed changes are the trapezoid's own (a dwell is its stop's fastest
    segment: no reading changes the dwells its steps are judged on). A stop ending at
    the stop rate (5 000 pps here, above a 2 000 pps start) is flagged as the moves are;
    a LOW stop ends slower than the stop rate and is allowed as the stop rate is."""
    from dataclasses import replace

    from profiles.ppmc312.criterion import all_length_problems

    motor = replace(MOTORS["nema17-1600"], start_pps=2000.0, max_jump_pps=1e5)
    table = FreeCurveTable(MHZ1, LE1.rates, LE1.accel_pulses, (4, 1))  # a 1-pulse decel
    found = stop_problems(table, motor)
    stops = {(stage, p.kind) for stage, p in found if p.rule == "start-speed"}
    assert (1, "stop") in stops and not {s for s, _ in stops} & {2, 3}
    moves = {(p.rule, p.v_from_pps, p.v_to_pps) for p in all_length_problems(table, motor)}
    assert {(p.rule, p.v_from_pps, p.v_to_pps) for _, p in found} <= moves
    assert {p.rule for _, p in found} >= {"accel", "decel", "start-speed"}
    assert not any(p.rule == "switch" for _, p in found)

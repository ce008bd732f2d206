"""Decel stops (81) from any pulse of the ramp (profiles/ppmc312/stops.py): what the chip
runs under each reading the manual leaves open, by hand on small LE=0 and LE=1 tables
(LOW included); the batch of every stop against `stop_runs`; the compiled verdict against
the plain-Python oracle; the all-stop verdict against every dwell judged."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles.errors import FieldRangeError, FormatError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.motor.rotor import SLIP_DEG
from profiles.ppmc312.clock import Clock
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
from tests.support.oracle_moves import whole_stop
from tests.support.strategies import rotor_motors as motors
from tests.support.strategies import rotor_tables as tables

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
    from dataclasses import replace

    motor = data.draw(motors())
    table = data.draw(tables(0.9 * motor.top_curve_pps))
    # Against the oracle without Coulomb friction: its sign flips where the rotor's speed
    # crosses zero, and there RK4 depends on how a dwell is cut into steps; the verdict
    # cuts a stage's dwell where its other stops end (as it cuts moves' dwells), which
    # with friction can move a result by a few tenths of a degree from the oracle's
    # integration of the stop whole (moves alike).
    smooth = replace(motor, friction_torque_nm=0.0)
    n = len(stop_angles(table, [smooth]).stage)
    assert_sampled_stops_are_the_oracles(
        table, smooth, data.draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=3)))
    found = stop_angles(table, [motor])
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


def test_stops_on_part_of_the_ramp_and_their_dwells_by_pulse_and_reading() -> None:
    """`--pulses` judges the stops on the ramp its moves run: a limit of 3 ramp pulses
    leaves stage 2 whole and stage 1's first pulse ((c) 1, (b) its 3, (a) 4)."""
    from profiles.ppmc312.stops import dwell_of, ramp_reach

    r = dwell_ranges(LE0, 3)
    assert list(zip(r.stage.tolist(), r.lo.tolist(), r.hi.tolist(), strict=True)) == [
        (1, 1, 1), (1, 3, 4), (2, 1, 4)]
    r = dwell_ranges(LE1, 1)  # LOW: the stop at once, under every reading
    assert list(zip(r.stage.tolist(), r.lo.tolist(), r.hi.tolist(), strict=True)) == [
        (3, 1, 1)]
    assert ramp_reach(LE0, [3]) == 1 and ramp_reach(LE0, [1, 30]) == 10
    assert [dwell_of(LE1, 1, 2, r) for r in "abc"] == [8, 3, 2]
    assert [dwell_of(LE1, 2, 1, r) for r in "abc"] == [1, 1, 1]


def nema23_moves_only() -> FreeCurveTable:
    """The NEMA23's 10 000-pulse plan tightened for its moves alone (no stops)."""
    from profiles.ppmc312.planner import plan_free_curve

    return plan_free_curve(MOTORS["nema23-heavy"], pulses=10_000, load_angle_deg=75.0,
                           decel_stops=False).table


def test_a_table_known_to_ring_on_a_stop_is_flagged() -> None:
    """A table whose every move is within the aim rings past it on a decel stop a few
    pulses into a mid-ramp stage (reading (a), the same stop as reading (c) a few pulses
    on): a warning, and
    past the 90° peak on a less damped motor an error, naming the command, the stage,
    the pulse of the ramp, the reading and the angle; `--commands 82` leaves it out."""
    from dataclasses import replace

    from verify.safety import judge_safety

    table = nema23_moves_only()
    motor = MOTORS["nema23-heavy"]
    verdict = judge_safety(table, motor)
    assert verdict.load_angle is not None and verdict.load_angle.worst_deg <= 75.0
    assert verdict.safe and not verdict.within_aim and verdict.failed == ()
    (warning,) = [f for f in verdict.findings() if f.rule.startswith("decel-stop")]
    assert warning.severity == "warning" and warning.rule == "decel-stop-load-angle-margin"
    assert warning.message.startswith("a decel stop (81) 2 pulses into stage 84 (pulse ")
    assert "reading (a): at once, same stage" in warning.message
    assert "the same stop as reading (c) 9 pulses into it" in warning.message
    assert "drives the rotor to 85.9° electrical" in warning.message
    assert judge_safety(table, motor, commands=["82"]).within_aim
    weak = replace(motor, damping_ratio=0.08)
    verdict = judge_safety(table, weak)
    assert verdict.load_angle is not None and verdict.load_angle.worst_deg < 90.0
    assert not verdict.safe and verdict.failed == ("decel-stop",)
    (error,) = [f for f in verdict.findings() if f.rule == "decel-stop-load-angle"]
    assert error.severity == "error" and "past the 90° peak" in error.message
    assert re.search(r"a decel stop \(81\) \d+ pulses into stage \d+ \(pulse \d+ of the ramp; "
                     r"reading \([abc]\): .*\) drives the rotor to 9\d\.\d° electrical",
                     error.message)
    stop = verdict.to_json()["commands"]["decel-stop"]
    assert not stop["safe"] and stop["worst_load_angle_deg"] >= 90.0
    assert whole_stop(table, weak, stop["stage"], stop["dwell_pulses"]) == pytest.approx(
        stop["worst_load_angle_deg"], abs=AGREE_DEG)


def test_the_verdicts_json_carries_the_commands_object() -> None:
    """`to_json()["commands"]["decel-stop"]`: safe, the worst angle and its margins to the
    aim and the peak, the reading (and every reading of that stop), the stage, the pulses
    into it, the pulse of the ramp; narrowed away by `commands`; an unknown command is
    refused in one line."""
    from verify.safety import judge_safety

    table = nema23_moves_only()
    stop = judge_safety(table, MOTORS["nema23-heavy"]).to_json()["commands"]["decel-stop"]
    assert set(stop) == {
        "command", "code", "safe", "within_aim", "worst_load_angle_deg", "margin_to_aim_deg",
        "margin_deg", "reading", "readings", "stage", "pulses_into_stage", "ramp_pulse",
        "dwell_pulses", "worst_direction", "worst_at", "first_unstable", "slips",
        "executions", "sample_failures", "criterion_findings"}
    assert (stop["command"], stop["code"], stop["safe"], stop["within_aim"]) == (
        "decel-stop", "81", True, False)
    assert stop["reading"] == "a" and stop["readings"] == [
        {"reading": "a", "pulses_into_stage": 2}, {"reading": "c", "pulses_into_stage": 9}]
    assert (stop["stage"], stop["pulses_into_stage"], stop["dwell_pulses"]) == (84, 2, 9)
    assert stop["ramp_pulse"] == sum(table.accel_pulses[85:]) + 2
    assert stop["margin_to_aim_deg"] == pytest.approx(75.0 - stop["worst_load_angle_deg"])
    assert stop["margin_deg"] == pytest.approx(90.0 - stop["worst_load_angle_deg"])
    assert stop["worst_at"] == "nominal" and stop["first_unstable"] is None
    for narrowed, left in ((["82"], []), (["accel", "0x80"], ["stop"])):
        assert list(judge_safety(table, MOTORS["nema23-heavy"],
                                 commands=narrowed).to_json()["commands"]) == left
    assert "decel-stop" in judge_safety(table, MOTORS["nema23-heavy"],
                                        commands=["82", "81"]).to_json()["commands"]
    with pytest.raises(FormatError, match="commands: 'jog' is neither") as e:
        judge_safety(table, MOTORS["nema23-heavy"], commands=["jog"])
    assert "\n" not in str(e.value)


def test_check_judges_stops_and_commands_narrows_them(tmp_path: Path) -> None:
    """`stepramp check TABLE --motor M` carries the decel stop's verdict in its JSON and
    its finding in the text; `--commands 82` leaves it out; a bad command is exit 2."""
    import contextlib
    import io
    import json

    from profiles.ppmc312.table import dump_table
    from verify import cli

    path = tmp_path / "t.table.json"
    path.write_text(dump_table(nema23_moves_only()))

    def run(*argv: str) -> tuple[int, str]:
        out = io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
            code = cli.main([str(a) for a in argv])
        return code, out.getvalue()

    code, out = run("check", str(path), "--motor", "nema23-heavy", "--format", "json")
    safety = json.loads(out)["files"][0]["safety"]
    assert code == 0 and safety["commands"]["decel-stop"]["stage"] == 84
    code, out = run("check", str(path), "--motor", "nema23-heavy")
    assert code == 0 and "warning [decel-stop-load-angle-margin]: a decel stop (81) 2" in out
    code, out = run("check", str(path), "--motor", "nema23-heavy", "--commands", "82",
                    "--format", "json")
    assert code == 0 and json.loads(out)["files"][0]["safety"]["commands"] == {}
    code, out = run("check", str(path), "--motor", "nema23-heavy", "--commands", "82,9")
    assert code == 2 and out.count("\n") == 1 and "'9' is neither" in out
    code, out = run("check", str(path), "--commands", "82")
    assert code == 2 and "--commands applies to the stall verdict: it needs --motor" in out


@settings(max_examples=60, suppress_health_check=[HealthCheck.too_slow])
@given(motors(), st.data())
def test_every_step_of_a_stop_is_one_its_trapezoid_takes(motor: Motor,
                                                         data: st.DataObject) -> None:
    """Why the verdict over every move length needs no criterion of its own on the stops:
    on any table, every speed change a stop breaks the criterion with (rule, from, to) is
    one the longest trapezoid breaks it with too."""
    from profiles.ppmc312.criterion import execution_problems
    from profiles.ppmc312.execution import simulate_move

    table = data.draw(tables(0.9 * motor.top_curve_pps))
    trapezoid = simulate_move(table, table.accel_total + table.decel_total)
    moves = {(p.rule, p.v_from_pps, p.v_to_pps)
             for p in execution_problems(trapezoid, motor, table.rates)}
    assert {(p.rule, p.v_from_pps, p.v_to_pps) for _, p in stop_problems(table, motor)} <= moves

"""What the chip runs for every motion command (profiles/ppmc312/command_runs.py), each
against a by-hand model of its figure (manual §8-1…§8-11, §7-6) on a three-stage table:

    rates 400, 800, 1600 (fastest first), accel pulses 10, 6, 4 (LE = 0): start and stop
    rate 1600, high rate 400; the ramp is 1600×4, 800×6, 400×10 (20 pulses).
"""

from __future__ import annotations

import pytest

from profiles.errors import FormatError
from profiles.motor import Motor, load_motor
from profiles.motor.angles import AIM_DEG
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.command_angles import command_envelopes, motion_angle
from profiles.ppmc312.command_runs import ProgramCommand as C
from profiles.ppmc312.command_runs import run_program
from profiles.ppmc312.table import FreeCurveTable, load_table
from tests.support.paths import ROOT

TABLE = FreeCurveTable(Clock.named("8MHz"), (400, 800, 1600), (10, 6, 4))


RAMP = [("accel", 1600, 4), ("accel", 800, 6), ("accel", 400, 10)]


DECEL = [("decel", 400, 10), ("decel", 800, 6), ("decel", 1600, 4)]


def pieces(commands: list[C], reading: str = "a", motion: int = 0) -> list[tuple[str, int, int]]:
    return run_program(TABLE, commands, reading=reading).motions[motion].runs()


def test_constant_is_a_jump_its_pulses_and_an_immediate_stop() -> None:
    run = run_program(TABLE, [C("constant", 800, 50)])
    assert run.motions[0].runs() == [("cruise", 800, 50)]
    assert run.motions[0].cause == "NOS"
    assert pieces([C("constant", 0, 7)]) == [("cruise", 400, 7)]   # 0: the high rate


def test_step_is_one_pulse_at_the_start_rate() -> None:
    assert pieces([C("step")]) == [("cruise", 1600, 1)]


def test_continuous_climbs_the_stages_then_runs_until_stopped() -> None:
    run = run_program(TABLE, [C("continuous"), C("stop", at=30)])
    assert run.motions[0].runs() == [*RAMP, ("cruise", 400, 10)]
    assert run.motions[0].cause == "STP"
    # a rate between stages: the stages at or above it, then the rate
    assert pieces([C("continuous", 1000), C("stop", at=9)]) == [
        ("accel", 1600, 4), ("cruise", 1000, 5)]


def test_continuous_constant_and_the_hard_limits_stop_at_once() -> None:
    run = run_program(TABLE, [C("continuous-constant", 800), C("FL", at=7)])
    assert run.motions[0].runs() == [("cruise", 800, 7)]
    assert run.motions[0].cause == "STL"


def test_a_decel_stop_in_the_cruise_runs_the_decel_stages_at_or_below_its_speed() -> None:
    assert pieces([C("continuous", 800), C("decel-stop", at=15)]) == [
        ("accel", 1600, 4), ("accel", 800, 6), ("cruise", 800, 5),
        ("decel", 800, 6), ("decel", 1600, 4)]
    assert pieces([C("continuous"), C("decel-stop", at=25)]) == [
        *RAMP, ("cruise", 400, 5), *DECEL]


def test_a_decel_stop_on_the_ramp_runs_every_reading() -> None:
    # pulse 12: 2 pulses into the top stage (400, 10 accel pulses)
    head = [("accel", 1600, 4), ("accel", 800, 6), ("accel", 400, 2)]
    tail = [("decel", 800, 6), ("decel", 1600, 4)]
    stop = [C("continuous"), C("decel-stop", at=12)]
    assert pieces(stop, "a") == [*head, ("decel", 400, 10), *tail]
    assert pieces(stop, "b") == [*head, ("decel", 400, 8), *tail]
    assert pieces(stop, "c") == [*head, *tail]


def test_origin_search_stops_at_once_on_org() -> None:
    run = run_program(TABLE, [C("origin-search", 800, at=25)])
    assert run.motions[0].runs() == [("cruise", 800, 25)]
    assert run.motions[0].cause == "ORG"


def test_origin_return_decelerates_then_runs_back_at_the_start_rate() -> None:
    m = run_program(TABLE, [C("origin-return", 0, ccw=True, at=25)]).motions[0]
    assert m.runs() == [*RAMP, ("cruise", 400, 5), *DECEL, ("cruise", 1600, 20)]
    assert [p.backward for p in m.pieces] == [False] * 7 + [True]
    assert m.ccw and m.cause == "ORG"
    assert [len(leg) for leg in m.legs()] == [7, 1]


def test_the_accel_move_keeps_its_execution() -> None:
    assert pieces([C("accel", 0, 100)]) == [*RAMP, ("cruise", 400, 60), *DECEL]


def test_a_speed_up_keeps_the_decel_point_and_stops_fast() -> None:
    """§8-8: a move at high rate 800 (decel point 90, 10 decel pulses) sped up to 400 at
    pulse 30 decelerates from 400 at pulse 90 for its 10 pulses: it stops at 400."""
    m = run_program(TABLE, [C("accel", 800, 100), C("change-speed", 400, at=30)]).motions[0]
    assert m.runs() == [("accel", 1600, 4), ("accel", 800, 6), ("cruise", 800, 20),
                        ("accel", 400, 10), ("cruise", 400, 50), ("decel", 400, 10)]
    assert m.final_rate == 400 and m.changed_at == (1, 30)


def test_a_slow_down_runs_the_rest_at_the_stop_rate() -> None:
    """§8-8's other case: decelerating to 800 leaves pulses after the decel stages, run
    at the stop rate (「停止パルスレートで定速運転」)."""
    m = run_program(TABLE, [C("accel", 0, 100), C("set-speed", 800, at=30)]).motions[0]
    assert m.runs() == [*RAMP, ("cruise", 400, 10), ("cruise", 800, 50),
                        ("decel", 800, 6), ("decel", 1600, 4), ("cruise", 1600, 10)]
    assert pieces([C("accel", 0, 100), C("change-speed", 800, at=30)]) == [
        *RAMP, ("cruise", 400, 10), ("decel", 800, 6), ("cruise", 800, 44),
        ("decel", 800, 6), ("decel", 1600, 4), ("cruise", 1600, 10)]


def test_a_speed_up_during_the_ramp_finishes_the_stage_under_way() -> None:
    assert pieces([C("continuous", 800), C("change-speed", 400, at=2), C("stop", at=30)]) == [
        ("accel", 1600, 4), ("accel", 800, 6), ("accel", 400, 10), ("cruise", 400, 10)]


def test_a_constant_move_sped_up_stops_at_once_after_its_pulses() -> None:
    assert pieces([C("constant", 1600, 50), C("set-speed", 400, at=10)]) == [
        ("cruise", 1600, 10), ("cruise", 400, 40)]


def test_the_high_speed_limit_decelerates_at_or_above_its_speed_and_ignores_slower() -> None:
    m = run_program(TABLE, [C("continuous"), C("FHL", at=25)]).motions[0]
    assert m.cause == "DEL" and m.runs()[-3:] == DECEL
    run = run_program(TABLE, [C("high-speed-limit", 700), C("continuous", 800),
                              C("FHL", at=15), C("FL", at=20)])
    assert run.motions[0].cause == "STL" and "ignored" in run.notes[0]
    run = run_program(TABLE, [C("high-speed-limit", 900), C("continuous", 800),
                              C("FHL", at=15)])
    assert run.motions[0].cause == "DEL"


def test_a_decel_stop_while_decelerating_is_ignored() -> None:
    run = run_program(TABLE, [C("accel", 0, 100), C("decel-stop", at=85)])
    assert run.motions[0].runs() == [*RAMP, ("cruise", 400, 60), *DECEL]
    assert "already decelerating" in run.notes[0]


def test_a_decel_stop_with_nothing_slower_stops_at_once() -> None:
    table = FreeCurveTable(Clock.named("8MHz"), (400, 800, 1600), (10, 6, 4), (10, 6))
    m = run_program(table, [C("continuous-constant", 1600), C("decel-stop", at=5)]).motions[0]
    assert m.runs() == [("cruise", 1600, 5)] and m.cause == "LOW"


@pytest.mark.parametrize(("commands", "words"), [
    ([C("continuous")], "the program ends while the motion started by commands[0]"),
    ([C("continuous"), C("constant", 800, 5)], "commands[1]: constant (83): the motion"),
    ([C("stop", at=3)], "commands[0]: stop (80): no motion is running"),
    ([C("constant", 800, 5), C("stop", at=5)], "commands[1].at: stop (80): 5 is past"),
    ([C("continuous"), C("stop", at=9), C("stop", at=10)], "ends after pulse 9"),
    ([C("continuous"), C("decel-stop", at=9), C("stop", at=10)], "already stopping"),
    ([C("continuous"), C("BL", at=9)], "runs CW there"),
    ([C("accel", 0, 100), C("set-speed", 800, at=85)], "decelerating there"),
    ([C("continuous"), C("set-speed", 800, at=9), C("stop", at=5)], "5 comes before"),
])
def test_what_the_chip_would_not_take_is_one_line_naming_the_command(
        commands: list[C], words: str) -> None:
    with pytest.raises(FormatError, match=r"^commands") as e:
        run_program(TABLE, commands)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_motions_follow_each_other_from_rest() -> None:
    run = run_program(TABLE, [C("step"), C("constant", 800, 3, ccw=True), C("step")])
    assert [(m.started_by, m.ccw, m.pulses) for m in run.motions] == [
        (0, False, 1), (1, True, 3), (2, False, 1)]


TABLE_ENV = load_table(ROOT / "examples" / "free-curve-nema17.json")


RAMP_ENV = sum(TABLE_ENV.accel_pulses)   # the table's whole ramp (85 at its high rate)


SLACK = 0.05                     # the two integrators agree far closer than this


@pytest.fixture(scope="module")
def nema17() -> Motor:
    return load_motor(ROOT / "profiles" / "data" / "motor-nema17-1600.json")


def worst(table: FreeCurveTable, motor: Motor, programs: list[list[C]]) -> float:
    return max(motion_angle(run_program(table, p).motions[0], [motor]).worst_deg
               for p in programs)


COUNTS = [*range(1, 160, 3), 3000]   # every phase of the first periods, and settled


def test_the_constant_runs_envelope_is_bracketed(nema17: Motor) -> None:
    env = command_envelopes(TABLE_ENV, nema17)["constant"]
    rate = env["fastest_rate"]
    assert TABLE_ENV.rates[0] < rate < TABLE_ENV.rates[-1]
    assert env["fastest_pps"] == pytest.approx(8e6 / rate)
    assert worst(TABLE_ENV, nema17, [[C("constant", rate, n)] for n in COUNTS]) <= AIM_DEG + SLACK
    assert worst(TABLE_ENV, nema17, [[C("constant", rate - 1, n)] for n in COUNTS]) >\
        AIM_DEG - SLACK
    # the table's own use, a constant run at its high rate, slips; the start rate does not
    assert env["worst_load_angle_deg"] > 90
    assert worst(TABLE_ENV, nema17, [[C("constant", TABLE_ENV.rates[-1], n)] for n in COUNTS]) < 30


def test_the_immediate_stops_envelope_is_bracketed_and_sets_the_05_rate(nema17: Motor
                                                                         ) -> None:
    env = command_envelopes(TABLE_ENV, nema17)["stop"]
    rate = env["fastest_rate"]
    assert env["high_speed_limit_rate"] == rate - 1

    def stops(r: int) -> list[list[C]]:
        ramp = sum(n for i, n in enumerate(TABLE_ENV.accel_pulses) if TABLE_ENV.rates[i] >= r)
        return [[C("continuous", r), C("stop", at=ramp + n)] for n in COUNTS]

    assert worst(TABLE_ENV, nema17, stops(rate)) <= AIM_DEG + SLACK
    assert worst(TABLE_ENV, nema17, stops(rate - 1)) > AIM_DEG - SLACK


def test_the_immediate_speed_change_envelope_is_bracketed(nema17: Motor) -> None:
    env = command_envelopes(TABLE_ENV, nema17)["set-speed"]
    to = env["down_to_rate"]
    assert env["largest_change_pps"] == pytest.approx(8e6 / TABLE_ENV.rates[0] - 8e6 / to)

    def jumps(r: int) -> list[list[C]]:
        # from the top down at once, and from r up at once, each after any phase of a cruise
        down = [[C("continuous"), C("set-speed", r, at=RAMP_ENV + n),
                 C("decel-stop", at=RAMP_ENV + 6000)] for n in COUNTS[:-1]]
        ramp = sum(n for i, n in enumerate(TABLE_ENV.accel_pulses) if TABLE_ENV.rates[i] >= r)
        up = [[C("continuous", r), C("set-speed", TABLE_ENV.rates[0], at=ramp + n),
               C("decel-stop", at=ramp + 6000)] for n in COUNTS[:-1]]
        return down + up

    assert worst(TABLE_ENV, nema17, jumps(to)) <= AIM_DEG + SLACK
    # found to 1 % of the rate (SET_SPEED_CLOSE): past that, the aim is passed
    assert worst(TABLE_ENV, nema17, jumps(to + max(1, int(0.01 * to)) + 1)) > AIM_DEG - SLACK

"""The command families' envelopes (profiles/ppmc312/command_angles.py): each bracketed
against runs judged apart, through the signed integrator programs use (`motion_angle`,
`rotor.follow`), not the batch verdict the bisection used: the rate the envelope gives
stays within the aim at every count tried, one rate faster does not."""

from __future__ import annotations

import pytest

from profiles.motor import Motor, load_motor
from profiles.motor.angles import AIM_DEG
from profiles.ppmc312.command_angles import command_envelopes, motion_angle
from profiles.ppmc312.command_runs import ProgramCommand as C
from profiles.ppmc312.command_runs import run_program
from profiles.ppmc312.table import FreeCurveTable, load_table
from tests.support.paths import ROOT

TABLE = load_table(ROOT / "examples" / "free-curve-nema17.json")
RAMP = sum(TABLE.accel_pulses)   # the table's whole ramp (85 at its high rate)
SLACK = 0.05                     # the two integrators agree far closer than this


@pytest.fixture(scope="module")
def nema17() -> Motor:
    return load_motor(ROOT / "profiles" / "data" / "motor-nema17-1600.json")


def worst(table: FreeCurveTable, motor: Motor, programs: list[list[C]]) -> float:
    return max(motion_angle(run_program(table, p).motions[0], [motor]).worst_deg
               for p in programs)


COUNTS = [*range(1, 160, 3), 3000]   # every phase of the first periods, and settled


def test_the_constant_runs_envelope_is_bracketed(nema17: Motor) -> None:
    env = command_envelopes(TABLE, nema17)["constant"]
    rate = env["fastest_rate"]
    assert TABLE.rates[0] < rate < TABLE.rates[-1]
    assert env["fastest_pps"] == pytest.approx(8e6 / rate)
    assert worst(TABLE, nema17, [[C("constant", rate, n)] for n in COUNTS]) <= AIM_DEG + SLACK
    assert worst(TABLE, nema17, [[C("constant", rate - 1, n)] for n in COUNTS]) > \
        AIM_DEG - SLACK
    # the table's own use, a constant run at its high rate, slips; the start rate does not
    assert env["worst_load_angle_deg"] > 90
    assert worst(TABLE, nema17, [[C("constant", TABLE.rates[-1], n)] for n in COUNTS]) < 30


def test_the_immediate_stops_envelope_is_bracketed_and_sets_the_05_rate(nema17: Motor
                                                                         ) -> None:
    env = command_envelopes(TABLE, nema17)["stop"]
    rate = env["fastest_rate"]
    assert env["high_speed_limit_rate"] == rate - 1

    def stops(r: int) -> list[list[C]]:
        ramp = sum(n for i, n in enumerate(TABLE.accel_pulses) if TABLE.rates[i] >= r)
        return [[C("continuous", r), C("stop", at=ramp + n)] for n in COUNTS]

    assert worst(TABLE, nema17, stops(rate)) <= AIM_DEG + SLACK
    assert worst(TABLE, nema17, stops(rate - 1)) > AIM_DEG - SLACK


def test_the_immediate_speed_change_envelope_is_bracketed(nema17: Motor) -> None:
    env = command_envelopes(TABLE, nema17)["set-speed"]
    to = env["down_to_rate"]
    assert env["largest_change_pps"] == pytest.approx(8e6 / TABLE.rates[0] - 8e6 / to)

    def jumps(r: int) -> list[list[C]]:
        # from the top down at once, and from r up at once, each after any phase of a cruise
        down = [[C("continuous"), C("set-speed", r, at=RAMP + n), C("decel-stop", at=RAMP + 6000)]
                for n in COUNTS[:-1]]
        ramp = sum(n for i, n in enumerate(TABLE.accel_pulses) if TABLE.rates[i] >= r)
        up = [[C("continuous", r), C("set-speed", TABLE.rates[0], at=ramp + n),
               C("decel-stop", at=ramp + 6000)] for n in COUNTS[:-1]]
        return down + up

    assert worst(TABLE, nema17, jumps(to)) <= AIM_DEG + SLACK
    # found to 1 % of the rate (SET_SPEED_CLOSE): past that, the aim is passed
    assert worst(TABLE, nema17, jumps(to + max(1, int(0.01 * to)) + 1)) > AIM_DEG - SLACK


def test_a_speed_up_to_the_top_stops_from_the_top_at_the_old_decel_point(nema17: Motor
                                                                           ) -> None:
    """§8-8 by hand: high rate 1668 leaves a decel of the six slowest stages (93 pulses);
    sped up to the top, the walk down from 400 runs out inside its first stage (100)."""
    env = command_envelopes(TABLE, nema17)["change-speed"]
    assert (env["high_rate"], env["stops_from_pps"]) == (1668, 20000.0)
    assert env["faster_than_stop_rate"] and env["above_start_speed"]
    assert env["worst_load_angle_deg"] > 90


def test_origin_return_reverses_from_the_stop_rate_to_the_start_rate(nema17: Motor) -> None:
    env = command_envelopes(TABLE, nema17)["origin-return"]
    assert env["reversal_pps"] == 1600.0
    assert env["worst_load_angle_deg"] < AIM_DEG


def test_a_motor_that_cannot_run_the_table_has_no_envelope() -> None:
    heavy = load_motor(ROOT / "profiles" / "data" / "motor-nema23-heavy.json")
    env = command_envelopes(TABLE, heavy)
    assert env["constant"]["fastest_rate"] is None
    assert env["stop"]["fastest_rate"] is None and env["stop"]["high_speed_limit_rate"] == 0xFFFF


def test_a_tolerance_box_narrows_the_envelope(nema17: Motor) -> None:
    boxed = load_motor(ROOT / "examples" / "motor-nema17-tolerances.json")
    env = command_envelopes(TABLE, boxed)
    assert env["box"]["constant"]["fastest_rate"] >= env["constant"]["fastest_rate"]
    assert env["box"]["stop"]["fastest_rate"] >= env["stop"]["fastest_rate"]

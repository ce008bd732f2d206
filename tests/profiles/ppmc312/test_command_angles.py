"""The command families' envelopes (profiles/ppmc312/command_angles.py): each bracketed
against runs judged apart, through the signed integrator programs use (`motion_angle`,
`rotor.follow`), not the batch verdict the bisection used: the rate the envelope gives
stays within the aim at every count tried, one rate faster does not."""

from __future__ import annotations

import numpy as np
import pytest

from profiles.motor import Motor, load_motor
from profiles.motor.angles import AIM_DEG
from profiles.motor.rotor import rotor_of, settle_s
from profiles.ppmc312.command_angles import command_envelopes, motion_angle
from profiles.ppmc312.program import load_program
from profiles.ppmc312.table import load_table
from tests.support.paths import ROOT
from tests.support.rotor_oracle import follow as oracle_follow

TABLE = load_table(ROOT / "examples" / "free-curve-nema17.json")


@pytest.fixture(scope="module")
def nema17() -> Motor:
    return load_motor(ROOT / "profiles" / "data" / "motor-nema17-1600.json")


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


EXAMPLE = ROOT / "examples" / "program-home-and-jog.json"


def test_the_load_angle_through_a_reversal_is_the_oracles() -> None:
    """11's way back is a negative command speed; the compiled `follow` and the plain-
    Python oracle integrate the same motion."""
    p = load_program(EXAMPLE)
    motion = p.run().motions[0]
    assert any(piece.backward for piece in motion.pieces)
    motor = load_motor(ROOT / "profiles" / "data" / "motor-nema17-1600.json")
    got = motion_angle(motion, [motor])
    rotor = rotor_of(motor, direction=-1)
    step = rotor.step_s()
    hz = motion.clock.hz
    spans = [(x.rate * x.pulses / hz, (-hz if x.backward else hz) / x.rate)
             for x in motion.pieces]
    joined: list[tuple[float, float]] = []
    for d, v in spans:   # one constant command is one span, as the verdict joins them
        joined[-1:] = [(joined[-1][0] + d, v)] if joined and joined[-1][1] == v else \
            [*joined[-1:], (d, v)]
    trace = oracle_follow(rotor, [*joined, (settle_s(rotor, step), 0.0)], step_s=step)
    want = float(np.degrees(max(trace.span_max) * rotor.c_e))
    assert got.worst_deg == pytest.approx(want, rel=1e-6, abs=1e-6)

"""verify.plan_text: what a plan says in plain words."""

from __future__ import annotations

import pytest

from profiles.ppmc312.clock import Clock
from profiles.ppmc312.table import FreeCurveTable
from verify.plan_text import ramp


def test_plan_says_what_the_tightening_changed_in_plain_words() -> None:
    # "start speed lowered to 2 840 pps …" rather than "start ×0.483"
    from types import SimpleNamespace

    from profiles.ppmc312.planner.problem import Shaping
    from verify.plan_text import LINE_MAX, _tightening

    motor = SimpleNamespace(start_pps=5880.0)
    assert _tightening(Shaping.uniform(0.483), motor, 75.0) == [
        "start speed lowered to 2 840 pps (from 5 880 pps)",
        "ramp made gentler everywhere (48% of the torque it could use) to keep the rotor "
        "within 75°"]
    assert _tightening(Shaping((), (1.0,), 0.483), motor, 75.0) == [
        "start speed lowered to 2 840 pps (from 5 880 pps) to keep the rotor within 75°"]
    banded = Shaping((9112.0, 30755.0), (1.0, 0.93, 1.0), 0.5)
    lines = _tightening(banded, motor, 75.0)
    assert lines == ["start speed lowered to 2 940 pps (from 5 880 pps)",
                     "ramp made gentler between 9 112 and 30 755 pps (down to 93% of the torque "
                     "it could use) to keep the rotor within 75°"]
    assert all(len(line) <= LINE_MAX for line in lines)


def test_a_tables_ramp_is_its_speed_gain_over_its_time_below_the_top() -> None:
    # 1 MHz: stages at 1000, 2000, 4000 pps (rates 1000, 500, 250), 10 pulses each: below
    # the top it spends 10·1000 + 10·500 ticks = 15 ms gaining 3000 pps: 200 000 pps²
    table = FreeCurveTable(Clock.internal("1MHz"), (250, 500, 1000), (10, 10, 10))
    start, top, accel = ramp(table)
    assert (start, top) == (1000.0, 4000.0)
    assert accel == pytest.approx(3000 / 0.015)


def test_a_lowered_top_speed_is_said_with_its_price() -> None:
    # the free curve's last lever (planner.free_curve.lower_top): the top speed lowered,
    # in plain words, and what it costs against the plain table
    from types import SimpleNamespace

    from verify.plan_text import LINE_MAX, price, top_lowered

    lowered = SimpleNamespace(pulses=4000, duration_s=0.688, extras={
        "top_lowered_pps": (22416.2, 7345.3), "untightened_s": 0.2946})
    lines = top_lowered(lowered, 50.0)
    assert lines == ["top speed lowered to 7 345 pps (from 22 416 pps) to keep the rotor "
                     "within 50°: the start and the ramp alone did not",
                     "price: a move of 4000 pulses takes 688 ms, 2.34× as long as the "
                     "untightened table's 294.6 ms"]
    assert all(len(line) <= LINE_MAX for line in lines)
    # the lever pulled at the motor's own top speed (the ramp floored): the price alone
    floored = SimpleNamespace(pulses=None, duration_s=0.5513, extras={"untightened_s": 0.2946})
    assert top_lowered(floored, 75.0) == [
        "price: the reference move takes 551.3 ms, 1.87× as long as the untightened table's "
        "294.6 ms"]
    assert price(100, 0.2, 0.2) == ("price: a move of 100 pulses takes 200 ms, as long as the "
                                    "untightened table's 200 ms")

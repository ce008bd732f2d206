"""verify.checks rules at the boundaries the mutation run found unpinned (bench/mutation.py).

8 MHz clock: a rate r runs 8e6 / r pps. Limits: a stage holds at most 0xFFFFF pulses,
and runs at least 256 ticks (pulses × rate); a stop above 62500 pps is warned about.
"""

from __future__ import annotations

from profiles.ppmc312.clock import Clock
from profiles.ppmc312.table import FreeCurveTable
from verify.checks import check_table

C8 = Clock.internal("8MHz")


def rules(table: FreeCurveTable) -> list[tuple[str, str, int | None]]:
    return [(f.severity, f.rule, f.stage) for f in check_table(table)]


def test_a_stage_of_exactly_0xfffff_pulses_fits_its_field() -> None:
    # stage 1 holds one pulse too many; stage 0 exactly the most (and the side total is over)
    got = rules(FreeCurveTable(C8, (100, 200), (0xFFFFF, 0x100000)))
    assert ("error", "pulses-field", 1) in got and ("error", "pulses-field", 0) not in got


def test_a_stop_rate_of_1_is_warned_about() -> None:
    # LE=1, one decel stage: it stops at rates[0] = 1, 8 Mpps (also a rate error)
    got = rules(FreeCurveTable(C8, (1, 100), (5, 5), (5,)))
    assert ("warning", "stop-speed-high", 0) in got and ("error", "rate-min", 0) in got


def test_pulses_needed_at_a_rate_of_1_is_the_tick_minimum() -> None:
    # 1 pulse at rate 1: the count must reach 256 ticks / rate 1 = 256 pulses
    found = [f for f in check_table(FreeCurveTable(C8, (1, 100), (1, 5)))
             if f.rule == "pulses-min"]
    assert [f.stage for f in found] == [0]
    assert found[0].message == "accel_pulses[0] = 1 is ≤ 1: raise it to ≥ 256"

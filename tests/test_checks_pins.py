"""verify.chip_rules rules at the boundaries the mutation run found unpinned (tools/mutation.py).

8 MHz clock: a rate r runs 8e6 / r pps. Limits: a stage holds at most 0xFFFFF pulses,
and runs at least 256 ticks (pulses × rate); a stop above 62500 pps is warned about.
"""

from __future__ import annotations

from profiles.ppmc312.clock import Clock
from profiles.ppmc312.table import FreeCurveTable
from verify.chip_rules import check_table

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


def test_a_stage_of_rate_0_is_short_and_needs_2_pulses() -> None:
    # stage 2 at rate 0 lasts 0 ticks against a mean of (2000 + 4000) / 2: the count that
    # would fix it cannot be computed from the rate, so the least count is named
    found = [f for f in check_table(FreeCurveTable(C8, (100, 200, 0, 400), (10, 10, 10, 10)))
             if f.rule == "stage-short"]
    assert [f.stage for f in found] == [2]
    assert found[0].message == ("accel stage 2 lasts 0 ticks, under 1/10 of its neighbours' "
                                "mean 3000 ticks: raise accel_pulses[2] to ≥ 2 or merge the "
                                "stage into a neighbour")


def test_init_rates_of_1_are_judged_for_speed() -> None:
    from profiles.ppmc312.table import InitTable

    # high_rate 1 runs at 8 Mpps; start_rate 1 stops there (LE=0: the start rate stops)
    got = [(f.rule, f.message.split(" = ")[0]) for f in check_table(
        InitTable(C8, "linear", 1, 1, 0x1000)) if f.rule in ("speed-max", "stop-speed-high")]
    assert got == [("speed-max", "high_rate"),
                   ("stop-speed-high", "start_rate (the stop rate, LE=0)")]
    le1 = InitTable(C8, "linear", 1000, 50, 0x1000, 100, 0x1000)  # stops at 80 kpps
    assert [f.message.split(" = ")[0] for f in check_table(le1)
            if f.rule == "stop-speed-high"] == ["stop_rate"]


def test_init_rates_of_0_are_range_errors_only() -> None:
    from profiles.ppmc312.table import InitTable

    # a rate of 0 has no speed to judge: the range rule names it, nothing divides by it
    assert [f.rule for f in check_table(InitTable(C8, "linear", 1000, 0, 0x1000))] == \
        ["rate-range"]
    got = [f.rule for f in check_table(InitTable(C8, "linear", 0, 0, 0x1000))]
    assert "stop-speed-high" not in got and "speed-max" not in got and "rate-range" in got


def test_a_last_stage_of_0_ticks_is_short_against_its_one_neighbour() -> None:
    # 1 MHz, rates 100/200/300, accel 10/10/0: the last stage lasts 0 × 300 = 0 ticks, under
    # 1/10 of its only neighbour's 10 × 200 = 2000 ticks (the last stage has one neighbour,
    # the one before it); stage 1 lasts 2000 ticks against stage 2's 0: not short.
    found = [f for f in check_table(FreeCurveTable(Clock.internal("1MHz"), (100, 200, 300),
                                                   (10, 10, 0))) if f.rule == "stage-short"]
    assert [f.stage for f in found] == [2]
    assert found[0].message.startswith("accel stage 2 lasts 0 ticks, under 1/10 of its "
                                       "neighbours' mean 2000 ticks")

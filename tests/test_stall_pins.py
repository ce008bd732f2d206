"""verify.criterion pinned: margins by hand, and findings from hand-made problems.

`findings_from_problems` is fed problem lists written out here (StepProblem values
whose numbers are round), so each finding's rule, stage, grouping, order and message
(the fix it names, with its number) is checked against arithmetic done by hand in the
comment beside it. The table runs on 8 MHz: rates 8000, 16000, 32000 are 1000, 500,
250 pps. The stand-in motor is the one of tests/test_criterion_pins.py.
"""

from __future__ import annotations

from typing import cast

import numpy as np
import pytest

from profiles.motor import Motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.criterion import StepProblem
from profiles.ppmc312.table import FreeCurveTable
from tests.support.stand_ins import StandIn
from verify.criterion import (
    check_stall,
    findings_from_problems,
    shortest_failing_pulses,
    stall_margins,
)

CLK = Clock.internal("8MHz")
T3 = FreeCurveTable(CLK, (8000, 16000, 32000), (10, 20, 40))  # 1000, 500, 250 pps
MOTOR = cast(Motor, StandIn(start_pps=200.0, top_pps=900.0, jump_pps=150.0))


def found(problems: list[StepProblem], table: FreeCurveTable = T3,
          motor: Motor = MOTOR) -> list[tuple[str, str, int | None, str]]:
    return [(f.severity, f.rule, f.stage, f.message)
            for f in findings_from_problems(table, motor, problems)]


def step(rule: str, a: int | None, b: int | None, va: float, vb: float, pulses: int = 50,
         **kw: object) -> StepProblem:
    return StepProblem(rule, "step", pulses, (pulses, pulses), a, b, va, vb,  # type: ignore[arg-type]
                       **kw)  # type: ignore[arg-type]


# --- margins ---------------------------------------------------------------------------


def test_margins_by_hand() -> None:
    # each step's need: Δv · v_slow / count_slow. Accel: 500 → 1000 on 20 pulses at 500:
    # 500 · 500 / 20 = 12500 against a_acc = 50 · 500 = 25000: 2.0; 250 → 500 on 40 at 250:
    # 250 · 250 / 40 = 1562.5 against 12500: 8.0. Decel (a_dec = 40 · the faster speed):
    # 40000 / 12500 = 3.2 and 20000 / 1562.5 = 12.8. The fastest stage has no step above.
    m = stall_margins(T3, MOTOR)
    assert list(m["accel"]) == [np.inf, 2.0, 8.0]
    assert list(m["decel"]) == [np.inf, 3.2, 12.8]
    assert m["min"] == 2.0
    # LE=1, decel on the 2 fastest stages with 20, 10: 500 · 500 / 10 = 25000 against
    # 40000: 1.6, now the smallest
    m = stall_margins(FreeCurveTable(CLK, (8000, 16000, 32000), (10, 20, 40), (20, 10)), MOTOR)
    assert list(m["decel"]) == [np.inf, 1.6] and m["min"] == 1.6
    # two stages are one step; one stage none
    m = stall_margins(FreeCurveTable(CLK, (8000, 16000), (10, 20)), MOTOR)
    assert list(m["accel"]) == [np.inf, 2.0] and m["min"] == 2.0
    m = stall_margins(FreeCurveTable(CLK, (8000,), (10,)), MOTOR)
    assert list(m["accel"]) == [np.inf] and m["min"] == np.inf


def test_a_gentle_step_still_has_a_finite_margin() -> None:
    # 1000 → 999.875 pps (rate 8001) on 1000 pulses needs Δv · v / 1000 ≈ 0.125 pps², far
    # below 1 pps², and still has a margin: a_acc / need = 50 · 1000 / Δv
    m = stall_margins(FreeCurveTable(CLK, (8000, 8001), (10, 1000)), MOTOR)
    dv = 1000 - 8e6 / 8001
    assert m["accel"][1] == pytest.approx(50 * 1000 / dv, rel=1e-9)


# --- check_stall: order first, then the criterion -------------------------------------------


def test_order_findings() -> None:
    # a repeat and a 0: both named, nothing else judged
    t = FreeCurveTable(CLK, (9500, 9500, 26667), (50, 60, 80))
    assert [(f.rule, f.stage) for f in check_stall(t, MOTOR)] == [("stall-order", 1)]
    t = FreeCurveTable(CLK, (0, 9500, 26667), (50, 60, 80))
    got = check_stall(t, MOTOR)
    assert [(f.rule, f.stage) for f in got] == [("stall-order", None)]
    assert "a rate of 0" in got[0].message
    t = FreeCurveTable(CLK, (9500, 0, 26667), (50, 60, 80))
    assert [(f.rule, f.stage) for f in check_stall(t, MOTOR)] == [("stall-order", 1),
                                                                  ("stall-order", None)]
    assert check_stall(FreeCurveTable(CLK, (), ()), MOTOR) == []


def test_given_lengths_judge_only_those_moves() -> None:
    # rates[0] (1000 pps) is above the top 900 pps; the accel reaches it after 40 + 20
    # pulses, so a move runs it from 2 · 61 = 122 pulses (symmetric halves) on
    t = T3
    fast = cast(Motor, StandIn(start_pps=300.0, top_pps=900.0, jump_pps=1e9, acc_k=1e9,
                               dec_k=1e9))
    assert check_stall(t, fast, pulses=[121]) == []
    got = check_stall(t, fast, pulses=[122])
    assert [(f.rule, f.stage) for f in got] == [("stall-top-speed", 0)]
    assert got[0].message.endswith("(shortest move that runs it: 122 pulses)")
    assert [(f.rule, f.stage) for f in check_stall(t, fast)] == [("stall-top-speed", 0)]


# --- findings from problems -------------------------------------------------------------------


def test_top_speed_message() -> None:
    # 1000 pps above the top 900: rate ≥ ⌈8e6 / 900⌉ = 8889
    p = StepProblem("top-speed", "top", 122, (122, 379), 0, 0, 1000.0, 1000.0)
    assert found([p]) == [("error", "stall-top-speed", 0,
                           "stage rates[0] runs 1000 pps, above the motor's top usable speed "
                           "900 pps: raise it to ≥ 8889 (shortest move that runs it: 122 "
                           "pulses)")]


def start(kind: str, stage: int | None, v: float, pulses: int) -> StepProblem:
    return StepProblem("start-speed", kind, pulses, (pulses, pulses), stage, stage, v, v)


def test_start_speed_messages() -> None:
    # the slowest stage at 250 pps above the start speed 200: rate ≥ ⌈8e6 / 200⌉ = 40000
    both = [start("start", 2, 250.0, 3), start("stop", 2, 250.0, 1)]
    assert found(both) == [("error", "stall-start-speed", 2,
                            "moves start and stop at the slowest decel stage rates[2] = 32000 "
                            "(250 pps), above the start speed 200 pps: raise rates[2] to ≥ "
                            "40000 (shortest move that runs it: 1 pulses)")]
    assert found([start("start", 2, 250.0, 4)])[0][3].startswith(
        "moves start from rest at the slowest accel stage rates[2] = 32000 (250 pps)")
    assert found([start("stop", 2, 250.0, 4)])[0][3].startswith(
        "moves stop at the slowest decel stage rates[2]")
    # LE=1 with a decel of 2 stages: rates[1] is its slowest, not the accel's
    le1 = FreeCurveTable(CLK, (8000, 16000, 32000), (10, 20, 40), (20, 10))
    assert "raise rates[1] to ≥ 40000" in found([start("stop", 1, 500.0, 4)], le1)[0][3]
    # a faster stage of an LE=1 table with sides of different counts: the fix is the
    # stage counts, not the rate
    msg = found([start("start", 1, 500.0, 4)], le1)[0][3]
    assert msg.startswith("moves start from rest at the accel stage rates[1] = 16000 (500 pps)")
    assert "give both sides the same stage count" in msg
    # the same counts on both sides: the pulse counts (or the rate) are the fix
    msg = found([start("start", 1, 500.0, 4)])[0][3]
    assert msg.endswith("above the start speed 200 pps: change the LE=1 pulse counts so that "
                        "no move starts on this faster stage, or raise rates[1] to ≥ 40000 "
                        "(shortest move that runs it: 4 pulses)")
    assert "raise" not in found([start("start", None, 500.0, 4)])[0][3]


def test_a_jump_up_and_down_is_one_finding_at_its_slow_stage() -> None:
    # 250 ↔ 500 pps, +250 above the jump limit 150: named once, by the shortest move
    up = step("jump", 2, 1, 250.0, 500.0, pulses=90)
    down = step("jump", 1, 2, 500.0, 250.0, pulses=70)
    assert found([up, down]) == [("error", "stall-jump", 2,
                                  "stage 2 → 1 steps from 250 to 500 pps (+250), above the "
                                  "largest jump 150 pps: insert a stage between rates[2] and "
                                  "rates[1] (shortest move that runs it: 70 pulses)")]
    # the high-rate override (no stage, index −1) to and from stage 1
    over = [step("jump", 1, None, 500.0, 800.0, 60), step("jump", None, 1, 800.0, 500.0, 60)]
    assert found(over) == [("error", "stall-jump", 1,
                            "stage 1 → -1 steps from 500 to 800 pps (+300), above the largest "
                            "jump 150 pps: insert a stage between rates[1] and the high-rate "
                            "override (shortest move that runs it: 60 pulses)")]


def test_different_jumps_are_different_findings() -> None:
    # pairs that share their slow or their fast end are still different steps
    probs = [step("jump", 2, 1, 250.0, 500.0), step("jump", 2, 0, 250.0, 1000.0),
             step("jump", 1, 0, 500.0, 1000.0), step("jump", 1, None, 500.0, 800.0),
             step("jump", 2, None, 250.0, 800.0)]
    assert [(f[2], f[3].split(" steps")[0]) for f in found(probs)] == [
        (1, "stage 1 → 0"), (1, "stage 1 → -1"), (2, "stage 2 → 1"), (2, "stage 2 → 0"),
        (2, "stage 2 → -1")]  # by slow stage, then in the order met


def test_accel_and_decel_messages() -> None:
    # accel: 5 pulses at 500 pps then +500 needs 500 / (5 / 500) = 50000 pps², the motor
    # gives 25000: ≥ ⌈500 · 500 / 25000⌉ = 10 pulses. Decel: the same step down with
    # 40000 pps²: ≥ ⌈6.25⌉ = 7.
    acc = [step("accel", 1, 0, 500.0, 1000.0, p, dwell_pulses=5, dwell_stage=1,
                dwell_side="accel", need_pps2=50000.0, cap_pps2=25000.0) for p in (30, 12)]
    dec = step("decel", 0, 1, 1000.0, 500.0, 14, dwell_pulses=5, dwell_stage=1,
               dwell_side="decel", need_pps2=50000.0, cap_pps2=40000.0)
    assert found([*acc, dec]) == [
        ("error", "stall-accel", 1, "accel_pulses[1] = 5 at 500 pps then +500 pps needs 50000 "
         "pps², the motor gives 25000 pps²: raise accel_pulses[1] from 5 to ≥ 10 (shortest "
         "move that runs it: 12 pulses)"),
        ("error", "stall-decel", 1, "decel_pulses[1] = 5 at 500 pps then −500 pps needs 50000 "
         "pps², the motor gives 40000 pps²: raise decel_pulses[1] from 5 to ≥ 7 (shortest "
         "move that runs it: 14 pulses)")]
    # the same step from a different dwell (another count) is another finding
    other = step("accel", 1, 0, 500.0, 1000.0, 40, dwell_pulses=6, dwell_stage=1,
                 dwell_side="accel", need_pps2=41666.0, cap_pps2=25000.0)
    assert [f[3].split(" at")[0] for f in found([*acc, other])] == ["accel_pulses[1] = 5",
                                                                    "accel_pulses[1] = 6"]


@pytest.mark.parametrize("cap", [0.0, -10.0])
def test_no_capability_at_all(cap: float) -> None:
    p = step("accel", 1, 0, 500.0, 1000.0, dwell_pulses=5, dwell_stage=1, dwell_side="accel",
             need_pps2=50000.0, cap_pps2=cap)
    assert found([p])[0][3] == (
        "accel_pulses[1] = 5 at 500 pps then +500 pps needs 50000 pps², but the motor cannot "
        "accelerate between 500 and 1000 pps at all: lower the top speed below 500 pps "
        "(shortest move that runs it: 50 pulses)")


def switch(family: tuple[int, int], a: int, b: int, va: float, vb: float, need: float = 0.0,
           cap: float = 1e9) -> StepProblem:
    return StepProblem("switch", "switch", family[0], family, a, b, va, vb, 3, b, "decel",
                       need, cap)


def test_switches_are_one_finding_naming_their_lengths() -> None:
    # five ranges: four are listed, "and 1 more"; the shortest move and the first switch
    # named are the shortest range's; the largest jump is 1000 → 250 (−750)
    probs = [switch((40, 40), 0, 1, 1000.0, 500.0), switch((10, 12), 1, 2, 500.0, 250.0),
             switch((13, 13), 1, 2, 500.0, 250.0), switch((14, 20), 0, 2, 1000.0, 250.0),
             switch((21, 30), 1, 2, 500.0, 250.0)]
    (f,) = found(probs)
    assert f[:3] == ("error", "stall-switch", 2)
    assert f[3].startswith("triangle moves of 10–12, 13, 14–20, 21–30 and 1 more ranges pulses "
                           "switch from accel stage 1 (500 pps) to decel stage 2 (250 pps), "
                           "-250 pps, above the largest jump 150 pps: ")
    assert f[3].endswith("largest switch jump -750 pps (accel stage 0 → decel stage 2) "
                         "(shortest move that runs it: 10 pulses)")
    four = found(probs[1:])[0][3]
    assert "21–30 pulses switch" in four and "more" not in four


def test_a_switch_names_each_rule_it_breaks() -> None:
    # −100 pps (within the jump limit 150) needing 30000 > 20000 pps²; then −250 with it
    small = switch((10, 12), 1, 2, 500.0, 400.0, need=30000.0, cap=20000.0)
    msg = found([small])[0][3]
    assert "-100 pps, with 3 pulse(s) at 400 pps it needs 30000 pps², the motor gives 20000 " \
        "pps²: " in msg
    big = switch((10, 12), 1, 2, 500.0, 250.0, need=30000.0, cap=20000.0)
    assert "-250 pps, above the largest jump 150 pps; with 3 pulse(s) at 250 pps it needs " \
        "30000 pps², the motor gives 20000 pps²: " in found([big])[0][3]


def test_jerk_findings_per_side_and_stage() -> None:
    def jerk(side: str, k: int, sigma: tuple[float, float], rate: float) -> StepProblem:
        return StepProblem("jerk", "step", 0, (0, 0), k, k, *sigma, 5, k, side, rate, 1e6)

    probs = [jerk("accel", 1, (12500.0, 50000.0), 3.75e6), jerk("accel", 0, (50000.0, 0.0), 5e6),
             jerk("decel", 1, (0.0, 25000.0), 1.25e6), jerk("decel", 0, (25000.0, 0.0), 1.25e6)]
    got = found(probs)
    assert [(f[1], f[2]) for f in got] == [("stall-jerk", 0), ("stall-jerk", 0),
                                           ("stall-jerk", 1), ("stall-jerk", 1)]
    assert got[2][3] == ("accel slope changes from 12500 to 50000 pps² over stage 1: 3.75e+06 "
                         "pps³ exceeds max_jerk_pps3 1e+06: raise accel_pulses[1] (and the "
                         "counts around it)")
    assert "shortest move" not in got[0][3]


def test_findings_are_ordered_by_rule_then_stage() -> None:
    probs = [switch((10, 12), 1, 2, 500.0, 250.0),
             step("decel", 0, 1, 1000.0, 500.0, dwell_pulses=5, dwell_stage=1,
                  dwell_side="decel", need_pps2=5e4, cap_pps2=4e4),
             step("accel", 1, 0, 500.0, 1000.0, dwell_pulses=5, dwell_stage=1,
                  dwell_side="accel", need_pps2=5e4, cap_pps2=2.5e4),
             step("jump", 2, 1, 250.0, 500.0), step("jump", 1, None, 500.0, 800.0),
             start("stop", 2, 250.0, 3),
             StepProblem("top-speed", "top", 9, (9, 9), 0, 0, 1000.0, 1000.0),
             StepProblem("jerk", "step", 0, (0, 0), 2, 2, 0.0, 1.0, 5, 2, "accel", 2e6, 1e6)]
    assert [(f[1], f[2]) for f in found(probs)] == [
        ("stall-top-speed", 0), ("stall-start-speed", 2), ("stall-jump", 1),
        ("stall-jump", 2), ("stall-accel", 1), ("stall-decel", 1), ("stall-switch", 2),
        ("stall-jerk", 2)]


def test_shortest_failing_pulses() -> None:
    assert shortest_failing_pulses([]) is None
    jerk = StepProblem("jerk", "step", 0, (0, 0), 1, 1, 0.0, 1.0)
    assert shortest_failing_pulses([jerk]) == 0  # a table rule: no move length
    assert shortest_failing_pulses([jerk, start("stop", 2, 250.0, 7),
                                    start("start", 2, 250.0, 3)]) == 3


def test_order_is_judged_on_every_neighbouring_pair() -> None:
    # the last pair out of order; rates 1 apart are in order (and a rate of 1 is a rate)
    t = FreeCurveTable(CLK, (9500, 26667, 14000), (50, 60, 80))
    assert [(f.rule, f.stage) for f in check_stall(t, MOTOR)] == [("stall-order", 2)]
    t = FreeCurveTable(CLK, (9500, 1, 26667), (50, 60, 80))
    assert [(f.rule, f.stage) for f in check_stall(t, MOTOR)] == [("stall-order", 1)]
    # in order: judged (8 Mpps and 7.999 Mpps are far above the top 900 pps)
    for rates in ((1, 2), (8000, 8001)):
        t = FreeCurveTable(CLK, rates, (50, 60))
        assert "stall-top-speed" in [f.rule for f in check_stall(t, MOTOR)], rates


def test_a_repeated_speed_has_no_step_and_an_infinite_margin() -> None:
    m = stall_margins(FreeCurveTable(CLK, (8000, 8000, 16000), (10, 10, 10)), MOTOR)
    assert m["accel"][1] == np.inf and m["decel"][1] == np.inf


def test_rule_order_beats_stage_order() -> None:
    # every rule on a faster stage than the rule before it: only the rule order sorts them
    t8 = FreeCurveTable(CLK, tuple(range(8000, 16001, 1000)), (10,) * 9)
    probs = [StepProblem("jerk", "step", 0, (0, 0), 1, 1, 0.0, 1.0, 5, 1, "accel", 2e6, 1e6),
             switch((10, 12), 3, 2, 500.0, 250.0),
             step("decel", 2, 3, 1000.0, 500.0, dwell_pulses=5, dwell_stage=3,
                  dwell_side="decel", need_pps2=5e4, cap_pps2=4e4),
             step("accel", 5, 4, 500.0, 1000.0, dwell_pulses=5, dwell_stage=4,
                  dwell_side="accel", need_pps2=5e4, cap_pps2=2.5e4),
             step("jump", 5, 4, 250.0, 500.0),
             start("stop", 6, 250.0, 3),
             StepProblem("top-speed", "top", 9, (9, 9), 7, 7, 1000.0, 1000.0)]
    assert [(f[1], f[2]) for f in found(probs, t8)] == [
        ("stall-top-speed", 7), ("stall-start-speed", 6), ("stall-jump", 5),
        ("stall-accel", 4), ("stall-decel", 3), ("stall-switch", 2), ("stall-jerk", 1)]


def test_a_tiny_capability_still_names_a_count() -> None:
    # 0.5 pps² is little but not nothing: ⌈500 · 500 / 0.5⌉ = 500000 pulses
    p = step("accel", 1, 0, 500.0, 1000.0, dwell_pulses=5, dwell_stage=1, dwell_side="accel",
             need_pps2=50000.0, cap_pps2=0.5)
    assert "raise accel_pulses[1] from 5 to ≥ 500000" in found([p])[0][3]


def test_a_switch_names_only_the_rules_it_breaks_at_their_boundary() -> None:
    from tests.support.stand_ins import exact_limit

    # |Δv| 250 exactly at the jump limit's tolerated bound, need exactly at the capability's
    at_jump = cast(Motor, StandIn(start_pps=200.0, top_pps=900.0, jump_pps=exact_limit(250.0)))
    edge = switch((10, 12), 1, 2, 500.0, 250.0, need=30000.0, cap=exact_limit(30000.0))
    msg = found([edge], motor=at_jump)[0][3]
    assert "above the largest jump" not in msg and "it needs" not in msg
    # a need far below the capability is no reason either
    low = switch((10, 12), 1, 2, 500.0, 250.0, need=30.0, cap=1e9)
    assert "it needs" not in found([low])[0][3]


def test_a_move_that_starts_on_a_decel_stage_is_named_so() -> None:
    # LE=1, two stages each side: a 2-pulse move gives both pulses to decel (its accel
    # share is empty), so it starts on the decel side's faster stage rates[0] = 14000
    # (571 pps at 8 MHz), above the start speed 200 pps. Both sides have two stages:
    # "give both sides the same stage count" would be no fix.
    from profiles.ppmc312.execution import simulate_move

    t = FreeCurveTable(CLK, (14000, 26667), (1, 1), (3, 1))
    first = simulate_move(t, 2).segments[0]
    assert (first.phase, first.rate) == ("decel", 14000)
    starts = [f for f in check_stall(t, MOTOR) if f.rule == "stall-start-speed"
              and f.stage == 0]
    assert len(starts) == 1
    assert starts[0].message.startswith(
        "moves start from rest at the decel stage rates[0] = 14000 (571.429 pps), above the "
        "start speed 200 pps: change the LE=1 pulse counts so that no move starts on this "
        "faster stage, or raise rates[0] to ≥ 40000")

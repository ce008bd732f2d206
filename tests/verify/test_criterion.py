"""Stall-safety criterion: each rule caught on hand-made tables, fixes clear it."""

from __future__ import annotations

import re
from typing import cast

import numpy as np
import pytest

from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import FreeCurveTable
from tests.support.stand_ins import StandIn
from verify.criterion import (
    check_stall,
    stall_margins,
)

NEMA23 = next(load_motor(p) for p in bundled_motor_paths() if "nema23" in p.name)


CLK = Clock.internal("8MHz")  # speed = 8e6 / rate


def rules(table: FreeCurveTable, motor: Motor = NEMA23) -> list[str]:
    return [f.rule for f in check_stall(table, motor)]


def good() -> FreeCurveTable:
    # 300 → 571.4 → 842.1 pps, fastest first; counts generous
    return FreeCurveTable(CLK, (9500, 14000, 26667), (50, 60, 80))


def test_generous_table_is_safe() -> None:
    assert check_stall(good(), NEMA23) == []
    m = stall_margins(good(), NEMA23)
    assert m["accel"][0] == np.inf and m["min"] > 1


def test_order() -> None:
    t = FreeCurveTable(CLK, (14000, 9500, 26667), (50, 60, 80))
    found = check_stall(t, NEMA23)
    assert [f.rule for f in found] == ["stall-order"] and found[0].stage == 1


def test_start_speed() -> None:
    t = FreeCurveTable(CLK, (9500, 14000, 20000), (50, 60, 80))  # slowest 400 pps > 300
    found = [f for f in check_stall(t, NEMA23) if f.rule == "stall-start-speed"]
    assert len(found) == 1 and found[0].stage == 2 and "rates[2]" in found[0].message
    assert "≥ 26667" in found[0].message


def test_top_speed() -> None:
    t = FreeCurveTable(CLK, (600, 26667), (2, 80))  # 13333 pps > curve top 12000
    assert "stall-top-speed" in rules(t)


def test_jump() -> None:
    t = FreeCurveTable(CLK, (9500, 26667), (50, 500))  # 300 → 842 pps: +542 > 300
    found = [f for f in check_stall(t, NEMA23) if f.rule == "stall-jump"]
    assert len(found) == 1 and found[0].stage == 1


def test_accel_finding_names_the_fix_and_the_fix_works() -> None:
    # 11142 → 11429 pps where a_acc is ~2.4e3 pps/s (it reaches 0 near 11556 pps)
    def accel_at_1(count: int) -> list[str]:
        t = FreeCurveTable(CLK, (700, 718, 26667), (2, count, 80))
        return [f.message for f in check_stall(t, NEMA23)
                if f.rule == "stall-accel" and f.stage == 1]

    found = accel_at_1(2)
    assert len(found) == 1
    m = re.search(r"raise accel_pulses\[1\] from 2 to ≥ (\d+)", found[0])
    assert m, found[0]
    need = int(m.group(1))
    assert need > 1000
    assert accel_at_1(need) == []
    assert accel_at_1(need - 1) != []  # the suggestion is the smallest fix
    margins = [stall_margins(FreeCurveTable(CLK, (700, 718, 26667), (2, c, 80)), NEMA23)
               ["accel"][1] for c in (need - 1, need)]
    assert margins[0] < 1 <= margins[1]


def test_decel_uses_a_dec_and_its_own_counts() -> None:
    # near the top of the heavy table's curve: 10884 → 11142 → 11429 pps
    rates = (700, 718, 735)
    t = FreeCurveTable(CLK, rates, (2, 20000, 20000), (2, 2, 2))
    found = [f for f in check_stall(t, NEMA23) if f.rule in ("stall-accel", "stall-decel")]
    assert {(f.rule, f.stage) for f in found} == {("stall-decel", 1), ("stall-decel", 2)}
    want = [int(re.search(r"to ≥ (\d+)", f.message).group(1))  # type: ignore[union-attr]
            for f in sorted(found, key=lambda f: f.stage or 0)]
    fixed = FreeCurveTable(CLK, rates, (2, 20000, 20000), (2, *want))
    assert not [f for f in check_stall(fixed, NEMA23) if f.rule == "stall-decel"]
    # the same counts on the accel side are far too few: a_dec (friction helps) > a_acc
    common = FreeCurveTable(CLK, rates, (2, *want))
    assert {f.stage for f in check_stall(common, NEMA23) if f.rule == "stall-accel"} == {1, 2}


def test_le1_sides_use_their_fastest_stages() -> None:
    # accel has 3 stages, decel only the fastest 2: decel's slowest stage is rates[1] = 571 pps,
    # above the start speed
    t = FreeCurveTable(CLK, (9500, 14000, 26667), (50, 60, 80), (50, 60))
    found = check_stall(t, NEMA23)
    assert [(f.rule, f.stage) for f in found] == [("stall-start-speed", 1)]
    assert "decel" in found[0].message
    assert len(stall_margins(t, NEMA23)["decel"]) == 2


def test_capability_zero() -> None:
    # a_acc of the heavy table reaches 0 near 11556 pps: no count can step past it
    t = FreeCurveTable(CLK, (689, 700, 26667), (2, 1000, 80))
    found = [f for f in check_stall(t, NEMA23) if f.rule == "stall-accel" and f.stage == 1]
    assert found and "cannot accelerate" in found[0].message


def test_jerk() -> None:
    jerky = Motor(**{**NEMA23.__dict__, "max_jerk_pps3": 1e3})
    found = [f for f in check_stall(good(), jerky) if f.rule == "stall-jerk"]
    assert found and all(f.stage is not None for f in found)
    slow = FreeCurveTable(CLK, (9500, 14000, 26667), (5000, 5000, 5000))
    assert "stall-jerk" not in rules(slow, jerky)


@pytest.mark.parametrize("path", bundled_motor_paths(), ids=lambda p: p.stem)
def test_planned_tables_have_margin_at_least_one(path) -> None:  # type: ignore[no-untyped-def]
    motor = load_motor(path)
    plan = plan_free_curve(motor, pulses=10000)
    m = stall_margins(plan.table, motor)
    assert 1 - 1e-9 <= m["min"] < 2  # tight (minimal counts) but never below 1


T3 = FreeCurveTable(CLK, (8000, 16000, 32000), (10, 20, 40))  # 1000, 500, 250 pps


MOTOR = cast(Motor, StandIn(start_pps=200.0, top_pps=900.0, jump_pps=150.0))


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

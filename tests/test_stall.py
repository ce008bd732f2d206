"""Stall-safety criterion: each rule caught on hand-made tables, fixes clear it."""

from __future__ import annotations

import re

import numpy as np
import pytest

from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import FreeCurveTable
from verify.criterion import check_stall, stall_margins

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

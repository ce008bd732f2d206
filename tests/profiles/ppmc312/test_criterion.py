"""The stall criterion's rules pinned one by one (profiles.ppmc312.criterion).

Every case is a hand-made move given as (phase, rate, pulses) segments on a 1 MHz
clock (speed = 1e6 / rate) and a stand-in motor whose limits are round numbers and
whose capability is a straight line in the speed (a_acc = acc_k · lo, a_dec = dec_k ·
hi over a step from lo to hi), so every expected problem below (rule, kind, stages,
speeds, dwell, need, capability) is worked out by hand in the comment beside it.
Limits are also pinned at their exact boundary: a value equal to limit × (1 +
REL_TOL) passes, the next float above it fails.
"""

from __future__ import annotations

import re
from dataclasses import astuple, replace
from typing import cast

import numpy as np
import pytest

from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.criterion import (
    StepProblem,
    _same_stages_switch_safe,
    all_length_problems,
    all_length_safe,
    check_stall,
    execution_problems,
    findings_from_problems,
    jerk_problems,
    length_problems,
    runs_problems,
    shortest_failing_pulses,
    stall_margins,
    switch_safe,
)
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import FreeCurveTable
from tests.support.stand_ins import StandIn, exact_limit

HZ = 1e6


RATES = (250, 500, 1000)  # fastest first: 4000, 2000, 1000 pps


STAND_IN = StandIn()


def judge(runs: list[tuple[str, int, int]], motor: StandIn = STAND_IN, *, hz: float = HZ,
          rates: tuple[int, ...] = RATES, pulses: int = 77,
          family: tuple[int, int] | None = None) -> list[tuple[object, ...]]:
    problems = runs_problems(runs, hz, pulses, cast(Motor, motor), rates, family)
    return [astuple(p) for p in problems]


def P(rule: str, kind: str, stages: tuple[int | None, int | None], v: tuple[float, float],
      dwell: tuple[int | None, int | None, str] | None = None, need: float = 0.0,
      cap: float = float("inf"), pulses: int = 77, family: tuple[int, int] = (77, 77)
      ) -> tuple[object, ...]:
    d = dwell or (None, None, None)
    return (rule, kind, pulses, family, *stages, *v, *d, need, cap)


# A start (stop) problem names the phase of the move's first (last) segment: an LE=1
# move can start on a decel stage or stop on an accel one (profiles.ppmc312.criterion
# words its fix).
SIDE: dict[str, tuple[None, None, str]] = {k: (None, None, k) for k in ("accel", "cruise",
                                                                        "decel")}


def below(limit: float) -> float:
    return float(np.nextafter(limit, 0.0))


# (runs, motor, expected problems) worked out by hand
CASES = {
    # v 1000 → 2000 → 1000, t 0.01, 0.02, 0.02 s. Up: need 1000 / 0.01 = 1e5 (the dwell
    # before), cap 50 · 1000 = 5e4: accel. Down: need 1000 / 0.02 = 5e4 (the dwell
    # after), cap 40 · 2000 = 8e4: fine.
    "accel": ([("accel", 1000, 10), ("cruise", 500, 40), ("decel", 1000, 20)], StandIn(),
              [P("accel", "step", (2, 1), (1000.0, 2000.0), (10, 2, "accel"), 1e5, 5e4)]),
    # Up: need 1000 / 0.02 = 5e4 ≤ cap 5e4 (equal: fine). Down: need 1000 / 0.005 = 2e5,
    # cap 40 · 2000 = 8e4: decel, dwell on the slower segment after the step.
    "decel": ([("accel", 1000, 20), ("cruise", 500, 10), ("decel", 1000, 5)], StandIn(),
              [P("decel", "step", (1, 2), (2000.0, 1000.0), (5, 2, "decel"), 2e5, 8e4)]),
    # 1000 ↔ 4000 pps: |Δv| 3000 > jump 1500 both ways; needs 3000 / 0.1 = 3e4 within
    # caps 5e4 (50 · 1000) and 1.6e5 (40 · 4000).
    "jump": ([("accel", 1000, 100), ("cruise", 250, 400), ("decel", 1000, 100)], StandIn(),
             [P("jump", "step", (2, 0), (1000.0, 4000.0), (100, 2, "accel"), 3e4, 5e4),
              P("jump", "step", (0, 2), (4000.0, 1000.0), (100, 2, "decel"), 3e4, 1.6e5)]),
    # A jump that also breaks the capability: two problems for one step, jump first.
    # Up 1000 → 4000: need 3000 / 0.001 = 3e6 > 5e4.
    "jump and accel": ([("accel", 1000, 1), ("cruise", 250, 4000), ("decel", 1000, 1000)],
                       StandIn(),
                       [P("jump", "step", (2, 0), (1000.0, 4000.0), (1, 2, "accel"), 3e6, 5e4),
                        P("accel", "step", (2, 0), (1000.0, 4000.0), (1, 2, "accel"), 3e6,
                          5e4),
                        P("jump", "step", (0, 2), (4000.0, 1000.0), (1000, 2, "decel"), 3e3,
                          1.6e5)]),
    # accel → accel fails its capability (need 1e5 > 5e4) and is a step; accel → decel
    # is the switch (need 1000 / 0.01 = 1e5 > cap 40 · 2000 = 8e4), one problem.
    "switch": ([("accel", 1000, 10), ("accel", 500, 10), ("decel", 1000, 10)], StandIn(),
               [P("accel", "step", (2, 1), (1000.0, 2000.0), (10, 2, "accel"), 1e5, 5e4),
                P("switch", "switch", (1, 2), (2000.0, 1000.0), (10, 2, "decel"), 1e5, 8e4)]),
    # A switch that breaks only the jump rule is still one switch problem.
    "switch jump": ([("accel", 1000, 100), ("accel", 250, 100), ("decel", 1000, 100)],
                    StandIn(acc_k=1e9, dec_k=1e9),
                    [P("jump", "step", (2, 0), (1000.0, 4000.0), (100, 2, "accel"), 3e4,
                       1e12),
                     P("switch", "switch", (0, 2), (4000.0, 1000.0), (100, 2, "decel"), 3e4,
                       4e12)]),
    # Starts at 2000 (> start 1000), tops at 5000 (> top 4000), stops at 2000: the top
    # first, then start and stop, each naming its own segment. No steps fail.
    "start top stop": ([("accel", 500, 10), ("cruise", 200, 10), ("decel", 500, 10)],
                       StandIn(jump_pps=1e9, acc_k=1e9, dec_k=1e9),
                       [P("top-speed", "top", (None, None), (5000.0, 5000.0)),
                        P("start-speed", "start", (1, 1), (2000.0, 2000.0), SIDE["accel"]),
                        P("start-speed", "stop", (1, 1), (2000.0, 2000.0), SIDE["decel"])]),
    "stop only": ([("accel", 1000, 10), ("cruise", 500, 10), ("decel", 500, 10)],
                  StandIn(jump_pps=1e9, acc_k=1e9, dec_k=1e9),
                  [P("start-speed", "stop", (1, 1), (2000.0, 2000.0), SIDE["decel"])]),
    "start only": ([("accel", 500, 10), ("cruise", 1000, 10), ("decel", 1000, 10)],
                   StandIn(jump_pps=1e9, acc_k=1e9, dec_k=1e9),
                   [P("start-speed", "start", (1, 1), (2000.0, 2000.0), SIDE["accel"])]),
    # Two segments still have a step: up 1000 → 2000, need 1000 / 0.001 = 1e6 > 5e4; the
    # stop at 2000 pps is above the start speed.
    "two segments": ([("accel", 1000, 1), ("cruise", 500, 1)], StandIn(),
                     [P("start-speed", "stop", (1, 1), (2000.0, 2000.0), SIDE["cruise"]),
                      P("accel", "step", (2, 1), (1000.0, 2000.0), (1, 2, "accel"), 1e6, 5e4)]),
    "one segment": ([("cruise", 250, 5)], StandIn(),
                    [P("start-speed", "start", (0, 0), (4000.0, 4000.0), SIDE["cruise"]),
                     P("start-speed", "stop", (0, 0), (4000.0, 4000.0), SIDE["cruise"])]),
    # Steps smaller than 1 pps keep their direction: 500 → 500.25 → 500 pps (rates 2000,
    # 1999: Δv = 1e6 / 1999 − 500 ≈ 0.25), each dwell 1 / 500 s: needs Δv · 500 ≈ 125 >
    # caps 0.1 · 500 = 50 (up, on the segment before) and 0.1 · 500.25 (down, after).
    "quarter pps": ([("accel", 2000, 1), ("cruise", 1999, 1), ("decel", 2000, 1)],
                    StandIn(start_pps=600, acc_k=0.1, dec_k=0.1),
                    [P("accel", "step", (None, None), (500.0, 1e6 / 1999), (1, None, "accel"),
                       (1e6 / 1999 - 500) * 500, 50.0),
                     P("decel", "step", (None, None), (1e6 / 1999, 500.0), (1, None, "decel"),
                       (1e6 / 1999 - 500) * 500, 0.1 * 1e6 / 1999)]),
    # The same stage twice (Δv = 0) is no step: needs nothing, breaks nothing.
    "flat": ([("accel", 1000, 1), ("cruise", 1000, 1), ("decel", 1000, 1)],
             StandIn(acc_k=0.0, dec_k=0.0), []),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_each_rule_on_hand_made_moves(name: str) -> None:
    runs, motor, want = CASES[name]
    got = judge(runs, motor)
    if name == "quarter pps":  # speeds from 1e6 / 1999 are not round: compare closely
        assert len(got) == len(want)
        for g, w in zip(got, want, strict=True):
            assert g[:6] == w[:6] and g[8:11] == w[8:11]
            assert g[6:8] + g[11:] == pytest.approx(w[6:8] + w[11:], rel=1e-12)
        return
    assert got == want


def test_steps_of_exactly_one_pps_are_steps() -> None:
    # 1001 kHz clock: rate 1001 → 1000 pps, rate 1000 → 1001 pps, Δv = ±1 exactly; dwell
    # 1 / 1000 s and 1 / 1000 s: need 1000 > caps 0.1 · 1000 = 100 and 0.1 · 1001 = 100.1
    runs = [("accel", 1001, 1), ("cruise", 1000, 1), ("decel", 1001, 1)]
    got = judge(runs, StandIn(start_pps=2000, acc_k=0.1, dec_k=0.1), hz=1001e3,
                rates=(1000, 1001))
    assert got == [P("accel", "step", (1, 0), (1000.0, 1001.0), (1, 1, "accel"), 1000.0,
                     100.0),
                   P("decel", "step", (0, 1), (1001.0, 1000.0), (1, 1, "decel"), 1000.0,
                     0.1 * 1001.0)]


def test_family_defaults_to_the_move_itself() -> None:
    runs = [("cruise", 250, 5)]
    assert {g[3] for g in judge(runs, pulses=5)} == {(5, 5)}
    assert {g[3] for g in judge(runs, pulses=5, family=(3, 9))} == {(3, 9)}
    assert judge([], StandIn()) == []


def test_top_speed_boundary() -> None:
    runs = [("accel", 1000, 1), ("cruise", 250, 1), ("decel", 1000, 1)]  # top 4000 pps
    free = StandIn(jump_pps=1e9, acc_k=1e9, dec_k=1e9)
    assert judge(runs, replace(free, top_pps=exact_limit(4000.0))) == []
    assert [g[0] for g in judge(runs, replace(free, top_pps=below(exact_limit(4000.0))))] \
        == ["top-speed"]


@pytest.mark.parametrize("where", ["start", "stop"])
def test_start_speed_boundary(where: str) -> None:
    runs = [("accel", 1000, 1), ("cruise", 500, 1), ("decel", 1000, 1)]  # ends at 1000
    runs = [("accel", 500, 1), *runs[1:]] if where == "start" else [*runs[:2], ("decel", 500, 1)]
    free = StandIn(jump_pps=1e9, acc_k=1e9, dec_k=1e9)
    assert judge(runs, replace(free, start_pps=exact_limit(2000.0))) == []
    assert [g[1] for g in judge(runs, replace(free, start_pps=below(exact_limit(2000.0))))] \
        == [where]


def test_jump_boundary() -> None:
    runs = [("accel", 1000, 1), ("cruise", 500, 1), ("decel", 1000, 1)]  # ±1000 pps
    free = StandIn(acc_k=1e9, dec_k=1e9)
    assert judge(runs, replace(free, jump_pps=exact_limit(1000.0))) == []
    assert [g[0] for g in judge(runs, replace(free, jump_pps=below(exact_limit(1000.0))))] \
        == ["jump", "jump"]


def test_capability_boundary() -> None:
    # up 1000 → 2000 with 0.01 s before: need 1e5 = acc_k · 1000 at acc_k = 100 (each side
    # on its own: the other side has all it needs)
    runs = [("accel", 1000, 10), ("cruise", 500, 10), ("decel", 1000, 10)]
    acc_k = exact_limit(1e5) / 1000
    assert acc_k * 1000 == exact_limit(1e5)
    assert judge(runs, StandIn(acc_k=acc_k, dec_k=1e9)) == []
    assert [g[0] for g in judge(runs, StandIn(acc_k=below(acc_k), dec_k=1e9))] == ["accel"]
    # down 2000 → 1000 with 0.01 s after: need 1e5 = dec_k · 2000 at dec_k = 50
    dec_k = exact_limit(1e5) / 2000
    assert dec_k * 2000 == exact_limit(1e5)
    assert judge(runs, StandIn(acc_k=1e9, dec_k=dec_k)) == []
    assert [g[0] for g in judge(runs, StandIn(acc_k=1e9, dec_k=below(dec_k)))] == ["decel"]


CLK = Clock.internal("8MHz")  # speed = 8e6 / rate


def test_jerk_by_hand() -> None:
    # rates 8000, 16000, 32000 → 1000, 500, 250 pps. Accel, slowest first: f 250, 500,
    # 1000; counts 5, 5, 10 → t 0.02, 0.01, 0.01 s; slopes σ = 12500, 50000, 0 pps²;
    # |Δσ| / t = 625000, 3.75e6, 5e6 pps³. Decel uses the 2 fastest stages: f 500, 1000;
    # counts 10, 20 → t 0.02, 0.02; σ = 25000, 0; |Δσ| / t = 1.25e6, 1.25e6.
    table = FreeCurveTable(CLK, (8000, 16000, 32000), (10, 5, 5), (20, 10))
    jerky = cast(Motor, StandIn(max_jerk_pps3=1e6))
    got = [astuple(p) for p in jerk_problems(table, jerky)]
    want = [("jerk", "step", 0, (0, 0), 1, 1, 12500.0, 50000.0, 5, 1, "accel", 3.75e6, 1e6),
            ("jerk", "step", 0, (0, 0), 0, 0, 50000.0, 0.0, 10, 0, "accel", 5e6, 1e6),
            ("jerk", "step", 0, (0, 0), 1, 1, 0.0, 25000.0, 10, 1, "decel", 1.25e6, 1e6),
            ("jerk", "step", 0, (0, 0), 0, 0, 25000.0, 0.0, 20, 0, "decel", 1.25e6, 1e6)]
    assert [g[:6] + g[8:11] for g in got] == [w[:6] + w[8:11] for w in want]
    assert [g[6:8] + g[11:] for g in got] == [pytest.approx(w[6:8] + w[11:]) for w in want]
    # 625000 pps³ is the smallest: a limit just above it flags everything else, and the
    # limit that makes 625000 exactly its tolerated bound passes it
    at = exact_limit(625000.0)
    assert len(jerk_problems(table, cast(Motor, StandIn(max_jerk_pps3=at)))) == 4
    assert len(jerk_problems(table, cast(Motor, StandIn(max_jerk_pps3=below(at))))) == 5
    assert jerk_problems(table, cast(Motor, StandIn())) == []


NEMA23 = next(load_motor(p) for p in bundled_motor_paths() if "nema23" in p.name)


def test_length_problems_judge_the_jerk_only_with_a_trapezoid() -> None:
    table = FreeCurveTable(CLK, (9500, 14000, 26667), (50, 60, 80))
    jerky = Motor(**{**NEMA23.__dict__, "max_jerk_pps3": 1e3})
    assert length_problems(table, jerky, [100, 379]) == []  # triangles: no jerk rule
    trapezoid = length_problems(table, jerky, [100, 380])  # 190 + 190: the whole table
    assert trapezoid and {p.rule for p in trapezoid} == {"jerk"}
    assert all_length_problems(table, jerky) == trapezoid  # every move: the jerk rule too
    assert not all_length_safe(table, jerky) and all_length_safe(table, NEMA23)


def test_execution_problems_read_the_segments() -> None:
    table = FreeCurveTable(CLK, (9500, 26667), (50, 500))  # 300 → 842 pps: +542 > 300
    run = simulate_move(table, 2000)
    got = execution_problems(run, NEMA23, table.rates)
    assert [(p.rule, p.stage_from, p.stage_to, p.pulses, p.family) for p in got] == \
        [("jump", 1, 0, 2000, (2000, 2000)), ("jump", 0, 1, 2000, (2000, 2000))]


def test_every_family_is_named_by_its_shortest_move() -> None:
    # 1053 pps (rate 9500) above a top of 700 pps: stage 0 first runs in the triangle of
    # 2 · (80 + 60 + 1) = 282 pulses (once up, once down), up to 379; 380 runs the whole
    # table with no cruise (the trapezoid), 381 and longer cruise at stage 0 too
    table = FreeCurveTable(CLK, (9500, 14000, 26667), (50, 60, 80))
    slow_top = cast(Motor, StandIn(start_pps=300, top_pps=700, jump_pps=1e9, acc_k=1e9,
                                   dec_k=1e9))
    got = [(p.rule, p.kind, p.pulses, p.family, p.stage_from, p.stage_to)
           for p in all_length_problems(table, slow_top)]
    top = ("top-speed", "top")
    assert got == [(*top, 282, (282, 379), 0, 0)] * 2 + [(*top, 380, (380, 380), 0, 0)] * 2 + \
        [(*top, 381, (381, 0xFFFFFFFF), 0, 0)] * 3
    # a high-rate override of rates[1] (571 pps) never runs stage 0: every family judged
    assert all_length_problems(table, slow_top, high_rate=14000) == []
    assert all_length_problems(table, slow_top, high_rate=9500) == \
        all_length_problems(table, slow_top)


def test_switch_safe_by_hand() -> None:
    # symmetric 10, 10: a = d = 20; the accel enters stage 1 at rest ⌈11 · 40 / 20⌉ = 22,
    # whose decel share ⌈22 · 20 / 40⌉ = 11 is exactly the 11 the decel needs to reach
    # stage 1 too; a decel-only move lasts ⌈40 / 20⌉ − 1 = 1 ≤ 10 pulses
    assert switch_safe(np.array([10, 10]), np.array([10, 10]))
    # decel 11, 10: rest ⌈11 · 41 / 20⌉ = 23, share ⌈23 · 21 / 41⌉ = 12 ≥ 11 + 1
    assert switch_safe(np.array([10, 10]), np.array([11, 10]))
    # heavy at the decel's slow end (slowest first 200, 2, 2 against 40, 40, 40): rests
    # 111 and 219 give shares 70 and 138, short of 201 and 203
    assert not switch_safe(np.array([40, 40, 40]), np.array([200, 2, 2]))
    # the same counts the other way round pass: shares 70, 138 ≥ 3, 5; decel-only moves
    # last ⌈324 / 120⌉ − 1 = 2 ≤ 2 pulses (the boundary)
    assert switch_safe(np.array([40, 40, 40]), np.array([2, 2, 200]))
    # 1, 1 against 1, 1: decel-only moves last ⌈4 / 2⌉ − 1 = 1 ≤ 1 (the boundary)
    assert switch_safe(np.array([1, 1]), np.array([1, 1]))
    # 1, 1 against 1, 3: the share test passes (rest 6, share 4 ≥ 2) but a decel-only move
    # of ⌈6 / 2⌉ − 1 = 2 pulses starts above the slowest decel stage (1 pulse)
    assert not switch_safe(np.array([1, 1]), np.array([1, 3]))
    # no pulses on a side: no triangle to speak of
    assert not switch_safe(np.array([0, 0]), np.array([1, 1]))
    assert not switch_safe(np.array([1, 1]), np.array([0, 0]))


def test_switch_safe_at_the_share_boundary() -> None:
    # 10, 10 against 12, 10: rest ⌈11 · 42 / 20⌉ = 24, share ⌈24 · 22 / 42⌉ = 13 = 12 + 1
    assert switch_safe(np.array([10, 10]), np.array([12, 10]))
    # 10, 10 against 13, 10: rest ⌈11 · 43 / 20⌉ = 24, share ⌈24 · 23 / 43⌉ = 13 < 14
    assert not switch_safe(np.array([10, 10]), np.array([13, 10]))
    # three stages, the second share decides: 10, 10, 10 against 10, 12, 10 (a 30, d 32):
    # first rest ⌈11 · 62 / 30⌉ = 23, share ⌈23 · 32 / 62⌉ = 12 ≥ 11; second rest
    # ⌈21 · 62 / 30⌉ = 44, share ⌈44 · 32 / 62⌉ = 23 ≥ 23
    assert switch_safe(np.array([10, 10, 10]), np.array([10, 12, 10]))
    # 10, 14, 10: second rest ⌈21 · 64 / 30⌉ = 45, share ⌈45 · 34 / 64⌉ = 24 < 10 + 14 + 1
    assert not switch_safe(np.array([10, 10, 10]), np.array([10, 14, 10]))


def test_which_tables_take_the_trapezoid_shortcut() -> None:
    assert _same_stages_switch_safe(FreeCurveTable(CLK, (9500, 14000), (50, 60)))
    assert _same_stages_switch_safe(FreeCurveTable(CLK, (9500, 14000), (50, 60), (50, 60)))
    # fastest first: decel 2, 2, 200 is slowest first 200, 2, 2 (not switch safe)
    unsafe = FreeCurveTable(CLK, (1455, 1873, 2500), (40, 40, 40), (2, 2, 200))
    assert not _same_stages_switch_safe(unsafe)
    assert _same_stages_switch_safe(FreeCurveTable(CLK, (1455, 1873, 2500), (40, 40, 40),
                                                   (200, 2, 2)))
    assert not _same_stages_switch_safe(FreeCurveTable(CLK, (9500, 14000, 26667), (50, 60, 80),
                                                       (50, 60)))


def test_switch_safe_with_one_stage() -> None:
    # one stage: no share to check; a decel-only move lasts ⌈(a + d) / a⌉ − 1 pulses
    assert switch_safe(np.array([2]), np.array([1]))  # ⌈3 / 2⌉ − 1 = 1 ≤ 1
    assert switch_safe(np.array([1]), np.array([5]))  # ⌈6 / 1⌉ − 1 = 5 ≤ 5
    assert not switch_safe(np.array([3]), np.array([0]))  # no decel pulses at all
    # one list for both sides is safe whatever its counts
    assert _same_stages_switch_safe(FreeCurveTable(CLK, (9500, 14000), (50, 0)))


def test_the_trapezoid_shortcut_is_taken_only_where_it_is_proven() -> None:
    """Same stages on both sides, switch safe, no high-rate override and not asked to be
    exhaustive: the trapezoid alone is judged; otherwise every family is."""
    from unittest import mock

    from profiles.ppmc312 import criterion

    safe = FreeCurveTable(CLK, (9500, 14000, 26667), (50, 60, 80))
    free = cast(Motor, StandIn(start_pps=300, top_pps=1e9, jump_pps=1e9, acc_k=1e9,
                               dec_k=1e9))
    no_families = mock.patch.object(criterion, "move_families",
                                    side_effect=AssertionError("every family judged"))
    no_trapezoid = mock.patch.object(criterion, "simulate_move",
                                     side_effect=AssertionError("trapezoid shortcut"))
    with no_families:
        assert all_length_problems(safe, free) == []
    for kw in ({"high_rate": 14000}, {"exhaustive": True}):
        with no_trapezoid:
            assert all_length_problems(safe, free, **kw) == []  # type: ignore[arg-type]
    unsafe = FreeCurveTable(CLK, (1455, 1873, 2500), (40, 40, 40), (2, 2, 200))
    with no_trapezoid:
        all_length_problems(unsafe, free)


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


# --- the criterion's findings on hand-made tables: each rule caught, fixes clear it ------

NEMA23 = next(load_motor(p) for p in bundled_motor_paths() if "nema23" in p.name)


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

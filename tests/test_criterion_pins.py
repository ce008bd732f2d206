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
    execution_problems,
    jerk_problems,
    length_problems,
    runs_problems,
    switch_safe,
)
from profiles.ppmc312.execution import simulate_move
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
# move can start on a decel stage or stop on an accel one (verify.criterion words its fix).
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


# --- each limit at its exact boundary: equal to limit · (1 + REL_TOL) passes ----------


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


# --- the jerk rule -------------------------------------------------------------------


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


# --- which moves are judged ------------------------------------------------------------


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


def problems_key(problems: list[StepProblem]) -> list[tuple[object, ...]]:
    return sorted((p.rule, p.pulses, p.stage_from, p.stage_to) for p in problems)


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


# --- which LE=1 tables may skip judging every family -------------------------------------


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

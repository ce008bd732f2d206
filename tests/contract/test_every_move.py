"""One table, every move: the executions the chip can run and both judges over them."""

from __future__ import annotations

import itertools
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.motor.angles import AIM_DEG
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.criterion import (
    all_length_problems,
    check_stall,
    execution_problems,
    switch_safe,
)
from profiles.ppmc312.execution import move_families, simulate_move
from profiles.ppmc312.move_batch import MOVE_PULSES_MAX
from profiles.ppmc312.planner import plan_duty_cycle, plan_free_curve
from profiles.ppmc312.table import FreeCurveTable
from verify.safety import judge_safety

CLK = Clock.internal("8MHz")


MOTORS = {p.stem: load_motor(p) for p in bundled_motor_paths()}


def small_motor(start: float, jump: float) -> Motor:
    return Motor(steps_per_rev=400, curve_speed_pps=np.array([0.0, 3000.0, 9000.0]),
                 curve_torque_nm=np.array([0.5, 0.4, 0.1]), inertia_kgm2=1e-4,
                 safety_factor=0.7, start_pps=start, friction_torque_nm=0.02,
                 max_jump_pps=jump)


@st.composite
def tables(draw: st.DrawFn) -> FreeCurveTable:
    n_acc = draw(st.integers(2, 5))
    n_dec = draw(st.sampled_from([n_acc, draw(st.integers(2, 5))]))
    speeds = sorted(draw(st.lists(st.integers(200, 8000), min_size=max(n_acc, n_dec),
                                  max_size=max(n_acc, n_dec), unique=True)), reverse=True)
    rates = tuple(sorted({round(CLK.hz / v) for v in speeds}))
    if len(rates) < max(n_acc, n_dec):
        n_acc = n_dec = len(rates)
        if len(rates) < 2:
            rates = (1000, 2000)
            n_acc = n_dec = 2
    acc = tuple(draw(st.integers(2, 25)) for _ in range(n_acc))
    separate = draw(st.booleans())
    dec = tuple(draw(st.integers(2, 25)) for _ in range(n_dec)) if separate else None
    longest = max(n_acc, n_dec if separate else n_acc)
    return FreeCurveTable(CLK, rates[:longest], acc, dec)


def segments(run):  # type: ignore[no-untyped-def]
    return [(s.phase, s.rate) for s in run.segments]


@pytest.mark.slow  # against simulate_move for every length; CI runs it
@settings(max_examples=60, deadline=None)
@given(tables(), st.integers(0, 3))
def test_families_partition_every_length_and_fix_the_segment_rates(table, hr_pick) -> None:  # type: ignore[no-untyped-def]
    high = 0 if hr_pick == 0 else sorted(table.rates)[min(hr_pick, len(table.rates) - 1)]
    fams = move_families(table, high_rate=high)
    assert fams[0].lo == 1 and fams[-1].hi == MOVE_PULSES_MAX
    assert all(a.hi + 1 == b.lo for a, b in itertools.pairwise(fams))
    top = table.accel_total + table.decel_total + 2
    for fam in fams:
        ref = segments(fam.execution())
        for n in range(fam.lo, min(fam.hi, top) + 1):
            assert segments(simulate_move(table, n, high_rate=high)) == ref


@pytest.mark.slow  # a reference comparison; CI runs it
@settings(max_examples=60, deadline=None)
@given(tables(), st.sampled_from([(300.0, 300.0), (2000.0, 800.0), (6000.0, 3000.0)]))
def test_all_length_verdict_equals_brute_force(table, limits) -> None:  # type: ignore[no-untyped-def]
    motor = small_motor(*limits)
    brute = [p for n in range(1, table.accel_total + table.decel_total + 2)
             for p in execution_problems(simulate_move(table, n), motor, table.rates)]
    fast = all_length_problems(table, motor)
    assert bool(fast) == bool(brute)
    assert min(p.pulses for p in fast) == min(p.pulses for p in brute) if brute else True
    # the shortcut for same-stage, switch-safe tables agrees with every family judged
    every = all_length_problems(table, motor, exhaustive=True)
    assert {(p.rule, p.stage_from, p.stage_to) for p in fast} == \
        {(p.rule, p.stage_from, p.stage_to) for p in every}


def test_a_downward_switch_is_caught_and_named_by_its_shortest_move() -> None:
    # LE=1 with the decel counts heavy at the slow end (as the last release's plans had
    # them): short moves end the accel on a faster stage than their decel starts on.
    motor = MOTORS["motor-nema23-heavy"]
    table = FreeCurveTable(CLK, (1455, 1873, 2500), (40, 40, 40), (2, 2, 200))
    switch = [f for f in check_stall(table, motor) if f.rule == "stall-switch"]
    assert len(switch) == 1
    shortest = int(re.search(r"shortest move that runs it: (\d+) pulses",  # type: ignore[union-attr]
                             switch[0].message).group(1))

    def drops(n: int) -> bool:
        return any(a.phase == "accel" and b.phase == "decel" and b.rate > a.rate
                   for a, b in itertools.pairwise(simulate_move(table, n).segments))

    assert drops(shortest) and not any(drops(n) for n in range(1, shortest))


@pytest.mark.parametrize("name", sorted(MOTORS))
@pytest.mark.parametrize("pulses", [300, 2000, 10_000])
def test_planned_tables_are_safe_for_every_length_by_both_judges(name: str, pulses: int) -> None:
    motor = MOTORS[name]
    plan = plan_free_curve(motor, pulses=pulses, load_angle_deg=AIM_DEG)
    assert check_stall(plan.table, motor) == []
    assert all_length_problems(plan.table, motor, exhaustive=True) == []
    verdict = judge_safety(plan.table, motor)
    assert verdict.safe and verdict.within_aim
    if plan.table.separate:
        assert switch_safe(np.asarray(plan.table.accel_pulses[::-1]),
                           np.asarray(plan.table.decel[::-1]))


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(MOTORS))
@pytest.mark.parametrize("pulses", [60, 150, 700, 5_000, 40_000, 250_000])
def test_more_planned_lengths_are_safe_by_both_judges(name: str, pulses: int) -> None:
    test_planned_tables_are_safe_for_every_length_by_both_judges(name, pulses)


@pytest.mark.parametrize("name", sorted(MOTORS))
def test_never_slower_than_the_symmetric_table(name: str) -> None:
    motor = MOTORS[name]
    for pulses in (2000, 100_000):
        auto = plan_free_curve(motor, pulses=pulses)
        sym = plan_free_curve(motor, pulses=pulses, separate_decel=False)
        assert auto.duration_s <= sym.duration_s
        assert simulate_move(auto.table, pulses).duration_s == pytest.approx(auto.duration_s)


def test_load_torque_is_planned_for_both_directions() -> None:
    base = MOTORS["motor-nema17-1600"]
    loaded = Motor(**{**base.__dict__, "load_torque_nm": 0.05})
    plan = plan_free_curve(loaded, pulses=5000)
    assert check_stall(plan.table, loaded) == []
    # slower than without the load: the load hinders one of the two directions
    assert plan.duration_s > plan_free_curve(base, pulses=5000).duration_s
    # the same table without accounting for the load's worse direction breaks the rule
    flipped = Motor(**{**base.__dict__, "load_torque_nm": -0.05})
    assert check_stall(plan.table, flipped) == []  # sign does not matter: both ways judged
    assert loaded.a_acc_pps2(0.0) == pytest.approx(flipped.a_acc_pps2(0.0))


@pytest.mark.slow  # against every single-length plan; CI runs it
def test_duty_cycle_never_worse_than_any_single_length_plan() -> None:
    motor = MOTORS["motor-pk566-5phase-half"]
    mix = [(200, 5.0), (2000, 2.0), (20_000, 1.0)]
    plan, times = plan_duty_cycle(motor, mix)
    weighted = sum(w * times[n] for n, w in mix)
    assert plan.duration_s == pytest.approx(weighted)
    for n, _ in mix:
        assert times[n] == pytest.approx(simulate_move(plan.table, n).duration_s)
        single = plan_free_curve(motor, pulses=n).table
        assert weighted <= sum(ww * simulate_move(single, nn).duration_s for nn, ww in mix) \
            * (1 + 1e-12)
    assert check_stall(plan.table, motor) == []

"""Planner: stall-safe, chip-legal, faster than the baseline, optimal on brute-forced cases."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from profiles.errors import PlanError, StepRampError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.criterion import check_stall
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.planner import (
    Shaping,
    choose_clock,
    plan,
    plan_baseline,
    plan_free_curve,
    reference_pulses,
    switch_safe,
)
from profiles.ppmc312.planner.free_curve import RAMP_FLOOR, TOP_ROUNDS, TOP_STEP, VARIANTS
from profiles.ppmc312.planner.problem import Plan
from profiles.ppmc312.planner.quantise import quantise_reference
from profiles.ppmc312.table import FreeCurveTable
from verify.safety import judge_safety

MOTORS = {p.stem: load_motor(p) for p in bundled_motor_paths()}


MOVES = (300, 2000, 10000, 100000, None)


def assert_chip_legal(table: FreeCurveTable, pulses: int | None) -> None:
    """SPEC §1.4 free-curve rules, written out here independently of profiles.ppmc312.chip_rules."""
    rates = np.asarray(table.rates)
    for counts in (table.accel_pulses, table.decel):
        c = np.asarray(counts)
        assert 2 <= len(c) <= 127
        assert np.all(c >= 2) and np.all(c <= 0xFFFFF)
        assert np.all(c * rates[: len(c)] >= 256)
        assert c.sum() <= 0xFFFFF
    assert np.all(rates >= 2) and np.all(rates <= 0xFFFF)
    assert np.all(np.diff(rates) > 0)
    assert table.clock.hz / rates[0] <= 2e6
    if pulses is not None:
        assert table.accel_total + table.decel_total <= pulses


def move_time(table: FreeCurveTable, pulses: int) -> float:
    """Chip trapezoid time, recomputed from the table alone."""
    f = table.speeds_pps()
    a, d = np.asarray(table.accel_pulses), np.asarray(table.decel)
    cruise = pulses - a.sum() - d.sum()
    return float(np.sum(a / f[: len(a)]) + np.sum(d / f[: len(d)]) + cruise / f[0])


@pytest.mark.parametrize("name", sorted(MOTORS))
@pytest.mark.parametrize("pulses", MOVES)
@pytest.mark.parametrize("max_stages", [2, 10, 127])
def test_plans_are_stall_safe_legal_and_beat_baseline(name: str, pulses: int | None,
                                                      max_stages: int) -> None:
    motor = MOTORS[name]
    plan = plan_free_curve(motor, pulses=pulses, max_stages=max_stages)
    assert check_stall(plan.table, motor) == []
    assert_chip_legal(plan.table, pulses)
    assert len(plan.table.rates) <= max_stages
    budget = pulses if pulses is not None else reference_pulses(motor)
    assert plan.duration_s == pytest.approx(move_time(plan.table, budget), rel=1e-12)
    base = plan_baseline(motor, pulses=pulses, max_stages=max_stages)
    assert check_stall(base.table, motor) == []
    assert_chip_legal(base.table, pulses)
    assert plan.duration_s <= base.duration_s * (1 + 1e-12)


@pytest.mark.slow  # a reference comparison; CI runs it
def test_beats_baseline_by_one_percent_geometric_mean() -> None:
    ratios = []
    for motor in MOTORS.values():
        for pulses in (300, 2000, 10000, 100000):
            ratios.append(plan_free_curve(motor, pulses=pulses).duration_s
                          / plan_baseline(motor, pulses=pulses).duration_s)
    gmean = math.exp(float(np.mean(np.log(ratios))))
    print(f"planner / baseline move time: geometric mean {gmean:.4f}, "
          f"per case {np.round(ratios, 4).tolist()}")
    assert max(ratios) <= 1 + 1e-12
    assert gmean <= 0.99


@pytest.mark.parametrize("name", sorted(MOTORS))
@pytest.mark.parametrize("pulses", [2000, None])
def test_more_stages_never_slower(name: str, pulses: int | None) -> None:
    times = [plan_free_curve(MOTORS[name], pulses=pulses, max_stages=m).duration_s
             for m in (2, 4, 10, 40, 127)]
    assert all(b <= a * (1 + 1e-12) for a, b in itertools.pairwise(times)), times


def test_separate_decel_choice() -> None:
    motor = MOTORS["motor-nema23-heavy"]
    auto = plan_free_curve(motor, pulses=100_000)
    common = plan_free_curve(motor, pulses=100_000, separate_decel=False)
    forced = plan_free_curve(motor, pulses=100_000, separate_decel=True)
    assert common.table.decel_pulses is None and forced.table.decel_pulses is not None
    # decel counts come from a_dec ≥ a_acc: LE=1 is never slower, and here strictly faster
    assert auto.duration_s <= common.duration_s
    assert forced.duration_s < common.duration_s
    assert sum(forced.table.decel) < sum(forced.table.accel_pulses)
    # ... and it stays safe for every move length (its triangles switch on safe stages)
    assert check_stall(forced.table, motor) == []
    assert switch_safe(np.array(forced.table.accel_pulses[::-1]),
                       np.array(forced.table.decel[::-1]))


def test_forced_le1_falls_back_to_the_symmetric_dps_rates() -> None:
    # at 10 000 pulses the heavy table's own LE=1 rates would need more decel pulses than
    # the move has to keep every triangle's switch safe; LE=0's rates with the decel
    # side's own counts are switch-safe, and faster than LE=0 itself
    motor = MOTORS["motor-nema23-heavy"]
    forced = plan_free_curve(motor, pulses=10_000, separate_decel=True)
    assert forced.extras["variant"] == "LE=1 on LE=0's rates"
    assert forced.table.decel_pulses is not None and check_stall(forced.table, motor) == []
    le0 = plan_free_curve(motor, pulses=10_000, separate_decel=False)
    assert le0.table.rates == forced.table.rates
    assert le0.table.accel_pulses == forced.table.accel_pulses
    assert forced.duration_s < le0.duration_s
    assert plan_free_curve(motor, pulses=10_000).table == forced.table  # auto picks it
    with pytest.raises(PlanError, match="switch safe"):  # LE=1's own DP alone
        plan(motor, None, 127, 10_000, True, variant="LE=1")


def test_each_variant_is_planned_on_its_own_dp() -> None:
    """"LE=1" is the LE=1 DP's staircase made switch-safe; "LE=0" the symmetric DP's; the
    baseline is symmetric (LE=0) as documented."""
    from profiles.ppmc312.planner.free_curve import plan_baseline, plan_staircase, table_of
    from profiles.ppmc312.planner.problem import choose_clock, make_problem
    from profiles.ppmc312.planner.refine import switch_safe_decel

    motor = MOTORS["motor-nema17-1600"]
    clock = choose_clock(motor)
    own = switch_safe_decel(make_problem(motor, clock, True),
                            plan_staircase(motor, clock, 127, 100_000, True), 100_000)
    assert own is not None
    le1 = plan(motor, None, 127, 100_000, True, variant="LE=1")
    assert le1.table == table_of(clock, own, not np.array_equal(own.n, own.d))
    le0 = plan(motor, None, 127, 100_000, False, variant="LE=0")
    assert le0.table == table_of(clock, plan_staircase(motor, clock, 127, 100_000, False), False)
    assert not plan_baseline(motor, pulses=100_000).table.separate


def test_the_decel_sides_own_counts_never_lose_to_le0() -> None:
    """On every bundled motor and move, the LE=1 variant on LE=0's rates is switch-safe
    and no slower than LE=0 (its symmetric end is LE=0); auto mode is no slower than
    either."""
    for motor in MOTORS.values():
        for pulses in (300, 2000, 10_000):
            le0 = plan_free_curve(motor, pulses=pulses, separate_decel=False)
            mixed = plan(motor, None, 127, pulses, True, variant="LE=1 on LE=0's rates")
            auto = plan_free_curve(motor, pulses=pulses)
            assert mixed.duration_s <= le0.duration_s
            assert auto.duration_s <= mixed.duration_s
            assert check_stall(mixed.table, motor) == []
    with pytest.raises(ValueError, match="variant"):
        plan(motor, None, 127, 2000, False, variant="LE=1")


def test_without_a_variant_is_the_fastest_of_the_others() -> None:
    """`without`: every variant but the one named, the fastest kept (what a gentler plan
    falls back to when the plain plan's variant has no table: NEMA23's LE=1 at 10 000
    pulses)."""
    motor = MOTORS["motor-nema23-heavy"]
    others = [plan(motor, None, 127, 10_000, None, variant=v) for v in VARIANTS[1:]]
    without = plan(motor, None, 127, 10_000, None, without="LE=1")
    fastest = min(others, key=lambda p: p.duration_s)
    assert without.table == fastest.table
    assert without.extras["variant"] == fastest.extras["variant"]
    assert without.table == plan(motor, None, 127, 10_000, None).table  # LE=1 has none
    with pytest.raises(ValueError, match="variant"):
        plan(motor, None, 127, 2000, False, without="LE=1")


def test_switch_safe_matches_the_move_model() -> None:
    # a table whose decel share reaches a slower stage than the accel share: the move
    # model shows the downward switch, switch_safe says no; equal counts say yes
    rates = (400, 800, 1600)
    n, d = (10, 10, 10), (2, 2, 40)   # fastest first: the decel's slow end is heavy
    table = FreeCurveTable(Clock.internal("8MHz"), rates, n, d)
    drops = [p for p in range(1, 80) if any(
        a.phase == "accel" and b.phase == "decel" and b.rate > a.rate
        for a, b in itertools.pairwise(simulate_move(table, p).segments))]
    assert drops and not switch_safe(np.array(n[::-1]), np.array(d[::-1]))
    assert switch_safe(np.array(n[::-1]), np.array(n[::-1]))


# --- optimality on a tiny problem -------------------------------------------------
def tiny_motor(**kw: float) -> Motor:
    args = dict(steps_per_rev=200, curve_speed_pps=np.array([0.0, 600.0, 1400.0, 2000.0]),
                curve_torque_nm=np.array([0.5, 0.45, 0.2, 0.1]), inertia_kgm2=2e-4,
                safety_factor=0.8, start_pps=450.0, friction_torque_nm=0.02,
                max_jump_pps=350.0)
    args.update(kw)
    return Motor(**args)  # type: ignore[arg-type]


def brute_force(motor: Motor, clock: Clock, stages: int, pulses: int,
                separate: bool) -> float:
    """Every strictly rising sequence of 2..stages integer rates, minimal counts."""
    hz = clock.hz
    r_hi = min(0xFFFF, 2 * math.ceil(hz / motor.start_pps))
    r_lo = max(2, math.ceil(hz / motor.top_pps))
    best = math.inf
    for k in range(2, stages + 1):
        combos = np.array(list(itertools.combinations(range(r_hi, r_lo - 1, -1), k)))
        f = hz / combos.astype(float)                      # slowest first
        ok = f[:, 0] <= motor.start_pps
        lo, hi = f[:, :-1], f[:, 1:]
        delta = hi - lo
        ok &= np.all(delta <= motor.jump_pps, axis=1)
        a_acc = motor.min_a_acc_pps2(lo, hi)
        a_dec = motor.min_a_dec_pps2(lo, hi)
        ok &= np.all(a_acc > 0, axis=1)
        floor = np.maximum(2, np.ceil(256 / combos))
        with np.errstate(divide="ignore", invalid="ignore"):
            n = np.maximum(floor[:, :-1], np.ceil(delta * lo / a_acc))
            d = np.maximum(floor[:, :-1], np.ceil(delta * lo / a_dec))
        if not separate:
            n = d = np.maximum(n, d)
        used = n.sum(1) + d.sum(1) + 2 * floor[:, -1]
        ok &= used <= pulses
        t = ((n + d) / lo).sum(1) + (pulses - (n + d).sum(1)) / f[:, -1]
        t = np.where(ok, t, np.inf)
        best = min(best, float(t.min()))
    return best


# 4 stages: a brute force over every 4-rate combination (seconds each): CI runs those
@pytest.mark.parametrize("stages", [2, 3, pytest.param(4, marks=pytest.mark.slow)])
@pytest.mark.parametrize("pulses", [60, 120, 400, 100000])
@pytest.mark.parametrize("separate", [False, True])
def test_dp_matches_brute_force(stages: int, pulses: int, separate: bool) -> None:
    motor = tiny_motor()
    clock = Clock.internal("15.625kHz")
    want = brute_force(motor, clock, stages, pulses, separate)
    got = plan_free_curve(motor, clock=clock, max_stages=stages, pulses=pulses,
                          separate_decel=separate)
    assert got.duration_s == pytest.approx(want, rel=1e-12)
    assert check_stall(got.table, motor) == []


@pytest.mark.parametrize("pulses", [400, 100000])
@pytest.mark.parametrize("separate", [False, True])
def test_dp_matches_brute_force_when_one_jump_reaches_the_top(pulses: int,
                                                              separate: bool) -> None:
    """Every rate within one jump of the start: the DP's second layer already reaches
    every node, and more stages still help (the capability falls with speed)."""
    motor = tiny_motor(max_jump_pps=2000.0)
    clock = Clock.internal("15.625kHz")
    want = brute_force(motor, clock, 3, pulses, separate)
    got = plan_free_curve(motor, clock=clock, max_stages=3, pulses=pulses,
                          separate_decel=separate)
    assert got.duration_s == pytest.approx(want, rel=1e-12)
    assert len(got.table.rates) == 3  # two stages would be slower


# --- clock, errors, jerk ---------------------------------------------------------
def test_choose_clock() -> None:
    assert all(choose_clock(m).name == "8MHz" for m in MOTORS.values())
    assert choose_clock(tiny_motor(start_pps=100.0)).name == "1MHz"  # 8e6/100 > 0xFFFF
    assert choose_clock(tiny_motor(start_pps=4.0)).name == "250kHz"  # 62500 fits
    assert choose_clock(tiny_motor(start_pps=3.0)).name == "62.5kHz"  # 83333 does not
    with pytest.raises(StepRampError, match="start_pps"):
        choose_clock(tiny_motor(start_pps=0.1))


def test_infeasible_requests_raise_one_line() -> None:
    motor = MOTORS["motor-nema23-heavy"]
    for kwargs in ({"max_stages": 1}, {"max_stages": 128}, {"pulses": 5}, {"pulses": -1}):
        with pytest.raises(StepRampError) as e:
            plan_free_curve(motor, **kwargs)  # type: ignore[arg-type]
        assert "\n" not in str(e.value)
    with pytest.raises(StepRampError, match="slower clock"):
        plan_free_curve(tiny_motor(start_pps=100.0), clock=Clock.internal("8MHz"))
    # at 15.625 kHz the two fastest rates at start speed are 13 pps apart, which this load
    # needs thousands of pulses for; 256 ticks alone need 8 pulses a stage
    weak = tiny_motor(inertia_kgm2=50.0)
    with pytest.raises(StepRampError, match="pulses") as e:
        plan_free_curve(weak, clock=Clock.internal("15.625kHz"), pulses=8)
    assert "\n" not in str(e.value)


def test_jerk_limited_motor() -> None:
    motor = tiny_motor(max_jerk_pps3=2e6, start_pps=300.0, max_jump_pps=200.0)
    clock = Clock.internal("250kHz")
    plan = plan_free_curve(motor, clock=clock, pulses=5000)
    assert check_stall(plan.table, motor) == []
    assert_chip_legal(plan.table, 5000)
    free = plan_free_curve(tiny_motor(start_pps=300.0, max_jump_pps=200.0), clock=clock,
                           pulses=5000)
    assert plan.duration_s >= free.duration_s


@pytest.mark.slow
# --- quantising a reference -------------------------------------------------------
def ruckig_reference(pulses: int, v_max: float, a_max: float, j_max: float,
                     samples: int = 8001) -> tuple[np.ndarray, ...]:
    from ruckig import InputParameter, Result, Ruckig, Trajectory
    t_ref = math.sqrt(pulses / a_max)  # normalised: position / N, time / t_ref
    inp = InputParameter(1)
    inp.current_position, inp.target_position = [0.0], [1.0]
    inp.max_velocity = [v_max * t_ref / pulses]
    inp.max_acceleration = [a_max * t_ref**2 / pulses]
    inp.max_jerk = [j_max * t_ref**3 / pulses]
    traj = Trajectory(1)
    assert Ruckig(1).calculate(inp, traj) == Result.Working
    tau = np.linspace(0.0, traj.duration, samples)
    pv = np.array([traj.at_time(x)[:2] for x in tau])[:, :, 0]
    return tau * t_ref, pv[:, 0] * pulses, pv[:, 1] * pulses / t_ref, traj, t_ref


@pytest.mark.parametrize("pulses", [500, 20000])
def test_quantise_reference_never_runs_ahead(pulses: int) -> None:
    t, x, v, traj, t_ref = ruckig_reference(pulses, 20000.0, 2e5, 2e7)
    q = quantise_reference(t, x, v, clock=Clock.internal("1MHz"))
    assert_chip_legal(q.table, pulses)
    f = q.table.speeds_pps()
    a, d = np.asarray(q.table.accel_pulses)[::-1], np.asarray(q.table.decel)[::-1]
    slow_first = f[::-1]
    cruise = pulses - a.sum() - d.sum()
    per_pulse = np.concatenate((np.repeat(slow_first[-len(a):], a), np.full(cruise, f[0]),
                                np.repeat(slow_first[-len(d):][::-1], d[::-1])))
    step_t = np.cumsum(1.0 / per_pulse)
    ref_x = np.array([traj.at_time(s / t_ref)[0][0] * pulses if s / t_ref < traj.duration
                      else pulses for s in step_t])
    assert np.all(ref_x >= np.arange(1, pulses + 1) - 1e-3)  # never ahead of the reference
    ideal = np.interp(np.arange(1, pulses + 1), x, t)
    late_us = (step_t - ideal) * 1e6
    assert q.extras["max_step_error_us"] == pytest.approx(late_us.max(), rel=1e-3, abs=1.0)
    assert q.extras["mean_step_error_us"] == pytest.approx(late_us.mean(), rel=1e-3, abs=1.0)
    assert late_us.min() > -1.0


def test_quantise_rejects_bad_input() -> None:
    t = np.linspace(0, 1, 10)
    with pytest.raises(StepRampError):
        quantise_reference(t, t * 0, t, clock=Clock.internal("1MHz"))  # 0-pulse move
    with pytest.raises(StepRampError):
        quantise_reference(t[::-1], t * 100, t, clock=Clock.internal("1MHz"))
    with pytest.raises(StepRampError, match="slower clock"):
        quantise_reference(t * 100, t * 100, t, clock=Clock.internal("8MHz"))


def test_plans_are_remembered_by_their_arguments_and_shared_read_only() -> None:
    """The same arguments (the motor by its values: loaded again, or with only its
    provenance added) give the remembered table; other arguments plan anew; forgetting
    plans anew; a remembered plan cannot be changed by one of its callers."""
    from dataclasses import replace

    from profiles.ppmc312.planner.free_curve import forget_plans

    path = bundled_motor_paths()[0]
    forget_plans()
    first = plan(load_motor(path), None, 127, 2000, None)
    again = plan(replace(load_motor(path), sources={"inertia_kgm2": [{"value": 1, "from": "x"}]}),
                 None, 127, 2000, None)
    assert again.table is first.table and again.extras is first.extras
    assert plan(load_motor(path), None, 127, 2001, None).table is not first.table
    assert plan(load_motor(path), None, 126, 2000, None).table is not first.table
    with pytest.raises(TypeError):
        first.extras["variant"] = "LE=0"  # type: ignore[index]
    forget_plans()
    fresh = plan(load_motor(path), None, 127, 2000, None)
    assert fresh.table is not first.table and fresh.table == first.table


def test_what_binds_a_plan_and_what_refinement_buys() -> None:
    """A motor with torque to spare at its last curve point cruises there: its long move
    is bound by the top speed. Refinement over exact integer rates shortens a bundled
    motor's move (the grid alone is coarser)."""
    strong = tiny_motor(curve_torque_nm=np.array([0.5, 0.45, 0.4, 0.35]), inertia_kgm2=2e-5)
    long = plan_free_curve(strong, pulses=100_000)
    assert long.binds == "top speed"
    assert long.table.clock.hz / long.table.rates[0] == pytest.approx(strong.top_pps)
    motor = MOTORS["motor-nema17-1600"]
    refined = plan(motor, None, 127, 10_000, None)
    coarse = plan(motor, None, 127, 10_000, None, refine=False)
    assert refined.duration_s < coarse.duration_s
    assert refined.binds == "stall criterion (capability and jump limit)"


def test_tightening_keeps_the_variant_the_criterion_chose() -> None:
    motor = MOTORS["motor-nema23-heavy"]
    plain = plan_free_curve(motor, pulses=10_000)
    tight = plan_free_curve(motor, pulses=10_000, load_angle_deg=75.0)
    assert not tight.extras["shaping"].plain
    assert tight.extras["variant"] == plain.extras["variant"] == "LE=1 on LE=0's rates"


def test_a_plan_is_immutable_and_hashable_without_its_extras() -> None:
    """Plans are remembered and handed to every caller that asks again (planner.free_curve
    `_plans`): none may change one. Their extras (a read-only mapping) stay out of the
    hash, so two plans of one table hash alike whatever they carry."""
    import dataclasses
    from types import MappingProxyType

    from profiles.result import PlanResult

    table = FreeCurveTable(Clock.internal("8MHz"), (4000, 2000), (10, 20), None)
    plan = PlanResult(table, 0.01, "top speed", "a plan",
                      extras=MappingProxyType({"variant": "LE=0"}))
    with pytest.raises(dataclasses.FrozenInstanceError):
        plan.duration_s = 0.0  # type: ignore[misc]
    other = dataclasses.replace(plan, extras=MappingProxyType({"plans": 3}))
    assert hash(plan) == hash(other)


@pytest.mark.parametrize("pulses", [7, 0, 2**32])
def test_a_move_shorter_than_the_smallest_trapezoid_is_refused(pulses: int) -> None:
    """2 stages × 2 pulses × 2 sides: 8 pulses is the shortest move a free curve plans for."""
    from profiles.errors import FieldRangeError

    with pytest.raises(FieldRangeError,
                       match=rf"^pulses: {pulses}.* allowed range 8\.\.4294967295"):
        plan_free_curve(load_motor(bundled_motor_paths()[0]), pulses=pulses)


# issue 32's datasheet NEMA17 (17HS19-like, on a lead screw, friction 0..0.0438 N·m) with
# 30× the load inertia, its top speed capped where the cruise reserve holds (22 416 pps)
HEAVY = Motor(
    steps_per_rev=1600,
    curve_speed_pps=np.array([0.0, 11464.0, 12335.0, 13308.0, 14390.0, 15601.0, 16968.0,
                              18520.0, 20282.0, 22303.0, 24636.0, 27215.0]),
    curve_torque_nm=np.array([0.4425, 0.441, 0.3904, 0.342, 0.2953, 0.2506, 0.2075, 0.1663,
                              0.1269, 0.0893, 0.0535, 0.0216]),
    inertia_kgm2=30 * 1.468e-5, safety_factor=0.6, start_pps=5546.0,
    friction_torque_nm=0.0438, holding_torque_nm=0.59, max_pps=22416.0,
    tolerances=(("friction_torque_nm", 0.0, 0.0438),))


@pytest.mark.slow  # about 5 s: a failed tightening, then the last lever's
def test_a_large_inertia_is_planned_with_the_ramp_floored_and_the_start_lowered() -> None:
    """Before, the band rounds lowered the start and the slow band together until no table
    fitted (a ramp share below the friction) and the plan failed (best 102.9°); with no
    band below RAMP_FLOOR and the start going on down, it is within the aim at the
    motor's own top speed, SAFE by the unchanged verdict."""
    from profiles.motor.tolerance import corners, worst_case_motor
    from profiles.ppmc312.planner.tightening import tighten

    def make(m: Motor, s: Shaping | None = None) -> Plan:
        return plan(m, None, 127, 4000, None, shaping=s)

    with pytest.raises(PlanError, match="best 10"):  # the band rounds alone
        tighten(worst_case_motor(HEAVY), make, 75.0,
                judges=[c.motor for c in corners(HEAVY)])
    got = plan_free_curve(HEAVY, pulses=4000, load_angle_deg=75.0)
    assert got.extras["worst_load_angle_deg"] <= 75.0
    assert "top_lowered_pps" not in got.extras and got.extras["untightened_s"] < got.duration_s
    assert min(got.extras["shaping"].scale) >= RAMP_FLOOR - 1e-12
    verdict = judge_safety(got.table, HEAVY, aim_deg=75.0)
    assert verdict.safe and verdict.within_aim


@pytest.mark.slow  # about 25 s: a dozen tightenings, some at a lower top speed
def test_the_top_speed_is_the_last_lever_and_then_what_would_help() -> None:
    """At a 40° aim the floored ramp and the lowest start are not enough at 22 416 pps:
    the top speed is lowered TOP_STEP a round until the table is within the aim, SAFE by
    the unchanged verdict; at 30° nothing is, and the closest says what would help."""
    got = plan_free_curve(HEAVY, pulses=4000, load_angle_deg=40.0)
    was, now = got.extras["top_lowered_pps"]
    assert was == HEAVY.top_pps and now < was
    assert any(now == pytest.approx(was * TOP_STEP ** k) for k in range(1, TOP_ROUNDS + 1))
    assert got.table.clock.hz / got.table.rates[0] <= now * 1.0001
    verdict = judge_safety(got.table, HEAVY, aim_deg=40.0)
    assert verdict.safe and verdict.within_aim
    closest = plan_free_curve(HEAVY, pulses=4000, load_angle_deg=30.0)
    assert closest.extras["worst_load_angle_deg"] > 30.0
    assert closest.extras["fix"].startswith("a lower load inertia or more drive current")
    assert judge_safety(closest.table, HEAVY, aim_deg=30.0).safe  # below the peak


def test_the_last_lever_keeps_the_first_top_speed_within_the_aim(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """lower_top's rounds, with the tightening stood in for: the motor's own top with the
    ramp floored first, then × TOP_STEP a round; the first within the aim is kept, named
    with its top speed; none below the peak at any top: a PlanError naming what would
    help."""
    import types

    from profiles.ppmc312.planner import free_curve

    asked: list[tuple[float, float]] = []
    worst = iter([90.0, 80.0, 70.0])

    def tighten(m: Motor, make: object, aim: float, **kw: object) -> Plan:
        asked.append((m.top_pps, float(kw["ramp_floor"])))  # type: ignore[arg-type]
        return Plan(FreeCurveTable(Clock.named("8MHz"), (400, 800), (10, 20)), 2.0, "", "",
                    extras={"worst_load_angle_deg": next(worst), "plans": 3})

    monkeypatch.setattr(free_curve, "tighten", tighten)
    plain = types.SimpleNamespace(duration_s=1.0)
    got = free_curve.lower_top(HEAVY, lambda m, s: plain, 75.0, [HEAVY], True, None,
                               None)  # type: ignore[arg-type]
    top = HEAVY.top_pps
    assert asked == [(top, RAMP_FLOOR), (top * TOP_STEP, RAMP_FLOOR),
                     (top * TOP_STEP ** 2, RAMP_FLOOR)]
    assert got.extras["top_lowered_pps"] == (top, top * TOP_STEP ** 2)
    assert got.extras["untightened_s"] == 1.0 and got.extras["plans"] == 9

    def refuse(*a: object, **kw: object) -> object:
        raise PlanError("no table keeps the load angle below 90°")

    monkeypatch.setattr(free_curve, "tighten", refuse)
    with pytest.raises(PlanError, match=r"^no table keeps .*; what would help: a lower load "
                                        r"inertia or more drive current"):
        free_curve.lower_top(HEAVY, lambda m, s: plain, 75.0, [HEAVY], True, None,
                             PlanError("no table keeps the load angle below 90°"))  # type: ignore[arg-type]

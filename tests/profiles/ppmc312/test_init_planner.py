"""The best stall-safe init tables, the yardstick for what the free curve buys."""

from __future__ import annotations

import pytest

from profiles.errors import InitPlanError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.init_planner import init_candidates, plan_init
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import FreeCurveTable
from verify.chip_rules import check_table
from verify.criterion import check_stall

MOTORS = [load_motor(p) for p in bundled_motor_paths()]


def staircase_time_s(stages: FreeCurveTable, pulses: int) -> float:
    """The move time of a staircase, computed here from the chip's documented shapes
    (docs/manual-notes.md), not by profiles.ppmc312.execution: a trapezoid runs both sides
    whole and cruises at the fastest rate; a triangle of an LE=0 table splits the pulses
    evenly (accel rounded down) and each side runs its slowest-first pulses."""
    rates, acc, dec = stages.rates, stages.accel_pulses, stages.decel
    total_acc, total_dec = sum(acc), sum(dec)
    if pulses >= total_acc + total_dec:
        ticks = (sum(p * r for p, r in zip(acc, rates, strict=False))
                 + sum(p * r for p, r in zip(dec, rates, strict=False))
                 + (pulses - total_acc - total_dec) * rates[0])
        return ticks / stages.clock.hz
    assert stages.decel_pulses is None, "the triangle here is the LE=0 one"
    a = pulses // 2

    def slowest_first_ticks(k: int) -> int:
        out = 0
        for p, r in reversed(list(zip(acc, rates, strict=False))):
            take = min(p, k)
            out, k = out + take * r, k - take
        return out

    return (slowest_first_ticks(a) + slowest_first_ticks(pulses - a)) / stages.clock.hz


def test_staircase_time_reference_on_a_hand_example() -> None:
    """The reference itself, on numbers worked by hand: rates 100, 200 at 1 MHz, 10 pulses
    each. 40 pulses: 10·200 + 10·100 + 10·100 + 10·200 = 6000 ticks, + 0 cruise; 50 pulses:
    + 10·100 = 7000 ticks; 7 pulses: accel 3 and decel 4 pulses at rate 200 = 1400 ticks;
    30 pulses: accel 15 = 10·200 + 5·100, decel the same: 5000 ticks."""
    t = FreeCurveTable(Clock.internal("1MHz"), (100, 200), (10, 10))
    assert staircase_time_s(t, 40) == 6000e-6
    assert staircase_time_s(t, 50) == 7000e-6
    assert staircase_time_s(t, 7) == 1400e-6
    assert staircase_time_s(t, 30) == 5000e-6


@pytest.mark.slow  # every candidate planned and judged; CI runs it
@pytest.mark.parametrize("motor", MOTORS, ids=lambda m: m.name[:8])
@pytest.mark.parametrize("shape", ["linear", "s_curve"])
def test_init_plans_are_stall_safe_legal_and_best_of_their_candidates(
        motor: Motor, shape: str) -> None:
    for separate in (False, True):
        # (LE=0 with fewer highs: candidates are costly, and the triangles are the point)
        cands = init_candidates(motor, shape, highs=8 if separate else 3,
                                separate_decel=separate)
        for c in cands:
            assert not [f for f in check_table(c.table) if f.severity == "error"]
            assert check_stall(c.stages, motor) == []
        longest = max(sum(c.stages.accel_pulses) + sum(c.stages.decel) for c in cands)
        # LE=1 candidates: only moves every candidate runs as a trapezoid
        for pulses in ((longest, longest + 5000) if separate else (2_000, 20_000, longest)):
            plan = plan_init(motor, shape, pulses, candidates=cands, separate_decel=separate)
            best = min(staircase_time_s(c.stages, pulses) for c in cands)
            assert plan.duration_s == pytest.approx(best, rel=1e-12, abs=0)
            assert plan.duration_s == pytest.approx(
                staircase_time_s(plan.extras["stages"], pulses), rel=1e-12, abs=0)
            if pulses in (2_000, 20_000):
                # The free curve can run any stall-safe staircase, so it is never slower.
                assert (plan_free_curve(motor, pulses=pulses).duration_s
                        <= plan.duration_s * 1.0001)


def test_counts_are_near_minimal() -> None:
    motor = MOTORS[0]
    cand = init_candidates(motor, "linear", highs=3, separate_decel=False)[0]  # fastest high
    smaller = type(cand.table)(cand.table.clock, "linear", cand.table.start_rate,
                               cand.table.high_rate, int(cand.table.accel_pulses * 0.97))
    from profiles.errors import InitBuildError
    from profiles.ppmc312.init_model import expand_init

    try:
        stages = expand_init(smaller)
    except InitBuildError:
        return  # cannot even be built: certainly not a better candidate
    assert check_stall(stages, motor), "3 % fewer pulses should break the criterion"


def test_bad_shape_is_refused() -> None:
    with pytest.raises(InitPlanError, match="shape"):
        init_candidates(MOTORS[0], "cubic")  # type: ignore[arg-type]

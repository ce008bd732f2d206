"""Tightening for the load angle where the rotor rings (profiles.ppmc312.planner.tightening):
the bands blamed are the ones whose speed steps drove the worst angles, a long move pays
little for short moves' ringing, and every table it returns is within the aim at every
move length, by the compiled model and by the plain-Python oracle."""

from __future__ import annotations

import numpy as np
import pytest
from oracle_moves import worst_whole_move

from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.motor.angles import AIM_DEG
from profiles.ppmc312.load_angle import angles, worst_load_angle
from profiles.ppmc312.planner import Shaping, plan, plan_free_curve
from profiles.ppmc312.planner.tightening import culprits, tighten_uniform
from verify.safety import judge_safety

MOTORS = {p.stem.removeprefix("motor-"): load_motor(p) for p in bundled_motor_paths()}
NEMA23 = MOTORS["nema23-heavy"]


def test_short_moves_ringing_is_blamed_on_the_slow_end() -> None:
    """The plain NEMA23 table rings past the aim on moves of a few tens of pulses: the
    speed steps before those worst angles lie in the table's slow speed bands."""
    table = plan_free_curve(NEMA23, pulses=10_000).table
    found = angles(table, [NEMA23])
    worst = found.worst(0)
    assert worst.worst_angle_deg > AIM_DEG and worst.worst_pulses < 100
    shaping = Shaping.bands(NEMA23)
    blame = culprits(table, [NEMA23], found, AIM_DEG, shaping)
    assert blame.bands and max(blame.bands) <= shaping.band(0.5 * NEMA23.top_pps)
    assert max(blame.bands.values()) == pytest.approx(worst.worst_angle_deg)


def test_a_long_move_pays_little_for_short_moves_ringing() -> None:
    plain = plan_free_curve(NEMA23, pulses=10_000)
    local = plan_free_curve(NEMA23, pulses=10_000, load_angle_deg=AIM_DEG)
    shaping = local.extras["shaping"]
    assert not shaping.plain
    # only some bands made gentler, and the fast end untouched
    assert any(s == 1.0 for s in shaping.scale) and shaping.scale[-1] == 1.0
    assert local.duration_s <= 1.02 * plain.duration_s  # type: ignore[operator]

    def make(m: Motor, sh: Shaping | None = None) -> object:
        return plan(m, None, 127, 10_000, False, shaping=sh)

    uniform = tighten_uniform(NEMA23, make, AIM_DEG)  # type: ignore[arg-type]
    assert local.duration_s < uniform.duration_s  # type: ignore[operator]


@pytest.mark.parametrize("name", sorted(MOTORS))
def test_tightened_tables_are_within_the_aim_by_both_models(name: str) -> None:
    motor = MOTORS[name]
    table = plan_free_curve(motor, pulses=2000, load_angle_deg=AIM_DEG).table
    verdict = judge_safety(table, motor)
    assert verdict.safe and verdict.within_aim
    fast = worst_load_angle(table, motor)
    for n in sorted({fast.worst_pulses, 20, 2000}):
        assert worst_whole_move(table, motor, n) <= AIM_DEG + 0.1


def test_shaping_scales_capability_and_jump_band_by_band() -> None:
    from profiles.ppmc312.planner import choose_clock, make_problem

    clock = choose_clock(NEMA23)
    bands = Shaping.bands(NEMA23)
    shaping = bands.scaled({bands.band(5000.0): 0.5})
    plain = make_problem(NEMA23, clock, True)
    gentle = make_problem(NEMA23, clock, True, shaping)
    for f_slow, in_band in ((5000.0, True), (310.0, False)):  # the gentler band, another
        r_slow = np.array([round(clock.hz / f_slow)])
        r_fast = np.array([round(clock.hz / (f_slow + 100.0))])  # a step of 100 pps
        n0, d0, ok0 = plain.counts(r_slow, r_fast)
        n1, d1, ok1 = gentle.counts(r_slow, r_fast)
        assert ok0[0] and ok1[0]
        if in_band:  # half the torque share: about twice the accel pulses for the step
            # (decel less: friction, which helps it, is not scaled)
            assert n1[0] >= 2 * n0[0] - 1 > n0[0] and d1[0] > d0[0]
        else:
            assert n1[0] == n0[0] and d1[0] == d0[0]
    assert float(gentle.jump_at(5000.0)) == pytest.approx(0.5 * NEMA23.jump_pps)
    assert float(gentle.jump_at(300.0)) == pytest.approx(NEMA23.jump_pps)


def test_a_table_judged_again_is_remembered_for_equal_motors_only() -> None:
    """All-length verdicts are remembered by table and motor values (tightening judges a
    table and the verdict judges it again; a duty cycle tightens candidates whose tables
    coincide): an equal table on an equal motor loaded again is the same verdict, shared
    read-only, and so is one that only says where its values came from; another damping
    is judged anew; forgetting clears them; verdicts over given lengths are not kept."""
    from dataclasses import replace

    from profiles.ppmc312 import load_angle

    path = bundled_motor_paths()[0]
    motor = load_motor(path)
    table = plan_free_curve(motor, pulses=2000).table
    load_angle.forget_verdicts()
    first = angles(table, [motor])
    again = angles(type(table)(table.clock, table.rates, table.accel_pulses,
                               table.decel_pulses), [load_motor(path)])
    assert again is first and not first.deg.flags.writeable
    documented = replace(motor, sources={"inertia_kgm2": [{"value": 1.0, "from": "datasheet"}]})
    assert angles(table, [documented]) is first  # provenance is no physics
    other = angles(table, [replace(motor, damping_ratio=motor.damping_ratio * 2)])
    assert other is not first and other.deg.max() < first.deg.max()
    given = angles(table, [motor], pulses=[40, 400])
    assert given is not angles(table, [motor], pulses=[40, 400])
    load_angle.forget_verdicts()
    fresh = angles(table, [motor])
    assert fresh is not first
    np.testing.assert_array_equal(fresh.deg, first.deg)


def test_a_tightened_plan_says_where_and_binds_on_the_load_angle() -> None:
    """A plan the bands made gentler says which speed bands (and by how much), binds on
    the load angle, and carries its shaping; one the plain criterion already keeps
    within the aim says only its worst angle."""
    local = plan_free_curve(NEMA23, pulses=10_000, load_angle_deg=AIM_DEG)
    assert "tightened where it rings: " in local.info and "pps ×" in local.info
    assert local.binds == "load angle (tightened)"
    assert local.extras["worst_load_angle_deg"] <= AIM_DEG
    pk566 = load_motor(bundled_motor_paths()[2])  # its plain 10 000-pulse table: < 70°
    plain = plan_free_curve(pk566, pulses=10_000)
    easy = plan_free_curve(pk566, pulses=10_000, load_angle_deg=AIM_DEG)
    assert easy.extras["shaping"].plain and "tightened" not in easy.info
    assert easy.binds == plain.binds and "worst load angle" in easy.info


def test_no_plain_table_is_a_plan_error_not_a_gentler_search() -> None:
    """When the plain criterion has no table for the move, nothing gentler has one: the
    error is the planner's, said at once (never a search that ends without a plan)."""
    from profiles.errors import PlanError
    from profiles.ppmc312.planner.tightening import tighten

    calls: list[Shaping | None] = []

    def make(m: Motor, sh: Shaping | None = None) -> object:
        calls.append(sh)
        raise PlanError("no table for this move")

    with pytest.raises(PlanError, match="no table for this move"):
        tighten(NEMA23, make, AIM_DEG)  # type: ignore[arg-type]
    assert calls == [None]

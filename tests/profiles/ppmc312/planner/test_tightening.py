"""Tightening for the load angle where the rotor rings (profiles.ppmc312.planner.tightening):
the bands blamed are the ones whose speed steps drove the worst angles, a long move pays
little for short moves' ringing, and every table it returns is within the aim at every
move length, by the compiled model and by the plain-Python oracle."""

from __future__ import annotations

import numpy as np
import pytest

from profiles.errors import PlanError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.motor.angles import AIM_DEG
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.load_angle import angles, worst_load_angle
from profiles.ppmc312.planner import Shaping, plan, plan_free_curve
from profiles.ppmc312.planner.tightening import culprits, tighten_uniform
from tests.support.oracle_moves import whole_stop, worst_whole_move
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
    # only the last 0.75 natural periods before the worst angle: not the move's first
    # stages, nor its jump from rest
    assert min(blame.bands) > 0 and blame.start == 0.0


def test_a_move_exactly_at_the_aim_is_no_culprit() -> None:
    """Only executions past the aim are traced: one exactly at it blames nothing."""
    from profiles.ppmc312.load_angle import Angles

    table = plan_free_curve(NEMA23, pulses=10_000).table
    one = np.zeros(1, np.int64)
    at_aim = Angles(np.array([40]), np.array([[AIM_DEG]]), np.zeros((1, 1), bool), one,
                    one + 1)
    blame = culprits(table, [NEMA23], at_aim, AIM_DEG, Shaping.bands(NEMA23))
    assert blame.bands == {} and blame.start == 0.0
    past = Angles(at_aim.lengths, at_aim.deg + 1.0, at_aim.slipped, one, one + 1)
    assert culprits(table, [NEMA23], past, AIM_DEG, Shaping.bands(NEMA23)).bands


def test_a_long_move_pays_little_for_short_moves_ringing() -> None:
    """Tightened for the moves alone (decel stops are the next test's)."""
    plain = plan_free_curve(NEMA23, pulses=10_000)
    local = plan_free_curve(NEMA23, pulses=10_000, load_angle_deg=AIM_DEG, decel_stops=False)
    shaping = local.extras["shaping"]
    assert not shaping.plain
    # only some bands made gentler, and the fast end untouched
    assert any(s == 1.0 for s in shaping.scale) and shaping.scale[-1] == 1.0
    assert local.duration_s <= 1.02 * plain.duration_s  # type: ignore[operator]

    def make(m: Motor, sh: Shaping | None = None) -> object:
        return plan(m, None, 127, 10_000, False, shaping=sh)

    uniform = tighten_uniform(NEMA23, make, AIM_DEG, stops=False)  # type: ignore[arg-type]
    assert local.duration_s < uniform.duration_s  # type: ignore[operator]


def test_a_decel_stop_that_rings_is_tightened_where_it_rings() -> None:
    """The NEMA23's 10 000-pulse plan tightened for its moves alone rings past the aim
    on a decel stop (81) mid-ramp (about 86°, a few pulses into a stage); planned for
    the stops too, every move and every stop is within the aim, only some bands are made
    gentler (not the fast end), and the move pays at most 6 % over the moves-only plan
    (bench/bench_stops.py has the price per motor and length)."""
    from profiles.ppmc312.stops import stop_angles

    moves_only = plan_free_curve(NEMA23, pulses=10_000, load_angle_deg=AIM_DEG,
                                 decel_stops=False)
    rung = stop_angles(moves_only.table, [NEMA23]).worst(0)
    assert rung is not None and rung.worst_angle_deg > AIM_DEG + 5
    both = plan_free_curve(NEMA23, pulses=10_000, load_angle_deg=AIM_DEG)
    assert stop_angles(both.table, [NEMA23]).worst_deg() <= AIM_DEG
    assert angles(both.table, [NEMA23]).deg.max() <= AIM_DEG
    assert both.extras["worst_load_angle_deg"] <= AIM_DEG and "every decel stop" in both.info
    shaping = both.extras["shaping"]
    assert any(s < 1.0 for s in shaping.scale) and shaping.scale[-1] == 1.0
    assert both.duration_s <= 1.06 * moves_only.duration_s  # type: ignore[operator]


@pytest.mark.parametrize("name", sorted(MOTORS))
def test_tightened_tables_are_within_the_aim_by_both_models(name: str) -> None:
    """Every move and every decel stop (every pulse of the ramp, every reading) within the
    aim by the compiled model; the worst moves and the three worst stops by the oracle."""
    from profiles.ppmc312.stops import stop_angles

    motor = MOTORS[name]
    table = plan_free_curve(motor, pulses=2000, load_angle_deg=AIM_DEG).table
    verdict = judge_safety(table, motor)
    assert verdict.safe and verdict.within_aim
    assert verdict.to_json()["commands"]["decel-stop"]["within_aim"]
    fast = worst_load_angle(table, motor)
    for n in sorted({fast.worst_pulses, 20, 2000}):
        assert worst_whole_move(table, motor, n) <= AIM_DEG + 0.1
    stops = stop_angles(table, [motor])
    per_stop = stops.deg.max(axis=0)
    assert per_stop.max() <= AIM_DEG
    for e in np.argsort(per_stop)[::-1][:3].tolist():
        assert whole_stop(table, motor, int(stops.stage[e]), int(stops.dwell[e])) \
            <= AIM_DEG + 0.1


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
    shaping = local.extras["shaping"]
    gentler = sum(s < 1.0 for s in shaping.scale)
    assert 0 < gentler < len(shaping.scale)
    assert local.info.count(" pps ×") == gentler  # only the bands made gentler are named
    assert local.binds == "load angle (tightened)"
    assert "tolerance corners" not in local.info  # one motor, no box
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


# --- starting from a shaping (a duty cycle's later candidates) ------------------------------
def counting_make(pulses: int, calls: list[Shaping | None]) -> object:
    def make(m: Motor, sh: Shaping | None = None) -> object:
        calls.append(sh)
        return plan(m, None, 127, pulses, None, shaping=sh)
    return make


def test_a_start_within_the_aim_is_one_attempt_and_kept() -> None:
    """Where tightening ended for one move of a motor is where its other moves ring: from
    it, a move whose table it keeps within the aim takes one plan, not a search."""
    from profiles.ppmc312.planner.tightening import tighten

    first = plan_free_curve(NEMA23, pulses=31_623, load_angle_deg=AIM_DEG)
    start = first.extras["shaping"]
    assert not start.plain
    calls: list[Shaping | None] = []
    warm = tighten(NEMA23, counting_make(10_000, calls), AIM_DEG,  # type: ignore[arg-type]
                   start=start)
    assert calls == [start] and warm.extras["shaping"] == start
    assert warm.extras["worst_load_angle_deg"] <= AIM_DEG
    assert judge_safety(warm.table, NEMA23).within_aim
    cold: list[Shaping | None] = []
    tighten(NEMA23, counting_make(10_000, cold), AIM_DEG)  # type: ignore[arg-type]
    assert len(cold) > 1 and cold[0] is None  # from the plain criterion: a search


def test_a_start_past_the_aim_goes_on_tightening_from_there() -> None:
    from profiles.ppmc312.planner.tightening import tighten

    start = Shaping.bands(NEMA23).scaled({0: 0.99})  # all but plain: NEMA23 rings past 75°
    calls: list[Shaping | None] = []
    got = tighten(NEMA23, counting_make(10_000, calls), AIM_DEG,  # type: ignore[arg-type]
                  start=start)
    assert calls[0] == start and len(calls) > 1 and None not in calls
    assert all(s is not None and s.scale[0] <= 0.99 for s in calls)  # never back past it
    assert got.extras["worst_load_angle_deg"] <= AIM_DEG


def test_a_start_with_no_table_or_another_motors_bands_begins_plain() -> None:
    """A start too gentle for the move (no table fits it) begins again from the plain
    criterion; one from another motor's bands is not this motor's ringing: ignored.
    Both end where tightening from the plain criterion does."""
    from profiles.ppmc312.planner.tightening import tighten

    cold = plan_free_curve(NEMA23, pulses=300, load_angle_deg=AIM_DEG)
    edges = Shaping.bands(NEMA23).edges_pps
    too_gentle = Shaping(edges, (0.05,) * (len(edges) + 1), 0.05)
    other = Shaping.bands(MOTORS["pk566-5phase-half"]).scaled({2: 0.5})
    for start in (too_gentle, other):
        calls: list[Shaping | None] = []
        got = tighten(NEMA23, counting_make(300, calls), AIM_DEG,  # type: ignore[arg-type]
                      start=start)
        assert None in calls and calls[-1] != start
        assert got.table == cold.table


def test_a_duty_cycle_starts_later_candidates_where_the_first_ended() -> None:
    """plan --moves with a load-angle aim: the first candidate tightened from the plain
    criterion, the later ones from where it ended; every table within the aim, and
    never worse on the mix than the first tightened candidate's."""
    import profiles.ppmc312.planner.duty_cycle as dc

    starts: list[Shaping | None] = []
    real = dc.plan_free_curve

    def spy(motor: Motor, **kw: object) -> object:
        if kw.get("load_angle_deg") is not None:
            starts.append(kw.get("start_shaping"))  # type: ignore[arg-type]
        return real(motor, **kw)  # type: ignore[arg-type]

    mix = [(300, 4.0), (2_000, 3.0), (10_000, 2.0), (100_000, 1.0)]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(dc, "plan_free_curve", spy)
        got, times = dc.plan_duty_cycle(NEMA23, mix, load_angle_deg=AIM_DEG)
    assert len(starts) >= 2 and starts[0] is None
    assert all(s is not None and not s.plain for s in starts[1:])
    assert judge_safety(got.table, NEMA23).within_aim
    assert got.duration_s == pytest.approx(sum(w * times[n] for n, w in mix), rel=1e-12)

    def on_mix(table: object) -> float:
        return sum(w * simulate_move(table, n).duration_s for n, w in mix)  # type: ignore[arg-type]

    # the first tightened: the candidate whose plain table is best on the mix
    first = min(got.extras["candidates"], key=lambda t: on_mix(real(NEMA23, pulses=t).table))
    tightened = real(NEMA23, pulses=first, load_angle_deg=AIM_DEG)
    assert got.duration_s <= on_mix(tightened.table) * (1 + 1e-12)


def test_the_fastest_plan_within_the_aim_is_kept() -> None:
    """Of the plans tried, the fastest within the aim; none within it: the one with the
    smallest worst angle, marked as not reaching the aim."""
    from dataclasses import replace

    from profiles.ppmc312.planner.tightening import _best

    base = plan_free_curve(MOTORS["pk566-5phase-half"], pulses=2_000)
    tried = [replace(base, duration_s=d, extras={"worst_load_angle_deg": w})
             for d, w in ((0.30, 74.0), (0.20, 80.0), (0.25, 70.0), (0.40, 60.0))]
    assert _best(tried, AIM_DEG) is tried[2]
    past = _best(tried, 55.0)
    assert past.duration_s == 0.40 and "aim ≤ 55° not reached" in past.info
    with pytest.raises(PlanError, match="below 90°"):  # the peak itself is not below it
        _best([replace(base, extras={"worst_load_angle_deg": 90.0})], AIM_DEG)


def test_uniform_tightening_steps_down_then_bisects_back(monkeypatch: pytest.MonkeyPatch
                                                         ) -> None:
    """The whole table × 0.85 a round until within the aim, then two bisections back
    towards the last scale past it; a plain table within the aim is kept at once."""
    import types

    from profiles.ppmc312.planner import tightening

    base = plan_free_curve(MOTORS["pk566-5phase-half"], pulses=2_000)
    asked: list[Shaping | None] = []
    worst = iter([90.0, 80.0, 70.0, 74.0, 76.0])

    def make(m: Motor, sh: Shaping | None = None) -> object:
        asked.append(sh)
        return base

    monkeypatch.setattr(tightening, "angles", lambda table, judges, **kw: types.SimpleNamespace(
        deg=np.array([next(worst)]), refined=True))
    got = tighten_uniform(NEMA23, make, AIM_DEG, stops=False)  # type: ignore[arg-type]
    scales = [1.0 if s is None else s.scale[0] for s in asked]
    mid = (0.7225 + 0.85) / 2
    judged_scales = [1.0, 0.85, 0.7225, mid, (mid + 0.85) / 2]
    # the descent makes its next step's plan on a side thread while it judges this one,
    # so the calls come in any order, and the step after the last may be made and dropped
    made = [x for x in scales if not any(x == pytest.approx(e) for e in judged_scales)]
    assert all(any(x == pytest.approx(e) for x in scales) for e in judged_scales), scales
    assert all(x == pytest.approx(0.7225 * 0.85) for x in made), scales
    shaping = got.extras["shaping"]
    assert shaping == Shaping.uniform(shaping.scale[0])  # uniform, and
    assert shaping.scale[0] == pytest.approx(mid)  # the last within the aim
    assert got.extras["plans"] == 5
    worst = iter([60.0])
    asked.clear()
    kept = tighten_uniform(NEMA23, make, AIM_DEG, stops=False)  # type: ignore[arg-type]
    assert asked == [None] and kept.extras["shaping"].plain and kept.extras["plans"] == 1


def test_a_relax_step_past_the_aim_where_its_bound_was_worst_skips_the_full_verdict(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A relax step only asks whether its plan is within the aim: judged first at the move
    lengths where the last shaping past the aim was worst, a plan past the aim there is
    refused without the all-length verdict, and tightening ends on the same table as
    when every step is judged at every length."""
    from dataclasses import replace

    from profiles.ppmc312.load_angle import forget_verdicts
    from profiles.ppmc312.planner import tightening
    from profiles.ppmc312.planner.free_curve import forget_plans

    motor = replace(NEMA23, safety_factor=round(NEMA23.safety_factor * 0.9, 3))
    calls: list[str] = []

    def counted(table: object, judges: object, **kw: object) -> object:
        calls.append("screen" if kw.get("pulses") is not None else
                     "full" if kw.get("aim_deg") is not None else "kept")
        return angles(table, judges, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(tightening, "angles", counted)
    forget_plans(), forget_verdicts()
    screened = plan_free_curve(motor, pulses=15_000, load_angle_deg=AIM_DEG)
    full_screened = calls.count("full")
    calls.clear()
    monkeypatch.setattr(tightening, "SCREEN", 0)  # no lengths to screen: every step judged
    forget_plans(), forget_verdicts()
    judged = plan_free_curve(motor, pulses=15_000, load_angle_deg=AIM_DEG)
    assert calls.count("screen") == 0
    assert full_screened < calls.count("full")  # a relax step was refused by its screen
    assert screened.table == judged.table and screened.extras["shaping"] == \
        judged.extras["shaping"]
    assert screened.extras["worst_load_angle_deg"] == judged.extras["worst_load_angle_deg"]
    # as many plans either way: judged at every length, one verdict each (and the one
    # kept judged whole, when its samples were enough to say it is within the aim)
    assert screened.extras["plans"] == judged.extras["plans"] == calls.count("full")
    assert calls.count("kept") <= 1


class _Scripted:
    """Stand-ins for a tightening run: `make` plans the same table, faster the less its
    band 3 is scaled, and `angles` answers the next worst angle of `full` (every length)
    or `screen` (a relax step's lengths)."""

    def __init__(self, full: list[float], screen: list[float]) -> None:
        self.base = plan_free_curve(MOTORS["pk566-5phase-half"], pulses=2_000)
        self.full, self.screen = iter(full), iter(screen)
        self.asked: list[Shaping | None] = []

    def make(self, m: Motor, sh: Shaping | None = None) -> object:
        from dataclasses import replace

        self.asked.append(sh)
        return replace(self.base, duration_s=1.0 / (sh.scale[3] if sh else 1.0))

    def angles(self, table: object, judges: object, **kw: object) -> object:
        from profiles.ppmc312.load_angle import Angles

        deg = next(self.screen if kw.get("pulses") is not None else self.full)
        one = np.zeros(1, np.int64)
        return Angles(np.array([20]), np.array([[deg]]), np.zeros((1, 1), bool), one, one + 1)


def _scripted(monkeypatch: pytest.MonkeyPatch, full: list[float], screen: list[float]
              ) -> tuple[_Scripted, object]:
    from profiles.ppmc312.planner import tightening

    s = _Scripted(full, screen)
    blame = tightening.Blame()
    blame.add(3, 80.0)
    monkeypatch.setattr(tightening, "angles", s.angles)
    monkeypatch.setattr(tightening, "culprits", lambda *a: blame)
    return s, tightening.tighten(NEMA23, s.make, AIM_DEG, stops=False)  # type: ignore[arg-type]


def test_within_the_aim_with_room_two_bisections_go_back_towards_the_last_past_it(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Plain past the aim (80°), band 3 × 75/80 within it with room (70°): halfway back
    (74°: kept), then halfway again, refused at its screen (76°); the fastest within the
    aim is the first bisection, after four plans."""
    s, got = _scripted(monkeypatch, full=[80.0, 70.0, 74.0], screen=[74.0, 76.0])
    first = AIM_DEG / 80.0
    scale3 = [1.0 if sh is None else sh.scale[3] for sh in s.asked]
    assert scale3 == pytest.approx([1.0, first, first ** 0.5, first ** 0.25])
    assert got.extras["shaping"] == s.asked[2] and got.extras["plans"] == 4  # type: ignore[attr-defined]


def test_just_within_the_aim_is_kept_without_bisecting(monkeypatch: pytest.MonkeyPatch
                                                       ) -> None:
    """Within the aim by less than RELAX_ROOM_DEG: nothing to gain back, no more plans."""
    s, got = _scripted(monkeypatch, full=[80.0, AIM_DEG - 1.0], screen=[])
    assert len(s.asked) == 2 and got.extras["plans"] == 2  # type: ignore[attr-defined]


def test_uniform_tightening_takes_eight_rounds_and_refuses_a_motor_with_no_table(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Eight rounds of × 0.85 before giving up (then two bisections back, here both past
    the aim); no table at all is the planner's refusal."""
    import types

    from profiles.errors import PlanError
    from profiles.ppmc312.planner import tightening

    base = plan_free_curve(MOTORS["pk566-5phase-half"], pulses=2_000)
    worst = iter([89.0] * 7 + [70.0, 80.0, 80.0])
    monkeypatch.setattr(tightening, "angles", lambda table, judges, **kw: types.SimpleNamespace(
        deg=np.array([next(worst)]), refined=True))
    got = tighten_uniform(NEMA23, lambda m, sh=None: base, AIM_DEG,  # type: ignore[arg-type]
                          stops=False)
    assert got.extras["shaping"].scale[0] == pytest.approx(0.85 ** 7)
    assert got.extras["plans"] == 10

    def none(m: Motor, sh: Shaping | None = None) -> object:
        raise PlanError("no table")

    with pytest.raises(PlanError, match="no table"):
        tighten_uniform(NEMA23, none, AIM_DEG)  # type: ignore[arg-type]


FAST_START = Motor(  # a datasheet motor that starts fast (issue 32's 17HS19-like NEMA17)
    steps_per_rev=1600,
    curve_speed_pps=np.array([0.0, 11464.0, 12335.0, 13308.0, 14390.0, 15601.0, 16968.0,
                              18520.0, 20282.0, 22303.0, 24636.0, 27215.0]),
    curve_torque_nm=np.array([0.4425, 0.441, 0.3904, 0.342, 0.2953, 0.2506, 0.2075, 0.1663,
                              0.1269, 0.0893, 0.0535, 0.0216]),
    inertia_kgm2=1.468e-5, safety_factor=0.6, start_pps=5546.0, friction_torque_nm=0.0438,
    holding_torque_nm=0.59)


def test_ringing_after_the_stop_to_rest_is_blamed_on_the_start_speed() -> None:
    """A motor that starts fast rings worst after a short move's last pulse, where the
    command drops from its slowest stage to rest, a jump the start speed sets: the start
    is blamed (before, only the jump from rest was, and the band rounds lowered the slow
    band eight times in vain, then tightened the whole table alike), and the band rounds
    end within the aim, faster than the whole table tightened alike."""
    table = plan_free_curve(FAST_START, pulses=10_000).table
    found = angles(table, [FAST_START])
    worst = found.worst(0)
    assert worst.worst_angle_deg > AIM_DEG
    blame = culprits(table, [FAST_START], found, AIM_DEG, Shaping.bands(FAST_START))
    assert blame.start == pytest.approx(worst.worst_angle_deg)
    local = plan_free_curve(FAST_START, pulses=10_000, load_angle_deg=AIM_DEG)
    shaping = local.extras["shaping"]
    assert shaping.edges_pps and shaping.start_scale < 1.0  # the bands', not uniform
    assert local.extras["worst_load_angle_deg"] <= AIM_DEG
    uniform = tighten_uniform(FAST_START, lambda m, s: plan(m, None, 127, 10_000, None,
                                                           shaping=s), AIM_DEG)
    assert local.duration_s <= uniform.duration_s
    assert judge_safety(local.table, FAST_START, aim_deg=AIM_DEG).safe


def test_one_round_blames_every_band_that_rings(monkeypatch: pytest.MonkeyPatch) -> None:
    """The NEMA23's plain table at 11 000 pulses rings past the aim in eight speed bands,
    its worst six executions in four of them: blamed with the worst of each other band
    that rings 10 % past the aim too, one round reaches the aim (3 plans: plain,
    tightened, a relax step); the worst six alone surfaced the bands one by one (7
    plans) for a slower table."""
    from dataclasses import replace

    from profiles.ppmc312.load_angle import forget_verdicts
    from profiles.ppmc312.planner import tightening
    from profiles.ppmc312.planner.free_curve import forget_plans

    motor = replace(NEMA23, safety_factor=round(NEMA23.safety_factor * 0.98, 3))
    got = {}
    default = tightening.BAND_CULPRITS
    for band_culprits in (default, 0):
        monkeypatch.setattr(tightening, "BAND_CULPRITS", band_culprits)
        forget_plans(), forget_verdicts()
        got[band_culprits] = plan_free_curve(motor, pulses=11_000, load_angle_deg=AIM_DEG)
    diverse, worst_only = got[default], got[0]
    assert diverse.extras["worst_load_angle_deg"] <= AIM_DEG
    assert diverse.extras["plans"] <= 4 < worst_only.extras["plans"]
    assert diverse.duration_s <= worst_only.duration_s


def test_judged_by_samples_until_kept_the_same_table_as_judged_whole(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A tightening round whose samples already say within or past the aim is judged no
    further; the plan kept is judged whole. The table, its shaping and its worst angle
    are those of a tightening that judges every plan whole, and the worst is the whole
    verdict's."""
    from dataclasses import replace

    from profiles.ppmc312.load_angle import forget_verdicts
    from profiles.ppmc312.planner import tightening
    from profiles.ppmc312.planner.free_curve import forget_plans
    from profiles.ppmc312.planner.tightening import judged

    motor = replace(NEMA23, safety_factor=round(NEMA23.safety_factor * 0.98, 3))
    forget_plans(), forget_verdicts()
    lazy = plan_free_curve(motor, pulses=11_000, load_angle_deg=AIM_DEG)
    assert lazy.extras["worst_load_angle_deg"] == judged(lazy.table, [motor]).worst()
    whole: list[object] = []

    def every(table: object, judges: object, **kw: object) -> object:
        whole.append(kw.pop("aim_deg", None))
        return angles(table, judges, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(tightening, "angles", every)
    forget_plans(), forget_verdicts()
    eager = plan_free_curve(motor, pulses=11_000, load_angle_deg=AIM_DEG)
    assert AIM_DEG in whole  # the rounds asked with their aim, and were judged whole
    assert lazy.table == eager.table and lazy.extras["shaping"] == eager.extras["shaping"]
    assert lazy.extras["worst_load_angle_deg"] == eager.extras["worst_load_angle_deg"]
    assert lazy.extras["plans"] == eager.extras["plans"] > 2

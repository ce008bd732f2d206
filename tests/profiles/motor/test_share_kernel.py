"""Executions judged through the reference's states: the verdict integrates each move
only from where its command parts from the longest one (the reference) until its state
rejoins the reference's on their common decel tail, and takes the reference's worst for
the rest. Every length of a few tables, judged together, against each move integrated
whole by the plain-Python oracle: a shared prefix taken one span too short or too long,
a tail matched against the wrong segment, or the reference's worst taken from the wrong
span after the rejoin changes some length's worst angle. Small enough to run with the
kernels as plain Python (the kernel's mutation run)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.motor import Motor
from profiles.motor.batch import MoveBatch
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.load_angle import angles, worst_load_angle
from profiles.ppmc312.move_batch import moves
from profiles.ppmc312.table import FreeCurveTable
from tests.support.oracle_moves import kernel_step_counts, whole_move

MHZ1 = Clock.internal("1MHz")


AGREE_DEG = 0.1


def motor(**kw: object) -> Motor:
    """A NEMA17 at 1/8 step, lightly damped so that the ringing of one stage reaches
    the next (the reference's worst lies in different spans than a short move's)."""
    args: dict[str, object] = dict(
        steps_per_rev=1600, curve_speed_pps=np.array([0.0, 2000.0, 8000.0, 48000.0]),
        curve_torque_nm=np.array([0.4, 0.4, 0.32, 0.04]), inertia_kgm2=6.8e-6,
        safety_factor=0.6, start_pps=800.0, damping_ratio=0.15)
    args.update(kw)
    return Motor(**args)  # type: ignore[arg-type]


@pytest.mark.parametrize("table, m", [
    # LE=0: every trapezoid shares the whole decel side with the reference
    (FreeCurveTable(MHZ1, (150, 220, 330, 500, 750), (4, 4, 3, 3, 2)), motor()),
    # LE=1 under a load: decel tails differ from the accel side, both directions
    (FreeCurveTable(MHZ1, (150, 220, 330, 500, 750), (4, 4, 3, 3, 2), (2, 3, 5, 4, 3)),
     motor(load_torque_nm=0.04, friction_torque_nm=0.01)),
    # a fast start and stop under a load: the ringing after the last pulse is the worst
    # of some moves in one direction
    (FreeCurveTable(MHZ1, (120, 160, 210), (3, 3, 2), (2, 2, 3)),
     motor(load_torque_nm=0.08, damping_ratio=0.1)),
], ids=["LE0", "LE1-loaded", "fast-stop"])
def test_every_length_judged_together_is_the_oracles_whole_move(
        table: FreeCurveTable, m: Motor) -> None:
    """Each length's worst angle in each direction is the oracle's whole move's, and the
    shared prefixes and tails do save work: the batch takes under half the RK4 steps of
    its moves integrated whole (a rejoin that never happens would still give the right
    angles, slowly)."""
    top = table.accel_total + table.decel_total
    lengths = list(range(1, top + 12))  # every triangle, then trapezoids with a cruise
    with kernel_step_counts() as steps:
        found = angles(table, [m], pulses=lengths)
    assert not found.slipped.any()
    assert found.direction.tolist() == ([1, -1] if m.load_torque_nm else [1])
    whole_steps = 0
    for row, direction in enumerate(found.direction.tolist()):
        for e, n in enumerate(lengths):
            worst, used = whole_move(table, m, n, direction)
            whole_steps += used
            assert found.deg[row, e] == pytest.approx(worst, abs=AGREE_DEG), (direction, n)
    assert len(steps) == 1 and steps[0].sum() < whole_steps / 2


def test_long_moves_share_the_longest_cruise_and_rejoin_after_it() -> None:
    """Trapezoids whose cruise settles: the longest is the reference, its dwell at the top
    rate (top stage, cruise, top decel stage: one rate) cut where the shorter ones' end,
    so each shorter one starts its decel from the reference's state at the end of its
    own dwell, settled as the reference's is where their commands meet again: it joins
    the reference there without a step, whatever the slower decel stages (two tables
    that differ only there), and every worst angle is still the oracle's whole move's."""
    accel = (4, 4, 3, 3, 2)
    m = motor(damping_ratio=0.5, load_torque_nm=0.04)
    used = {}
    for decel in ((2, 3, 5, 4, 3), (2, 5, 2, 6, 4)):  # the same fastest decel stage
        table = FreeCurveTable(MHZ1, (150, 220, 330, 500, 750), accel, decel)
        top = table.accel_total + table.decel_total
        lengths = [top + 400, top + 700, top + 1500]
        with kernel_step_counts() as steps:
            found = angles(table, [m], pulses=lengths)
        assert not found.slipped.any()  # a rejoin is no slip
        for row, direction in enumerate(found.direction.tolist()):
            for e, n in enumerate(lengths):
                worst, _ = whole_move(table, m, n, direction)
                assert found.deg[row, e] == pytest.approx(worst, abs=AGREE_DEG), (direction, n)
        used[decel] = steps[0]
    first, second = used.values()
    assert (first[:, :2] == 0).all() and (second[:, :2] == 0).all()  # the shorter moves
    assert (first[:, 2] > 0).all() and not np.array_equal(first[:, 2], second[:, 2])


def test_a_short_cruise_integrates_its_decel_until_it_rejoins() -> None:
    """Trapezoids with cruises too short to settle start their decel from the reference's
    state at the end of their own cruise (none of it integrated) and integrate only
    their decel, each the oracle's whole move's worst angle."""
    table = FreeCurveTable(MHZ1, (150, 220, 330, 500, 750), (4, 4, 3, 3, 2), (2, 3, 5, 4, 3))
    m = motor()
    top = table.accel_total + table.decel_total
    lengths = [top + 3, top + 9, top + 20, top + 2000]
    with kernel_step_counts() as steps:
        found = angles(table, [m], pulses=lengths)
    for e, n in enumerate(lengths):
        worst, whole = whole_move(table, m, n, 1)
        assert found.deg[0, e] == pytest.approx(worst, abs=AGREE_DEG), n
        if e < 3:  # its cruise's steps saved: at most its decel's and rest's
            assert 0 < steps[0][0, e] < whole


def _follow(m: Motor, spans: np.ndarray, lag0: float, kb: np.ndarray,
            ref: tuple[np.ndarray, np.ndarray, np.ndarray], bound: float
            ) -> tuple[int, int, bool, np.ndarray]:
    """follow_spans over `spans` (the last one at rest) from a lag of `lag0` against the
    reference's boundary states and worst from each span on (`ref`): (steps, the
    boundary it stopped at or −1, slipped, per span done its worst, end lag and rate)."""
    from profiles.motor import rotor_kernel as rk
    from profiles.motor.rotor import MAX_SETTLE_PERIODS, SETTLE_TOL_DEG, SLIP_DEG, rotor_of

    rotor = rotor_of(m)
    out = np.zeros((3, len(spans)))
    nothing = np.empty(0)
    done, status, slipped, _, steps, stop, _ = rk.follow_spans(
        *rotor.curve(), rotor.row(), spans[:, 0].copy(), spans[:, 1].copy(), lag0, 0.0, 0.0,
        0.0, rotor.step_s(), np.radians(SLIP_DEG) / rotor.c_e,
        np.radians(SETTLE_TOL_DEG) / rotor.c_e, MAX_SETTLE_PERIODS, 10**7, kb, ref[0],
        ref[1], 0.0, 0.0, out[0], out[1], out[2], False, nothing, nothing, True, ref[2], 0.0,
        bound)
    assert status == rk.OK
    return steps, stop, bool(slipped), out[:, :done]


def test_a_tail_stops_where_what_it_has_seen_bounds_the_rest() -> None:
    """Two runs of one staircase (up in steps, a jump that rings most, down in steps,
    then rest), the reference from rest and the other from a lag of 0.6 pulses (its
    worst at first): with a bound, the other stops at
    the first boundary where its worst so far is at least the reference's worst from
    there on plus 3× the amplitude of their difference (at the natural frequency of the
    command speed); its worst is then exactly its whole run's, in fewer steps. Without
    a bound it runs to the end."""
    from profiles.motor import rotor_kernel as rk
    from profiles.motor.rotor import rotor_of

    m = motor(damping_ratio=0.3)
    spans = np.array([(0.004, 1000.0), (0.002, 1500.0), (0.002, 2000.0), (0.003, 6000.0),
                      *[(0.002, v) for v in (5000.0, 4000.0, 3000.0, 2000.0, 1000.0)],
                      (0.5, 0.0)])
    n = len(spans)
    no_kb = np.full(n, -1, np.int64)
    _, _, _, (ref_max, ref_lag, ref_s) = _follow(m, spans, 0.0, no_kb, (
        np.zeros(1), np.zeros(1), np.zeros(1)), 0.0)
    suffix = np.append(np.maximum.accumulate(ref_max[::-1])[::-1], 0.0)
    ref = (ref_lag, ref_s, suffix)
    kb = np.append(np.arange(n - 1), -1)  # the rest after the last pulse is no boundary
    whole_steps, whole_stop, _, whole = _follow(m, spans, 0.6, kb, ref, 0.0)
    assert whole_stop == -1 and whole.shape[1] == n
    steps, stop, slipped, seen = _follow(m, spans, 0.6, kb, ref, rk.BOUND)
    assert not slipped  # a stop is no slip
    assert stop == 3 and seen.shape[1] == stop + 1 and steps < whole_steps / 2  # the jump
    np.testing.assert_array_equal(seen, whole[:, :stop + 1])
    assert max(seen[0].max(), suffix[stop + 1]) == whole[0].max()  # exact
    rotor = rotor_of(m)
    worst = np.maximum.accumulate(whole[0])
    for i in range(stop + 1):  # it stops at the first boundary the rule allows
        amp = rk._amplitude(*rotor.curve(), rotor.row(), spans[i, 1],
                            whole[1, i] - ref_lag[i], whole[2, i] - ref_s[i])
        assert (worst[i] >= suffix[i + 1] + rk.BOUND * amp) == (i == stop), i


def _joined(runs: list[tuple[str, int, int]]) -> list[tuple[int, int]]:
    """A move's segments as (rate, pulses), neighbours of one rate joined."""
    out: list[tuple[int, int]] = []
    for _, rate, c in runs:
        if out and out[-1][0] == rate:
            out[-1] = (rate, out[-1][1] + c)
        else:
            out.append((rate, c))
    return out


@pytest.mark.parametrize("decel", [(2, 3, 5), None], ids=["LE1", "LE0"])
def test_families_cut_alike_are_prefixes_of_their_source(decel: tuple[int, ...] | None
                                                         ) -> None:
    """`dwells` then `shared_dwells` over every length up to a few trapezoids: every move
    keeps its pulses and its rates in order (joining its pieces gives its joined
    segments back); a move that parts from its source (the longest member of its
    family, or the reference for −1) at the source's rate, for another count (a family
    member: the triangles peaking at one stage, the trapezoids), has its pieces up to
    the end of that dwell equal to its source's first ones, so it starts from its
    source's state there. The reference is the longest trapezoid."""
    from profiles.motor.batch_angle import dwells, shared_dwells

    table = FreeCurveTable(MHZ1, (150, 220, 330), (4, 3, 2), decel)
    top = table.accel_total + table.decel_total
    lengths = np.array([*range(1, top + 1), top + 1, top + 7, top + 30, top + 31, top + 100])
    runs = dwells(moves(table, lengths))
    ref = int(np.lexsort((runs.pulses, np.diff(runs.offsets)))[-1])
    assert lengths[ref] == top + 100
    cut, source = shared_dwells(runs, ref)
    assert (source != np.arange(len(lengths))).all() and source[ref] == -1
    heads = set(source.tolist())  # a family's longest is the source of the others
    members = 0
    for e, n in enumerate(lengths.tolist()):
        mine = [(r, c) for _, r, c in cut.runs(e)]
        assert sum(c for _, c in mine) == n
        assert _joined(cut.runs(e)) == _joined(runs.runs(e))
        other = ref if source[e] < 0 else int(source[e])
        if e == other or e in heads:
            continue
        j_mine, j_theirs = _joined(runs.runs(e)), _joined(runs.runs(other))
        j = 0
        while j < min(len(j_mine), len(j_theirs)) and j_mine[j] == j_theirs[j]:
            j += 1
        if j == len(j_mine) or j == len(j_theirs) or j_mine[j][0] != j_theirs[j][0]:
            continue  # it parts at another rate (or not at all): nothing cut for it
        upto = sum(c for _, c in j_mine[:j + 1])  # the end of its dwell
        k = int(np.searchsorted(np.cumsum([c for _, c in mine]), upto)) + 1
        theirs = [(r, c) for _, r, c in cut.runs(other)]
        assert mine[:k] == theirs[:k], n
        members += 1
    assert members >= len(lengths) // 3


def test_only_moves_that_part_at_the_references_rate_are_cut() -> None:
    """A hand-made batch: the reference R (accel 300·2, 200·3; a dwell at 100 of 50;
    decel 200·3, 300·2), a shorter trapezoid T (dwell 20), a move P that is R's first
    two segments exactly, then moves F and G that start at 100 (50 and 30 pulses) where
    R starts at 300. R is T's source, its dwell cut where T's ends. P ends on R's
    segments: it parts nowhere, is in no family, and does not keep R from being T's
    source (a comparison running past its last segment would read F's, R's dwell
    exactly). F and G part from R at another rate: no family, not cut, though their
    first segments alone would make one."""
    from profiles.motor.batch import PHASES
    from profiles.motor.batch_angle import shared_dwells

    a, c, d = (PHASES.index(p) for p in ("accel", "cruise", "decel"))
    moves_ = [[(a, 300, 2), (a, 200, 3), (c, 100, 50), (d, 200, 3), (d, 300, 2)],  # R
              [(a, 300, 2), (a, 200, 3), (c, 100, 20), (d, 200, 3), (d, 300, 2)],  # T
              [(a, 300, 2), (a, 200, 3)],                                          # P
              [(c, 100, 50), (d, 300, 1)],                                         # F
              [(c, 100, 30), (d, 300, 1)],                                         # G
              [(d, 300, 1)]]
    segs = [s for m in moves_ for s in m]
    runs = MoveBatch(np.array([sum(x[2] for x in m) for m in moves_]),
                     np.zeros(len(moves_), np.int64), np.array([x[0] for x in segs], np.int8),
                     np.array([x[1] for x in segs], np.int64),
                     np.array([x[2] for x in segs], np.int64),
                     np.concatenate(([0], np.cumsum([len(m) for m in moves_]))).astype(np.int64))
    cut, source = shared_dwells(runs, 0)
    assert (source == -1).all()
    assert [(r, n) for _, r, n in cut.runs(0)] == [
        (300, 2), (200, 3), (100, 20), (100, 30), (200, 3), (300, 2)]
    for e in range(1, len(moves_)):
        assert cut.runs(e) == runs.runs(e), e


def test_thousands_of_trapezoids_are_not_cut_alike() -> None:
    """k trapezoids cut where every shorter one ends make ~k²/2 pieces: past
    SHARED_PIECES (a motor with no torque at the cruise samples 200 000 cruise
    lengths) the batch is judged as it is, never allocated quadratically."""
    from profiles.motor.batch_angle import SHARED_PIECES, dwells, shared_dwells

    table = FreeCurveTable(MHZ1, (150, 220, 330), (4, 3, 2))
    top = table.accel_total + table.decel_total
    many = int(np.sqrt(2 * SHARED_PIECES)) + 2
    runs = dwells(moves(table, np.arange(top + 1, top + 1 + many)))
    cut, source = shared_dwells(runs, many - 1)
    assert np.array_equal(cut.count, runs.count) and (source == -1).all()
    few = dwells(moves(table, np.arange(top + 1, top + 1 + 20)))
    cut, source = shared_dwells(few, 19)
    # the longest's dwell in 20 pieces, the others' in 1..19: 20·21/2 pieces for 20
    assert len(cut.rate) == len(few.rate) + 20 * 21 // 2 - 20 and (source == -1).all()


def _random_table(data: st.DataObject, most_stages: int, most_pulses: int
                  ) -> FreeCurveTable:
    """A random table at 1 MHz: LE=0 or LE=1, uneven counts."""
    n = data.draw(st.integers(2, most_stages))
    rates = sorted(data.draw(st.lists(st.integers(120, 900), min_size=n, max_size=n,
                                      unique=True)))
    accel = tuple(data.draw(st.lists(st.integers(1, most_pulses), min_size=n, max_size=n)))
    decel = data.draw(st.none() | st.lists(st.integers(1, most_pulses), min_size=n,
                                           max_size=n))
    return FreeCurveTable(MHZ1, tuple(rates), accel, None if decel is None else tuple(decel))


@settings(max_examples=25, deadline=None)
@given(st.data())
def test_a_family_starting_from_its_source_is_judged_as_alone(data: st.DataObject) -> None:
    """Every sampled length of random tables: judged with each family member starting
    from its source's state, the worst angles and slips are bit for bit those of each
    integrating its own dwell from the reference's state (the same spans, the same
    steps), in no more RK4 steps."""
    from profiles.motor.batch_angle import judge
    from profiles.motor.rotor import Rotors, rotors
    from profiles.ppmc312.load_angle import directions, samples

    table = _random_table(data, 6, 30)
    m = motor(load_torque_nm=data.draw(st.sampled_from([0.0, 0.05])),
              damping_ratio=data.draw(st.sampled_from([0.05, 0.2, 0.6])))
    lengths, _, _ = samples(table, [m])
    rot = Rotors.stack([rotors(m, direction=d) for d in directions(m)])
    runs = moves(table, lengths)
    with kernel_step_counts() as shared:
        together = judge(runs, MHZ1.hz, rot)
    with kernel_step_counts() as alone:
        apart = judge(runs, MHZ1.hz, rot, families=False)
    np.testing.assert_array_equal(together[0], apart[0])
    np.testing.assert_array_equal(together[1], apart[1])
    assert shared[0].sum() <= alone[0].sum()


@settings(max_examples=60, deadline=None)
@given(st.data())
def test_cutting_never_takes_a_shared_prefix_away(data: st.DataObject) -> None:
    """Every move of random tables up to a few trapezoids, joined and cut: each shares at
    least the pulses with its source that it shared with the reference before the cut
    (cutting the reference's stage for a triangle family once made the trapezoids,
    which run that stage whole, part from it there: 10× the steps)."""
    from profiles.motor.batch_angle import dwells, shared_dwells

    table = _random_table(data, 12, 40)
    top = table.accel_total + table.decel_total
    lengths = np.unique(np.concatenate((
        data.draw(st.lists(st.integers(1, top + 50), min_size=1, max_size=80)),
        [top + 60])))
    joined = dwells(moves(table, lengths))
    ref = int(np.lexsort((joined.pulses, np.diff(joined.offsets)))[-1])
    cut, source = shared_dwells(joined, ref)
    for e in range(len(lengths)):
        before = _prefix_pulses(joined, e, ref)
        assert _prefix_pulses(cut, e, ref if source[e] < 0 else int(source[e])) >= before, e


def _prefix_pulses(runs: MoveBatch, e: int, other: int) -> int:
    """The pulses of the segments move e runs exactly as move `other` does, from the start."""
    shared = 0
    for mine, theirs in zip(runs.runs(e), runs.runs(other), strict=False):
        if mine[1:] != theirs[1:]:
            break
        shared += mine[2]
    return shared


def test_a_cruise_where_the_motor_has_no_torque_slips() -> None:
    """A table cruising at 20 kpps on a motor whose curve ends at 4 kpps: the rotor
    cannot hold the command there, and the verdict says it slips (a finding: exit 1),
    judging the cruise up to a few periods at rest (the settled-cruise rule has no
    period to go by where the motor has no stiffness; it once sampled a second of
    cruise, 200 000 lengths, and was refused by the step budget)."""
    from verify.safety import judge_safety

    weak = Motor(steps_per_rev=200, curve_speed_pps=np.array([0.0, 4000.0]),
                 curve_torque_nm=np.array([0.1, 0.1]), inertia_kgm2=2e-6, safety_factor=0.6,
                 start_pps=100.0, damping_ratio=1.0)
    table = FreeCurveTable(MHZ1, (50, 5000), (2, 2))
    found = worst_load_angle(table, weak)
    assert found.slipped and found.worst_angle_deg >= 180.0
    assert found.first_unstable_pulses is not None
    verdict = judge_safety(table, weak)
    assert not verdict.safe and verdict.load_angle is not None and verdict.load_angle.slips


def test_moves_of_one_triangle_family_judged_together_are_the_oracles() -> None:
    """Triangles only (no trapezoid: the reference is a triangle too, and the others have
    as many segments as it, differing only in their partial stages' pulses): each is
    integrated from where it parts from the reference, never taken for it."""
    table = FreeCurveTable(MHZ1, (150, 220, 330, 500, 750), (4, 4, 3, 3, 2))
    m = motor()
    lengths = list(range(20, 31))  # below the 32 pulses of both sides: triangles
    found = angles(table, [m], pulses=lengths)
    worst = [whole_move(table, m, n)[0] for n in lengths]
    np.testing.assert_allclose(found.deg[0], worst, atol=AGREE_DEG)
    assert len(set(np.round(worst, 1))) > 3  # the family's moves do differ


def test_a_rejoin_needs_the_references_lag_and_rate_and_counts_its_span() -> None:
    """At the first boundary, an execution whose state is the reference's rejoins there
    (that span done and its worst kept); one at the reference's lag but moving the other
    way does not (the rates differ by twice the rate), nor does a bound stop it."""
    m = motor(damping_ratio=0.3)
    spans = np.array([(0.004, 1000.0), (0.002, 1500.0), (0.002, 2000.0), (0.5, 0.0)])
    n = len(spans)
    no_kb = np.full(n, -1, np.int64)
    nothing = (np.zeros(1), np.zeros(1), np.zeros(1))
    _, _, _, (own_max, own_lag, own_s) = _follow(m, spans, 0.3, no_kb, nothing, 0.0)
    assert abs(own_s[0]) > 1.0  # still ringing at the first boundary: the rate tells apart
    kb = np.append(np.arange(n - 1), -1)
    suffix = np.append(np.maximum.accumulate(own_max[::-1])[::-1], 0.0)
    _, stop, _, seen = _follow(m, spans, 0.3, kb, (own_lag, own_s, suffix), 0.0)
    assert stop == 0 and seen.shape[1] == 1 and seen[0, 0] == own_max[0]
    _, stop, _, seen = _follow(m, spans, 0.3, kb, (own_lag, -own_s, suffix), 0.0)
    assert stop == -1 and seen.shape[1] == n


def test_an_execution_that_slips_while_the_reference_does_not_is_named() -> None:
    """Uneven LE=1 sides whose short triangles step down hard after their peak: those
    slip a pole, the longest execution (the reference) does not. Each execution's slip
    is its own (the oracle's, move by move), never the reference's."""
    weak = Motor(steps_per_rev=200, curve_speed_pps=np.array([0.0, 3000.0, 6000.0]),
                 curve_torque_nm=np.array([0.3, 0.25, 0.05]), inertia_kgm2=2e-5,
                 safety_factor=0.6, start_pps=200.0, damping_ratio=0.2)
    table = FreeCurveTable(MHZ1, (544, 2541, 3339, 3729, 4804), (23, 12, 19, 5, 22),
                           (15, 33, 42, 15, 51))
    lengths = list(range(150, 240))
    found = angles(table, [weak], pulses=lengths)
    slipped = found.slipped[0]
    runs = moves(table, lengths)
    reference = int(np.argmax(np.diff(runs.offsets)))  # the most segments
    assert not slipped[reference] and 0 < slipped.sum() < len(lengths)
    for e in np.flatnonzero(slipped)[:3].tolist() + np.flatnonzero(~slipped)[-3:].tolist():
        oracle = whole_move(table, weak, lengths[e])[0]
        assert (oracle >= 180.0) == bool(slipped[e])
        if not slipped[e]:
            assert abs(oracle - found.deg[0, e]) <= AGREE_DEG

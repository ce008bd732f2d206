"""profiles.ppmc312.load_angle: the all-length load-angle verdict of a table, against moves
integrated whole by the plain-Python oracle."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from itertools import pairwise

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.motor.rotor import (
    rotor_of,
)
from profiles.motor.tolerance import corners
from profiles.ppmc312.load_angle import worst_load_angle, worst_load_angles
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import FreeCurveTable
from tests.support.oracle_moves import whole_move, worst_whole_move
from tests.support.stand_ins import plain_motor
from tests.support.strategies import MHZ1
from tests.support.strategies import rotor_motors as motors
from tests.support.strategies import rotor_tables as tables

AGREE_DEG = 0.1   # the kernel and the oracle: the bound (they agree to rounding)


SETTINGS = settings(max_examples=25, suppress_health_check=[HealthCheck.too_slow])


@pytest.mark.slow
@SETTINGS
@given(motors(), st.data())
def test_the_all_length_verdict_is_brute_force_over_every_length(
        motor: Motor, data: st.DataObject) -> None:
    """Every length up to a cruise long enough to settle, each judged on its own, against
    the sampled-and-refined verdict: the same worst angle and shortest unstable move.
    (Tables within the motor's curve: beyond it every move slips at once.)"""
    table = data.draw(tables(0.9 * motor.top_curve_pps))
    rotor = rotor_of(motor)
    top = table.clock.hz / table.rates[0]
    cruise = math.ceil(top * 10 * min(rotor.natural_period_s(top), 1.0)) + 1
    # a barely stable top speed (a period near 1 s) needs tens of thousands of lengths:
    # past the brute force's step budget (and the verdict's: it refuses, saying why), not
    # a question about the sampling
    assume(cruise <= 4000)
    verdict = worst_load_angle(table, motor)
    every = worst_load_angle(table, motor, pulses=range(
        1, table.accel_total + table.decel_total + cruise + 1))
    if every.slipped:  # past a pole slip the angle is no longer a margin: same verdict
        assert verdict.slipped
        return
    assert verdict.worst_angle_deg == pytest.approx(every.worst_angle_deg, abs=AGREE_DEG)
    assert verdict.first_unstable_pulses == every.first_unstable_pulses


def test_tolerance_corners_in_one_call_are_each_corners_own_verdict() -> None:
    base = load_motor(next(p for p in bundled_motor_paths() if "nema17" in p.name))
    motor = replace(base, load_torque_nm=0.01, tolerances=(
        ("inertia_kgm2", 4.8e-6, 8.8e-6), ("torque_scale", 0.8, 1.0),
        ("load_torque_nm", -0.02, 0.02)))
    table = plan_free_curve(base, pulses=3000).table
    box = corners(motor)
    together = worst_load_angles(table, [c.motor for c in box], pulses=[40, 300, 3000])
    for corner, verdict in zip(box, together, strict=True):
        alone = worst_load_angle(table, corner.motor, pulses=[40, 300, 3000])
        assert verdict == alone
        assert verdict.worst_angle_deg == pytest.approx(
            worst_whole_move(table, corner.motor, verdict.worst_pulses), abs=AGREE_DEG)


def test_a_few_moves_of_a_tiny_table_are_the_oracles_whole_moves() -> None:
    """Every execution kernel on a 3-stage table (LE=1: the decel side differs), a few
    lengths judged together (each from where it parts from the longest one until it
    rejoins it), both directions under a load: each length's worst angle in each
    direction is the oracle's whole move. Small enough to run as plain Python (the
    kernel's mutation run)."""
    from profiles.ppmc312.load_angle import angles

    motor = plain_motor(load_torque_nm=0.05, friction_torque_nm=0.02, damping_ratio=0.3)
    table = FreeCurveTable(MHZ1, (120, 200, 400), (3, 3, 2), (2, 4))
    lengths = [1, 4, 9, 15, 40]
    found = angles(table, [motor], pulses=lengths)
    assert found.deg.shape == (2, len(lengths)) and list(found.lengths) == lengths
    for row, direction in enumerate(found.direction.tolist()):
        for e, n in enumerate(lengths):
            assert found.deg[row, e] == pytest.approx(
                whole_move(table, motor, n, direction)[0], abs=AGREE_DEG), (direction, n)
    assert not found.slipped.any()


@pytest.mark.parametrize("load_nm, accel, decel, top_rate", [
    (0.0, (6, 5, 4, 3), None, 200),            # LE=0, safe: the worst is sampled right
    (0.03, (6, 5, 4, 3), (3, 8), 200),         # LE=1 under a load: both directions
    (0.0, (3, 3, 3, 3), None, 40),             # too fast: past 90° from some length on
])
def test_the_sampled_verdict_is_brute_force_over_every_length(
        load_nm: float, accel: tuple[int, ...], decel: tuple[int, ...] | None,
        top_rate: int) -> None:
    """The all-length verdict (each move family sampled by the ringing's phase, the
    worst families refined) against every length judged one by one, up to a cruise long
    enough to settle: the same worst angle, the same shortest unstable move."""
    motor = plain_motor(load_torque_nm=load_nm, friction_torque_nm=0.01, damping_ratio=0.2)
    rates = (top_rate, 2 * top_rate, 4 * top_rate, 8 * top_rate)
    table = FreeCurveTable(MHZ1, rates, accel, decel)
    verdict = worst_load_angle(table, motor)
    rotor = rotor_of(motor)
    top = MHZ1.hz / rates[0]
    cruise = math.ceil(top * 10 * min(rotor.natural_period_s(top), 1.0)) + 1
    every = worst_load_angle(table, motor, pulses=range(
        1, table.accel_total + table.decel_total + cruise + 1))
    assert verdict.slipped == every.slipped
    assert verdict.worst_angle_deg == pytest.approx(every.worst_angle_deg, abs=AGREE_DEG)
    assert verdict.first_unstable_pulses == every.first_unstable_pulses
    assert verdict.worst_direction == every.worst_direction


def test_a_move_at_exactly_the_peak_angle_is_unstable() -> None:
    """90° is the top of the torque–angle curve: a move reaching it has no margin left
    and is the shortest unstable move."""
    from profiles.ppmc312.load_angle import Angles

    found = Angles(np.array([10, 20, 30]), np.array([[40.0, 90.0, 95.0]]),
                   np.zeros((1, 3), bool), np.array([0]), np.array([1]))
    assert found.worst(0).first_unstable_pulses == 20
    assert found.worst(0).worst_pulses == 30


def test_verdicts_are_values() -> None:
    import dataclasses

    motor = plain_motor()
    table = FreeCurveTable(MHZ1, (200, 400), (4, 4))
    verdict = worst_load_angle(table, motor, pulses=[5])
    with pytest.raises(dataclasses.FrozenInstanceError):
        verdict.worst_angle_deg = 0.0  # type: ignore[misc]
    from profiles.ppmc312.load_angle import angles

    with pytest.raises(dataclasses.FrozenInstanceError):
        angles(table, [motor], pulses=[5]).deg = np.zeros(1)  # type: ignore[misc]


def test_a_verdict_refuses_no_lengths_a_bad_step_and_an_endless_run() -> None:
    """No move length to judge, a step outside 1 ns..1 s, or a verdict past its budget
    (here: steps of 1 ns over a 2 ms move): refused, naming the field or the budget."""
    from profiles.errors import FieldRangeError, StepRampError

    motor = plain_motor()
    table = FreeCurveTable(MHZ1, (200, 400), (4, 4))
    with pytest.raises(FieldRangeError) as empty:
        worst_load_angle(table, motor, pulses=[])
    assert (empty.value.field, empty.value.value, empty.value.lo, empty.value.hi) == (
        "move lengths to judge", 0, 1, 0xFFFFFFFF)
    for step in (0.0, 0.99e-9, 1.01, 2.0):
        with pytest.raises(FieldRangeError, match=r"max step \[s\]"):
            worst_load_angle(table, motor, pulses=[5], max_step_s=step)
    assert worst_load_angle(table, motor, pulses=[5], max_step_s=1.0).executions == 1
    with pytest.raises(StepRampError, match="more than 8000000 RK4 steps"):
        worst_load_angle(table, motor, pulses=[10], max_step_s=1e-9)


def test_a_verdict_names_its_direction_and_counts_its_executions() -> None:
    """Without a load a move is judged forward only (direction 1); with one, both ways:
    the executions counted are the lengths judged times the directions, and the worst
    is named by its direction (±1)."""
    table = FreeCurveTable(MHZ1, (200, 400), (4, 4))
    free = worst_load_angle(table, plain_motor(), pulses=[3, 8, 20])
    assert (free.worst_direction, free.executions) == (1, 3)
    loaded = worst_load_angle(table, plain_motor(load_torque_nm=0.1), pulses=[3, 8, 20])
    assert loaded.executions == 6 and loaded.worst_direction in (1, -1)


class _Asked:
    """A stand-in for the kernel under `refine`: each length's angle from `curve`, every
    call recorded (ascending, none asked before, none of the samples)."""

    def __init__(self, curve: Callable[[int], float], sampled: np.ndarray) -> None:
        self.curve, self.sampled, self.calls = curve, set(sampled.tolist()), []

    def __call__(self, lengths: np.ndarray) -> np.ndarray:
        asked = lengths.tolist()
        assert lengths.dtype.kind == "i" and asked == sorted(set(asked))
        assert not set(asked) & (self.sampled | set(self.every))
        self.calls.append(asked)
        return np.array([self.curve(n) for n in asked])

    @property
    def every(self) -> list[int]:
        return [n for call in self.calls for n in call]


def _refined(lengths: list[int], family: list[int], spacing: list[int],
             curve: Callable[[int], float]) -> _Asked:
    from profiles.motor.batch_angle import refine

    at = np.array(lengths)
    asked = _Asked(curve, at)
    refine(at, np.array(family), np.array(spacing), np.array([curve(n) for n in lengths]),
           asked)
    return asked


def test_refine_finds_the_peak_of_every_family_near_the_worst_and_no_other() -> None:
    """`refine`: a family within REFINE_DEG of the worst sample is searched until its
    peak between samples is judged (80° at 27, 79° at 224: each sampled lower), a family
    far below gets nothing, and the search asks fewer lengths than the spans hold."""
    def curve(n: int) -> float:
        if n < 100:
            return 80.0 - 0.05 * (n - 27) ** 2
        return 25.0 if n < 200 else 79.0 - 0.05 * (n - 224) ** 2

    lengths = [10, 20, 30, 40, 100, 110, 120, 200, 210, 220, 230]
    asked = _refined(lengths, [0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 2], [10, 10, 10], curve)
    assert max(asked.every, key=curve) == 27 and 224 in asked.every
    assert not [n for n in asked.every if 100 <= n <= 120]
    assert all(21 <= n <= 39 or 211 <= n <= 229 for n in asked.every)
    assert len(asked.every) < 2 * 18  # each family's two spans hold 18 lengths
    assert not _refined(lengths, [0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 2], [1, 1, 1], curve).calls


@pytest.mark.parametrize("peak", [11, 12, 15, 19, 20, 21, 25, 29])
def test_refine_finds_a_peak_anywhere_between_the_samples(peak: int) -> None:
    """Wherever the top lies beside the worst sample (20), on either side, next to a
    sample or halfway, the search judges it."""
    asked = _refined([0, 10, 20, 30, 40], [0] * 5, [10],
                     lambda n: 60.0 - 0.1 * abs(n - peak))
    assert peak in asked.every or peak in (10, 20)


def test_refine_judges_every_length_before_the_first_sample_past_the_peak() -> None:
    """A family whose samples pass the 90° peak gets every length before its first
    unstable sample (so the shortest unstable move is named exactly), even when it is
    far below the worst family; not those up to a later unstable sample."""
    from profiles.motor.batch_angle import PEAK_DEG

    worst = {10: 10.0, 20: 20.0, 30: PEAK_DEG + 5.0}
    asked = _refined([10, 20, 30], [0, 0, 0], [10], lambda n: worst.get(n, 20.0 + n))
    assert asked.every == list(range(21, 30))
    # spacing 2: one length between samples; a family at exactly 90° (far below a 99°
    # one) names its shortest unstable move too
    worst = {10: 50.0, 12: 99.0, 14: 60.0, 16: 95.0, 100: 40.0, 104: 90.0, 108: 85.0,
             112: 88.0}
    asked = _refined(list(worst), [0, 0, 0, 0, 1, 1, 1, 1], [2, 4],
                     lambda n: worst.get(n, 0.0))
    assert sorted(asked.every) == [11, 13, 101, 102, 103]


def test_a_batch_on_threads_judges_every_cell_as_one_at_a_time() -> None:
    """Enough (rotor, execution) cells to be split over threads: every cell gets the
    angle its move gets judged alone (on the calling thread), the first and the last
    included."""
    from profiles.motor.batch_angle import PARALLEL_MIN_CELLS
    from profiles.ppmc312.load_angle import angles

    motor = plain_motor(load_torque_nm=0.05, damping_ratio=0.3)
    table = FreeCurveTable(MHZ1, (120, 200, 400), (3, 3, 2))
    lengths = list(range(1, PARALLEL_MIN_CELLS + 3))
    batch = angles(table, [motor], pulses=lengths)
    assert batch.deg.size >= PARALLEL_MIN_CELLS
    for e, n in enumerate(lengths):
        alone = angles(table, [motor], pulses=[n])
        np.testing.assert_allclose(batch.deg[:, e], alone.deg[:, 0], atol=AGREE_DEG)
    assert batch.deg.min() > 0


def _judge_in_child(lengths: list[int], out: object) -> None:
    from profiles.ppmc312.load_angle import angles

    motor = plain_motor(load_torque_nm=0.05, damping_ratio=0.3)
    table = FreeCurveTable(MHZ1, (120, 200, 400), (3, 3, 2))
    out.put(angles(table, [motor], pulses=lengths).deg.tolist())  # type: ignore[attr-defined]


def test_a_forked_child_judges_on_threads_of_its_own() -> None:
    """The threads are kept between verdicts; a child forked after the parent judged (a
    sweep's worker) does not have them and must start its own, not wait forever."""
    import multiprocessing

    from profiles.motor.batch_angle import PARALLEL_MIN_CELLS
    from profiles.ppmc312.load_angle import angles

    lengths = list(range(1, PARALLEL_MIN_CELLS + 3))
    motor = plain_motor(load_torque_nm=0.05, damping_ratio=0.3)
    table = FreeCurveTable(MHZ1, (120, 200, 400), (3, 3, 2))
    here = angles(table, [motor], pulses=lengths).deg.tolist()  # the parent's threads start
    fork = multiprocessing.get_context("fork")
    out = fork.Queue()
    child = fork.Process(target=_judge_in_child, args=(lengths, out))
    child.start()
    child.join(timeout=60)
    if child.is_alive():
        child.kill()
    assert child.exitcode == 0, "the child hung or failed"
    assert out.get(timeout=5) == here


def test_after_the_last_pulse_a_loaded_rotor_creeping_to_its_held_lag_is_followed() -> None:
    """A heavy, critically damped rotor under a load: after a 1-pulse move its lag peaks
    (7.05°), dips, then creeps up to where the load holds it (7.18°). The verdict follows
    the rest until its ringing fades above that held lag, so it names the oracle's worst,
    not the first peak. (Found by the shared-prefix property.)"""
    motor = plain_motor(steps_per_rev=1600, curve_speed_pps=np.array([0.0, 4000.0]),
                        curve_torque_nm=np.array([1.0, 1.0]), inertia_kgm2=7.8167e-4,
                        start_pps=100.0, friction_torque_nm=0.0625, damping_ratio=1.0,
                        load_torque_nm=0.125)
    table = FreeCurveTable(MHZ1, (4975, 5000), (2, 2))
    fast = worst_load_angle(table, motor, pulses=[1]).worst_angle_deg
    assert fast == pytest.approx(worst_whole_move(table, motor, 1), abs=AGREE_DEG)
    assert fast > 7.1


def test_the_options_are_keyword_only() -> None:
    with pytest.raises(TypeError, match="positional argument"):
        worst_load_angles(None, [], None)  # type: ignore[arg-type, misc]


def test_a_slow_rotors_dwell_settles_within_periods_of_at_most_1_s() -> None:
    """`dwell_sampling`: the densely judged runs last SETTLE_CRUISE_PERIODS natural
    periods of the dwell, each counted as at most 1 s (a rotor with a 4 s period at
    rest: 10 s of dwell, not 40)."""
    from profiles.motor.batch_angle import SETTLE_CRUISE_PERIODS, dwell_sampling

    rotor = rotor_of(load_motor(bundled_motor_paths()[0]))
    slow = replace(rotor, k=rotor.k * (rotor.natural_period_s(0.0) / 4.0) ** 2)
    speed = np.array([10.0])
    assert slow.natural_periods_s(speed)[0] > 2.0
    _, dense = dwell_sampling([slow], speed, np.array([0]), np.array([10**6]), 1)
    assert dense.tolist() == [math.ceil(10.0 * SETTLE_CRUISE_PERIODS * 1.0)]


def test_the_all_length_verdict_is_remembered_read_only_and_a_step_of_its_own_is_not(
) -> None:
    """`angles`: the all-length verdict is remembered and shared, its arrays read-only; a
    verdict with a step bound of its own is judged afresh (it is not the remembered one)."""
    from profiles.ppmc312.load_angle import angles

    motor = load_motor(bundled_motor_paths()[0])
    table = plan_free_curve(motor, pulses=400).table
    first = angles(table, [motor])
    assert angles(table, [motor]) is first
    assert not any(a.flags.writeable for a in vars(first).values()
                   if isinstance(a, np.ndarray))
    own = angles(table, [motor], max_step_s=1.0)
    assert own is not first and own.deg.flags.writeable


def test_aim_deg_stops_at_the_samples_when_they_settle_within_or_past(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """`angles(aim_deg=…)`: a sample past the aim, or every sample REFINE_DEG or more
    below it, gives the samples' verdict alone (not refined: its worst that of the
    samples); a worst sample just below the aim, the whole verdict. The whole verdict
    asked later goes on from the remembered samples (the kernel not run on them again)
    and is the one judged from scratch."""
    from profiles.motor.batch_angle import REFINE_DEG
    from profiles.ppmc312 import load_angle
    from profiles.ppmc312.load_angle import angles, forget_verdicts

    motor = load_motor(next(p for p in bundled_motor_paths() if "nema23" in p.name))
    table = plan_free_curve(motor, pulses=12_000).table
    forget_verdicts()
    whole = angles(table, [motor])
    worst = float(whole.deg.max())
    forget_verdicts()
    sampled = angles(table, [motor], aim_deg=worst - 10.0)
    assert not sampled.refined and len(sampled.lengths) < len(whole.lengths)
    top = float(sampled.deg.max())
    assert worst - 10.0 < top <= worst
    assert not angles(table, [motor], aim_deg=top + REFINE_DEG).refined  # well within
    judged: list[int] = []
    real = load_angle.judge

    def counted(runs: object, *args: object, **kw: object) -> object:
        judged.append(len(runs))  # type: ignore[arg-type]
        return real(runs, *args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(load_angle, "judge", counted)
    again = angles(table, [motor], aim_deg=top + REFINE_DEG / 2)  # may be past: refined
    assert again.refined and sum(judged) == len(again.lengths) - len(sampled.lengths)
    np.testing.assert_array_equal(again.lengths, whole.lengths)
    np.testing.assert_allclose(again.deg, whole.deg)
    assert angles(table, [motor], aim_deg=0.0) is again  # the whole one, once known


def test_a_dwell_with_no_torque_or_no_speed_is_sampled_whole_and_settles_by_rest() -> None:
    """`dwell_sampling` where a rotor has no torque (past its curve: no natural period
    there): spaced by the whole run range, dense for SETTLE_CRUISE_PERIODS natural periods
    at rest (0 pps, not 1 pps); a dwell at 0 pps is dense for one run."""
    from profiles.motor.batch_angle import SETTLE_CRUISE_PERIODS, dwell_sampling
    from profiles.motor.rotor import Rotor

    base = rotor_of(load_motor(bundled_motor_paths()[0]))
    steep = replace(base, curve_v=(0.0, 2.0, 10.0), curve_t=(0.5, 1e-4, 0.0))
    assert isinstance(steep, Rotor)
    rest = steep.natural_period_s(0.0)
    assert steep.natural_period_s(1.0) > 1.2 * rest
    speed = 1e6  # past the curve: no torque; the dense runs then count many pulses
    spacing, dense = dwell_sampling([steep], np.array([speed]), np.array([100]),
                                    np.array([10**12]), 1)
    assert spacing.tolist() == [10**12 - 100]
    assert dense.tolist() == [100 + math.ceil(speed * SETTLE_CRUISE_PERIODS * rest)]
    _, still = dwell_sampling([base], np.array([0.0]), np.array([100]), np.array([500]), 3)
    assert still.tolist() == [103]


def test_a_trace_joins_a_rate_into_one_span_and_ends_resting() -> None:
    """`spans_of`: the command as the verdict integrates it: neighbouring segments of one
    rate one span (their time summed), then the command at rest (0 pps) while the rotor
    settles, as the kernel's executions end."""
    from profiles.motor.rotor import settle_s
    from profiles.ppmc312.execution import simulate_move
    from profiles.ppmc312.load_angle import spans_of

    motor = plain_motor(damping_ratio=0.3)
    table = FreeCurveTable(MHZ1, (120, 200, 400), (3, 3, 2))
    run = simulate_move(table, 40)  # a trapezoid: the top stage, cruise and decel at 120
    rotor = rotor_of(motor)
    step = rotor.step_s()
    spans = spans_of(run, rotor, step)
    assert spans[-1] == (settle_s(rotor, step), 0.0)
    speeds = [v for _, v in spans[:-1]]
    assert all(a != b for a, b in pairwise(speeds))  # one span a rate in a row
    assert speeds.count(MHZ1.hz / 120) == 1
    assert sum(d for d, _ in spans[:-1]) == pytest.approx(run.duration_s)

"""Duty-cycle planning bounded: a mix's lengths deduplicated and capped, a bounded number
of candidate tables, every length timed at once exactly as the chip runs it, and
`plan --moves` naming the CSV file, line and field of a bad row in one short line."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.errors import FieldRangeError, PlanError
from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.planner import duty_cycle, plan_duty_cycle, plan_free_curve
from profiles.ppmc312.planner.duty_cycle import candidate_lengths, mix_arrays, move_ticks
from profiles.ppmc312.table import FreeCurveTable

MOTORS = {p.stem: p for p in bundled_motor_paths()}


PK566 = MOTORS["motor-pk566-5phase-half"]


CLK = Clock.internal("8MHz")


# LE=1 with uneven sides (triangles keep the ratio, straight triangles run the extra
# stages) and LE=0: every shape the move model has
TABLES = [FreeCurveTable(CLK, (100, 180, 300, 700), (3, 9, 40, 12), (20, 2, 5, 7)),
          FreeCurveTable(CLK, (100, 180, 300), (3, 9, 40), (30, 2)),
          FreeCurveTable(CLK, (250, 400), (4, 6), None)]


@given(table=st.sampled_from(TABLES),
       lengths=st.lists(st.one_of(st.integers(1, 200), st.integers(1, 0xFFFFFFFF)),
                        min_size=1, max_size=20))
def test_move_ticks_are_the_chips_moves(table: FreeCurveTable, lengths: list[int]) -> None:
    ticks = move_ticks(table, np.array(lengths))
    assert ticks.tolist() == [simulate_move(table, n).ticks for n in lengths]


def test_mix_arrays_sum_equal_lengths_and_name_a_bad_row() -> None:
    lengths, weights = mix_arrays([(300, 1.0), (20, 2.0), (300, 0.5), (20, 0.0)])
    assert lengths.tolist() == [20, 300] and weights.tolist() == [2.0, 1.5]
    with pytest.raises(FieldRangeError, match=r"^move mix row 2: pulses: 5 "):
        mix_arrays([(300, 1.0), (5, 1.0)])  # never blamed on a --pulses option
    with pytest.raises(FieldRangeError, match="row 1: weight: nan"):
        mix_arrays([(300, float("nan"))])
    with pytest.raises(PlanError, match="sum to 0"):
        mix_arrays([(300, 0.0)])
    with pytest.raises(PlanError, match="empty"):
        mix_arrays([])


def test_mix_arrays_cap_distinct_lengths(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(duty_cycle, "MIX_LENGTHS_MAX", 3)
    assert len(mix_arrays([(n, 1.0) for n in (10, 20, 30, 10, 20)])[0]) == 3
    with pytest.raises(PlanError, match="4 distinct lengths, more than the 3"):
        mix_arrays([(n, 1.0) for n in (10, 20, 30, 40)])


def test_a_mix_of_exactly_the_documented_distinct_lengths_is_taken() -> None:
    """The guide's cap: 100 000 distinct lengths, and one more is refused."""
    assert len(mix_arrays([(n, 1.0) for n in range(8, 8 + 100_000)])[0]) == 100_000
    with pytest.raises(PlanError, match="100001 distinct lengths, more than the 100000 a duty"):
        mix_arrays([(n, 1.0) for n in range(8, 8 + 100_001)])


@settings(max_examples=50)
@given(st.lists(st.tuples(st.integers(8, 10**7), st.floats(0.0, 100.0)), min_size=1,
                max_size=100).filter(lambda m: sum(w for _, w in m) > 0),
       st.integers(4, 32))
def test_candidates_are_bounded_and_span_the_mix(mix: list[tuple[int, float]],
                                                  count: int) -> None:
    lengths, weights = mix_arrays(mix)
    picked = candidate_lengths(lengths, weights, count)
    assert picked == sorted(set(picked)) and len(picked) <= count
    assert lengths[0] * 0.95 <= picked[0] and picked[-1] <= lengths[-1]
    assert lengths[-1] <= picked[-1] * 1.05 + 1
    if len(lengths) <= count // 2:  # a small mix: a table for every one of its lengths
        assert set(lengths.tolist()) <= set(picked)
    heavy = lengths[np.argmax(weights)]
    if weights.max() > weights.sum() / (count // 2):  # a length with > one share of weight
        assert heavy in picked


def test_duty_cycle_is_never_worse_than_any_candidates_plan() -> None:
    motor = load_motor(PK566)
    mix = [(n, float(1 + n % 3)) for n in range(200, 6200, 500)]  # 12 lengths
    calls: list[tuple[int, int]] = []
    plan, times = plan_duty_cycle(motor, mix, candidates=4,
                                  progress=lambda d, t: calls.append((d, t)))
    picked = plan.extras["candidates"]
    assert len(picked) <= 4 and calls[0] == (0, len(picked)) and calls[-1][0] == len(picked)
    weighted = sum(w * times[n] for n, w in mix)
    assert plan.duration_s == pytest.approx(weighted, rel=1e-12)
    assert times == {n: simulate_move(plan.table, n).duration_s for n, _ in mix}
    for n in picked:
        single = plan_free_curve(motor, pulses=n).table
        assert weighted <= sum(w * simulate_move(single, m).duration_s for m, w in mix) \
            * (1 + 1e-12)

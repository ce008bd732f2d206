"""profiles/ppmc312/move_batch.py: the move model over many lengths at once — a batch of
moves is each move alone, the families as arrays partition every length, and the
model is remembered per table until forgotten."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.errors import MoveParameterError
from profiles.ppmc312.execution import move_families, simulate_move
from profiles.ppmc312.move_batch import (
    MOVE_PULSES_MAX,
    SHAPES,
    check_pulses,
    families,
    forget_tables,
    move_model,
    moves,
)
from profiles.ppmc312.table import FreeCurveTable
from tests.support.strategies import MHZ1
from tests.support.strategies import stage_tables as tables

COMMON = FreeCurveTable(MHZ1, (100, 200, 300, 400), (10, 20, 30, 40))


@settings(max_examples=60, deadline=None)
@given(table=tables(), lengths=st.lists(st.integers(1, 3000), min_size=1, max_size=8))
def test_a_batch_is_each_move_alone(table: FreeCurveTable, lengths: list[int]) -> None:
    batch = moves(table, lengths)
    assert len(batch) == len(lengths) and batch.pulses.tolist() == lengths
    for e, n in enumerate(lengths):
        alone = simulate_move(table, n)
        assert batch.runs(e) == [(s.phase, s.rate, s.pulses) for s in alone.segments]
        assert SHAPES[int(batch.shape[e])] == alone.shape


@settings(max_examples=60, deadline=None)
@given(table=tables())
def test_the_families_as_arrays_are_the_family_objects(table: FreeCurveTable) -> None:
    bounds = families(table)
    fams = move_families(table)
    assert bounds.lo.tolist() == [f.lo for f in fams]
    assert bounds.hi.tolist() == [f.hi for f in fams]
    assert [SHAPES[s] for s in bounds.shape.tolist()] == [f.shape for f in fams]
    assert bounds.lo[0] == 1 and bounds.hi[-1] == MOVE_PULSES_MAX
    assert (bounds.lo[1:] == bounds.hi[:-1] + 1).all()
    # the first move of each family differs from the move before it in rates or shape
    assert not bounds.batch.repeats()[bounds.first].any()


def test_repeats_tell_moves_that_differ_only_in_counts() -> None:
    # triangles (one more decel pulse; then a stage more), a trapezoid, with a cruise
    batch = moves(COMMON, [100, 101, 150, 200, 201, 500])
    assert batch.repeats().tolist() == [False, True, False, False, False, True]


def test_the_model_is_remembered_until_forgotten() -> None:
    assert move_model(COMMON, 0)[1] is move_model(COMMON, 0)[1]
    first = move_model(COMMON, 0)[1]
    forget_tables()
    assert move_model(COMMON, 0)[1] is not first
    assert move_model(COMMON, 300)[1].cruise_rate == 300


@pytest.mark.parametrize("pulses", [0, MOVE_PULSES_MAX + 1, True, 1.5, np.int64(-1)])
def test_a_length_outside_the_chips_range_is_refused(pulses: object) -> None:
    with pytest.raises(MoveParameterError, match="pulses"):
        check_pulses(pulses)


@pytest.mark.parametrize("pulses", [0, MOVE_PULSES_MAX + 1])
def test_a_batch_with_a_length_outside_the_range_is_refused(pulses: int) -> None:
    with pytest.raises(MoveParameterError, match="pulses"):
        moves(COMMON, [5, pulses])

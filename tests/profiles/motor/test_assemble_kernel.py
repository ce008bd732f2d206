"""The compiled move assembly (`assemble_kernel`, what the load-angle verdict uses) equals
the numpy one every other command uses, array for array and dtype for dtype: every shape
(trapezoids, triangles with LE=1's clamped decel, straight triangles both ways), a
high-rate override (and the no-acceleration case), zero-pulse stages, and every length
around each family's first."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.motor.batch import MoveBatch
from profiles.ppmc312.execution import move_families
from profiles.ppmc312.move_batch import MOVE_PULSES_MAX, moves
from profiles.ppmc312.table import FreeCurveTable
from tests.support.strategies import MHZ1
from tests.support.strategies import stage_tables as tables

FIELDS = ("pulses", "shape", "phase", "rate", "count", "offsets")


def assert_same(a: MoveBatch, b: MoveBatch) -> None:
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and np.array_equal(x, y), name


@settings(max_examples=300, deadline=None)
@given(table=tables(), pick=st.integers(0, 10**6), use_high=st.booleans(),
       extra=st.lists(st.integers(1, MOVE_PULSES_MAX), max_size=20))
def test_compiled_assembly_equals_numpy(table: FreeCurveTable, pick: int, use_high: bool,
                                        extra: list[int]) -> None:
    lo, hi = min(table.rates), max(table.rates)
    high = lo + pick % (hi - lo + 1) if use_high else 0
    firsts = [f.lo for f in move_families(table, high_rate=high)]
    lengths = np.unique(np.clip(np.concatenate((
        np.arange(1, 200), *(np.arange(f - 2, f + 3) for f in firsts), extra)),
        1, MOVE_PULSES_MAX))
    assert_same(moves(table, lengths, high_rate=high),
                moves(table, lengths, high_rate=high, compiled=True))


def test_compiled_assembly_of_no_moves_and_of_one() -> None:
    table = FreeCurveTable(MHZ1, (100, 200, 400), (3, 5, 7), (4, 6, 2))
    for lengths in ([], [1], [MOVE_PULSES_MAX]):
        assert_same(moves(table, np.asarray(lengths, dtype=np.int64)),
                    moves(table, np.asarray(lengths, dtype=np.int64), compiled=True))


@settings(max_examples=60, deadline=None)
@given(table=tables())
def test_families_found_by_either_assembly_are_the_same(table: FreeCurveTable) -> None:
    """The load-angle verdict finds a table's families with the compiled assembly, the
    criterion with numpy's; whichever comes first is remembered for both."""
    from profiles.ppmc312.move_batch import families, forget_tables

    forget_tables()
    compiled = families(table, compiled=True)
    assert families(table) is compiled  # remembered
    forget_tables()
    plain = families(table)
    assert families(table, compiled=True) is plain
    for a, b in zip(compiled[:4], plain[:4], strict=True):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    assert_same(compiled.batch, plain.batch)
    assert compiled.cruise_rate == plain.cruise_rate

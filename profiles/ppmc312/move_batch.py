"""The PPMC-312's move model over many move lengths at once (command 82): a table's two
sides as one move command sees them (`MoveModel`, after any high-rate override; the
one source of `execution.simulate_move` and of the families), the moves of many
lengths as flat segment arrays (`moves` → `MoveBatch`, assembled in numpy or by the
compiled twin `assemble_kernel`), and every distinct execution over the lengths
1..0xFFFFFFFF as arrays (`families` → `FamilyBounds`, found from the stage boundaries,
never by iterating lengths). The shapes and their rules: profiles/ppmc312/execution.py's
docstring and docs/manual-notes.md."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any, Literal, NamedTuple

import numpy as np

from profiles.errors import FieldRangeError, MoveParameterError
from profiles.motor.batch import MoveBatch, PhaseRuns, ranges
from profiles.ppmc312.table import RATE_FIELD_MAX, STAGE_COUNT_FIELD_MAX, FreeCurveTable, InitTable

MoveShape = Literal["trapezoid", "triangle", "straight_triangle_decel", "straight_triangle_accel"]

MOVE_PULSES_MAX = 0xFFFFFFFF
CHIP_RATE_OUT_OF_RANGE = 0x20   # parameter error: pulse rate setting out of range (§11-6)
CHIP_BAD_PULSE_COUNT = 0x23     # parameter error: the move's pulse count is wrong (§11-6)


Stage = tuple[int, int, int]  # (index in the fastest-first lists, rate, pulses)


@dataclass(frozen=True)
class MoveModel:
    """A table's two sides as one move command sees them (after any high-rate override):
    the single source of both `simulate_move` and `move_families`."""

    acc: list[Stage]
    dec: list[Stage]
    cruise_rate: int
    given: bool
    no_accel: bool   # a high rate slower than the accel side's 2nd stage: no acceleration
    shared: int      # stages with index ≥ shared belong to one side only
    split: _Split = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "split", _split(self.acc, self.dec, self.shared,
                                                 self.cruise_rate if self.no_accel else 0))

    def runs(self, pulses: int) -> tuple[MoveShape, PhaseRuns]:
        """The segments of the move as (phase, rate, pulses) (see `moves`)."""
        batch = self.moves(np.asarray([pulses], dtype=np.int64))
        return SHAPES[int(batch.shape[0])], batch.runs(0)

    def moves(self, pulses: np.ndarray, *, compiled: bool = False) -> MoveBatch:
        """The moves of the given lengths at once (numpy over moves and segments;
        `compiled`: the segments assembled by `assemble_kernel`, its compiled twin).

        A move is five parts in order: two accel parts (the stages one side has beyond
        the other, then the shared ones), the cruise, two decel parts (shared, then the
        other side's extra stages), each the first (accel) or last (decel) pulses of its
        stages from their slow end; empty parts drop out, and a part at the same phase and
        rate as the one before is joined to it (e.g. clamped decel pulses at the peak)."""
        sp = self.split
        p = np.asarray(pulses, dtype=np.int64)
        zero = np.zeros_like(p)
        if self.no_accel:
            # High rate slower than the 2nd stage: the chip cannot accelerate (manual §8-3);
            # it runs at `cruise_rate`, then down the decel stages slower than that.
            total = sp.ladders[5].total
            shape = np.full(len(p), SHAPES.index("straight_triangle_decel"))
            x = (zero, zero, np.maximum(p - total, 0), np.minimum(p, total), zero)
        else:
            trap = p >= sp.a_total + sp.d_total
            tri = ~trap & (p >= sp.rate_diff)
            rest = p - sp.rate_diff
            a_sh, d_sh = sp.a_sh, sp.d_sh
            # The chip keeps the table's accel:decel ratio; the accel share rounds down.
            q_acc = rest * a_sh // (a_sh + d_sh) if a_sh + d_sh else zero
            q_dec = rest - q_acc
            straight_up = sp.ladders[2].total > 0  # the accel side has the extra stages
            straight = ~trap & ~tri
            acc_x, dec_x = sp.ladders[2].total, sp.ladders[6].total
            x = (np.where(trap, acc_x, np.where(tri, sp.rate_diff if sp.acc_extra else 0,
                                                np.where(straight & straight_up, p, 0))),
                 np.where(trap, a_sh, np.where(tri, q_acc, 0)),
                 np.where(trap, p - sp.a_total - sp.d_total, 0),
                 np.where(trap, d_sh, np.where(tri, q_dec, 0)),
                 np.where(trap, dec_x, np.where(tri, sp.rate_diff if sp.dec_extra else 0,
                                                np.where(straight & ~straight_up, p, 0))))
            shape = np.where(trap, 0, np.where(tri, 1, np.where(straight_up, 3, 2)))
        clamp = shape == SHAPES.index("triangle")
        if compiled:
            from ..motor.assemble_kernel import assemble

            batch = assemble(np.stack(x), *self.packed_parts, self.cruise_rate, clamp)
            return MoveBatch(p, shape, *batch)
        return _assemble(p, shape, sp.ladders[2:], x, self.cruise_rate, clamp=clamp)

    @functools.cached_property
    def packed_parts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The five parts' ladders as the compiled assembly takes them: (starts, rates,
        counts, cum), part i's stages at starts[i]:starts[i + 1]."""
        ladders = self.split.ladders[2:]

        def joined(name: str) -> np.ndarray:
            return np.concatenate([getattr(lad, name) for lad in ladders]).astype(np.int64)

        starts = np.cumsum([0, *(len(lad.rates) for lad in ladders)]).astype(np.int64)
        return starts, joined("rates"), joined("counts"), joined("cum")

    @functools.cached_property
    def families(self) -> FamilyBounds:
        """The move families (`families`), found once per move model: a verdict's
        criterion and its load angle both walk them. Read-only: they are shared."""
        return self._families(compiled=False)

    def compiled_families(self) -> FamilyBounds:
        """`families`, assembled by the compiled twin when not found yet (the same
        arrays, pinned by tests/profiles/motor/test_assemble_kernel.py)."""
        if "families" not in self.__dict__:
            self.__dict__["families"] = self._families(compiled=True)
        return self.families

    def _families(self, *, compiled: bool) -> FamilyBounds:
        starts = self.breakpoints()
        batch = self.moves(np.asarray(starts, dtype=np.int64), compiled=compiled)
        index = np.flatnonzero(~batch.repeats())  # where the segment rates or shape change
        lo = np.asarray(starts, dtype=np.int64)[index]
        hi = np.append(lo[1:] - 1, MOVE_PULSES_MAX)
        bounds = FamilyBounds(lo, hi, batch.shape[index], index, batch, self.cruise_rate)
        for a in (*bounds[:4], *vars(batch).values()):
            a.flags.writeable = False
        return bounds

    def breakpoints(self) -> list[int]:
        """Every move length at which the sequence of segment rates may change (the first
        length of each `MoveFamily`), ascending, starting at 1."""
        out = {1}
        if self.no_accel:
            tail = [s for s in self.dec if s[1] > self.cruise_rate]
            total = sum(p for _, _, p in tail)
            out.update((total, total + 1))  # the cruise appears one pulse past the tail
            out.update(c + 1 for c in _slow_end_cumsum(tail))
            return sorted(b for b in out if 1 <= b <= MOVE_PULSES_MAX)
        sp = self.split
        acc_extra, dec_extra, acc_shared, dec_shared = (sp.acc_extra, sp.dec_extra,
                                                        sp.acc_shared, sp.dec_shared)
        rate_diff, a_total, d_total = sp.rate_diff, sp.a_total, sp.d_total
        out.update((rate_diff, a_total + d_total, a_total + d_total + 1))  # +1: a cruise
        # straight triangles: the stage reached changes one pulse past each stage boundary
        out.update(c + 1 for c in _slow_end_cumsum(acc_extra) + _slow_end_cumsum(dec_extra)
                   if c + 1 < rate_diff)
        # triangles: the accel share q_a = ⌊rest·a/(a+d)⌋ and decel share q_d = rest − q_a
        # enter a new stage one pulse past each boundary (and leave 0)
        a, d = sp.a_sh, sp.d_sh
        if a + d:
            for c in [0, *_slow_end_cumsum(acc_shared)]:
                if a:  # smallest rest with q_a ≥ c + 1
                    out.add(rate_diff + -(-(c + 1) * (a + d) // a))
            for c in [0, *_slow_end_cumsum(dec_shared)]:
                if d:  # q_d = ⌈rest·d/(a+d)⌉ ≥ c + 1 ⟺ rest·d > c·(a+d)
                    out.add(rate_diff + c * (a + d) // d + 1)
        return sorted(b for b in out if 1 <= b <= min(MOVE_PULSES_MAX, a_total + d_total + 1))


def _slow_end_cumsum(side: list[Stage]) -> list[int]:
    """Pulses of a side's slowest 1, 2, … stages (all but the whole side)."""
    counts = [p for _, _, p in reversed(side)]
    return [int(c) for c in np.cumsum(counts[:-1])] if len(counts) > 1 else []


def move_model(table: FreeCurveTable | InitTable, high_rate: int
               ) -> tuple[FreeCurveTable, MoveModel]:
    """The table as a free curve and its move model at `high_rate` (0: the table's),
    remembered for the last few tables."""
    if type(high_rate) is int:  # (tables are frozen, so hashable; other types are refused)
        return _known_model(table, high_rate)
    return _new_model(table, high_rate)


@functools.lru_cache(maxsize=16)
def _known_model(table: FreeCurveTable | InitTable, high_rate: int
                 ) -> tuple[FreeCurveTable, MoveModel]:
    """`_new_model`, remembered: a verdict or a plan asks for the same table's moves
    several times (families, samples, refinements), each a few hundred µs to prepare."""
    return _new_model(table, high_rate)


def forget_tables() -> None:
    """Forget the remembered move models (a benchmark times a table's first verdict)."""
    _known_model.cache_clear()


def _new_model(table: FreeCurveTable | InitTable, high_rate: Any
               ) -> tuple[FreeCurveTable, MoveModel]:
    from profiles.ppmc312.init_model import as_free_curve

    table = as_free_curve(table)
    rates = table.rates
    acc = [(i, rates[i], p) for i, p in enumerate(table.accel_pulses)]
    dec = [(i, rates[i], p) for i, p in enumerate(table.decel)]
    for name, side in (("accel", acc), ("decel", dec)):
        if not side:
            raise FieldRangeError(f"{name} stage count", 0, 1, STAGE_COUNT_FIELD_MAX)
    for i, r in enumerate(rates):
        if r < 1:
            raise FieldRangeError(f"rates[{i}]", r, 1, RATE_FIELD_MAX)
    lo, hi = min(rates), max(rates)
    if isinstance(high_rate, bool) or not isinstance(high_rate, int | np.integer) or (
            high_rate != 0 and not lo <= high_rate <= hi):
        raise MoveParameterError("high rate (0 = the table's)", high_rate, lo, hi,
                                 CHIP_RATE_OUT_OF_RANGE)
    high_rate = int(high_rate)
    given = high_rate != 0
    shared = min(len(table.accel_pulses), len(table.decel))
    if given and len(acc) >= 2 and high_rate > acc[-2][1]:
        return table, MoveModel(acc, dec, max(high_rate, acc[-1][1]), True, True, shared)
    if given:  # stages faster than the high rate are never reached
        acc = [s for s in acc if s[1] >= high_rate]
        dec = [s for s in dec if s[1] >= high_rate]
    return table, MoveModel(acc, dec, high_rate if given else rates[0], given, False, shared)


def moves(table: FreeCurveTable | InitTable, pulses: Any, *, high_rate: int = 0,
          compiled: bool = False) -> MoveBatch:
    """The accel/decel moves of the given lengths, all at once, as flat segment arrays
    (what a verdict over many moves needs, without an `Execution` each). `compiled`:
    assembled by the compiled twin (`assemble_kernel`; for callers that load numba
    anyway)."""
    lengths = np.asarray(pulses, dtype=np.int64).reshape(-1)
    for n in (lengths.min(), lengths.max()) if len(lengths) else ():
        check_pulses(int(n))
    _, sides = move_model(table, high_rate)
    return sides.moves(lengths, compiled=compiled)


class FamilyBounds(NamedTuple):
    """The move families as arrays: family f runs lengths lo[f]..hi[f], shape index
    shape[f] (SHAPES), its shortest move is move first[f] of `batch` (the moves at every
    breakpoint), and `cruise_rate` is what a trapezoid cruises at."""

    lo: np.ndarray
    hi: np.ndarray
    shape: np.ndarray
    first: np.ndarray
    batch: MoveBatch
    cruise_rate: int


def families(table: FreeCurveTable | InitTable, *, high_rate: int = 0,
             compiled: bool = False) -> FamilyBounds:
    """`move_families` as arrays, without an object per family (what a verdict over every
    move length walks). `compiled`: found, when not yet, with the compiled assembly (as
    `moves`)."""
    sides = move_model(table, high_rate)[1]
    return sides.compiled_families() if compiled else sides.families


class _Split(NamedTuple):
    """A pair of sides cut into the stages both have and the rate-difference stages one
    side has beyond the other, with their pulse totals (computed once per move model)."""

    acc_extra: list[Stage]
    dec_extra: list[Stage]
    acc_shared: list[Stage]
    dec_shared: list[Stage]
    rate_diff: int      # pulses of the rate-difference stages
    a_total: int
    d_total: int
    a_sh: int           # pulses of the shared stages, accel side
    d_sh: int
    # acc, dec, then the five parts' stages: acc_extra, acc_shared, (cruise: none),
    # dec_shared, dec_extra
    ladders: tuple[_Ladder, ...]


def _split(acc: list[Stage], dec: list[Stage], shared: int, no_accel_level: int = 0) -> _Split:
    acc_extra = [s for s in acc if s[0] >= shared]
    dec_extra = [s for s in dec if s[0] >= shared]
    acc_shared = [s for s in acc if s[0] < shared]
    dec_shared = [s for s in dec if s[0] < shared]
    if no_accel_level:  # no acceleration: the cruise, then the decel stages slower than it
        parts = [[], [], [], [s for s in dec if s[1] > no_accel_level], []]
    else:
        parts = [acc_extra, acc_shared, [], dec_shared, dec_extra]
    return _Split(acc_extra, dec_extra, acc_shared, dec_shared,
                  sum(p for _, _, p in acc_extra) + sum(p for _, _, p in dec_extra),
                  sum(p for _, _, p in acc), sum(p for _, _, p in dec),
                  sum(p for _, _, p in acc_shared), sum(p for _, _, p in dec_shared),
                  tuple(_Ladder(side) for side in [acc, dec, *parts]))


class _Ladder:
    """Stages of one side ready to be run from their slow end: the first `count` pulses
    are the stages whose cumulative pulses stay below `count`, then part of the next."""

    def __init__(self, side: list[Stage]) -> None:
        slow_first = [(rate, p) for _, rate, p in reversed(side) if p]
        self.rates = np.asarray([r for r, _ in slow_first], dtype=np.int64)
        self.counts = np.asarray([p for _, p in slow_first], dtype=np.int64)
        self.cum = np.cumsum(self.counts)
        self.total = int(self.cum[-1]) if len(self.cum) else 0

    def take(self, count: np.ndarray, *, down: bool) -> tuple[np.ndarray, np.ndarray,
                                                             np.ndarray]:
        """For each move, its first (`down`: last) `count` pulses: per move the number of
        segments, and all moves' (rates, counts) in move order, each move's segments in
        running order (slowest first accelerating, fastest first decelerating)."""
        k = len(self.cum)
        count = np.maximum(count, 0)
        whole = np.searchsorted(self.cum, count, side="left")
        before = np.where(whole > 0, self.cum[np.maximum(whole - 1, 0)] if k else 0, 0)
        part = np.where(whole < k, count - before, 0)
        n = whole + (part > 0)
        total = int(n.sum())
        starts = np.cumsum(n) - n
        # slow-first index of each segment (< k: a move's partial stage is below `whole`)
        stage = (np.repeat(starts + n - 1, n) - np.arange(total) if down
                 else np.arange(total) - np.repeat(starts, n))
        counts = self.counts[stage]
        partial = part > 0  # its segment: the last of the move up, the first down
        counts[starts[partial] + (0 if down else whole[partial])] = part[partial]
        return n, self.rates[stage], counts


SHAPES: tuple[MoveShape, ...] = ("trapezoid", "triangle", "straight_triangle_decel",
                             "straight_triangle_accel")


def _assemble(pulses: np.ndarray, shape: np.ndarray, ladders: tuple[_Ladder, ...],
              x: tuple[np.ndarray, ...], cruise_rate: int, *, clamp: np.ndarray) -> MoveBatch:
    """Moves from their five parts' pulses `x` (accel, accel, cruise, decel, decel)."""
    moves = len(pulses)
    parts = []
    for i, (ladder, count) in enumerate(zip(ladders, x, strict=True)):
        if i == 2:  # the cruise: one segment when it has pulses
            n = (count > 0).astype(np.int64)
            parts.append((n, np.full(int(n.sum()), cruise_rate, np.int64), count[n > 0]))
        else:
            parts.append(ladder.take(count, down=i > 2))
    sizes = np.stack([n for n, _, _ in parts])           # (5, moves)
    per_move = sizes.sum(axis=0)
    offsets = np.concatenate(([0], np.cumsum(per_move)))
    total = int(offsets[-1])
    phase = np.empty(total, np.int8)
    rate = np.empty(total, np.int64)
    count = np.empty(total, np.int64)
    start = offsets[:-1] + np.concatenate((np.zeros((1, moves), np.int64),
                                           np.cumsum(sizes, axis=0)[:-1]))  # (5, moves)
    for i, (n, r, c) in enumerate(parts):
        dest = ranges(start[i], n)
        phase[dest] = 0 if i < 2 else (1 if i == 2 else 2)
        rate[dest] = r
        count[dest] = c
    accel = sizes[0] + sizes[1]
    clamped = clamp & (accel > 0)
    if clamped.any():
        # With LE=1 the split can end the accel below the stage the decel share starts
        # on; decelerating never speeds up, so those decel pulses run at the peak rate.
        firsts = offsets[:-1][clamped]
        peak = np.minimum.reduceat(rate[ranges(firsts, accel[clamped])],
                                   np.cumsum(accel[clamped]) - accel[clamped])
        decel = (sizes[3] + sizes[4])[clamped]
        down = ranges(offsets[1:][clamped] - decel, decel)
        rate[down] = np.maximum(rate[down], np.repeat(peak, decel))
    # a part at the same phase and rate as the one before (in the same move) joins it
    new = np.ones(total, bool)
    new[1:] = (phase[1:] != phase[:-1]) | (rate[1:] != rate[:-1])
    new[offsets[:-1][per_move > 0]] = True
    if not new.all():
        heads = np.flatnonzero(new)
        count = np.add.reduceat(count, heads)
        phase, rate = phase[heads], rate[heads]
        offsets = np.concatenate(([0], np.cumsum(new)))[offsets]
    return MoveBatch(pulses, shape, phase, rate, count, offsets)


def check_pulses(pulses: Any) -> None:
    if isinstance(pulses, bool) or not isinstance(pulses, int | np.integer) or \
            not 1 <= pulses <= MOVE_PULSES_MAX:
        raise MoveParameterError("pulses", pulses, 1, MOVE_PULSES_MAX, CHIP_BAD_PULSE_COUNT)

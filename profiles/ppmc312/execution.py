"""What the PPMC-312 runs for an accel/decel move (command 82): a model, per stage.

The chip walks a staircase of (rate, pulse count) stages. This module turns a
table and a move's pulse count into the segments the chip outputs, in exact
integer clock ticks (a segment of `pulses` at `rate` lasts `pulses × rate`
ticks), the response status it reports and the first-pulse latency
(manual §8-3, SPEC §1.6). It never iterates per pulse: a 0xFFFFFFFF-pulse move
is a handful of segments.

Shapes (choices where the manual is silent: docs/manual-notes.md):
- trapezoid, pulses ≥ accel total + decel total: accel stages slowest →
  fastest, cruise at the high rate, decel stages fastest → slowest.
- triangle, fewer pulses but ≥ the rate-difference pulses (the pulses of the
  stages one side has beyond the other, LE=1): the longer side runs its extra
  stages whole; the rest is split between the shared stages in the table's
  accel:decel ratio (accel share rounded down); accel runs the first pulses of
  its staircase, decel the last pulses of its staircase (the chip decelerates by
  pulses remaining: manual §8-8, "the decel point stays the same").
- straight triangle, fewer pulses than the rate-difference pulses: start →
  accel → stop (accel side longer: the first pulses of its extra stages) or
  start → decel → stop (decel side longer: the last pulses of its extra stages).
- high-rate override: a high rate slower than the accel side's 2nd stage cannot
  accelerate (straight triangle decel: the move runs at the slower of the high
  and start rates, then down the decel stages slower than that); otherwise the
  stages faster than the high rate are dropped and the cruise runs at it.

Time origin: t = 0 is the start of the first pulse's period; a pulse counts as
emitted at the END of its period, so `position_at(0) == 0` and the last pulse
lands exactly at `duration_s`. The first-pulse latency is reported apart.
"""

from __future__ import annotations

import functools
import io
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, NamedTuple

import numpy as np

from profiles.errors import FieldRangeError, MoveParameterError, require_int
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.table import RATE_FIELD_MAX, STAGE_COUNT_FIELD_MAX, FreeCurveTable, InitTable

Phase = Literal["accel", "cruise", "decel"]
MoveShape = Literal["trapezoid", "triangle", "straight_triangle_decel", "straight_triangle_accel"]

MOVE_PULSES_MAX = 0xFFFFFFFF
STATUS: dict[str, int] = {"trapezoid": 0x00, "triangle": 0x10,
                          "straight_triangle_decel": 0x20, "straight_triangle_accel": 0x40}
HELD_BY_RUN = 0x01
# Manual §8-3 table: time from the last parameter written to the first pulse.
LATENCY_S: dict[tuple[bool, bool], float] = {
    # (is_trapezoid, high_rate_given): seconds
    (True, False): 100e-6, (False, False): 700e-6,
    (True, True): 900e-6, (False, True): 1400e-6,
}
CHIP_RATE_OUT_OF_RANGE = 0x20   # parameter error: pulse rate setting out of range (§11-6)
CHIP_BAD_PULSE_COUNT = 0x23     # parameter error: the move's pulse count is wrong (§11-6)


@dataclass(frozen=True)
class Segment:
    """`pulses` pulses at divisor `rate`, starting `start_tick` clock ticks after t = 0."""

    phase: Phase
    rate: int
    pulses: int
    start_tick: int

    @property
    def ticks(self) -> int:
        return self.pulses * self.rate

    @property
    def end_tick(self) -> int:
        return self.start_tick + self.ticks


@dataclass(frozen=True)
class Execution:
    """One accel/decel move as the chip runs it (see the module docstring)."""

    shape: str
    status: int
    segments: list[Segment]
    pulses: int
    clock: Clock
    high_rate: int          # the rate the cruise would run at (after any override)
    high_rate_given: bool   # a non-zero high rate in the command (longer latency)
    held_by_run: bool = False
    ticks: int = field(init=False)
    _rate: np.ndarray = field(init=False, repr=False, compare=False)
    _count: np.ndarray = field(init=False, repr=False, compare=False)
    _start: np.ndarray = field(init=False, repr=False, compare=False)
    _before: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        rate = np.array([s.rate for s in self.segments], dtype=np.int64)
        count = np.array([s.pulses for s in self.segments], dtype=np.int64)
        ticks = rate * count
        start = np.concatenate([[0], np.cumsum(ticks)[:-1]]) if len(ticks) else ticks
        object.__setattr__(self, "ticks", int(ticks.sum()))
        object.__setattr__(self, "_rate", rate)
        object.__setattr__(self, "_count", count)
        # Ticks stay below 2**53 (0xFFFFFFFF × 0xFFFF ≈ 2.8e14): exact as float64.
        object.__setattr__(self, "_start", start.astype(float))
        object.__setattr__(self, "_before",
                           np.concatenate([[0], np.cumsum(count)[:-1]]) if len(count) else count)

    # --- summary ----------------------------------------------------------
    @property
    def duration_s(self) -> float:
        """From the start of the first pulse's period to the end of the last one."""
        return self.ticks / self.clock.hz

    @property
    def first_pulse_latency_s(self) -> float:
        return LATENCY_S[(self.shape == "trapezoid", self.high_rate_given)]

    @property
    def status_hex(self) -> str:
        return f"0x{self.status:02X}"

    # --- time queries (vectorised, per segment) ----------------------------
    def _locate(self, t_s: Any) -> tuple[np.ndarray, np.ndarray]:
        """Ticks since t = 0 (snapped to whole ticks when within float noise) and the
        index of the segment whose span [start, end) holds them (clipped to valid)."""
        ticks = np.asarray(t_s, dtype=float) * self.clock.hz
        whole = np.rint(ticks)
        # t = k / hz round-trips to k·(1 ± 2ε): snap it so exact pulse instants count.
        ticks = np.where(np.abs(ticks - whole) <= 4 * np.spacing(np.abs(ticks)), whole, ticks)
        idx = np.searchsorted(self._start, ticks, side="right") - 1
        return ticks, np.clip(idx, 0, max(len(self.segments) - 1, 0))

    def position_at(self, t_s: Any) -> np.ndarray:
        """Pulses emitted by time `t_s` (a pulse counts at the end of its period)."""
        ticks, idx = self._locate(t_s)
        if not self.segments:
            return np.zeros(np.shape(ticks), dtype=np.int64)
        within = np.floor((ticks - self._start[idx]) / self._rate[idx])
        within = np.clip(within, 0, self._count[idx])
        pos = self._before[idx] + within.astype(np.int64)
        pos = np.where(ticks <= 0, 0, pos)
        return np.where(ticks >= self.ticks, self.pulses, pos).astype(np.int64)

    def position_linear_at(self, t_s: Any) -> np.ndarray:
        """The staircase integrated continuously: linear within each segment, equal to
        `position_at` at every pulse instant and above it between them."""
        ticks, idx = self._locate(t_s)
        if not self.segments:
            return np.zeros(np.shape(ticks))
        within = np.clip((ticks - self._start[idx]) / self._rate[idx], 0, self._count[idx])
        pos = self._before[idx] + within
        pos = np.where(ticks <= 0, 0.0, pos)
        return np.where(ticks >= self.ticks, float(self.pulses), pos)

    def speed_at(self, t_s: Any) -> np.ndarray:
        """The staircase speed in pps: the running segment's clock.hz / rate, 0 outside
        [0, duration)."""
        ticks, idx = self._locate(t_s)
        if not self.segments:
            return np.zeros(np.shape(ticks))
        speed = self.clock.hz / self._rate[idx]
        return np.where((ticks >= 0) & (ticks < self.ticks), speed, 0.0)

    def segment_accel_pps2(self) -> np.ndarray:
        """Per segment: the slope from its start (time, speed) to the next segment's
        start, i.e. the finite difference of the staircase's stage starts; 0 for the
        last segment. The jumps from rest and back to rest are not included."""
        if not self.segments:
            return np.zeros(0)
        speed = self.clock.hz / self._rate
        dur = self._rate * self._count / self.clock.hz
        out = np.zeros(len(speed))
        out[:-1] = np.diff(speed) / np.where(dur[:-1] > 0, dur[:-1], np.inf)
        return out

    def sample(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """`n` equally spaced instants over [0, duration]: (t_s, pulses emitted, staircase
        speed_pps, accel_pps2 from `segment_accel_pps2`; 0 outside the move)."""
        t = np.linspace(0.0, self.duration_s, require_int("sample n", n, 2, 10**8))
        ticks, idx = self._locate(t)
        a = self.segment_accel_pps2()[idx] if self.segments else np.zeros(len(t))
        a = np.where((ticks >= 0) & (ticks < self.ticks), a, 0.0)
        return t, self.position_at(t), self.speed_at(t), a

    def edges(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The staircase's corners for step plots: (t_s, pulses emitted, speed_pps) at each
        segment start plus the end (the last speed repeated), against time or position."""
        hz = self.clock.hz
        starts = np.array([s.start_tick for s in self.segments] + [self.ticks], float)
        pulses = np.array([s.pulses for s in self.segments], float)
        speeds = hz / np.array([s.rate for s in self.segments], float)
        return starts / hz, np.concatenate([[0.0], np.cumsum(pulses)]), np.append(speeds,
                                                                                 speeds[-1])

    def pulse_times_s(self, limit: int = 10_000_000) -> np.ndarray:
        """The instant of every pulse (end of its period), built with repeat/cumsum.
        Refuses moves of more than `limit` pulses rather than exhausting memory."""
        if self.pulses > limit:
            raise FieldRangeError("move pulses with every pulse time listed (the limit)",
                                  self.pulses, 0, limit)
        period = np.repeat(self._rate, self._count)
        return np.cumsum(period) / self.clock.hz

    # --- output -------------------------------------------------------------
    def to_json(self) -> dict[str, Any]:
        return {"shape": self.shape, "status": self.status, "status_hex": self.status_hex,
                "held_by_run": self.held_by_run, "pulses": self.pulses,
                "clock": self.clock.to_json(), "high_rate": self.high_rate,
                "high_rate_given": self.high_rate_given, "ticks": self.ticks,
                "duration_s": self.duration_s,
                "first_pulse_latency_s": self.first_pulse_latency_s,
                "segments": [{"phase": s.phase, "rate": s.rate,
                              "speed_pps": self.clock.speed_pps(s.rate), "pulses": s.pulses,
                              "start_tick": s.start_tick, "end_tick": s.end_tick}
                             for s in self.segments]}


def to_csv(execution: Execution) -> str:
    """One line per segment: phase, rate, speed_pps, pulses, start/end tick and seconds."""
    out = io.StringIO()
    out.write("phase,rate,speed_pps,pulses,start_tick,end_tick,start_s,end_s\n")
    hz = execution.clock.hz
    for s in execution.segments:
        out.write(f"{s.phase},{s.rate},{execution.clock.speed_pps(s.rate)!r},{s.pulses},"
                  f"{s.start_tick},{s.end_tick},{s.start_tick / hz!r},{s.end_tick / hz!r}\n")
    return out.getvalue()


# --- the chip's move model ------------------------------------------------------

Stage = tuple[int, int, int]  # (index in the fastest-first lists, rate, pulses)
PhaseRuns = list[tuple[Phase, int, int]]


@dataclass(frozen=True)
class _Sides:
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
            from .assemble_kernel import assemble

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
        arrays, pinned by tests/profiles/ppmc312/test_assemble_kernel.py)."""
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


def _sides(table: FreeCurveTable | InitTable, high_rate: int) -> tuple[FreeCurveTable, _Sides]:
    if type(high_rate) is int:  # (tables are frozen, so hashable; other types are refused)
        return _known_sides(table, high_rate)
    return _new_sides(table, high_rate)


@functools.lru_cache(maxsize=16)
def _known_sides(table: FreeCurveTable | InitTable, high_rate: int
                 ) -> tuple[FreeCurveTable, _Sides]:
    """`_new_sides`, remembered: a verdict or a plan asks for the same table's moves
    several times (families, samples, refinements), each a few hundred µs to prepare."""
    return _new_sides(table, high_rate)


def forget_tables() -> None:
    """Forget the remembered move models (a benchmark times a table's first verdict)."""
    _known_sides.cache_clear()


def _new_sides(table: FreeCurveTable | InitTable, high_rate: Any
               ) -> tuple[FreeCurveTable, _Sides]:
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
        return table, _Sides(acc, dec, max(high_rate, acc[-1][1]), True, True, shared)
    if given:  # stages faster than the high rate are never reached
        acc = [s for s in acc if s[1] >= high_rate]
        dec = [s for s in dec if s[1] >= high_rate]
    return table, _Sides(acc, dec, high_rate if given else rates[0], given, False, shared)


def simulate_move(table: FreeCurveTable | InitTable, pulses: int, *, high_rate: int = 0,
                  held_by_run: bool = False) -> Execution:
    """The accel/decel move (82) of `pulses` pulses with `table` loaded.

    `high_rate` 0 runs the table's fastest stage; otherwise it must lie within the
    table's rate range. `held_by_run` (RUN low at the start) adds 1 to the status.
    """
    _check_pulses(pulses)
    table, sides = _sides(table, high_rate)
    return _execute(table, sides, int(pulses), held_by_run)


def simulate_moves(table: FreeCurveTable | InitTable, pulses: Sequence[int], *,
                   high_rate: int = 0) -> list[Execution]:
    """`simulate_move` for each of several lengths, their segments assembled at once (a
    move alone costs most of that)."""
    for n in pulses:
        _check_pulses(n)
    free, sides = _sides(table, high_rate)
    batch = sides.moves(np.asarray(pulses, dtype=np.int64).reshape(-1))
    return [_execution(free, sides, int(n), SHAPES[int(batch.shape[e])], batch.runs(e))
            for e, n in enumerate(pulses)]


def moves(table: FreeCurveTable | InitTable, pulses: Any, *, high_rate: int = 0,
          compiled: bool = False) -> MoveBatch:
    """The accel/decel moves of the given lengths, all at once, as flat segment arrays
    (what a verdict over many moves needs, without an `Execution` each). `compiled`:
    assembled by the compiled twin (`assemble_kernel`; for callers that load numba
    anyway)."""
    lengths = np.asarray(pulses, dtype=np.int64).reshape(-1)
    for n in (lengths.min(), lengths.max()) if len(lengths) else ():
        _check_pulses(int(n))
    _, sides = _sides(table, high_rate)
    return sides.moves(lengths, compiled=compiled)


def _execute(table: FreeCurveTable, sides: _Sides, pulses: int,
             held_by_run: bool = False) -> Execution:
    return _execution(table, sides, pulses, *sides.runs(pulses), held_by_run)


def _execution(table: FreeCurveTable, sides: _Sides, pulses: int, shape: MoveShape, runs: PhaseRuns,
               held_by_run: bool = False) -> Execution:
    segments: list[Segment] = []
    tick = 0
    for phase, rate, count in runs:
        segments.append(Segment(phase, rate, count, tick))
        tick += rate * count
    status = STATUS[shape] + (HELD_BY_RUN if held_by_run else 0)
    return Execution(shape=shape, status=status, segments=segments, pulses=pulses,
                     clock=table.clock, high_rate=sides.cruise_rate, high_rate_given=sides.given,
                     held_by_run=bool(held_by_run))


@dataclass(frozen=True)
class MoveFamily:
    """The move lengths `lo`..`hi` for which the chip runs the same sequence of segment
    rates with one table (only partial stages and the cruise change length). The
    families of a table partition 1..0xFFFFFFFF; see `move_families`."""

    table: FreeCurveTable
    high_rate: int
    lo: int
    hi: int
    shape: str
    _sides: _Sides = field(repr=False, compare=False)
    _batch: MoveBatch = field(repr=False, compare=False)  # the families' shortest moves
    _index: int = field(repr=False, compare=False)        # this family's move in it

    def execution(self, pulses: int | None = None) -> Execution:
        """The move of `pulses` (default: the shortest of the family)."""
        n = self.lo if pulses is None else int(pulses)
        if not self.lo <= n <= self.hi:
            raise FieldRangeError("move pulses of this family", n, self.lo, self.hi)
        return _execute(self.table, self._sides, n)

    def runs(self, pulses: int | None = None) -> PhaseRuns:
        """The segments of a move of the family as (phase, rate, pulses), without building
        an `Execution` (what the criterion needs)."""
        if pulses is None or int(pulses) == self.lo:
            return self._batch.runs(self._index)
        return self._sides.runs(int(pulses))[1]

    def __contains__(self, pulses: object) -> bool:
        return isinstance(pulses, int) and self.lo <= pulses <= self.hi

    @property
    def cruise_rate(self) -> int:
        """The rate a trapezoid of the family cruises at (after any high-rate override)."""
        return self._sides.cruise_rate


def move_families(table: FreeCurveTable | InitTable, *, high_rate: int = 0) -> list[MoveFamily]:
    """Every distinct execution the chip can produce with `table` for move lengths
    1..0xFFFFFFFF (trapezoid, each triangle switch, straight triangles), found from the
    stage boundaries, never by iterating lengths. Ascending and contiguous."""
    free, sides = _sides(table, high_rate)
    bounds = sides.families
    return [MoveFamily(free, high_rate, lo, hi, SHAPES[shape], sides, bounds.batch, e)
            for lo, hi, shape, e in zip(bounds.lo.tolist(), bounds.hi.tolist(),
                                        bounds.shape.tolist(), bounds.first.tolist(),
                                        strict=True)]


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
    sides = _sides(table, high_rate)[1]
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


PHASE_CODES = {"accel": 0, "cruise": 1, "decel": 2}
PHASES: tuple[Phase, ...] = ("accel", "cruise", "decel")
SHAPES: tuple[MoveShape, ...] = ("trapezoid", "triangle", "straight_triangle_decel",
                             "straight_triangle_accel")


@dataclass(frozen=True)
class MoveBatch:
    """Moves of several lengths as flat segment arrays: move e is the segments
    offsets[e]..offsets[e+1] of (phase, rate, count); phase indexes PHASES, shape
    SHAPES."""

    pulses: np.ndarray
    shape: np.ndarray
    phase: np.ndarray
    rate: np.ndarray
    count: np.ndarray
    offsets: np.ndarray

    def __len__(self) -> int:
        return len(self.pulses)

    def runs(self, e: int) -> PhaseRuns:
        """Move e's segments as (phase, rate, pulses)."""
        a, b = int(self.offsets[e]), int(self.offsets[e + 1])
        return [(PHASES[f], r, c) for f, r, c in zip(self.phase[a:b].tolist(),
                                                     self.rate[a:b].tolist(),
                                                     self.count[a:b].tolist(), strict=True)]

    def repeats(self) -> np.ndarray:
        """For each move, whether it has the shape and the sequence of (phase, rate) of
        the move before it (only the segments' counts differ)."""
        size = np.diff(self.offsets)
        same = np.zeros(len(size), bool)
        same[1:] = (size[1:] == size[:-1]) & (self.shape[1:] == self.shape[:-1])
        alike = np.flatnonzero(same & (size > 0))
        if len(alike):
            n = size[alike]
            rows = _ranges(self.offsets[alike], n)
            before = rows - np.repeat(n, n)  # the same segment of the move before
            differ = (self.rate[rows] != self.rate[before]) | \
                (self.phase[rows] != self.phase[before])
            same[alike] = ~np.logical_or.reduceat(differ, np.cumsum(n) - n)
        return same


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
        dest = _ranges(start[i], n)
        phase[dest] = 0 if i < 2 else (1 if i == 2 else 2)
        rate[dest] = r
        count[dest] = c
    accel = sizes[0] + sizes[1]
    clamped = clamp & (accel > 0)
    if clamped.any():
        # With LE=1 the split can end the accel below the stage the decel share starts
        # on; decelerating never speeds up, so those decel pulses run at the peak rate.
        firsts = offsets[:-1][clamped]
        peak = np.minimum.reduceat(rate[_ranges(firsts, accel[clamped])],
                                   np.cumsum(accel[clamped]) - accel[clamped])
        decel = (sizes[3] + sizes[4])[clamped]
        down = _ranges(offsets[1:][clamped] - decel, decel)
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


def _ranges(starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """The indices starts[i] .. starts[i] + lengths[i] − 1, concatenated."""
    return np.repeat(starts - np.cumsum(lengths) + lengths, lengths) + np.arange(lengths.sum())


def _check_pulses(pulses: Any) -> None:
    if isinstance(pulses, bool) or not isinstance(pulses, int | np.integer) or \
            not 1 <= pulses <= MOVE_PULSES_MAX:
        raise MoveParameterError("pulses", pulses, 1, MOVE_PULSES_MAX, CHIP_BAD_PULSE_COUNT)


# --- CSV files of a move (`stepramp simulate --pulse-times / --samples`) ---------

PULSE_TIMES_CSV_MAX = 10_000_000  # one row per pulse: ~200 MB of text at this size


def pulse_times_csv(execution: Execution) -> str:
    """Every pulse's time as CSV `pulse,time_s` (pulse numbered from 1, ns resolution);
    refuses moves of more than PULSE_TIMES_CSV_MAX pulses (one row each)."""
    return "".join(pulse_times_csv_chunks(execution))


def pulse_times_csv_chunks(execution: Execution, chunk: int = 1 << 16) -> Iterator[str]:
    """`pulse_times_csv` in pieces of at most `chunk` rows, computed segment by segment
    (pulse k of a segment ends at start_tick + k·rate ticks), so memory does not grow with
    the move; the limit is checked before the first piece."""
    if execution.pulses > PULSE_TIMES_CSV_MAX:
        raise FieldRangeError("pulses (one CSV row per pulse)", execution.pulses, 1,
                              PULSE_TIMES_CSV_MAX)
    yield "pulse,time_s\n"
    hz, number = execution.clock.hz, 1
    for s in execution.segments:
        for k0 in range(0, s.pulses, chunk):
            k = np.arange(k0 + 1, min(s.pulses, k0 + chunk) + 1, dtype=np.int64)
            times = (s.start_tick + k * s.rate) / hz
            yield "".join(f"{n},{t:.9f}\n" for n, t in enumerate(times.tolist(), number))
            number += len(k)


def samples_csv(execution: Execution, n: int = 1000) -> str:
    """The staircase sampled at `n` points as CSV `t_s,x_pulses,v_pps,a_pps2`."""
    t, x, v, a = execution.sample(n)
    return "t_s,x_pulses,v_pps,a_pps2\n" + "".join(
        f"{ti:.9f},{xi:.6f},{vi:.6f},{ai:.6f}\n" for ti, xi, vi, ai in zip(t, x, v, a,
                                                                           strict=True))

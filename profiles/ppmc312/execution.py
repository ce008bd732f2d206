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

import io
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from profiles.errors import FieldRangeError, require_int
from profiles.motor.batch import MoveBatch, Phase, PhaseRuns
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.move_batch import (
    SHAPES,
    MoveModel,
    MoveShape,
    check_pulses,
    move_model,
)
from profiles.ppmc312.table import FreeCurveTable, InitTable

STATUS: dict[str, int] = {"trapezoid": 0x00, "triangle": 0x10,
                          "straight_triangle_decel": 0x20, "straight_triangle_accel": 0x40}
HELD_BY_RUN = 0x01
# Manual §8-3 table: time from the last parameter written to the first pulse.
LATENCY_S: dict[tuple[bool, bool], float] = {
    # (is_trapezoid, high_rate_given): seconds
    (True, False): 100e-6, (False, False): 700e-6,
    (True, True): 900e-6, (False, True): 1400e-6,
}


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


def simulate_move(table: FreeCurveTable | InitTable, pulses: int, *, high_rate: int = 0,
                  held_by_run: bool = False) -> Execution:
    """The accel/decel move (82) of `pulses` pulses with `table` loaded.

    `high_rate` 0 runs the table's fastest stage; otherwise it must lie within the
    table's rate range. `held_by_run` (RUN low at the start) adds 1 to the status.
    """
    check_pulses(pulses)
    table, model = move_model(table, high_rate)
    return _execute(table, model, int(pulses), held_by_run)


def simulate_moves(table: FreeCurveTable | InitTable, pulses: Sequence[int], *,
                   high_rate: int = 0) -> list[Execution]:
    """`simulate_move` for each of several lengths, their segments assembled at once (a
    move alone costs most of that)."""
    for n in pulses:
        check_pulses(n)
    free, model = move_model(table, high_rate)
    batch = model.moves(np.asarray(pulses, dtype=np.int64).reshape(-1))
    return [_execution(free, model, int(n), SHAPES[int(batch.shape[e])], batch.runs(e))
            for e, n in enumerate(pulses)]


def _execute(table: FreeCurveTable, model: MoveModel, pulses: int,
             held_by_run: bool = False) -> Execution:
    return _execution(table, model, pulses, *model.runs(pulses), held_by_run)


def _execution(table: FreeCurveTable, model: MoveModel, pulses: int, shape: MoveShape,
               runs: PhaseRuns, held_by_run: bool = False) -> Execution:
    segments: list[Segment] = []
    tick = 0
    for phase, rate, count in runs:
        segments.append(Segment(phase, rate, count, tick))
        tick += rate * count
    status = STATUS[shape] + (HELD_BY_RUN if held_by_run else 0)
    return Execution(shape=shape, status=status, segments=segments, pulses=pulses,
                     clock=table.clock, high_rate=model.cruise_rate, high_rate_given=model.given,
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
    _model: MoveModel = field(repr=False, compare=False)
    _batch: MoveBatch = field(repr=False, compare=False)  # the families' shortest moves
    _index: int = field(repr=False, compare=False)        # this family's move in it

    def execution(self, pulses: int | None = None) -> Execution:
        """The move of `pulses` (default: the shortest of the family)."""
        n = self.lo if pulses is None else int(pulses)
        if not self.lo <= n <= self.hi:
            raise FieldRangeError("move pulses of this family", n, self.lo, self.hi)
        return _execute(self.table, self._model, n)

    def runs(self, pulses: int | None = None) -> PhaseRuns:
        """The segments of a move of the family as (phase, rate, pulses), without building
        an `Execution` (what the criterion needs)."""
        if pulses is None or int(pulses) == self.lo:
            return self._batch.runs(self._index)
        return self._model.runs(int(pulses))[1]

    def __contains__(self, pulses: object) -> bool:
        return isinstance(pulses, int) and self.lo <= pulses <= self.hi

    @property
    def cruise_rate(self) -> int:
        """The rate a trapezoid of the family cruises at (after any high-rate override)."""
        return self._model.cruise_rate


def move_families(table: FreeCurveTable | InitTable, *, high_rate: int = 0) -> list[MoveFamily]:
    """Every distinct execution the chip can produce with `table` for move lengths
    1..0xFFFFFFFF (trapezoid, each triangle switch, straight triangles), found from the
    stage boundaries, never by iterating lengths. Ascending and contiguous."""
    free, model = move_model(table, high_rate)
    bounds = model.families
    return [MoveFamily(free, high_rate, lo, hi, SHAPES[shape], model, bounds.batch, e)
            for lo, hi, shape, e in zip(bounds.lo.tolist(), bounds.hi.tolist(),
                                        bounds.shape.tolist(), bounds.first.tolist(),
                                        strict=True)]


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

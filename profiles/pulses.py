"""Pulse trains: an axis's pulse instants as pieces, and the joint path's distance from
the straight line in bounded memory and time, however many pulses an axis makes.

A move of 4 294 967 295 pulses has as many instants: one float each would be 34 GB. A
`PulseTrain` holds them as pieces instead: a run of pulses whose instants a formula
gives (pulse k → t [s]), with its exact period when the run is at one constant speed (a
chip's segment, an A-Link cruise). `line_deviation` merges the trains a chunk at a time
(at most `CHUNK` pulses an axis in memory) and steps over a long stretch where every
axis runs at constant speed by their joint period (`_skip`), so its work grows with the
ramps and the pieces, not with the cruise.

Why the step is exact. Over a stretch where axis i pulses every p_i seconds, let L be a
common multiple of every p_i: shifting an instant by L adds exactly s_i = L/p_i pulses
to every axis, so the distance vector from the line (`P·x`, P the projection off the
line) changes by the constant m·P·s after m periods. A norm is convex, so over m it is
largest at the first or the last period: the exact maximum over the stretch is the one
over its first and its last periods, which are evaluated pulse by pulse. Only when the
joint period holds more than `WINDOW_MAX` pulses (periods without a small common
multiple: an external clock, many axes at unrelated speeds) is the middle bounded from
above instead (`_vertex_bound`): each count lies within one pulse below its constant-
speed line, and the largest distance of that box is at one of its corners.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from fractions import Fraction
from itertools import pairwise, product

import numpy as np

CHUNK = 1 << 20        # pulses of one axis merged at a time
WINDOW_MAX = 1 << 21   # pulses of a joint period evaluated exactly, at most
TRACE_MAX = 1 << 21    # moves of at most this many pulses keep every instant in the trace
TRACE_BINS = 1024      # longer moves keep, per chunk, the farthest instant of each bin

Times = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Piece:
    """Pulses `first`..`first + count − 1` (numbered from 1 in the whole train), their
    instants by `time_s` (global pulse numbers → seconds, non-decreasing), and the exact
    period [s] when the piece runs at one constant speed."""

    first: int
    count: int
    time_s: Times
    period_s: Fraction | None = None

    @property
    def last(self) -> int:
        return self.first + self.count - 1


class PulseTrain:
    """One axis's pulse instants, piece by piece (pieces in order, numbered without gaps)."""

    def __init__(self, pieces: Sequence[Piece]) -> None:
        self.pieces = tuple(p for p in pieces if p.count > 0)
        self._firsts = np.array([p.first for p in self.pieces], dtype=np.int64)
        self.count = self.pieces[-1].last if self.pieces else 0

    @classmethod
    def of_instants(cls, times: np.ndarray) -> PulseTrain:
        """A train of explicit, sorted instants (one piece, no period)."""
        t = np.asarray(times, dtype=float)
        return cls([Piece(1, len(t), lambda k: t[k - 1])])

    def piece_at(self, k: int) -> Piece:
        return self.pieces[int(np.searchsorted(self._firsts, k, side="right")) - 1]

    def time_of(self, k: np.ndarray) -> np.ndarray:
        """The instants of pulses `k` (numbers 1..count)."""
        k = np.asarray(k, dtype=np.int64)
        which = np.searchsorted(self._firsts, k, side="right") - 1
        out = np.empty(k.shape, dtype=float)
        for j in np.unique(which):
            sel = which == j
            out[sel] = self.pieces[j].time_s(k[sel])
        return out

    def times(self, first: int, last: int) -> np.ndarray:
        """The instants of pulses first..last (a sorted run: piece by piece, no search)."""
        if last < first:
            return np.zeros(0)
        lo = int(np.searchsorted(self._firsts, first, side="right")) - 1
        hi = int(np.searchsorted(self._firsts, last, side="right"))
        return np.concatenate([p.time_s(np.arange(max(first, p.first), min(last, p.last) + 1,
                                                  dtype=np.int64))
                               for p in self.pieces[lo:hi]])

    def emitted(self, t: np.ndarray) -> np.ndarray:
        """Pulses emitted by each instant of `t` (instant ≤ t), by bisection over pulse
        numbers: nothing is listed."""
        t = np.asarray(t, dtype=float)
        lo = np.zeros(t.shape, dtype=np.int64)           # emitted ≥ lo
        hi = np.full(t.shape, self.count, dtype=np.int64)  # emitted ≤ hi
        while (open_ := lo < hi).any():
            mid = (lo + hi + 1) // 2
            ok = np.zeros(t.shape, dtype=bool)
            ok[open_] = self.time_of(mid[open_]) <= t[open_]
            lo = np.where(open_ & ok, mid, lo)
            hi = np.where(open_ & ~ok, mid - 1, hi)
        return lo


def as_train(x: PulseTrain | np.ndarray) -> PulseTrain:
    return x if isinstance(x, PulseTrain) else PulseTrain.of_instants(np.asarray(x))


def line_deviation(trains: Sequence[PulseTrain | np.ndarray]
                   ) -> tuple[float, np.ndarray, np.ndarray]:
    """(largest distance, instants, distance at each instant) between the joint path as the
    axes pulse and the straight line from the start to the end point, in pulses (each
    axis's pulse one unit), over every instant any axis pulses (and t = 0). The trace holds
    every instant for moves of up to `TRACE_MAX` pulses, else the farthest instant of each
    of `TRACE_BINS` bins per chunk. See the module doc for how long moves stay bounded."""
    run = _Merge([as_train(x) for x in trains])
    while (run.done < run.n).any():
        if not run.skip():
            run.chunk(run.limit())
    t, d = run.trace()
    return run.best, t, d


class _Merge:
    """The state of one merge: pulses done per axis, the instant reached, the trace."""

    def __init__(self, trains: list[PulseTrain]) -> None:
        self.trains = trains
        self.n = np.array([t.count for t in trains], dtype=np.int64)
        norm = float(np.linalg.norm(self.n.astype(float)))
        self.u = self.n / norm if norm else np.zeros(len(trains))
        self.done = np.zeros(len(trains), dtype=np.int64)
        self.now = 0.0
        self.best = 0.0
        self.full = int(self.n.sum()) <= TRACE_MAX
        self.t_parts: list[np.ndarray] = [np.zeros(1)]
        self.d_parts: list[np.ndarray] = [np.zeros(1)]

    def active(self) -> list[int]:
        return [i for i in range(len(self.trains)) if self.done[i] < self.n[i]]

    def limit(self) -> float:
        """The instant by which every active axis has made at most CHUNK more pulses."""
        return min(float(self.trains[i].time_of(np.array([min(self.done[i] + CHUNK,
                                                               self.n[i])]))[0])
                   for i in self.active())

    def distance(self, x: list[np.ndarray]) -> np.ndarray:
        """Distance from the line of the joint states whose counts are the columns `x`: the
        component off the line, never a difference of squares (that cancels at 1e6
        pulses); for two axes the cross product with the line's direction."""
        u = self.u
        if len(x) == 2:
            return np.abs(x[0] * u[1] - x[1] * u[0])
        along = sum(xi * ui for xi, ui in zip(x, u, strict=True))
        return np.sqrt(sum((xi - along * ui) ** 2 for xi, ui in zip(x, u, strict=True)))

    def chunk(self, lim: float) -> None:
        """Every pulse up to instant `lim`, pulse by pulse: the axes' sorted runs merged
        (a stable sort of sorted runs is a merge), each instant once with every pulse at
        it counted."""
        ends = [int(tr.emitted(np.array([lim]))[0]) if self.done[i] < self.n[i]
                else int(self.done[i]) for i, tr in enumerate(self.trains)]
        runs = [tr.times(int(self.done[i]) + 1, ends[i]) for i, tr in enumerate(self.trains)]
        merged = np.concatenate(runs)
        order = np.argsort(merged, kind="stable")
        t = merged[order]
        axis = np.repeat(np.arange(len(runs), dtype=np.int32), [len(r) for r in runs])[order]
        last = np.ones(len(t), dtype=bool)  # the last of equal instants carries the counts
        last[:-1] = t[1:] != t[:-1]
        x = [float(self.done[i]) + np.cumsum(axis == i)[last] for i in range(len(runs))]
        t = t[last]
        d = self.distance(x)
        if len(d):
            self.best = max(self.best, float(d.max()))
            self._record(t, d)
        self.done = np.array(ends, dtype=np.int64)
        self.now = max(self.now, lim)

    def _record(self, t: np.ndarray, d: np.ndarray) -> None:
        if not self.full and len(t) > TRACE_BINS:
            edges = np.linspace(0, len(t), TRACE_BINS + 1).astype(np.int64)
            pick = np.array([a + int(np.argmax(d[a:b])) for a, b in pairwise(edges)
                             if b > a])
            t, d = t[pick], d[pick]
        self.t_parts.append(t)
        self.d_parts.append(d)

    def skip(self) -> bool:
        """Step over a long stretch where every active axis runs at constant speed (see
        the module doc); False when there is none worth stepping over."""
        active = self.active()
        pieces = [self.trains[i].piece_at(int(self.done[i]) + 1) for i in active]
        periods = [p.period_s for p in pieces]
        if any(p is None or p <= 0 for p in periods):
            return False
        per = [p for p in periods if p is not None]
        horizon = min(float(self.trains[i].time_of(np.array([p.last]))[0])
                      for i, p in zip(active, pieces, strict=True))
        rate = sum(1.0 / float(p) for p in per)  # pulses per second, all axes
        if (horizon - self.now) * rate < 8 * CHUNK:
            return False
        joint = _lcm(per)
        shifts = [int(joint / p) for p in per]
        if sum(shifts) > WINDOW_MAX:
            return self._bound(active, pieces, horizon, rate)
        # start where every axis's previous pulse is behind: its progression covers all
        start = max(self.now, *(float(self.trains[i].time_of(np.array([self.done[i] + 1]))[0])
                                - float(p) for i, p in zip(active, per, strict=True)))
        period = float(joint)
        windows = math.floor((horizon - start) / period) - 2
        if windows < 2:
            return False
        self.chunk(start)
        self.chunk(start + period)  # the first joint period, pulse by pulse
        for i, s in zip(active, shifts, strict=True):
            self.done[i] += windows * s
        self.now = start + (windows + 1) * period  # the last periods come pulse by pulse
        return True

    def _bound(self, active: list[int], pieces: list[Piece], horizon: float,
               rate: float) -> bool:
        """The middle of a constant-speed stretch whose joint period is too long: the
        first and last chunk pulse by pulse, the rest bounded from above."""
        self.chunk(self.limit())
        t0 = self.now
        t1 = horizon - CHUNK / rate
        if t1 <= t0:
            return True
        nxt = [float(self.trains[i].time_of(np.array([self.done[i] + 1]))[0]) for i in active]
        per = [float(p.period_s) for p in pieces if p.period_s is not None]
        self.best = max(self.best, _vertex_bound(self.done.astype(float), self.u, active,
                                                 nxt, per, t0, t1))
        ends = [int(self.trains[i].emitted(np.array([t1]))[0]) for i in active]
        for i, e in zip(active, ends, strict=True):
            self.done[i] = e
        self.now = t1
        return True

    def trace(self) -> tuple[np.ndarray, np.ndarray]:
        return np.concatenate(self.t_parts), np.concatenate(self.d_parts)


def _lcm(periods: Sequence[Fraction]) -> Fraction:
    """The least common multiple of positive rationals (lcm of numerators over gcd of
    denominators, each in lowest terms)."""
    num, den = 1, 0
    for p in periods:
        num = num * p.numerator // math.gcd(num, p.numerator)
        den = math.gcd(den, p.denominator)
    return Fraction(num, den)


def _vertex_bound(done: np.ndarray, u: np.ndarray, active: list[int], nxt: list[float],
                  per: list[float], t0: float, t1: float) -> float:
    """The largest distance from the line any joint state over [t0, t1] can have when
    each active axis i, next pulse at nxt[i] after `done[i]` pulses, pulses every per[i]:
    its count lies in (A_i(t) − 1, A_i(t)], A_i(t) = done_i + 1 + (t − nxt_i)/per_i; the
    distance is convex in (t, the offsets), so its maximum is at a corner."""
    best = 0.0
    for t in (t0, t1):
        base = done.copy()
        for i, q, p in zip(active, nxt, per, strict=True):
            base[i] += 1 + (t - q) / p
        corners = np.array(list(product((0.0, 1.0), repeat=len(active))))
        x = np.tile(base, (len(corners), 1))
        x[:, active] -= corners
        resid = x - np.outer(x @ u, u)
        best = max(best, float(np.sqrt(np.sum(resid * resid, axis=1)).max()))
    return best

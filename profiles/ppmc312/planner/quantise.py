"""Quantising a continuous reference (ruckig, toppra) into a free-curve table.

The table's executed move never runs ahead of the reference: every step i lands
no earlier than the reference's time for it, τ(i). How late the steps land is
reported in the terms Klipper uses for its step compression (it holds every
step within [τ − 25 µs, τ]); a ≤ 127-stage staircase cannot reach that, but it
recovers lag instead of accumulating it. The algorithm is described in
docs/manual-notes.md (planner section).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import FieldRangeError, PlanError
from ...result import PlanResult
from ..clock import MAX_OUTPUT_PPS, Clock
from ..execution import simulate_move
from ..limits import (
    MIN_STAGE_TICKS,
    RATE_MAX,
    RATE_MIN,
    SIDE_TOTAL_MAX,
    STAGE_PULSES_MAX,
    STAGE_PULSES_MIN,
    STAGES_MIN,
)
from ..table import FreeCurveTable
from .problem import check_plan_args

QUANTISE_MAX_PULSES = 10_000_000  # the quantiser keeps a few float arrays of one entry per pulse
_EPS_TICKS = 1e-6      # float slack of the internal "never early" test, in clock ticks
_SCAN_FIRST = 64       # first chunk of a forward scan (chunks then grow ×4)
_TARGETS = np.geomspace(2e-6, 0.1, 14)  # lateness targets tried, × the reference's duration
_REFINE = 8            # targets tried between the best one's grid neighbours
_INSERTS = 6           # stages put in for the decel per target at most
_FLOORS = 4            # the decel may end on any of the accel's slowest _FLOORS stages


@dataclass
class _Stage:
    rate: int
    start: int   # pulses emitted before the stage's first pulse
    t0: int      # staircase time of that point, clock ticks
    count: int


@dataclass
class _Quantised:
    rates: np.ndarray     # slowest first (K)
    acc: np.ndarray       # accel counts, slowest first (K), the top's = its chip minimum
    dec: np.ndarray       # decel counts, fastest first (K_d ≤ K, the top's first)
    cruise: int
    late_ticks: np.ndarray  # lateness of every pulse vs the reference, clock ticks
    target_ticks: float
    stages: list[_Stage]  # the accel staircase it came from
    decel: _Decel
    floor: int            # the decel's slowest stage (slow-first index)


def quantise_reference(t_s: Any, x_pulses: Any, v_pps: Any, *, clock: Clock,
                       max_stages: int = 127) -> PlanResult[FreeCurveTable]:
    """A staircase table that never runs ahead of a sampled rest-to-rest reference.

    The reference is its samples with linear position between them (as
    `Reference.position_at`); τ(i) is the first time it reaches position i, and the
    move is round(x_end − x_0) pulses. The table's trapezoid (see verify/simulate.py)
    emits every pulse i at T(i) ≥ τ(i). Accel side: from the staircase's point, the
    fastest integer rate that keeps every pulse of the stage at or after τ (the tangent
    from the point to the reference) run while the lateness stays within a target, then
    the next stage. Decel side (same rates): each stage, from the top down, runs as long
    as the slowest legal completion (every lower stage at its chip minimum) still never
    runs ahead. The target is searched for the smallest worst-step lateness. v_pps is
    only checked for shape: positions define the reference.

    `extras`: `max_step_error_us` and `mean_step_error_us` (how late the steps land),
    `end_lag_us` (how late the last pulse lands).
    """
    started = time.perf_counter()
    check_plan_args(max_stages, None)
    t, x, v = (np.asarray(a, dtype=float) for a in (t_s, x_pulses, v_pps))
    for name, arr in (("t_s", t), ("x_pulses", x), ("v_pps", v)):
        if arr.ndim != 1 or len(arr) != len(t) or len(arr) < 2 or not np.all(np.isfinite(arr)):
            raise PlanError(f"{name}: expected a finite 1-D array as long as t_s (≥ 2 samples)")
    if np.any(np.diff(t) < 0) or t[-1] <= t[0]:
        raise PlanError("t_s: sample times must not decrease and must span a time")
    if np.any(np.diff(x) < -1e-6 * max(1.0, abs(x[-1]))):
        raise PlanError("x_pulses: the reference moves backwards; give one rest-to-rest move")
    xm = np.maximum.accumulate(x - x[0])
    total = round(float(xm[-1]))
    if not 8 <= total <= QUANTISE_MAX_PULSES:
        raise FieldRangeError("x_pulses (move length)", total, 8, QUANTISE_MAX_PULSES)
    hz = clock.hz
    tau = _first_reach(t - t[0], xm, total) * hz  # clock ticks
    # The slowest staircase (every pulse at rate 0xFFFF) is the latest possible: if even
    # it runs ahead somewhere, no table on this clock can follow the reference.
    slowest = np.arange(total + 1, dtype=float) * RATE_MAX
    ahead = np.flatnonzero(slowest < tau - _EPS_TICKS)
    if len(ahead):
        i = int(ahead[0])
        raise PlanError(f"clock {clock.name}: the reference reaches pulse {i} only at "
                        f"{tau[i] / hz:.4g} s, slower than rate {RATE_MAX} runs "
                        f"({hz / RATE_MAX:.4g} pps); use a slower clock")
    r_fast = max(RATE_MIN, math.ceil(hz / MAX_OUTPUT_PPS - 1e-9))
    targets = list(_TARGETS * tau[-1])
    found = {i: _quantise_for(tau, lt, max_stages, r_fast) for i, lt in enumerate(targets)}
    scored = [(*_score(q), i) for i, q in found.items() if q is not None]
    if not scored:
        raise PlanError("no legal staircase follows this reference without running ahead "
                        "(each stage needs 2 pulses and 256 clock ticks on both sides); give a "
                        "longer move or a slower clock")
    b = min(scored)[2]
    best = next(q for i, q in found.items() if i == b and q is not None)
    lo, hi = targets[max(b - 1, 0)], targets[min(b + 1, len(targets) - 1)]
    for lt in np.geomspace(lo, hi, _REFINE + 2)[1:-1]:
        q = _quantise_for(tau, float(lt), max_stages, r_fast)
        if q is not None and _score(q) < _score(best):
            best = q
    return _quantised_plan(best, clock, total, max_stages, started)


def _quantised_plan(q: _Quantised, clock: Clock, total: int, max_stages: int,
                    started: float) -> PlanResult[FreeCurveTable]:

    late_s = q.late_ticks / clock.hz
    if late_s.min() < -1e-9:  # the construction guarantees it; refuse rather than run ahead
        raise PlanError(f"internal: pulse {int(late_s.argmin()) + 1} would run "
                        f"{-late_s.min() * 1e6:.3g} µs ahead of the reference")
    acc = tuple(int(c) for c in q.acc[::-1])
    dec = tuple(int(c) for c in q.dec)
    sep = acc != dec
    table = FreeCurveTable(clock, tuple(int(r) for r in q.rates[::-1]), acc, dec if sep else None)
    worst, mean, end = float(late_s.max()), float(late_s.mean()), float(late_s[-1])
    info = (f"quantised {total} pulses into {len(acc)} stages (decel uses {len(dec)}, "
            f"LE={int(sep)}), accel {sum(acc)} + cruise {q.cruise} + decel {sum(dec)} pulses; "
            f"never ahead of the reference; worst step {worst * 1e6:.4g} µs late (pulse "
            f"{int(late_s.argmax()) + 1}), mean {mean * 1e6:.4g} µs, behind the reference by "
            f"{end * 1e3:.4g} ms at the end (accel lateness target "
            f"{q.target_ticks / clock.hz * 1e6:.4g} µs)")
    binds = "the reference (never ahead of it)" + (
        f", and the stage budget ({max_stages})" if len(acc) >= max_stages else "")
    return PlanResult(table, simulate_move(table, total).duration_s, binds, info, total, clock,
                      time.perf_counter() - started,
                      extras={"max_step_error_us": worst * 1e6,
                              "mean_step_error_us": mean * 1e6, "end_lag_us": end * 1e6})


def _first_reach(t: np.ndarray, xm: np.ndarray, total: int) -> np.ndarray:
    """τ(i), i = 0…total: the first time the linearly interpolated reference reaches
    position i (xm non-decreasing from 0); the reference's end time beyond its end."""
    pos = np.arange(total + 1, dtype=float)
    j = np.searchsorted(xm, pos, side="left")  # first sample at or past pos
    jc = np.clip(j, 1, len(xm) - 1)
    x0, x1 = xm[jc - 1], xm[jc]
    # j ≥ 1 ⇒ x0 < pos ≤ x1, so x1 > x0; elsewhere the value is replaced below
    frac = (pos - x0) / np.where(x1 > x0, x1 - x0, 1.0)
    tau = t[jc - 1] + np.clip(frac, 0.0, 1.0) * (t[jc] - t[jc - 1])
    tau = np.where(j == 0, t[0], tau)
    return np.where(j >= len(xm), t[-1], tau)


def _stage_base(rate: int) -> int:
    """Chip minimum of a stage: 2 pulses and 256 clock ticks."""
    return max(STAGE_PULSES_MIN, -(-MIN_STAGE_TICKS // int(rate)))


def _accel_window(tau: np.ndarray, i: int, t0: int, target: float, r_fast: int,
                  fastest_after: np.ndarray) -> tuple[int, int, bool] | None:
    """The next accel stage from (pulse i, time t0): (count, rate), the rate the slowest
    integer that keeps every pulse of the window at or after τ; the window the longest
    (≥ the chip minimum) whose lateness stays ≤ target, but at least up to the tangent
    point (where the reference's own speed reaches the stage's): a stage that ends before
    it runs faster than the reference there, and the next, faster stage could not follow.
    With no tangent point near (a cruise or a slowdown ahead) the stage runs no faster than
    the reference at its last pulse, and if the reference never again runs faster than the
    stage would have, the stage is the top (third item True). None if no legal rate fits."""
    left = len(tau) - 1 - i
    if left <= 0:
        return None
    need_hi, room_lo = -math.inf, math.inf
    done, size = 0, _SCAN_FIRST
    n_ok = n_tan = -1
    while done < left and (n_ok < 0 or (n_tan < 0 and done < 4 * max(n_ok, _SCAN_FIRST))):
        m = np.arange(done + 1, min(done + size, left) + 1)
        rel = tau[i + m] - t0 - _EPS_TICKS
        # period ≥ need (never early) and period ≤ room (lateness ≤ target), both over
        # every pulse so far of the window: a running max and a running min
        need = np.maximum(np.maximum.accumulate(rel / m), need_hi)
        room = np.minimum(np.minimum.accumulate((rel + target) / m), room_lo)
        if n_ok < 0:
            bad = np.flatnonzero(np.maximum(np.ceil(need), r_fast) > room)
            if len(bad):
                n_ok = int(m[bad[0]]) - 1
        if n_tan < 0:
            caught = np.flatnonzero(tau[i + m] - tau[i + m - 1] <= need)
            if len(caught):
                n_tan = int(m[caught[0]])
        need_hi, room_lo, done, size = float(need[-1]), float(room[-1]), int(m[-1]), size * 4
    n_ok = left if n_ok < 0 else n_ok
    n = min(max(n_ok, n_tan, STAGE_PULSES_MIN), left, STAGE_PULSES_MAX)
    top = False
    for _ in range(3):  # the chip minimum depends on the rate, the rate on the window
        m = np.arange(1, n + 1)
        rate = max(r_fast, math.ceil(float(np.max((tau[i + m] - t0 - _EPS_TICKS) / m))))
        if n_tan < 0:
            top = bool(fastest_after[i + 1] >= rate)
            rate = max(rate, math.ceil(float(tau[i + n] - tau[i + n - 1]) - _EPS_TICKS))
        base = _stage_base(rate)
        if n >= base or n == left:
            break
        n = min(base, left)
    if n < _stage_base(rate) or rate > RATE_MAX:
        return None
    return n, rate, top


def _accel_stages(tau: np.ndarray, target: float, max_stages: int, r_fast: int
                  ) -> list[_Stage]:
    """Greedy accel staircase, slowest first, until the next tangent rate is no faster
    (the reference's peak) or the stage budget is spent; the last stage is the top."""
    stages: list[_Stage] = []
    i, t0, total = 0, 0, len(tau) - 1
    # fastest_after[q], q = 1…N: the reference's shortest pulse period from pulse q on
    fastest_after = np.concatenate(([np.inf], np.minimum.accumulate(np.diff(tau)[::-1])[::-1],
                                    [np.inf]))
    while i < total:
        w = _accel_window(tau, i, t0, target, r_fast, fastest_after)
        if w is None:
            break
        n, rate, top = w
        if stages and rate >= stages[-1].rate:
            last = stages[-1]
            if rate > last.rate or last.count + n > STAGE_PULSES_MAX:
                break
            last.count += n  # the same rate again: the stage runs on
        else:
            if len(stages) == max_stages:
                break
            stages.append(_Stage(rate, i, t0, n))
        i, t0 = i + n, t0 + n * rate
        if top:  # the decel decides how long the top runs
            break
    if len(stages) == 1:
        # a table needs two stages: put a slower one in front (later pulses: still safe)
        s = stages[0]
        slow = min(RATE_MAX, s.rate + 1)
        n0 = _stage_base(slow)
        if slow == s.rate or n0 >= total:
            return []
        stages = [_Stage(slow, 0, 0, n0), _Stage(s.rate, n0, n0 * slow, s.count)]
    return stages


def _safe_run(tau: np.ndarray, i: int, t0: int, rate: int) -> int:
    """How many pulses from (pulse i, time t0) at `rate` in a row land at or after τ."""
    left = len(tau) - 1 - i
    done, size = 0, _SCAN_FIRST
    while done < left:
        m = np.arange(done + 1, min(done + size, left) + 1)
        bad = np.flatnonzero(t0 + m * rate < tau[i + m] - _EPS_TICKS)
        if len(bad):
            return int(m[bad[0]]) - 1
        done, size = int(m[-1]), size * 4
    return left


class _Completion:
    """Is the slowest legal decel from a point safe? From pulse j at time t_j with the next
    stage k: every stage k, k−1, …, floor at its chip minimum, then the floor stage (the
    decel's slowest) to the end (if the move ends sooner, the last whole stage takes the
    rest). Every other decel down to that floor emits each pulse no later, so if this one
    runs ahead, all do."""

    def __init__(self, tau: np.ndarray, rates: np.ndarray, floor: int) -> None:
        self.tau = tau
        self.rates = rates
        self.floor = floor
        self.bases = np.array([_stage_base(int(r)) for r in rates], dtype=np.int64)
        self.total = len(tau) - 1
        self.p0 = int(rates[floor])
        q = np.arange(self.total + 1, dtype=float)
        # the tail at the floor rate is safe from pulse q on iff
        # t_q' − q'·p0 ≥ max_{q'' ≥ q'} (τ(q'') − q''·p0): suffix maxima, once per staircase
        self.suffix = np.append(np.maximum.accumulate((tau - q * self.p0)[::-1])[::-1], -np.inf)
        self._seq: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def _sequence(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        if k not in self._seq:
            rates = self.rates[self.floor: k + 1][::-1]
            bases = self.bases[self.floor: k + 1][::-1]
            self._seq[k] = (np.cumsum(np.repeat(rates, bases)), np.cumsum(bases))
        return self._seq[k]

    def ok(self, j: int, t_j: int, k: int) -> bool:
        ticks, ends = self._sequence(k)
        room = self.total - j
        tau = self.tau
        if room >= len(ticks):
            m = len(ticks)
            if np.any(t_j + ticks < tau[j + 1: j + m + 1] - _EPS_TICKS):
                return False
            return room == m or (t_j + int(ticks[-1]) - (j + m) * self.p0
                                 >= self.suffix[j + m + 1] - _EPS_TICKS)
        whole = int(np.searchsorted(ends, room, side="right"))
        if whole == 0:
            return False
        full = int(ends[whole - 1])
        times = t_j + ticks[:full]
        rest = room - full
        if rest:
            rate = int(self.rates[k - whole + 1])
            times = np.concatenate((times, t_j + int(ticks[full - 1])
                                    + rate * np.arange(1, rest + 1)))
        return not np.any(times < tau[j + 1:] - _EPS_TICKS)


@dataclass
class _Decel:
    runs: list[int]    # pulses at each stage from the top down (the top's holds the cruise)
    starts: list[int]  # pulse index where each run starts
    forced: list[bool]  # the run ended because its own next pulse would run ahead


def _decel_runs(tau: np.ndarray, stages: list[_Stage], comp: _Completion) -> _Decel | None:
    """Pulses run at each stage from the top stage's start down (the top's run holds its
    accel minimum, the cruise and its decel minimum); each stage runs as long as it stays
    safe and the slowest completion below it too. None if the top cannot start the decel
    safely (the caller then drops the top stage)."""
    total = len(tau) - 1
    top = len(stages) - 1
    k, i, t0 = top, stages[top].start, stages[top].t0
    need = 2 * int(comp.bases[top])
    out = _Decel([], [], [])
    while True:
        rate = int(comp.rates[k])
        safe = _safe_run(tau, i, t0, rate)
        out.starts.append(i)
        if k < top and i + safe >= total:  # this stage runs safely to the end
            if total - i < need or total - i > STAGE_PULSES_MAX:
                return None
            out.runs.append(total - i)
            out.forced.append(False)
            return out
        if k == comp.floor:
            return None
        lo = i + need
        hi = min(i + safe, total - int(comp.bases[k - 1]))
        if k < top:
            hi = min(hi, i + STAGE_PULSES_MAX)
        if lo > hi or not comp.ok(lo, t0 + (lo - i) * rate, k - 1):
            return None
        while lo < hi:  # switching later is never safer: bisect for the last safe switch
            mid = (lo + hi + 1) // 2
            if comp.ok(mid, t0 + (mid - i) * rate, k - 1):
                lo = mid
            else:
                hi = mid - 1
        out.runs.append(lo - i)
        out.forced.append(lo == i + safe)
        t0 += (lo - i) * rate
        i, k = lo, k - 1
        need = int(comp.bases[k])


def _quantise_for(tau: np.ndarray, target: float, max_stages: int, r_fast: int
                  ) -> _Quantised | None:
    """The staircase for one accel lateness target, with the exact lateness of every pulse;
    None if it cannot be made legal. Then, while stages are left, a rate the decel lacks
    is put in where the worst pulse needs it (see _wanted_rate), if that helps."""
    stages = _accel_stages(tau, target, max_stages, r_fast)
    best = _finish(tau, stages, target)
    for _ in range(_INSERTS):
        if best is None or len(best.rates) >= max_stages:
            break
        wanted = _wanted_rate(tau, best)
        if wanted is None:
            break
        cand = _finish(tau, _with_stage(best.stages, *wanted), target)
        if cand is None or _score(cand) >= _score(best):
            break
        best = cand
    return best


def _score(q: _Quantised) -> tuple[float, float]:
    return float(q.late_ticks.max()), float(q.late_ticks.mean())


def _finish(tau: np.ndarray, stages: list[_Stage], target: float) -> _Quantised | None:
    """The best over the decel's slowest stage (the accel's slowest few: a decel that ends
    on a faster stage skips the chip minimum of the slowest ones, which the reference's
    last pulses may be too quick for)."""
    best = None
    for floor in range(min(_FLOORS, len(stages) - STAGES_MIN + 1)):
        q = _finish_floor(tau, stages, target, floor)
        if q is not None and (best is None or _score(q) < _score(best)):
            best = q
    return best


def _finish_floor(tau: np.ndarray, stages: list[_Stage], target: float, floor: int
                  ) -> _Quantised | None:
    """Decel counts for an accel staircase down to stage `floor` (dropping top stages until
    the decel can start safely), the trapezoid's counts and the exact lateness of every
    pulse."""
    stages = [_Stage(s.rate, s.start, s.t0, s.count) for s in stages]
    rates = np.array([s.rate for s in stages], dtype=np.int64)
    comp = _Completion(tau, rates, floor)
    dec = None
    while len(stages) >= floor + STAGES_MIN:
        dec = _decel_runs(tau, stages, comp)
        if dec is not None:
            break
        stages.pop()  # the decel must start earlier: end the accel one stage lower
    if dec is None:
        return None
    k = len(stages)
    rates = rates[:k]
    base_top = int(comp.bases[k - 1])
    acc = np.array([s.count for s in stages[:-1]] + [base_top], dtype=np.int64)
    counts = np.array([base_top, *dec.runs[1:]], dtype=np.int64)
    cruise = dec.runs[0] - 2 * base_top
    if acc.sum() > SIDE_TOTAL_MAX or counts.sum() > SIDE_TOTAL_MAX:
        return None
    # the chip's trapezoid: accel slowest → fastest, cruise, decel fastest → slowest
    seq_rates = np.concatenate((rates, rates[-1:], rates[::-1][: len(counts)]))
    seq_counts = np.concatenate((acc, [cruise], counts))
    ticks = np.cumsum(np.repeat(seq_rates, seq_counts))
    if len(ticks) != len(tau) - 1:
        return None
    return _Quantised(rates, acc, counts, cruise, ticks - tau[1:], target, stages, dec, floor)


def _wanted_rate(tau: np.ndarray, q: _Quantised) -> tuple[int, int] | None:
    """(index, rate) of a stage to insert: if the worst pulse lies in a decel run that began
    because the stage above would have run ahead (on a cruise the top is a hair faster than
    the reference once it has caught up; the next rate may be far slower), the slowest rate
    that is safe from that switch to the worst pulse, if it lies strictly between the two."""
    worst = int(np.argmax(q.late_ticks)) + 1  # pulse number
    starts = np.asarray(q.decel.starts)
    run = int(np.searchsorted(starts, worst - 1, side="right")) - 1
    if run < 1 or not q.decel.forced[run - 1]:
        return None
    k_above = len(q.rates) - run  # slow-first index of the stage above that run
    j = int(starts[run])
    t_j = round(float(q.late_ticks[j - 1] + tau[j])) if j > 0 else 0  # integer ticks
    m = np.arange(1, worst - j + 1)
    rate = math.ceil(float(np.max((tau[j + m] - t_j - _EPS_TICKS) / m)))
    if not q.rates[k_above] < rate < q.rates[k_above - 1]:
        return None
    return k_above, rate


def _rebuild(rates: list[int], counts: list[int]) -> list[_Stage]:
    """Accel stages (slowest first) with their start pulses and times."""
    out: list[_Stage] = []
    start, t0 = 0, 0
    for r, c in zip(rates, counts, strict=True):
        out.append(_Stage(r, start, t0, c))
        start, t0 = start + c, t0 + c * r
    return out


def _with_stage(stages: list[_Stage], k: int, rate: int) -> list[_Stage]:
    """The accel staircase with a stage of `rate` (between stages k−1 and k in speed) run for
    its chip minimum just before stage k; stage k gives up those pulses if it can spare
    them, else everything after starts that much later. Each pulse then runs at the same
    or a slower rate than before, so the accel side stays safe."""
    base = _stage_base(rate)
    rates = [s.rate for s in stages]
    counts = [s.count for s in stages]
    top = len(stages) - 1
    if k == top or counts[k] - base >= _stage_base(rates[k]):
        counts[k] -= base
    rates.insert(k, rate)
    counts.insert(k, base)
    return _rebuild(rates, counts)

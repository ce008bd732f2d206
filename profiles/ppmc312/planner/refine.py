"""A staircase's exact move time, its refinement over exact integer rates, and the
pulse counts other rules raise: the jerk limit and LE=1's triangle switch."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..limits import RATE_MAX, SIDE_TOTAL_MAX, STAGE_PULSES_MAX, STAGES_MIN
from .problem import Problem, base_pulses


# --------------------------------------------------------------------------- evaluation
@dataclass
class Staircase:
    rates: np.ndarray   # slowest first
    n: np.ndarray       # accel counts, slowest first (top stage included)
    d: np.ndarray
    time_s: float
    total: int


def evaluate(pb: Problem, rates: np.ndarray, budget: int,
              counts: tuple[np.ndarray, np.ndarray] | None = None) -> Staircase | None:
    """Exact move time of a staircase with minimal counts (or the given ones); None if the
    staircase breaks a rule or does not fit the budget."""
    rates = np.asarray(rates, dtype=np.int64)
    if len(rates) < STAGES_MIN or np.any(np.diff(rates) >= 0) or not pb.top_ok(rates[-1:])[0]:
        return None
    if counts is None:
        n, d, valid = pb.counts(rates[:-1], rates[1:])
        if not np.all(valid):
            return None
        top = base_pulses(rates[-1:])
        n = np.concatenate((n, top))
        d = np.concatenate((d, top))
    else:
        n, d = (np.asarray(c, dtype=float) for c in counts)
    time_s = float(move_times(pb, rates, budget, n, d[None, :])[0])
    if not np.isfinite(time_s):
        return None
    return Staircase(rates, n, d, time_s, int(n.sum() + d.sum()))


def move_times(pb: Problem, rates: np.ndarray, budget: int, n: np.ndarray,
               d: np.ndarray) -> np.ndarray:
    """The move time of the staircase on `rates` with accel counts `n` for each row of
    decel counts `d` (rows × stages), inf where the counts break a field's limit or do
    not fit the budget."""
    f = pb.hz / rates.astype(float)
    d_sum = d.sum(axis=1)
    total = n.sum() + d_sum
    fits = ((total <= budget) & (n.sum() <= SIDE_TOTAL_MAX) & (d_sum <= SIDE_TOTAL_MAX)
            & ~np.any(n > STAGE_PULSES_MAX) & ~np.any(d > STAGE_PULSES_MAX, axis=1))
    times = np.sum((n + d) / f, axis=1) + (budget - total) / f[-1]
    return np.where(fits, times, np.inf)


# The rate offsets a refinement move tries per stage: every one within ±24, then
# geometric steps out to ±4000.
OFFSETS = np.unique(np.concatenate((np.arange(-24, 25), np.round(np.geomspace(25, 4000, 24)),
                                    -np.round(np.geomspace(25, 4000, 24))))).astype(np.int64)


def refine_rates(pb: Problem, ev: Staircase, budget: int, sweeps: int = 3) -> Staircase:
    """Coordinate descent over exact integer rates: move every other stage at once (its
    neighbours fixed), then the others, then the top; keep a move only if the exact move
    time falls."""
    best = ev
    for _ in range(sweeps):
        improved = False
        for parity in (0, 1):
            cand = _refine_inner(pb, best, budget, parity, OFFSETS)
            if cand is not None and cand.time_s < best.time_s * (1 - 1e-13):
                best, improved = cand, True
        cand = _refine_top(pb, best, budget, OFFSETS)
        if cand is not None and cand.time_s < best.time_s * (1 - 1e-13):
            best, improved = cand, True
        if not improved:
            break
    return best


def _refine_inner(pb: Problem, ev: Staircase, budget: int, parity: int,
                  offsets: np.ndarray) -> Staircase | None:
    """Every other stage below the top (from `parity`) moved at once, its neighbours
    fixed: each to the rate among `r + offsets` whose step down to the next stage and
    step into it cost least at λ = 1/f_top, if it costs less than its own; when the
    moves together raise the pulses past the budget's slack, only those that do not
    add pulses. Compiled (dp_kernel.refine_inner)."""
    from .dp_kernel import refine_inner

    new = np.empty_like(ev.rates)
    if not refine_inner(ev.rates, offsets, parity, pb.r_start, RATE_MAX,
                        float(budget - ev.total), new, *pb.count_constants):
        return None
    return evaluate(pb, new, budget)


def _refine_top(pb: Problem, ev: Staircase, budget: int, offsets: np.ndarray) -> Staircase | None:
    r = ev.rates
    cand = r[-1] + offsets
    cand = cand[(cand >= pb.r_fast) & (cand < r[-2])]
    cand = cand[pb.top_ok(cand)]
    if len(cand) == 0:
        return None
    f = pb.hz / r.astype(float)
    n, d, valid = pb.counts(np.full(len(cand), r[-2]), cand)
    fixed_n, fixed_d = ev.n[:-2].sum(), ev.d[:-2].sum()
    fixed_t = float(np.sum((ev.n[:-2] + ev.d[:-2]) / f[:-2]))
    top = base_pulses(cand)
    acc, dec = fixed_n + n + top, fixed_d + d + top
    fits = valid & (acc + dec <= budget) & (acc <= SIDE_TOTAL_MAX) & (dec <= SIDE_TOTAL_MAX)
    f_c = pb.hz / cand.astype(float)
    with np.errstate(invalid="ignore"):
        t = fixed_t + (n + d) / f[-2] + (budget - fixed_n - fixed_d - n - d) / f_c
    t = np.where(fits, t, np.inf)
    k = int(np.argmin(t))
    if not np.isfinite(t[k]):
        return None
    trial = r.copy()
    trial[-1] = cand[k]
    return evaluate(pb, trial, budget)



def jerk_counts(pb: Problem, ev: Staircase, budget: int) -> Staircase | None:
    """Raise counts so that the stall-jerk rule of profiles.ppmc312.criterion holds: stage
    by stage from the slowest, the smallest count whose slope change from the previous
    stage is within max_jerk_pps3 (σ = 0 before the first stage and in the top stage)."""
    jerk = pb.motor.max_jerk_pps3
    if jerk is None:
        return ev
    f = pb.hz / ev.rates.astype(float)
    delta = np.append(np.diff(f), 0.0)

    def side(base: np.ndarray) -> np.ndarray:
        out = base.copy()
        prev = 0.0
        for i in range(len(f)):
            c = float(base[i])
            for _ in range(4):
                t = c / f[i]
                sigma = delta[i] / t
                if abs(sigma - prev) <= jerk * t:
                    break
                if delta[i] <= 0:
                    t_new = prev / jerk
                else:
                    t_new = (-prev + math.sqrt(prev * prev + 4 * jerk * delta[i])) / (2 * jerk)
                    if t_new < t or abs(delta[i] / max(t_new, t) - prev) > jerk * max(t_new, t):
                        disc = prev * prev - 4 * jerk * delta[i]
                        t_new = (prev + math.sqrt(max(disc, 0.0))) / (2 * jerk)
                c = max(c + 1, math.ceil(max(t_new, t) * f[i]))
            out[i] = c
            prev = delta[i] / (out[i] / f[i])
        return out

    if pb.separate:
        n, d = side(ev.n), side(ev.d)
    else:
        n = d = side(np.maximum(ev.n, ev.d))
    return evaluate(pb, ev.rates, budget, (n, d))



def own_decel_counts(pb: Problem, ev: Staircase, budget: int) -> Staircase | None:
    """An LE=0 staircase's rates and accel counts with the decel side's own least counts
    (`pb` separate: from a_dec ≥ a_acc, so never more than the accel's), the jerk rule
    applied again: an LE=1 table on the rates the symmetric DP found, for
    `switch_safe_decel` to make switch-safe. Its symmetric end (decel = accel) is the
    LE=0 table itself, so the switch-safe result is never slower than LE=0."""
    _, d, valid = pb.counts(ev.rates[:-1], ev.rates[1:])
    if not np.all(valid):
        return None
    d = np.concatenate((np.minimum(d, ev.d[:-1]), ev.d[-1:]))
    own = evaluate(pb, ev.rates, budget, (ev.n, d))
    return None if own is None else jerk_counts(pb, own, budget)


def switch_safe_decel(pb: Problem, ev: Staircase, budget: int) -> Staircase | None:
    """The fastest switch-safe decel counts for `ev`'s stages (None: none fits the budget).

    Two levers, both only raising decel counts: a floor proportional to the accel counts,
    d_k ≥ c·n_k (c = 1 is the symmetric table, always switch-safe), and extra pulses on
    the top stage (free on the planned move, but they count against its pulses). For
    each c on a grid the fewest top pulses that make the table `switch_safe` are found,
    every c at once: doubling until safe, then bisection back. (Safe top pulses are an
    interval, not a ray: far too many shift the accel:decel ratio so that short
    triangles switch down again — doubling from 1 finds its first part.)"""
    from .dp_kernel import switch_safe_tops

    floors = np.linspace(0.0, 1.0, 21)
    d0 = np.maximum(ev.d[None, :], np.ceil(floors[:, None] * ev.n[None, :])).astype(np.int64)
    room = np.minimum(SIDE_TOTAL_MAX, budget) - d0.sum(axis=1)  # top pulses that can fit
    hi = np.zeros(len(floors), dtype=np.int64)
    found = np.zeros(len(floors), dtype=np.bool_)
    switch_safe_tops(ev.n.astype(np.int64), d0, room, hi, found)  # compiled: row by row
    d = d0[found].astype(float)
    d[:, -1] += hi[found]
    times = move_times(pb, ev.rates, budget, ev.n, d)
    if not np.any(np.isfinite(times)):
        return None
    return evaluate(pb, ev.rates, budget, (ev.n, d[int(np.argmin(times))]))

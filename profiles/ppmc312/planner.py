"""Optimal stall-safe free-curve planner, baseline planner and clock choice.

The planner chooses the stage rates of a PPMC-312 free curve (fastest first on
the wire, slowest first here) and their pulse counts so that the table obeys
the stall-safety criterion of `verify.stall` and the chip's free-curve rules,
and minimises the move time of `pulses`:

    T = Σ_{k<N} w_k / f_k + (pulses − Σ_{k<N} w_k) / f_N,

w_k being the pulses of stage k on the accel plus the decel side (the top
stage's own pulses run at f_N, exactly like the cruise, so they cancel), subject
to accel total + decel total ≤ pulses (the chip then runs a trapezoid that stays
on the planned staircase). For a fixed top speed f_N = 1/λ the cost is additive
over stages, w_k·(1/f_k − λ), and given the speeds the smallest legal counts are
optimal (an extra pulse below f_N only costs time), so the speeds are chosen by a
dynamic programme over a rate grid: state (stages used, rate), transition to a
faster rate within the jump limit, stage count

    n_k = max(2, ceil(256 / r_k), ceil((f_{k+1} − f_k)·f_k / A_k))

with A_k the exact minimum of the capability over [f_k, f_{k+1}]. Every DP run
also yields, for every other top rate, a real path whose exact time is known;
the top is searched by re-running the DP at the best top's λ (a smaller λ is a
Lagrange multiplier on the pulse budget, used when the budget binds). The grid
is every integer rate where speed resolution is coarse and a uniform speed
subset elsewhere; the result is then refined over exact integer rates.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import FieldRangeError, PlanError, require_int
from ..motor import Motor
from ..motor.resonance import band_edges_rates, stage_allowed, top_allowed
from ..result import PlanResult
from .clock import INTERNAL_HZ, MAX_OUTPUT_PPS, Clock
from .criterion import switch_safe
from .limits import (
    MIN_STAGE_TICKS,
    RATE_MAX,
    RATE_MIN,
    SIDE_TOTAL_MAX,
    STAGE_PULSES_MAX,
    STAGES_MAX,
    STAGES_MIN,
)
from .table import FreeCurveTable

GRID_TARGET = 900          # DP nodes when the integer rate range is larger
REFERENCE_MOVE_FACTOR = 10  # pulses=None: 10 × the continuous ramps' pulses (see notes)
BASELINE_POINTS = 600


Plan = PlanResult[FreeCurveTable]  # what every free-curve planner here returns


# --------------------------------------------------------------------------- clock
def choose_clock(motor: Motor) -> Clock:
    """The fastest internal clock (finest speed resolution) whose rates reach the start speed.

    The slowest stage must run at ≤ start_pps, i.e. rate ≥ f_clk / start_pps, and that
    rate must fit the 16-bit field. Top speed only needs rate ≥ 2, which a faster
    clock meets at least as well, so the start speed decides. EXTCK is never chosen.
    """
    for name, hz in INTERNAL_HZ.items():
        if math.ceil(hz / motor.start_pps) <= RATE_MAX:
            return Clock.internal(name)
    slowest = min(INTERNAL_HZ.values())
    raise PlanError(f"start_pps {motor.start_pps:g} is below the slowest speed any internal clock "
                    f"can run ({slowest / RATE_MAX:.4g} pps at 15.625kHz); raise start_pps")


# --------------------------------------------------------------------------- problem
def _base_pulses(rates: Any) -> Any:
    """Chip minimum of a stage: 2 pulses and 256 clock ticks."""
    r = np.asarray(rates, dtype=float)
    return np.maximum(2.0, np.ceil(MIN_STAGE_TICKS / r))


@dataclass
class _Problem:
    motor: Motor
    hz: float
    separate: bool
    jump: float
    start: float
    r_fast: int    # smallest rate allowed (top speed, 2 Mpps, rate ≥ 2)
    r_start: int   # smallest rate at or below the start speed

    def counts(self, r_slow: Any, r_fast: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Minimal (accel, decel) counts of the slower stage of each step, and validity."""
        rs = np.asarray(r_slow, dtype=float)
        rf = np.asarray(r_fast, dtype=float)
        f_slow = self.hz / rs
        f_fast = self.hz / np.where(rf > 0, rf, 1.0)
        delta = f_fast - f_slow
        a_acc = np.asarray(self.motor.min_a_acc_pps2(f_slow, f_fast), dtype=float)
        a_dec = np.asarray(self.motor.min_a_dec_pps2(f_slow, f_fast), dtype=float)
        base = _base_pulses(rs)
        with np.errstate(divide="ignore", invalid="ignore"):
            n = np.where(a_acc > 0, np.ceil(delta * f_slow / a_acc), np.inf)
            d = np.where(a_dec > 0, np.ceil(delta * f_slow / a_dec), np.inf)
        n = np.maximum(n, base)
        d = np.maximum(d, base)
        if not self.separate:
            n = d = np.maximum(n, d)
        valid = ((rf > 0) & (delta > 0) & (delta <= self.jump) & (n <= STAGE_PULSES_MAX)
                 & (d <= STAGE_PULSES_MAX))
        if self.motor.resonance_bands_pps:  # no stage in a band a jump can step over
            valid &= stage_allowed(f_slow, self.motor) & stage_allowed(f_fast, self.motor)
        return n, d, valid

    def top_ok(self, rates: Any) -> np.ndarray:
        """The top stage (the cruise) lies outside every resonance band."""
        return top_allowed(self.hz / np.asarray(rates, dtype=float), self.motor)


def _problem(motor: Motor, clock: Clock, separate: bool) -> _Problem:
    hz = clock.hz
    top = min(motor.top_pps, MAX_OUTPUT_PPS)
    r_fast = max(RATE_MIN, math.ceil(hz / top))
    r_start = math.ceil(hz / motor.start_pps)
    if r_start > RATE_MAX:
        raise PlanError(f"clock {clock.name}: the start speed {motor.start_pps:g} pps needs rate "
                        f"{r_start} > {RATE_MAX}; use a slower clock (choose_clock picks one)")
    if r_start <= r_fast:
        raise PlanError(f"clock {clock.name}: no rate lies between the start speed "
                        f"{motor.start_pps:g} pps and the top speed {top:g} pps; a table needs "
                        "two stages")
    return _Problem(motor, hz, separate, motor.jump_pps, motor.start_pps, r_fast, r_start)


def check_plan_args(max_stages: int, pulses: int | None) -> None:
    require_int("max_stages", max_stages, STAGES_MIN, STAGES_MAX)
    if pulses is not None:
        # 2 stages × 2 pulses × 2 sides is the smallest trapezoid a free curve can run
        require_int("pulses", pulses, 8, 0xFFFFFFFF)


def reference_pulses(motor: Motor) -> int:
    """The move `pulses=None` plans for: 10 × the pulses the continuous (exact, no-jerk)
    optimum spends accelerating from start_pps to 90 % of the top usable speed and back.

    The top usable speed is the curve's top, capped at 2 Mpps and at the first speed
    where a_acc reaches 0 (the ramp's pulses diverge there).
    """
    top = min(motor.top_pps, MAX_OUTPUT_PPS)
    v = np.linspace(0.0, top, 4001)
    dead = np.flatnonzero(motor.a_acc_pps2(v) <= 0)
    if len(dead):
        top = float(v[dead[0]])
    v_hi = max(0.9 * top, motor.start_pps)
    v = np.linspace(motor.start_pps, v_hi, 2001)
    dens = v / motor.a_acc_pps2(v) + v / motor.a_dec_pps2(v)
    ramp = float(np.sum((dens[1:] + dens[:-1]) * np.diff(v)) / 2)
    return int(max(1000, math.ceil(REFERENCE_MOVE_FACTOR * ramp)))


# --------------------------------------------------------------------------- grid
def _grid_rates(pb: _Problem, target: int) -> np.ndarray:
    """DP nodes (rates, slowest first): all integers where the speed step between adjacent
    rates is coarse, a uniform speed subset where it is fine, the exact jump chain from
    the start rate (the optimum in the jump-limited region) and a few rates below start."""
    hz = pb.hz
    r_slow = min(RATE_MAX, 2 * pb.r_start)
    if r_slow - pb.r_fast + 1 <= target:
        rates = np.arange(r_slow, pb.r_fast - 1, -1, dtype=np.int64)
    else:
        f_lo, f_hi = hz / r_slow, hz / pb.r_fast

        def build(step: float) -> np.ndarray:
            r_dense = max(pb.r_fast, math.floor((math.sqrt(1 + 4 * hz / step) - 1) / 2))
            dense = np.arange(r_dense, pb.r_fast - 1, -1, dtype=np.int64)
            f_top = hz / r_dense
            coarse = np.round(hz / np.arange(f_lo, f_top, step)).astype(np.int64)
            return np.unique(np.concatenate((coarse, dense)))

        lo, hi = (f_hi - f_lo) / (4 * target), (f_hi - f_lo) / (target / 4)
        for _ in range(30):
            mid = math.sqrt(lo * hi)
            if len(build(mid)) > target:
                lo = mid
            else:
                hi = mid
        rates = build(hi)
    chain = [pb.r_start]
    r = pb.r_start
    while r > pb.r_fast:
        nxt = math.ceil(hz / (hz / r + pb.jump))
        while nxt < r and hz / nxt - hz / r > pb.jump:
            nxt += 1
        if nxt >= r:
            break
        chain.append(nxt)
        r = nxt
    # the rates just outside each resonance band: the stages a jump over it starts and ends on
    edges = np.asarray(band_edges_rates(pb.motor, hz), dtype=np.int64)
    rates = np.unique(np.concatenate((rates, np.asarray(chain, dtype=np.int64), [pb.r_fast],
                                      edges)))
    rates = rates[(rates >= pb.r_fast) & (rates <= RATE_MAX)]
    return rates[::-1].copy()  # slowest first


@dataclass
class _Graph:
    rates: np.ndarray       # (G,) slowest first
    f: np.ndarray           # (G,) speeds, ascending
    pred: np.ndarray        # (G, W) predecessor index (slower node), 0 where invalid
    valid: np.ndarray       # (G, W)
    w: np.ndarray           # (G, W) accel + decel pulses of the predecessor stage
    wa: np.ndarray          # (G, W) accel pulses of the predecessor stage
    start: np.ndarray       # (G,) bool: may be the slowest stage
    wtop: np.ndarray        # (G,) accel + decel pulses of a top stage at this node
    watop: np.ndarray       # (G,) accel pulses of a top stage at this node


def _graph(pb: _Problem, rates: np.ndarray) -> _Graph:
    f = pb.hz / rates.astype(float)
    g = len(rates)
    first = np.searchsorted(f, f - pb.jump * (1 + 1e-12), side="left")
    width = int(max(1, np.max(np.arange(g) - first)))
    j = np.arange(g)[:, None]
    pred = j - 1 - np.arange(width)[None, :]
    ok = pred >= 0
    pred = np.where(ok, pred, 0)
    n, d, valid = pb.counts(rates[pred], np.broadcast_to(rates[:, None], pred.shape))
    valid &= ok
    base = _base_pulses(rates)
    return _Graph(rates, f, pred, valid, np.where(valid, n + d, 0.0), np.where(valid, n, 0.0),
                  f <= pb.start, 2 * base, base)


@dataclass
class _DP:
    value: np.ndarray      # (G,) min Σ w (1/f − λ) over paths of 2..M stages ending here
    pulses: np.ndarray     # (G,) Σ w of that path (top stage excluded)
    accel: np.ndarray      # (G,) Σ accel pulses of that path (top stage excluded)
    parent: np.ndarray     # (L, G) predecessor at each layer, −1 = same as previous layer
    lam: float


def _run_dp(gr: _Graph, lam: float, max_stages: int, start_f: float, jump: float) -> _DP:
    g, width = gr.pred.shape
    cost = np.where(gr.valid, gr.w * (1.0 / gr.f[gr.pred] - lam), np.inf)
    # accel and total pulses of a path packed in one int64 (total · 2^32 + accel): one
    # gather per layer instead of two; both stay far below 2^31 (127 × 0xFFFFF × 2)
    packed_w = (gr.w.astype(np.int64) << 32) + gr.wa.astype(np.int64)
    pred_flat = gr.pred.ravel()
    packed_flat = packed_w.ravel()
    value = np.where(gr.start, 0.0, np.inf)
    packed = np.zeros(g, dtype=np.int64)
    parents = [np.full(g, -1, dtype=np.int32), np.full(g, -1, dtype=np.int32)]
    base_idx = np.arange(g) * width
    for m in range(2, max_stages + 1):
        hi = int(np.searchsorted(gr.f, start_f + (m - 1) * jump * (1 + 1e-9), side="right"))
        hi = min(hi, g)
        cand = value[gr.pred[:hi]]
        cand += cost[:hi]
        idx = cand.argmin(axis=1)
        idx += base_idx[:hi]
        best = cand.ravel()[idx]
        src = pred_flat[idx]
        par = np.full(g, -1, dtype=np.int32)
        if m == 2:  # a table has at least two stages: one-stage paths are not kept
            better = np.isfinite(best)
            new_packed = np.where(better, packed_flat[idx], 0)
            value = np.full(g, np.inf)
            packed = np.zeros(g, dtype=np.int64)
            value[:hi] = best
            packed[:hi] = new_packed
        else:
            better = best < value[:hi]
            if hi == g and not better.any():
                break  # nothing changes any more: more stages do not help
            new_packed = np.where(better, packed[src] + packed_flat[idx], packed[:hi])
            np.minimum(value[:hi], best, out=value[:hi])
            packed[:hi] = new_packed
        par[:hi] = np.where(better, src, -1)
        parents.append(par)
    pulses = (packed >> 32).astype(float)
    accel = (packed & 0xFFFFFFFF).astype(float)
    return _DP(value, pulses, accel, np.asarray(parents), lam)


def _backtrack(dp: _DP, j: int) -> list[int]:
    path = [j]
    m = len(dp.parent) - 1
    while m >= 2:
        p = int(dp.parent[m, j])
        if p >= 0:
            j = p
            path.append(j)
        m -= 1
    return path[::-1]


# --------------------------------------------------------------------------- evaluation
@dataclass
class _Eval:
    rates: np.ndarray   # slowest first
    n: np.ndarray       # accel counts, slowest first (top stage included)
    d: np.ndarray
    time_s: float
    total: int


def _evaluate(pb: _Problem, rates: np.ndarray, budget: int,
              counts: tuple[np.ndarray, np.ndarray] | None = None) -> _Eval | None:
    """Exact move time of a staircase with minimal counts (or the given ones); None if the
    staircase breaks a rule or does not fit the budget."""
    rates = np.asarray(rates, dtype=np.int64)
    if len(rates) < STAGES_MIN or np.any(np.diff(rates) >= 0) or not pb.top_ok(rates[-1:])[0]:
        return None
    if counts is None:
        n, d, valid = pb.counts(rates[:-1], rates[1:])
        if not np.all(valid):
            return None
        top = _base_pulses(rates[-1:])
        n = np.concatenate((n, top))
        d = np.concatenate((d, top))
    else:
        n, d = (np.asarray(c, dtype=float) for c in counts)
    f = pb.hz / rates.astype(float)
    total = int(n.sum() + d.sum())
    if (total > budget or n.sum() > SIDE_TOTAL_MAX or d.sum() > SIDE_TOTAL_MAX
            or np.any(n > STAGE_PULSES_MAX) or np.any(d > STAGE_PULSES_MAX)):
        return None
    time_s = float(np.sum((n + d) / f) + (budget - total) / f[-1])
    return _Eval(rates, n, d, time_s, total)


def _refine(pb: _Problem, ev: _Eval, budget: int, sweeps: int = 3) -> _Eval:
    """Coordinate descent over exact integer rates: move every other stage at once (its
    neighbours fixed), then the others, then the top; keep a move only if the exact move
    time falls."""
    best = ev
    offsets = np.unique(np.concatenate((np.arange(-24, 25),
                                        np.round(np.geomspace(25, 4000, 24)),
                                        -np.round(np.geomspace(25, 4000, 24))))).astype(np.int64)
    for _ in range(sweeps):
        improved = False
        for parity in (0, 1):
            cand = _refine_inner(pb, best, budget, parity, offsets)
            if cand is not None and cand.time_s < best.time_s * (1 - 1e-13):
                best, improved = cand, True
        cand = _refine_top(pb, best, budget, offsets)
        if cand is not None and cand.time_s < best.time_s * (1 - 1e-13):
            best, improved = cand, True
        if not improved:
            break
    return best


def _refine_inner(pb: _Problem, ev: _Eval, budget: int, parity: int,
                  offsets: np.ndarray) -> _Eval | None:
    r = ev.rates
    m = len(r)
    ks = np.arange(parity, m - 1, 2)  # stages that move (never the top here)
    if len(ks) == 0:
        return None
    lam = r[-1] / pb.hz
    cand = r[ks][:, None] + offsets[None, :]
    upper = np.where(ks > 0, r[np.maximum(ks - 1, 0)], RATE_MAX + 1)[:, None]
    lower = r[ks + 1][:, None]
    ok = (cand > lower) & (cand < upper) & (cand <= RATE_MAX)
    ok &= np.where(ks[:, None] == 0, cand >= pb.r_start, True)
    cand = np.where(ok, cand, r[ks][:, None])
    f_c = pb.hz / cand.astype(float)
    n_out, d_out, v_out = pb.counts(cand, np.broadcast_to(lower, cand.shape))
    cost = (n_out + d_out) * (1.0 / f_c - lam)
    w = n_out + d_out
    has_in = ks > 0
    r_in = np.broadcast_to(upper, cand.shape)
    n_in, d_in, v_in = pb.counts(np.where(has_in[:, None], r_in, cand + 1), cand)
    f_in = pb.hz / r_in.astype(float)
    cost = cost + np.where(has_in[:, None], (n_in + d_in) * (1.0 / f_in - lam), 0.0)
    w = w + np.where(has_in[:, None], n_in + d_in, 0.0)
    feasible = ok & v_out & np.where(has_in[:, None], v_in, True)
    cost = np.where(feasible, cost, np.inf)
    cur = np.flatnonzero(offsets == 0)[0]
    pick = np.argmin(cost, axis=1)
    rows = np.arange(len(ks))
    gain = cost[rows, cur] - cost[rows, pick]
    dw = w[rows, pick] - w[rows, cur]
    slack = budget - ev.total
    move = (gain > 0) & np.isfinite(cost[rows, pick])
    if np.sum(np.where(move, dw, 0)) > slack:
        move &= dw <= 0
    if not np.any(move):
        return None
    new = r.copy()
    new[ks[move]] = cand[rows[move], pick[move]]
    return _evaluate(pb, new, budget)


def _refine_top(pb: _Problem, ev: _Eval, budget: int, offsets: np.ndarray) -> _Eval | None:
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
    top = _base_pulses(cand)
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
    return _evaluate(pb, trial, budget)


# --------------------------------------------------------------------------- search
def _search(pb: _Problem, gr: _Graph, max_stages: int, budget: int, *,
            exhaustive_tops: bool = False, plain: bool = False) -> _Eval:
    """Best staircase over the grid: DP at λ = 1/f of the best top found so far, until the
    top repeats; then smaller λ while the pulse budget binds."""
    tried: dict[float, _DP] = {}
    found: list[tuple[float, int, float]] = []  # (time, node, λ of the DP that found it)

    def run(lam: float) -> _DP:
        if lam not in tried:
            tried[lam] = _run_dp(gr, lam, max_stages, pb.start, pb.jump)
        return tried[lam]

    def score(dp: _DP) -> tuple[np.ndarray, np.ndarray]:
        lam_j = 1.0 / gr.f
        est = dp.value + (dp.lam - lam_j) * dp.pulses + budget * lam_j
        fits = ((dp.pulses + gr.wtop <= budget) & (dp.accel + gr.watop <= SIDE_TOTAL_MAX)
                & (dp.pulses - dp.accel + gr.wtop - gr.watop <= SIDE_TOTAL_MAX)
                & pb.top_ok(gr.rates))
        return est, fits

    def visit(lam: float) -> tuple[int, bool] | None:
        dp = run(lam)
        est, fits = score(dp)
        ok = np.isfinite(est) & fits
        if not np.any(ok):
            return None
        j = int(np.argmin(np.where(ok, est, np.inf)))
        found.append((float(est[j]), j, lam))
        # a faster top whose path does not fit: the pulse budget binds
        return j, bool(np.any(np.isfinite(est) & ~fits & (est < est[j])))

    lam = 0.0 if plain else 1.0 / gr.f[-1]
    step = visit(lam)
    for _ in range(0 if plain else 4):  # fixed point: DP at the best top's own λ
        if step is None or 1.0 / gr.f[step[0]] == lam:
            break
        lam = 1.0 / gr.f[step[0]]
        step = visit(lam)
    if not plain and step is not None and step[1]:
        # the budget binds: a smaller λ is a Lagrange multiplier on the pulses, and
        # trades time for pulses so that a faster top fits
        best_t = min(found)[0]
        for nu in (0.02, 0.06, 0.15, 0.35):
            if visit(lam * (1 - nu)) is None or min(found)[0] >= best_t:
                break
            best_t = min(found)[0]
    if exhaustive_tops:
        for j in range(len(gr.f)):
            dp = run(1.0 / gr.f[j])
            est, fits = score(dp)
            if np.isfinite(est[j]) and fits[j]:
                found.append((float(est[j]), j, dp.lam))
    if not found:
        raise PlanError(_infeasible_reason(pb, budget, max_stages))
    found.sort()
    best: _Eval | None = None
    for _, j, lam_found in found[:3]:
        path = gr.rates[_backtrack(tried[lam_found], j)]
        e = _evaluate(pb, path, budget)
        if e is not None and (best is None or e.time_s < best.time_s):
            best = e
    if best is None:
        raise PlanError(_infeasible_reason(pb, budget, max_stages))
    return best


def _infeasible_reason(pb: _Problem, budget: int, max_stages: int) -> str:
    return (f"no stall-safe table of ≤ {max_stages} stages fits {budget} pulses with this motor "
            f"and clock (start {pb.start:g} pps, largest jump {pb.jump:g} pps); give more pulses, "
            "more stages or a slower clock")


def _jerk_counts(pb: _Problem, ev: _Eval, budget: int) -> _Eval | None:
    """Raise counts so that the stall-jerk rule of verify.stall holds: stage by stage from
    the slowest, the smallest count whose slope change from the previous stage is within
    max_jerk_pps3 (σ = 0 before the first stage and in the top stage)."""
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
    return _evaluate(pb, ev.rates, budget, (n, d))


def _plan_variant(motor: Motor, clock: Clock, max_stages: int, budget: int, separate: bool,
                  *, grid: str = "adaptive", refine: bool = True,
                  exhaustive_tops: bool = False) -> _Eval:
    pb = _problem(motor, clock, separate)
    if grid == "adaptive":
        rates = _grid_rates(pb, GRID_TARGET)
    elif grid == "all":
        rates = _grid_rates(pb, 1 << 30)
    else:  # the baseline's geometric grid between the start rate and the top rate
        rates = np.unique(np.round(np.geomspace(pb.r_start, pb.r_fast, BASELINE_POINTS))
                          .astype(np.int64))[::-1].copy()
    gr = _graph(pb, rates)
    ev = _search(pb, gr, max_stages, budget, exhaustive_tops=exhaustive_tops,
                 plain=grid == "geometric")
    if refine:
        ev = _refine(pb, ev, budget)
    jerked = _jerk_counts(pb, ev, budget)
    if jerked is None:
        raise PlanError(f"the jerk limit max_jerk_pps3 = {motor.max_jerk_pps3:g} raises the "
                        f"table's pulses above the {budget}-pulse move; give more pulses")
    return jerked


def _switch_safe_decel(pb: _Problem, ev: _Eval, budget: int) -> _Eval | None:
    """The fastest switch-safe decel counts for `ev`'s stages (None: none fits the budget).

    Two levers, both only raising decel counts: a floor proportional to the accel counts,
    d_k ≥ c·n_k (c = 1 is the symmetric table, always switch-safe), and extra pulses on
    the top stage (free on the planned move, but they count against its pulses). For
    each c on a grid the fewest top pulses that make the table `switch_safe` are found
    by bisection (more of them only help: they raise the decel total, not its slow end)."""
    best: _Eval | None = None
    for c in np.linspace(0.0, 1.0, 21):
        d0 = np.maximum(ev.d, np.ceil(c * ev.n))

        def with_extra(x: int, d0: np.ndarray = d0) -> np.ndarray:
            d = d0.copy()
            d[-1] += x
            return d

        if switch_safe(ev.n, d0):
            hi = 0
        else:
            hi = 1
            while not switch_safe(ev.n, with_extra(hi)):
                hi *= 2
                if d0.sum() + hi > min(SIDE_TOTAL_MAX, budget):
                    break
            else:
                lo = 0  # not safe at lo, safe at hi
                while hi - lo > 1:
                    mid = (lo + hi) // 2
                    lo, hi = (lo, mid) if switch_safe(ev.n, with_extra(mid)) else (mid, hi)
            if not switch_safe(ev.n, with_extra(hi)):
                continue
        cand = _evaluate(pb, ev.rates, budget, (ev.n, with_extra(hi)))
        if cand is not None and (best is None or cand.time_s < best.time_s):
            best = cand
    return best


def _table(clock: Clock, ev: _Eval, separate: bool) -> FreeCurveTable:
    rates = [int(x) for x in ev.rates[::-1]]
    acc = [int(x) for x in ev.n[::-1]]
    dec = [int(x) for x in ev.d[::-1]]
    return FreeCurveTable(clock, tuple(rates), tuple(acc), tuple(dec) if separate else None)


def _plan(motor: Motor, clock: Clock | None, max_stages: int, pulses: int | None,
          separate_decel: bool | None, *, grid: str, refine: bool, label: str,
          exhaustive_tops: bool = False) -> Plan:
    t0 = time.perf_counter()
    check_plan_args(max_stages, pulses)
    clock = clock or choose_clock(motor)
    budget = reference_pulses(motor) if pulses is None else int(pulses)
    # LE=1 is never slower: for the same speeds its decel counts (from a_dec ≥ a_acc) are
    # at most the common LE=0 counts, so it takes less time and fewer pulses. Auto mode
    # plans LE=1 and writes LE=0 when the decel counts come out equal anyway.
    # LE=1's decel counts (from a_dec ≥ a_acc) are smaller than LE=0's, but the chip runs
    # short moves as triangles that keep the accel:decel ratio, and with uneven sides the
    # decel can start on a slower stage than the accel reached: a jump the table never
    # shows. `_switch_safe_decel` raises the top decel count (free on the planned move:
    # the top stage runs at cruise speed) until no triangle does that. The symmetric LE=0
    # table is always all-length safe; auto mode keeps whichever is faster.
    variants: list[tuple[_Eval, bool]] = []
    if separate_decel is not False:
        pb = _problem(motor, clock, True)
        ev1 = _plan_variant(motor, clock, max_stages, budget, True, grid=grid, refine=refine,
                            exhaustive_tops=exhaustive_tops)
        safe = _switch_safe_decel(pb, ev1, budget)
        if safe is not None:
            variants.append((safe, not np.array_equal(safe.n, safe.d)))
    if separate_decel is not True:
        ev0 = _plan_variant(motor, clock, max_stages, budget, False, grid=grid, refine=refine,
                            exhaustive_tops=exhaustive_tops)
        variants.append((ev0, False))
    if not variants:
        raise PlanError(f"no LE=1 table fits {budget} pulses and keeps every triangle's "
                        "accel→decel switch safe; give more pulses or allow LE=0 "
                        "(--no-separate-decel)")
    ev, sep = min(variants, key=lambda v: v[0].time_s)
    time_s = ev.time_s
    table = _table(clock, ev, sep)
    objective = (f"move of {pulses} pulses" if pulses is not None
                 else f"reference move of {budget} pulses (no move length given)")
    info = (f"{label}: {len(ev.rates)} stages, LE={int(sep)}, top {clock.hz / ev.rates[-1]:.6g} pps"
            f", accel {int(ev.n.sum())} + decel {int(ev.d.sum())} pulses, {objective} "
            f"{time_s * 1e3:.6g} ms")
    if len(ev.rates) >= max_stages:
        binds = "stage budget"
    elif ev.total >= budget:
        binds = "move length"  # the ramps use every pulse: a faster top does not fit
    elif clock.hz / ev.rates[-1] >= min(motor.top_pps, MAX_OUTPUT_PPS) * (1 - 1e-9):
        binds = "top speed"
    else:
        binds = "stall criterion (capability and jump limit)"
    return Plan(table, time_s, binds, info, pulses, clock, time.perf_counter() - t0)


def plan_free_curve(motor: Motor, *, clock: Clock | None = None, max_stages: int = 127,
                    pulses: int | None = None, separate_decel: bool | None = None,
                    load_angle_deg: float | None = None) -> Plan:
    """The stall-safe free curve that minimises the move time of `pulses` (None: the
    reference move of `reference_pulses(motor)`); separate_decel None picks LE=1 only
    when it is faster. The table passes the criterion for every move length the chip
    can run with it. With `load_angle_deg` (e.g. 75) the plan is also judged by the
    load-angle model on every execution and tightened until its worst angle is within
    that (see `tighten`). A motor with `tolerances` gets one table safe over its whole
    box: the criterion on the box's worst-case capability (exact over the box,
    profiles.motor.tolerance), the load angle judged at every corner."""
    def make(m: Motor) -> Plan:
        return _plan(m, clock, max_stages, pulses, separate_decel, grid="adaptive",
                     refine=True, label="planner")

    if not motor.tolerances:
        return make(motor) if load_angle_deg is None else tighten(motor, make, load_angle_deg)
    from ..motor.tolerance import corners, worst_case_motor

    worst = worst_case_motor(motor)
    if load_angle_deg is None:
        return make(worst)
    return tighten(worst, make, load_angle_deg,
                   judges=[c.motor for c in corners(motor)])


TIGHTEN_STEP = 0.85
TIGHTEN_ROUNDS = 8
TIGHTEN_BISECT = 2


def tighten(motor: Motor, make: Callable[[Motor], Plan], load_angle_deg: float, *,
            judges: list[Motor] | None = None) -> Plan:
    """Plan with `make`, judge the table on the nominal motor by the load-angle model
    over every execution, and while its worst angle exceeds `load_angle_deg`, plan again
    with a tighter motor: the safety factor, the largest jump and the start speed scaled
    by 0.85 each round (smaller steps, gentler slopes, a softer start: what ringing after
    a step feeds on). Refuses when no round gets below the 90° peak. `judges`: judge
    the load angle on each of these motors (a tolerance box's corners) and take the
    worst, instead of on `motor`. The plan's `extras["worst_load_angle_deg"]` is that
    verdict, so callers need not judge the table again."""
    from ..motor.rotor import PEAK_DEG
    from .load_angle import worst_load_angle

    if not 1.0 <= load_angle_deg <= PEAK_DEG:
        raise FieldRangeError("load angle target [°]", load_angle_deg, 1, PEAK_DEG)
    t0 = time.perf_counter()
    best: tuple[float, Plan] | None = None

    def attempt(scale: float) -> tuple[float, Plan]:
        nonlocal best
        tight = motor if scale == 1.0 else replace(
            motor, safety_factor=motor.safety_factor * scale,
            max_jump_pps=motor.jump_pps * scale, start_pps=motor.start_pps * scale)
        plan = make(tight)
        worst = max(worst_load_angle(plan.table, m).worst_angle_deg
                    for m in (judges or [motor]))
        note = (f"; worst load angle {worst:.1f}° electrical over every move length"
                + (f" at {len(judges)} tolerance corners" if judges else "")
                + (f" (tightened ×{scale:.3g}: safety factor, jump and start speed)"
                   if scale < 1 else ""))
        plan = replace(plan, info=plan.info + note, solve_s=time.perf_counter() - t0,
                       binds=plan.binds if scale == 1.0 else "load angle (tightened)",
                       extras={**plan.extras, "worst_load_angle_deg": worst})
        if best is None or worst < best[0]:
            best = (worst, plan)
        return worst, plan

    scale, failed = 1.0, None
    for _ in range(TIGHTEN_ROUNDS):
        worst, plan = attempt(scale)
        if worst <= load_angle_deg:
            # the largest scale that passes, between this one and the last that failed
            for _ in range(TIGHTEN_BISECT if failed is not None else 0):
                mid = (scale + failed) / 2  # type: ignore[operator]
                w_mid, p_mid = attempt(mid)
                if w_mid <= load_angle_deg:
                    scale, plan = mid, p_mid
                else:
                    failed = mid
            return plan
        failed, scale = scale, scale * TIGHTEN_STEP
    assert best is not None
    if best[0] >= PEAK_DEG:
        raise PlanError(f"no table keeps the load angle below {PEAK_DEG:g}° for every move "
                        f"length (best {best[0]:.1f}°): raise the motor's damping_ratio if the "
                        "drive damps more, or lower safety_factor and start_pps")
    return replace(best[1], info=best[1].info + f" (aim ≤ {load_angle_deg:g}° not reached)")


def plan_duty_cycle(motor: Motor, mix: list[tuple[int, float]], *, clock: Clock | None = None,
                    max_stages: int = 127, separate_decel: bool | None = None,
                    load_angle_deg: float | None = None, candidates: int = 16,
                    progress: Callable[[int, int], None] | None = None,
                    ) -> tuple[Plan, dict[int, float]]:
    """One table for a machine's mix of moves: `mix` is (pulses, weight) per move length
    (equal lengths' weights summed; profiles.ppmc312.duty_cycle states the bounds).
    Minimises Σ weight × move time, each length timed as the chip runs it, over the
    tables `plan_free_curve` (same options) plans for at most `candidates` lengths: the
    mix's weighted quantiles, or every length when it has at most candidates // 2, and
    lengths spread geometrically from its shortest to its longest (`candidate_lengths`).
    Guarantee: never worse on the mix than the plan for any of those lengths (so, for a
    mix of at most candidates // 2 lengths, than the plan for any length of it); the
    cost is a bounded number of plans, each table timed on every length at once.
    `progress` hears each candidate planned. Returns the plan (`duration_s` the weighted
    time, `extras["candidates"]` the lengths planned for) and each length's time."""
    from ..progress import track
    from .duty_cycle import candidate_lengths, mix_arrays, move_times_s

    check_plan_args(max_stages, None)
    lengths, weights = mix_arrays(mix)
    targets = candidate_lengths(lengths, weights, candidates)
    best: tuple[float, Plan, np.ndarray] | None = None
    for target in track(targets, progress):
        try:
            plan = plan_free_curve(motor, clock=clock, max_stages=max_stages, pulses=target,
                                   separate_decel=separate_decel, load_angle_deg=load_angle_deg)
        except PlanError:
            continue  # e.g. too short a move for a table: the other candidates remain
        times = move_times_s(plan.table, lengths)
        total = float(np.dot(weights, times))
        if best is None or total < best[0]:
            best = (total, plan, times)
    if best is None:
        raise PlanError(f"no table could be planned for any of the {len(targets)} candidate "
                        "lengths of the mix")
    total, plan, times = best
    info = (plan.info + f"; duty cycle of {len(lengths)} move lengths, best of "
            f"{len(targets)} candidate tables: weighted time {total:.6g} s")
    extras = {**plan.extras, "candidates": targets}
    return (replace(plan, duration_s=total, pulses=None, info=info, extras=extras),
            dict(zip(lengths.tolist(), times.tolist(), strict=True)))


def plan_baseline(motor: Motor, *, clock: Clock | None = None, max_stages: int = 127,
                  pulses: int | None = None) -> Plan:
    """The plain method: shortest path over a 600-point geometric rate grid between the start
    rate and the top rate with minimal pulse counts (LE=0), no refinement."""
    return _plan(motor, clock, max_stages, pulses, False, grid="geometric", refine=False,
                 label="baseline")

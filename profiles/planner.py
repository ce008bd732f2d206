"""Optimal stall-safe free-curve planner, baseline planner, clock choice, quantising.

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
from dataclasses import dataclass
from typing import Any

import numpy as np

from .clock import INTERNAL_HZ, MAX_OUTPUT_PPS, Clock
from .errors import FieldRangeError, StepRampError
from .motor import Motor
from .table import FreeCurveTable

RATE_MIN = 2
RATE_MAX = 0xFFFF
STAGE_PULSES_MAX = 0xFFFFF
SIDE_TOTAL_MAX = 0xFFFFF
MIN_STAGE_TICKS = 256
STAGES_MIN, STAGES_MAX = 2, 127
GRID_TARGET = 900          # DP nodes when the integer rate range is larger
REFERENCE_MOVE_FACTOR = 10  # pulses=None: 10 × the continuous ramps' pulses (see notes)
BASELINE_POINTS = 600


class PlanError(StepRampError, ValueError):
    """A request no stall-safe, chip-legal table can satisfy."""


@dataclass(frozen=True)
class Plan:
    table: FreeCurveTable
    move_time_s: float
    pulses: int | None
    clock: Clock
    solve_s: float
    info: str


@dataclass(frozen=True)
class QuantisedPlan:
    table: FreeCurveTable
    max_step_error_us: float
    mean_step_error_us: float
    info: str
    end_lag_us: float = 0.0  # how late the last pulse lands


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
        return n, d, valid


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


def _check_args(max_stages: int, pulses: int | None) -> None:
    if isinstance(max_stages, bool) or not isinstance(max_stages, int | np.integer) or not (
            STAGES_MIN <= max_stages <= STAGES_MAX):
        raise FieldRangeError("max_stages", max_stages, STAGES_MIN, STAGES_MAX)
    if pulses is not None and (isinstance(pulses, bool) or not isinstance(pulses, int | np.integer)
                               or not 8 <= pulses <= 0xFFFFFFFF):
        # 2 stages × 2 pulses × 2 sides is the smallest trapezoid a free curve can run
        raise FieldRangeError("pulses", pulses, 8, 0xFFFFFFFF)


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
    rates = np.unique(np.concatenate((rates, np.asarray(chain, dtype=np.int64), [pb.r_fast])))
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
    if len(rates) < STAGES_MIN or np.any(np.diff(rates) >= 0):
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
                & (dp.pulses - dp.accel + gr.wtop - gr.watop <= SIDE_TOTAL_MAX))
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


def _table(clock: Clock, ev: _Eval, separate: bool) -> FreeCurveTable:
    rates = [int(x) for x in ev.rates[::-1]]
    acc = [int(x) for x in ev.n[::-1]]
    dec = [int(x) for x in ev.d[::-1]]
    return FreeCurveTable(clock, tuple(rates), tuple(acc), tuple(dec) if separate else None)


def _plan(motor: Motor, clock: Clock | None, max_stages: int, pulses: int | None,
          separate_decel: bool | None, *, grid: str, refine: bool, label: str,
          exhaustive_tops: bool = False) -> Plan:
    t0 = time.perf_counter()
    _check_args(max_stages, pulses)
    clock = clock or choose_clock(motor)
    budget = reference_pulses(motor) if pulses is None else int(pulses)
    # LE=1 is never slower: for the same speeds its decel counts (from a_dec ≥ a_acc) are
    # at most the common LE=0 counts, so it takes less time and fewer pulses. Auto mode
    # plans LE=1 and writes LE=0 when the decel counts come out equal anyway.
    sep = True if separate_decel is None else bool(separate_decel)
    ev = _plan_variant(motor, clock, max_stages, budget, sep, grid=grid, refine=refine,
                       exhaustive_tops=exhaustive_tops)
    if separate_decel is None and np.array_equal(ev.n, ev.d):
        sep = False
    time_s = ev.time_s
    table = _table(clock, ev, sep)
    objective = (f"move of {pulses} pulses" if pulses is not None
                 else f"reference move of {budget} pulses (pulses=None)")
    info = (f"{label}: {len(ev.rates)} stages, LE={int(sep)}, top {clock.hz / ev.rates[-1]:.6g} pps"
            f", accel {int(ev.n.sum())} + decel {int(ev.d.sum())} pulses, {objective} "
            f"{time_s * 1e3:.6g} ms")
    return Plan(table, time_s, pulses, clock, time.perf_counter() - t0, info)


def plan_free_curve(motor: Motor, *, clock: Clock | None = None, max_stages: int = 127,
                    pulses: int | None = None, separate_decel: bool | None = None) -> Plan:
    """The stall-safe free curve that minimises the move time of `pulses` (None: the
    reference move of `reference_pulses(motor)`); separate_decel None picks LE=1 only
    when it is faster."""
    return _plan(motor, clock, max_stages, pulses, separate_decel, grid="adaptive", refine=True,
                 label="planner")


def plan_baseline(motor: Motor, *, clock: Clock | None = None, max_stages: int = 127,
                  pulses: int | None = None) -> Plan:
    """The plain method: shortest path over a 600-point geometric rate grid between the start
    rate and the top rate with minimal pulse counts (LE=0), no refinement."""
    return _plan(motor, clock, max_stages, pulses, False, grid="geometric", refine=False,
                 label="baseline")


# --------------------------------------------------------------------------- quantising
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
                       max_stages: int = 127) -> QuantisedPlan:
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
    """
    _check_args(max_stages, None)
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
    return _quantised_plan(best, clock, total)


def _quantised_plan(q: _Quantised, clock: Clock, total: int) -> QuantisedPlan:
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
            f"{int(late_s.argmax()) + 1}), mean {mean * 1e6:.4g} µs, lag at the end "
            f"{end * 1e3:.4g} ms (accel lateness target {q.target_ticks / clock.hz * 1e6:.4g} µs)")
    return QuantisedPlan(table, worst * 1e6, mean * 1e6, info, end * 1e6)


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
    return max(2, -(-MIN_STAGE_TICKS // int(rate)))


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
    n = min(max(n_ok, n_tan, 2), left, STAGE_PULSES_MAX)
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

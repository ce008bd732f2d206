"""The DP over a rate grid: the grid, the graph of allowed steps, the DP layers and the
search over top speeds (the method is in the package docstring)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ...errors import PlanError
from ...motor.resonance import band_edges_rates
from ..limits import RATE_MAX, SIDE_TOTAL_MAX
from .problem import Problem, base_pulses
from .refine import Staircase, evaluate

GRID_TARGET = 900          # DP nodes when the integer rate range is larger

# --------------------------------------------------------------------------- grid
def grid_rates(pb: Problem, target: int) -> np.ndarray:
    """DP nodes (rates, slowest first): all integers where the speed step between adjacent
    rates is coarse, a uniform speed subset where it is fine, the exact jump chain from
    the start rate (the optimum in the jump-limited region) and a few rates below start."""
    hz = pb.hz
    rates = _speed_grid(hz, pb.r_start, pb.r_fast, target)
    chain = [pb.r_start]
    r = pb.r_start
    while r > pb.r_fast:
        jump = pb.jump_at(hz / r)
        nxt = math.ceil(hz / (hz / r + jump))
        while nxt < r and hz / nxt - hz / r > jump:
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


@functools.lru_cache(maxsize=64)
def _speed_grid(hz: float, r_start: int, r_fast: int, target: int) -> np.ndarray:
    """The grid's rates before the jump chain and the band edges: every integer from twice
    the start rate to the fast rate, or where that is more than `target`, every integer
    where adjacent rates differ coarsely in speed and a uniform speed subset elsewhere,
    its step bisected to about `target` nodes. Remembered: every plan of a motor and
    clock, and both LE variants, start from the same one."""
    r_slow = min(RATE_MAX, 2 * r_start)
    if r_slow - r_fast + 1 <= target:
        rates = np.arange(r_slow, r_fast - 1, -1, dtype=np.int64)
    else:
        f_lo, f_hi = hz / r_slow, hz / r_fast

        def build(step: float) -> np.ndarray:
            r_dense = max(r_fast, math.floor((math.sqrt(1 + 4 * hz / step) - 1) / 2))
            dense = np.arange(r_dense, r_fast - 1, -1, dtype=np.int64)
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
    rates.flags.writeable = False  # shared by every plan that asks again
    return rates


@dataclass
class Graph:
    rates: np.ndarray       # (G,) slowest first
    f: np.ndarray           # (G,) speeds, ascending
    width: int              # node j's predecessors: j − 1 … j − width
    valid: np.ndarray       # (G, W)
    w: np.ndarray           # (G, W) accel + decel pulses of the predecessor stage
    wa: np.ndarray          # (G, W) accel pulses of the predecessor stage
    packed_w: np.ndarray    # (G, W) both in one int64: w << 32 | wa
    start: np.ndarray       # (G,) bool: may be the slowest stage
    wtop: np.ndarray        # (G,) accel + decel pulses of a top stage at this node
    watop: np.ndarray       # (G,) accel pulses of a top stage at this node
    reach: np.ndarray       # (G,) 1 + the last valid predecessor's w (0: none)

    @property
    def pred(self) -> np.ndarray:
        """(G, W) predecessor index (the slower node), 0 where there is none."""
        pred = np.arange(len(self.rates))[:, None] - 1 - np.arange(self.width)[None, :]
        return np.maximum(pred, 0)


def graph(pb: Problem, rates: np.ndarray) -> Graph:
    f = pb.hz / rates.astype(float)
    g = len(rates)
    # no step is longer than the largest jump any band allows (a shaped plan's are shorter)
    jump = pb.jump * (1.0 if pb.shaping.plain else max(pb.shaping.scale))
    first = np.searchsorted(f, f - jump * (1 + 1e-12), side="left")
    width = int(max(1, np.max(np.arange(g) - first)))
    # pb.counts(rates[j − 1 − w], rates[j]), valid where j − 1 − w ≥ 0
    w, wa, packed_w, valid, reach = pb.graph_counts(rates, width)
    base = base_pulses(rates)
    return Graph(rates, f, width, valid, w, wa, packed_w, f <= pb.start, 2 * base, base, reach)


@dataclass
class DP:
    value: np.ndarray      # (G,) min Σ w (1/f − λ) over paths of 2..M stages ending here
    pulses: np.ndarray     # (G,) Σ w of that path (top stage excluded)
    accel: np.ndarray      # (G,) Σ accel pulses of that path (top stage excluded)
    parent: np.ndarray     # (L, G) predecessor at each layer, −1 = same as previous layer
    lam: float


def run_dp(gr: Graph, lam: float, max_stages: int, start_f: float, jump: float) -> DP:
    """The DP at top-speed multiplier `lam`: for each node the cheapest path of 2..max_stages
    stages ending there (the layers run compiled: profiles.ppmc312.planner.dp_kernel)."""
    from .dp_kernel import layers

    g = len(gr.f)
    # a step's cost w · (1/f_pred − λ) (invalid: infinite) is worked out as the layers
    # look at it; accel and total pulses of a path packed in one int64 (gr.packed_w)
    value = np.empty(g)
    packed = np.empty(g, dtype=np.int64)
    parents = np.full((max_stages + 1, g), -1, dtype=np.int32)
    used = layers(gr.valid, gr.w, gr.packed_w, gr.start, gr.f, float(lam), float(start_f),
                  float(jump), int(max_stages), value, packed, parents, gr.reach)
    pulses = (packed >> 32).astype(float)
    accel = (packed & 0xFFFFFFFF).astype(float)
    return DP(value, pulses, accel, parents[:used], lam)


def backtrack(dp: DP, j: int) -> list[int]:
    path = [j]
    m = len(dp.parent) - 1
    while m >= 2:
        p = int(dp.parent[m, j])
        if p >= 0:
            j = p
            path.append(j)
        m -= 1
    return path[::-1]



# --------------------------------------------------------------------------- search
def search(pb: Problem, gr: Graph, max_stages: int, budget: int, *,
            exhaustive_tops: bool = False, plain: bool = False) -> Staircase:
    """Best staircase over the grid: DP at λ = 1/f of the best top found so far, until the
    top repeats; then smaller λ while the pulse budget binds."""
    tried: dict[float, DP] = {}
    found: list[tuple[float, int, float]] = []  # (time, node, λ of the DP that found it)

    def run(lam: float) -> DP:
        if lam not in tried:
            tried[lam] = run_dp(gr, lam, max_stages, pb.start, pb.jump)
        return tried[lam]

    def score(dp: DP) -> tuple[np.ndarray, np.ndarray]:
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
    best: Staircase | None = None
    for _, j, lam_found in found[:3]:
        path = gr.rates[backtrack(tried[lam_found], j)]
        e = evaluate(pb, path, budget)
        if e is not None and (best is None or e.time_s < best.time_s):
            best = e
    if best is None:
        raise PlanError(_infeasible_reason(pb, budget, max_stages))
    return best


def _infeasible_reason(pb: Problem, budget: int, max_stages: int) -> str:
    return (f"no stall-safe table of ≤ {max_stages} stages fits {budget} pulses with this motor "
            f"and clock (start {pb.start:g} pps, largest jump {pb.jump:g} pps); give more pulses, "
            "more stages or a slower clock")



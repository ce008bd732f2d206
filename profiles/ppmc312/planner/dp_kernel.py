"""The planner's compiled kernels (numba, cached on disk): the DP's layers, where the loop
over stages must stay a loop, and the stage counts of many steps at once, where numpy
spent most of a plan's time on its temporaries. `search.run_dp` and `Problem.counts` hold
the methods; this module only runs them."""

from __future__ import annotations

import math

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True)
def layers(pred: np.ndarray, cost: np.ndarray, packed_w: np.ndarray, start: np.ndarray,
           f: np.ndarray, start_f: float, jump: float, max_stages: int, value: np.ndarray,
           packed: np.ndarray, parents: np.ndarray) -> int:
    """Paths of 2..max_stages stages: `value[j]` the least cost of a path ending at node j,
    `packed[j]` its pulses (total << 32 | accel), `parents[m, j]` the predecessor of j in
    layer m (−1: the path of layer m − 1 stands). Each layer is computed from the one
    before it. Returns the number of layers written (the last ones change nothing)."""
    g, width = pred.shape
    for j in range(g):
        value[j] = 0.0 if start[j] else math.inf
        packed[j] = 0
    prev = np.empty(g)
    prev_packed = np.empty(g, dtype=np.int64)
    count = 2
    for m in range(2, max_stages + 1):
        hi = min(int(np.searchsorted(f, start_f + (m - 1) * jump * (1 + 1e-9), side="right")),
                 g)
        prev[:] = value
        prev_packed[:] = packed
        changed = False
        for j in range(hi):
            best = math.inf
            pick = 0
            for w in range(width):
                c = prev[pred[j, w]] + cost[j, w]
                if c < best:  # the first of equal costs, as numpy's argmin
                    best = c
                    pick = w
            src = pred[j, pick]
            if m == 2:  # a table has at least two stages: one-stage paths are not kept
                better = math.isfinite(best)
                value[j] = best
                packed[j] = packed_w[j, pick] if better else 0
            else:
                better = best < prev[j]
                if better:
                    value[j] = best
                    packed[j] = prev_packed[src] + packed_w[j, pick]
                    changed = True
            parents[m, j] = src if better else -1
        # (past `hi` no path of m stages reaches, and no start node lies: value stays inf)
        if m > 2 and hi == g and not changed:
            break  # nothing changes any more: more stages do not help
        count = m + 1
    return count


@nb.njit(cache=True, nogil=True, inline="always")
def _torque(x: float, v: np.ndarray, t: np.ndarray) -> float:
    """`np.interp(x, v, t, right=0.0)`, the same arithmetic (numpy's compiled_base.c):
    the counts below equal the capability's (`Motor.min_a_acc_pps2`) to the bit. numpy's
    second try when the first gives NaN cannot happen here: the speeds strictly
    increase and every value is finite."""
    last = len(v) - 1
    if x < v[0]:
        return t[0]
    if x > v[last]:
        return 0.0
    if x == v[last]:
        return t[last]
    lo, hi = 0, last  # v[lo] <= x < v[hi]
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if v[mid] <= x:
            lo = mid
        else:
            hi = mid
    if v[lo] == x:
        return t[lo]
    slope = (t[lo + 1] - t[lo]) / (v[lo + 1] - v[lo])
    return slope * (x - v[lo]) + t[lo]


@nb.njit(cache=True, nogil=True, inline="always")
def _least_torque(lo: float, hi: float, v: np.ndarray, t: np.ndarray) -> float:
    """The least torque over [lo, hi]: at an end or a breakpoint inside (the curve is
    piecewise linear)."""
    least = min(_torque(lo, v, t), _torque(hi, v, t))
    for i in range(1, len(v) - 1):
        if lo < v[i] and v[i] < hi and t[i] < least:
            least = t[i]
    return least


@nb.njit(cache=True, nogil=True)
def stage_counts(rs: np.ndarray, rf: np.ndarray, hz: float, v: np.ndarray, t: np.ndarray,
                 sf: float, friction: float, load: float, k: float, edges: np.ndarray,
                 scale: np.ndarray, plain: bool, jump: float, separate: bool,
                 bands: np.ndarray, base_ticks: float, most: float, n: np.ndarray,
                 d: np.ndarray, valid: np.ndarray) -> None:
    """`Problem.counts` element by element (the method and its comments are there): the
    planner's graph and refinement call it on tens of thousands of steps, and numpy's
    temporaries (a torque interpolation per end and breakpoint) were half a plan."""
    c_acc = (friction + load) * k
    c_dec = (load - friction) * k
    for e in range(len(rs)):
        r_slow, r_fast = rs[e], rf[e]
        f_slow = hz / r_slow
        f_fast = hz / (r_fast if r_fast > 0 else 1.0)
        delta = f_fast - f_slow
        # a_acc and a_dec grow with the torque, and rounding keeps that order: the least
        # capability is the capability of the least torque, to the bit
        torque = _least_torque(f_slow, f_fast, v, t)
        a_acc = (sf * torque - friction - load) * k
        a_dec = (sf * torque + friction - load) * k
        jump_e = jump
        if not plain:
            band = np.searchsorted(edges, f_slow, side="right")
            sigma = scale[band]
            a_acc = sigma * (a_acc + c_acc) - c_acc
            a_dec = sigma * (a_dec + c_dec) - c_dec
            jump_e = jump * sigma
        base = max(2.0, np.ceil(base_ticks / r_slow))
        n_e = np.ceil(delta * f_slow / a_acc) if a_acc > 0 else math.inf
        d_e = np.ceil(delta * f_slow / a_dec) if a_dec > 0 else math.inf
        n_e = max(n_e, base)
        d_e = max(d_e, base)
        if not separate:
            n_e = d_e = max(n_e, d_e)
        ok = r_fast > 0 and delta > 0 and delta <= jump_e and n_e <= most and d_e <= most
        for b in range(bands.shape[0]):  # no stage in a band a jump can step over
            if bands[b, 0] <= f_slow <= bands[b, 1] or bands[b, 0] <= f_fast <= bands[b, 1]:
                ok = False
        n[e], d[e], valid[e] = n_e, d_e, ok

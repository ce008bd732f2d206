"""The DP's layers, compiled (numba, cached on disk): the loop over stages must stay a
loop, and numpy spent most of a plan's time on its temporaries. `search.run_dp` holds the
method; this module only runs it."""

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
        if m == 2:
            for j in range(hi, g):
                value[j] = math.inf
                packed[j] = 0
        elif hi == g and not changed:
            break  # nothing changes any more: more stages do not help
        count = m + 1
    return count

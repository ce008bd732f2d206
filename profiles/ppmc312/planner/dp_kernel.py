"""The planner's compiled kernels (numba, cached on disk): the DP's layers, where the loop
over stages must stay a loop, and the stage counts of many steps at once, where numpy
spent most of a plan's time on its temporaries. `search.run_dp` and `Problem.counts` hold
the methods; this module only runs them."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ...compiling import watch

watch()  # the first compilation on a machine is said (profiles.compiling)


@nb.njit(cache=True, nogil=True)
def layers(valid: np.ndarray, weight: np.ndarray, packed_w: np.ndarray, start: np.ndarray,
           f: np.ndarray, lam: float, start_f: float, jump: float, max_stages: int,
           value: np.ndarray, packed: np.ndarray, parents: np.ndarray, reach: np.ndarray
           ) -> int:
    """Paths of 2..max_stages stages: `value[j]` the least cost of a path ending at node j,
    `packed[j]` its pulses (total << 32 | accel), `parents[m, j]` the predecessor of j in
    layer m (−1: the path of layer m − 1 stands). Each layer is computed from the one
    before it. Returns the number of layers written (the last ones change nothing).
    Node j's w-th predecessor is node j − 1 − w; the step costs weight · (1/f_pred − lam)
    where `valid` (numpy's arithmetic, in its order), else it is never taken, and past
    the first `reach[j]` none is valid (they are not looked at)."""
    g = valid.shape[0]
    inv = np.empty(g)
    for j in range(g):
        inv[j] = 1.0 / f[j]
    for j in range(g):
        value[j] = 0.0 if start[j] else math.inf
        packed[j] = 0
    prev = np.empty(g)
    prev_packed = np.empty(g, dtype=np.int64)
    # A node's value can improve in layer m only if a predecessor's improved in layer m − 1
    # (else its best is the same sum as before, which its value already holds): `moved`
    # counts the nodes that improved in the last layer, node by node, and a node none of
    # whose predecessors (j − 1 … j − reach[j]: search.graph) moved is skipped. Most of a
    # layer is, and the result is the same to the bit.
    moved = np.zeros(g + 1, dtype=np.int64)
    count = 2
    hi_prev = 0
    for m in range(2, max_stages + 1):
        hi = min(int(np.searchsorted(f, start_f + (m - 1) * jump * (1 + 1e-9), side="right")),
                 g)
        prev[:] = value
        prev_packed[:] = packed
        changed = False
        every = m <= 3  # layer 2 sets every value; layer 3 compares with all of them
        for j in range(hi):
            if not every and j < hi_prev and moved[j] == moved[max(j - reach[j], 0)]:
                continue  # no predecessor moved: parents[m, j] stays −1
            best = math.inf
            pick = 0
            for w in range(reach[j]):
                if not valid[j, w]:
                    continue  # an infinite cost: never less than `best`
                c = prev[j - 1 - w] + weight[j, w] * (inv[j - 1 - w] - lam)
                if c < best:  # the first of equal costs, as numpy's argmin
                    best = c
                    pick = w
            src = max(j - 1 - pick, 0)
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
        total = 0
        for j in range(g):  # moved[j]: how many nodes before j improved in this layer
            moved[j] = total
            if value[j] != prev[j] or m == 2:
                total += 1
        moved[g] = total
        hi_prev = hi
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


def _count_py(r_slow: float, r_fast: float, hz: float, v: np.ndarray, t: np.ndarray,
              sf: float, friction: float, load: float, k: float, edges: np.ndarray,
              scale: np.ndarray, plain: bool, jump: float, separate: bool, bands: np.ndarray,
              base_ticks: float, most: float) -> tuple[float, float, bool]:
    """One step's (accel count, decel count, valid): `Problem.counts` (the method and its
    comments are there)."""
    f_slow = hz / r_slow
    f_fast = hz / (r_fast if r_fast > 0 else 1.0)
    # a_acc and a_dec grow with the torque, and rounding keeps that order: the least
    # capability is the capability of the least torque, to the bit
    torque = _least_torque(f_slow, f_fast, v, t)
    sigma = 1.0 if plain else scale[np.searchsorted(edges, f_slow, side="right")]
    base = max(2.0, np.ceil(base_ticks / r_slow))
    banned = not r_fast > 0 or _in_band(f_slow, bands) or _in_band(f_fast, bands)
    return _counts_of(torque, f_slow, f_fast, sigma, base, banned, sf, friction, load, k,
                      plain, jump, separate, most)


@nb.njit(cache=True, nogil=True, inline="always")
def _in_band(f: float, bands: np.ndarray) -> bool:
    """Whether speed `f` lies in one of the (lo, hi) `bands` (a jump may step over them)."""
    for b in range(bands.shape[0]):
        if bands[b, 0] <= f <= bands[b, 1]:
            return True
    return False


@nb.njit(cache=True, nogil=True, inline="always")
def _counts_of(torque: float, f_slow: float, f_fast: float, sigma: float, base: float,
               banned: bool, sf: float, friction: float, load: float, k: float,
               plain: bool, jump: float, separate: bool, most: float
               ) -> tuple[float, float, bool]:
    """A step's counts and validity (`_count_py`) from the least torque over it, its
    slower stage's band scale `sigma` and chip minimum `base`, and whether a stage lies in
    a band a jump may step over (`banned`)."""
    c_acc = (friction + load) * k
    c_dec = (load - friction) * k
    delta = f_fast - f_slow
    a_acc = (sf * torque - friction - load) * k
    a_dec = (sf * torque + friction - load) * k
    jump_e = jump
    if not plain:
        a_acc = sigma * (a_acc + c_acc) - c_acc
        a_dec = sigma * (a_dec + c_dec) - c_dec
        jump_e = jump * sigma
    n_e = np.ceil(delta * f_slow / a_acc) if a_acc > 0 else math.inf
    d_e = np.ceil(delta * f_slow / a_dec) if a_dec > 0 else math.inf
    n_e = max(n_e, base)
    d_e = max(d_e, base)
    if not separate:
        n_e = d_e = max(n_e, d_e)
    ok = (not banned and delta > 0 and delta <= jump_e and n_e <= most and d_e <= most)
    return n_e, d_e, ok


# Inlined where a loop over steps does nothing else (stage_counts); called where it is
# one part of a larger loop (refine_inner: inlining it twice there took ten seconds to
# compile, for no measurable gain).
_count_inline = nb.njit(cache=True, nogil=True, inline="always")(_count_py)
_count = nb.njit(cache=True, nogil=True)(_count_py)


@nb.njit(cache=True, nogil=True)
def stage_counts(rs: np.ndarray, rf: np.ndarray, hz: float, v: np.ndarray, t: np.ndarray,
                 sf: float, friction: float, load: float, k: float, edges: np.ndarray,
                 scale: np.ndarray, plain: bool, jump: float, separate: bool,
                 bands: np.ndarray, base_ticks: float, most: float, n: np.ndarray,
                 d: np.ndarray, valid: np.ndarray) -> None:
    """`Problem.counts` element by element: the planner's graph calls it on tens of
    thousands of steps, and numpy's temporaries (a torque interpolation per end and
    breakpoint) were half a plan."""
    for e in range(len(rs)):
        n[e], d[e], valid[e] = _count_inline(rs[e], rf[e], hz, v, t, sf, friction, load, k,
                                             edges, scale, plain, jump, separate, bands,
                                             base_ticks, most)


@nb.njit(cache=True, nogil=True)
def graph_counts(rates: np.ndarray, width: int, hz: float, v: np.ndarray, t: np.ndarray,
                 sf: float, friction: float, load: float, k: float, edges: np.ndarray,
                 scale: np.ndarray, plain: bool, jump: float, separate: bool,
                 bands: np.ndarray, base_ticks: float, most: float, weight: np.ndarray,
                 accel: np.ndarray, packed_w: np.ndarray, valid: np.ndarray,
                 reach: np.ndarray) -> None:
    """`stage_counts` over the planner's whole graph (`search.graph`: node j's
    predecessors are j − 1 … j − width, `rates` slowest first), to the bit, with what
    depends on one stage alone worked out once per node: its torque, band scale, chip
    minimum and resonance band; the least torque over the curve's breakpoints inside a
    step is carried from one predecessor to the next slower one (the step [f_i, f_j]
    holds the breakpoints of [f_(i+1), f_j] and those in (f_i, f_(i+1)]: the minimum of
    the same values). A motor whose jump limit is large against the grid's spacing (a
    datasheet motor that starts fast: hundreds of predecessors a node) spent most of a
    plan interpolating the curve at every step. Writes each step's weight (accel + decel
    count), accel count and both packed (weight << 32 | accel) where valid, 0 elsewhere;
    entries with no predecessor (w ≥ j) are invalid; `reach[j]`: 1 + the last valid w of
    node j (0: none), where the DP stops."""
    g = len(rates)
    last = len(v) - 1
    f = np.empty(g)
    at = np.empty(g)
    sigma = np.ones(g)
    base = np.empty(g)
    banned = np.empty(g, dtype=np.bool_)
    for i in range(g):
        f[i] = hz / float(rates[i])
        at[i] = _torque(f[i], v, t)
        if not plain:
            sigma[i] = scale[np.searchsorted(edges, f[i], side="right")]
        base[i] = max(2.0, np.ceil(base_ticks / float(rates[i])))
        banned[i] = _in_band(f[i], bands)
    for j in range(g):
        f_fast = f[j]
        b = last - 1  # the highest inner breakpoint below f_fast
        while b >= 1 and not v[b] < f_fast:
            b -= 1
        inner = math.inf  # the least torque of the breakpoints strictly inside the step
        reach[j] = 0
        for w in range(width):
            i = j - 1 - w
            if i < 0:
                weight[j, w] = accel[j, w] = 0.0
                packed_w[j, w] = 0
                valid[j, w] = False
                continue
            f_slow = f[i]
            while b >= 1 and f_slow < v[b]:
                if t[b] < inner:
                    inner = t[b]
                b -= 1
            torque = min(at[i], at[j])
            if inner < torque:
                torque = inner
            n_e, d_e, ok = _counts_of(torque, f_slow, f_fast, sigma[i], base[i],
                                      banned[i] or banned[j], sf, friction, load, k, plain,
                                      jump, separate, most)
            valid[j, w] = ok
            if ok:
                weight[j, w] = n_e + d_e
                accel[j, w] = n_e
                packed_w[j, w] = (np.int64(n_e + d_e) << 32) + np.int64(n_e)
                reach[j] = w + 1
            else:
                weight[j, w] = accel[j, w] = 0.0
                packed_w[j, w] = 0


@nb.njit(cache=True, nogil=True)
def refine_inner(r: np.ndarray, offsets: np.ndarray, parity: int, r_start: int,
                 rate_max: int, slack: float, new: np.ndarray, hz: float, v: np.ndarray,
                 t: np.ndarray, sf: float, friction: float, load: float, k: float,
                 edges: np.ndarray, scale: np.ndarray, plain: bool, jump: float,
                 separate: bool, bands: np.ndarray, base_ticks: float, most: float) -> bool:
    """One move of `refine._refine_inner` (the method is there), compiled: each stage of
    `parity` below the top tries the rates `r[k] + offsets` between its neighbours and
    takes the one that costs least (its step down to the next stage and the step into
    it, priced at λ = 1/f_top), within `slack` pulses. Writes the moved rates into
    `new`; False when no stage moves. (In numpy, its temporaries were a fifth of a
    plan.)"""
    m = len(r)
    lam = r[m - 1] / hz
    cur = 0
    while offsets[cur] != 0:
        cur += 1
    count = (m - 1 - parity + 1) // 2
    picks = np.empty(count, dtype=np.int64)
    moving = np.zeros(count, dtype=np.bool_)
    dws = np.zeros(count)
    total_dw = 0.0
    any_move = False
    for i in range(count):
        ks = parity + 2 * i
        upper = r[ks - 1] if ks > 0 else rate_max + 1
        lower = r[ks + 1]
        best = cost_cur = math.inf
        pick = 0
        w_pick = w_cur = 0.0
        for o in range(len(offsets)):
            cand = r[ks] + offsets[o]
            ok = cand > lower and cand < upper and cand <= rate_max
            if ks == 0:
                ok = ok and cand >= r_start
            if not ok:
                if o != cur:
                    continue  # out of range: infinite cost (pick stays the first least)
                cand = r[ks]
            f_c = hz / float(cand)
            n_out, d_out, v_out = _count(float(cand), float(lower), hz, v, t, sf, friction,
                                         load, k, edges, scale, plain, jump, separate, bands,
                                         base_ticks, most)
            cost = (n_out + d_out) * (1.0 / f_c - lam)
            w = n_out + d_out
            feasible = ok and v_out
            if ks > 0:
                n_in, d_in, v_in = _count(float(upper), float(cand), hz, v, t, sf, friction,
                                          load, k, edges, scale, plain, jump, separate,
                                          bands, base_ticks, most)
                f_in = hz / float(upper)
                cost = cost + (n_in + d_in) * (1.0 / f_in - lam)
                w = w + (n_in + d_in)
                feasible = feasible and v_in
            if not feasible:
                cost = math.inf
            if cost < best:  # the first of equal costs, as numpy's argmin
                best = cost
                pick = o
                w_pick = w
            if o == cur:
                cost_cur = cost
                w_cur = w
        picks[i] = r[ks] + offsets[pick]
        gain = cost_cur - best
        dws[i] = w_pick - w_cur
        moving[i] = gain > 0 and math.isfinite(best)
        if moving[i]:
            total_dw += dws[i]
    if total_dw > slack:
        for i in range(count):
            moving[i] = moving[i] and dws[i] <= 0
    new[:] = r
    for i in range(count):
        if moving[i]:
            new[parity + 2 * i] = picks[i]
            any_move = True
    return any_move


@nb.njit(cache=True, nogil=True)
def _switch_safe(n: np.ndarray, d: np.ndarray, extra: int) -> bool:
    """`criterion.switch_safe_rows` for one row of decel counts `d` with `extra` pulses
    on its top stage, the same integer arithmetic, stopping at the first triangle that
    switches down."""
    m = len(n)
    a = 0
    for k in range(m):
        a += n[k]
    dd = extra
    for k in range(m):
        dd += d[k]
    if a == 0 or dd <= 0:
        return False
    total = a + dd
    if -(-(a + dd) // a) - 1 > (d[0] + (extra if m == 1 else 0)):
        return False  # a decel-only move would start above the slowest stage
    cn = 0
    cd = 0
    for j in range(m - 1):
        cn += n[j]
        cd += d[j]
        rest = -(-(cn + 1) * total // a)  # the first rest whose accel enters stage j + 1
        if -(-(rest * dd) // total) < cd + 1:
            return False
    return True


@nb.njit(cache=True, nogil=True)
def switch_safe_tops(n: np.ndarray, d0: np.ndarray, room: np.ndarray, hi: np.ndarray,
                     found: np.ndarray) -> None:
    """For each row k of decel counts `d0` (rows × stages, slowest first) the fewest
    pulses `hi[k]` ≤ `room[k]` to add on the top stage that make the table switch-safe
    against accel counts `n`: doubling from 1 until safe, then bisection back
    (`refine.switch_safe_decel` says why); `found[k]` False when doubling passed the room
    first."""
    for k in range(d0.shape[0]):
        row = d0[k]
        h = 0
        ok = _switch_safe(n, row, 0)
        if not ok and room[k] >= 1:
            h = 1
            while True:
                if _switch_safe(n, row, h):
                    ok = True
                    break
                h *= 2
                if h > room[k]:
                    break
        lo = h // 2 if ok and h > 0 else 0
        while ok and h - lo > 1:  # unsafe at lo (or h = 0), safe at h
            mid = (lo + h) // 2
            if _switch_safe(n, row, mid):
                h = mid
            else:
                lo = mid
        hi[k] = h
        found[k] = ok

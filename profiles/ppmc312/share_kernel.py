"""How the load-angle verdict's executions share their integration, compiled (numba,
cached on disk): the batch of moves rewritten so that each starts from the state of
another move whose command it repeats (profiles.ppmc312.load_angle.judge).

- `dwells`: neighbouring segments of one rate joined: a constant command is one span.
  A triangle's peak runs the accel side's partial stage and then the decel side's
  first at one rate; a trapezoid runs its top stage, its cruise and its decel's top
  stage at one rate. Each is one dwell, whose length alone changes within a family.
- `shared_dwells`: the moves that part from the reference (the move with the most
  segments) at one segment, at its rate but for another count (a family: the
  triangles peaking at one stage, the trapezoids, their dwell growing with the move),
  cut where each of them ends that segment. Each is then its family's longest
  member's prefix to the end of its own dwell, and starts from that member's state
  there (its source), integrating none of its dwell. When the reference's own dwell
  is its family's longest and no other move runs that segment whole, the reference is
  that source (the trapezoids' dwell at the top speed); cutting a segment that other
  moves run whole would make them part from the reference there.

Cut alike, k moves make ~k²/2 pieces: past `cap` pieces a batch is left as it is
(each move integrates its own dwell). These are loops over ~10⁵ segments, which
numpy's repeat-and-cumsum passes took a quarter of a verdict to do.
"""

from __future__ import annotations

import numba as nb
import numpy as np

_jit = nb.njit(cache=True, nogil=True)

Batch = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]  # phase, rate, count, offsets


@_jit
def dwells(phase: np.ndarray, rate: np.ndarray, count: np.ndarray, offsets: np.ndarray,
           out_phase: np.ndarray, out_rate: np.ndarray, out_count: np.ndarray
           ) -> tuple[int, np.ndarray]:
    """The moves with neighbouring segments of one rate joined (the first one's phase),
    into out_*[:k] (as long as the input at least): (k, the new offsets)."""
    out_offsets = np.empty_like(offsets)
    k = 0
    for e in range(len(offsets) - 1):
        out_offsets[e] = k
        for i in range(offsets[e], offsets[e + 1]):
            if i > offsets[e] and rate[i] == rate[i - 1]:
                out_count[k - 1] += count[i]
            else:
                out_phase[k], out_rate[k], out_count[k] = phase[i], rate[i], count[i]
                k += 1
    out_offsets[len(offsets) - 1] = k
    return k, out_offsets


@_jit
def _cut(phase: np.ndarray, rate: np.ndarray, count: np.ndarray, offsets: np.ndarray,
         at: np.ndarray, pieces: np.ndarray, start: np.ndarray, table: np.ndarray,
         out_phase: np.ndarray, out_rate: np.ndarray, out_count: np.ndarray
         ) -> tuple[int, np.ndarray]:
    """The moves with segment at[c] (ascending) cut into `pieces[c]` segments of its phase
    and rate, of counts table[start[c]:start[c] + pieces[c]], into out_*[:k]: (k, the new
    offsets), or (−k, offsets) when out_* hold fewer than the k segments."""
    total = len(rate)
    for c in range(len(at)):
        total += pieces[c] - 1
    out_offsets = np.empty_like(offsets)
    if total > len(out_rate):
        return -total, out_offsets
    k = 0
    c = 0
    e = 0
    for i in range(len(rate)):
        while offsets[e] == i:  # the moves that start here (a move has a segment at least)
            out_offsets[e] = k
            e += 1
        if c < len(at) and at[c] == i:
            for j in range(pieces[c]):
                out_phase[k], out_rate[k], out_count[k] = phase[i], rate[i], table[start[c] + j]
                k += 1
            c += 1
        else:
            out_phase[k], out_rate[k], out_count[k] = phase[i], rate[i], count[i]
            k += 1
    out_offsets[e:] = k
    return k, out_offsets


@_jit
def shared_dwells(phase: np.ndarray, rate: np.ndarray, count: np.ndarray, offsets: np.ndarray,
                  ref: int, cap: int, out_phase: np.ndarray, out_rate: np.ndarray,
                  out_count: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """The moves with each family's dwell cut alike, into out_*[:k]: (k, the new offsets,
    each move's source, −1 for the reference `ref`); k = 0 when nothing is cut (past
    `cap` pieces), −k when out_* hold fewer than the k segments."""
    moves = len(offsets) - 1
    source = np.full(moves, -1, np.int64)
    r0 = offsets[ref]
    m = offsets[ref + 1] - r0
    at = np.full(moves, -1, np.int64)  # the segment where a move parts, at the ref's rate
    key = np.zeros(moves, np.int64)    # its family (that segment's index) then its count
    deepest = 0  # the most segments another move shares with the reference
    for e in range(moves):
        size = offsets[e + 1] - offsets[e]
        lim = min(size, m)
        head = 0
        while head < lim and rate[offsets[e] + head] == rate[r0 + head] and \
                count[offsets[e] + head] == count[r0 + head]:
            head += 1
        if e == ref:
            continue
        deepest = max(deepest, head)
        if head < lim and rate[offsets[e] + head] == rate[r0 + head]:
            at[e] = offsets[e] + head
            key[e] = (head << 32) | count[at[e]]  # counts are at most 0xFFFFFFFF
    parts = np.flatnonzero(at >= 0)
    parts = parts[np.argsort(key[parts], kind="mergesort")]
    # the cuts: at each member's segment and at the reference's where it is the source
    cut_at = np.empty(2 * len(parts), np.int64)
    pieces = np.empty(2 * len(parts), np.int64)
    start = np.empty(2 * len(parts), np.int64)
    table = np.empty(2 * len(parts), count.dtype)  # each family's distinct counts, as pieces
    cuts = 0
    distinct = 0
    a = 0
    while a < len(parts):  # one family: parts[a:b]
        b = a + 1
        while b < len(parts) and key[parts[b]] >> 32 == key[parts[a]] >> 32:
            b += 1
        # the reference is the family's source when its dwell is the longest and no
        # other move runs that segment whole (cut, it would part from the reference
        # there): the trapezoids' dwell at the top speed
        mine = r0 + (key[parts[a]] >> 32)  # the reference's segment there
        own = count[mine] >= count[at[parts[b - 1]]] and key[parts[a]] >> 32 >= deepest
        longest = -1 if own else parts[b - 1]
        first = distinct
        previous = 0
        for j in range(a, b + (1 if longest < 0 else 0)):
            seg = mine if j == b else at[parts[j]]
            if count[seg] != previous:
                table[distinct] = count[seg] - previous
                previous = count[seg]
                distinct += 1
            cut_at[cuts], pieces[cuts], start[cuts] = seg, distinct - first, first
            cuts += 1
            if j < b and parts[j] != longest:
                source[parts[j]] = longest
        a = b
    order = np.argsort(cut_at[:cuts])
    if pieces[:cuts].sum() > cap:
        return 0, offsets, np.full(moves, -1, np.int64)
    k, out_offsets = _cut(phase, rate, count, offsets, cut_at[:cuts][order],
                          pieces[:cuts][order], start[:cuts][order], table, out_phase,
                          out_rate, out_count)
    return k, out_offsets, source

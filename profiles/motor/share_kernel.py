"""How the load-angle verdict's executions share their integration, compiled (numba,
cached on disk): the batch of moves rewritten so that each starts from the state of
another move whose command it repeats (profiles.ppmc312.load_angle.judge).

- `dwells`: neighbouring segments of one rate joined: a constant command is one span.
  A triangle's peak runs the accel side's partial stage and then the decel side's
  first at one rate; a trapezoid runs its top stage, its cruise and its decel's top
  stage at one rate. Each is one dwell, whose length alone changes within a family.
- `parting`, `families`, `cut`: the moves that part from the reference (the move with
  the most segments) at one segment, at its rate but for another count (a family: the
  triangles peaking at one stage, the trapezoids, their dwell growing with the move),
  cut where each of them ends that segment. Each is then its family's longest
  member's prefix to the end of its own dwell, and starts from that member's state
  there (its source), integrating none of its dwell. When the reference's own dwell
  is its family's longest and no other move runs that segment whole, the reference is
  that source (the trapezoids' dwell at the top speed); cutting a segment that other
  moves run whole would make them part from the reference there.
  `load_angle.shared_dwells` runs the three, sorting in numpy between them (numba's
  sorts took ten seconds to compile) and giving up past `SHARED_PIECES` pieces (cut
  alike, k moves make ~k²/2: each then integrates its own dwell).

These are loops over ~10⁵ segments, which numpy's repeat-and-cumsum passes took a
quarter of a verdict to do. Outputs go to buffers the caller gives (reused between
verdicts: fresh ones fault their pages in).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..compiling import watch

watch()  # the first compilation on a machine is said (profiles.compiling)

_jit = nb.njit(cache=True, nogil=True)



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
def cut(phase: np.ndarray, rate: np.ndarray, count: np.ndarray, offsets: np.ndarray,
        at: np.ndarray, pieces: np.ndarray, start: np.ndarray, table: np.ndarray,
        out_phase: np.ndarray, out_rate: np.ndarray, out_count: np.ndarray
        ) -> tuple[int, np.ndarray]:
    """The moves with segment at[c] (ascending) cut into `pieces[c]` segments of its phase
    and rate, of counts table[start[c]:start[c] + pieces[c]], into out_*[:k] (room for
    len(rate) + Σ(pieces − 1) segments at least): (k, the new offsets)."""
    out_offsets = np.empty_like(offsets)
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
def parting(rate: np.ndarray, count: np.ndarray, offsets: np.ndarray, ref: int
            ) -> tuple[np.ndarray, np.ndarray, int]:
    """Where each move parts from the reference `ref` at its rate for another count:
    (that segment's index or −1, its family key: that segment's place in the move, then
    its count, the most segments another move shares with the reference)."""
    moves = len(offsets) - 1
    r0 = offsets[ref]
    m = offsets[ref + 1] - r0
    at = np.full(moves, -1, np.int64)
    key = np.zeros(moves, np.int64)
    deepest = 0
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
    return at, key, deepest


@_jit
def families(count: np.ndarray, offsets: np.ndarray, ref: int, at: np.ndarray,
             key: np.ndarray, parts: np.ndarray, deepest: int
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The cuts of the moves `parts` (sorted by family key, `parting`): (the segments to
    cut, into how many pieces, from which entry of the table of pieces, that table, each
    move's source (−1: the reference)).

    A family's dwell is cut where each member's ends; its longest member is the others'
    source. The reference is the source instead when its dwell is the longest and no
    other move runs that segment whole (cut, it would part from the reference there):
    the trapezoids' dwell at the top speed."""
    source = np.full(len(offsets) - 1, -1, np.int64)
    r0 = offsets[ref]
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
    return cut_at[:cuts], pieces[:cuts], start[:cuts], table[:distinct], source

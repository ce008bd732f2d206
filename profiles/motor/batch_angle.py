"""The load angle over a batch of moves (`batch.MoveBatch`), whatever device runs them:
the compiled rotor model (`rotor_kernel`) run over every move of the batch for every
rotor (`judge`), sharing work between moves (`share_kernel`: a constant command is one
dwell, cut alike within a family, each member starting from its family's longest
member's state), on threads; how to sample runs whose dwell grows (`dwell_sampling`,
`sample_grid`) and which to judge again around the worst (`refine`); a tolerance box's
Monte Carlo samples on a batch (`batch_sample_peaks`). Each device's verdict builds the
batches (the PPMC-312's executions: `profiles.ppmc312.load_angle`; the A-Link unit's
motions: `profiles.alink.safety`).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence

import numpy as np

from ..threads import pool
from .batch import MoveBatch
from .model import Motor
from .rotor import (
    MAX_RK4_STEPS,
    MAX_SETTLE_PERIODS,
    PEAK_DEG,
    SETTLE_TOL_DEG,
    SLIP_DEG,
    Rotor,
    Rotors,
    rotors,
    too_stiff,
)
from .tolerance import sample_params

REJOIN_TOL_DEG = 0.05
MAX_VERDICT_STEPS = 8_000_000   # RK4 steps for every execution of one verdict, per rotor
SETTLE_CRUISE_PERIODS = 10
PHASE_SAMPLES = 8               # samples per natural period of a partial stage's dwell
REFINE_DEG = 3.0                # sampled families this close to the worst: their peak searched
STOP_REFINE_DEG = 1.5           # stops' sampled ranges this close to the worst: refined


def sample_grid(lo: np.ndarray, spacing: np.ndarray, dense: np.ndarray, hi: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Every range k's samples lo[k], lo[k] + spacing[k], … up to dense[k], then dense[k]
    and hi[k] themselves: (the values, the range of each), in that order, repeats kept
    (the caller makes them unique, by what it keys them on)."""
    count = (dense - lo) // spacing + 1
    family = np.repeat(np.arange(len(lo)), count)
    within = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    values = np.concatenate((np.minimum(lo[family] + within * spacing[family], dense[family]),
                             dense, hi))
    return values, np.concatenate((family, np.arange(len(lo)), np.arange(len(lo))))


def dwell_sampling(rotor_list: Sequence[Rotor], speed: np.ndarray, lo: np.ndarray,
                   hi: np.ndarray, share: np.ndarray | int) -> tuple[np.ndarray, np.ndarray]:
    """How to sample runs lo..hi whose dwell at `speed` grows by 1/`share` pulse a run
    (a move family's, a stop's dwell): (the spacing that moves the dwell by at most
    1/PHASE_SAMPLES of the natural period there, the stiffest rotor's; the last run
    sampled so: past it the dwell has lasted SETTLE_CRUISE_PERIODS natural periods for
    every rotor, and a longer one repeats that settled state)."""
    spacing = np.maximum(hi - lo, 1)
    periods = np.array([r.natural_periods_s(speed) for r in rotor_list])
    period = periods.min(axis=0)
    # a motor with no torque at that speed has no period there: it cannot hold the
    # command, and a dwell of a few periods at rest is long enough to show it slipping
    rest = np.array([[r.natural_period_s(0.0)] for r in rotor_list])
    settle = np.where(np.isfinite(periods), np.minimum(periods, 1.0), rest).max(axis=0)
    finite = np.isfinite(period)
    spacing[finite] = np.maximum(1, np.minimum(
        spacing[finite], (period[finite] * speed[finite] / PHASE_SAMPLES).astype(np.int64)))
    dense = np.minimum(hi, lo + share * np.maximum(
        np.ceil(speed * SETTLE_CRUISE_PERIODS * settle).astype(np.int64), 1))
    return spacing, dense


def refine(lengths: np.ndarray, family: np.ndarray, spacing: np.ndarray,
           worst_deg: np.ndarray, judge_at: Callable[[np.ndarray], np.ndarray]) -> None:
    """Judge, through `judge_at` (lengths never asked before, ascending → each one's
    worst angle), what the samples of the families that come out worst leave open: each
    such family's peak (sampling may pass its top by a little), for the families within
    REFINE_DEG of the worst of all, and every length before a family's first sample past
    the 90° peak (so the shortest unstable move is named exactly).

    A peak is searched between the family's worst sample and each of its neighbours:
    the worst angle varies with the length as the ringing's phase at the next speed
    change, smooth over the eighth of a period between samples, so each span rises to
    one top. A round judges SEARCH_POINTS lengths evenly inside every open span and
    keeps the spans beside each one's highest point, until no length is left inside;
    a span of SEARCH_POINTS lengths or fewer is judged whole. (Checked against every
    length: tests/profiles/ppmc312/test_load_angle.py; about a quarter of the lengths.)"""
    best = float(worst_deg.max())
    starts = np.flatnonzero(np.diff(family, prepend=-1))
    ends = np.append(starts[1:], len(family))
    top = np.maximum.reduceat(worst_deg, starts)  # each family's worst sample
    wanted = (spacing[family[starts]] > 1) & ((top >= best - REFINE_DEG) | (top >= PEAK_DEG))
    spans: list[tuple[int, float, int, float]] = []  # (a, angle at a, b, angle at b)
    asked: set[int] = set()  # judged in the next round
    for a, b in zip(starts[wanted].tolist(), ends[wanted].tolist(), strict=True):
        w, at = worst_deg[a:b].tolist(), lengths[a:b].tolist()
        k = int(np.argmax(w))
        if w[k] >= best - REFINE_DEG:
            spans += [(at[j], w[j], at[j + 1], w[j + 1]) for j in (k - 1, k)
                      if 0 <= j < len(w) - 1]
        unstable = np.flatnonzero(np.asarray(w) >= PEAK_DEG)
        if len(unstable) and unstable[0] > 0:
            asked.update(range(at[unstable[0] - 1] + 1, at[unstable[0]]))
    known: dict[int, float] = {}
    while spans or asked:
        inside = [_inside(a, b) for a, _, b, _ in spans]
        asked.update(n for points in inside for n in points)
        ask = np.array(sorted(asked.difference(known)), dtype=np.int64)
        asked = set()
        if len(ask):
            known.update(zip(ask.tolist(), judge_at(ask).tolist(), strict=True))
        spans = [s for span, points in zip(spans, inside, strict=True)
                 for s in _beside_top(span, points, known)]


SEARCH_POINTS = 3   # lengths judged inside a span a round while searching for its top


def merged(parts: Sequence[tuple[np.ndarray, ...]]) -> tuple[np.ndarray, ...]:
    """Parts of one verdict judged apart (as `refine` asks for them), each (the keys of
    its executions, then arrays of rows × executions), as one in the order of the keys
    (none in two parts)."""
    if len(parts) == 1:
        return tuple(parts[0])
    keys = np.concatenate([p[0] for p in parts])
    order = np.argsort(keys, kind="stable")
    return (keys[order], *(np.concatenate([p[i] for p in parts], axis=1)[:, order]
                           for i in range(1, len(parts[0]))))


def _inside(a: int, b: int) -> list[int]:
    """The lengths a round judges strictly between a and b: all of them when there are
    SEARCH_POINTS or fewer, else SEARCH_POINTS evenly spread (nearest, halves to even)."""
    if b - a - 1 <= SEARCH_POINTS:
        return list(range(a + 1, b))
    return sorted({round(a + (b - a) * k / (SEARCH_POINTS + 1))
                   for k in range(1, SEARCH_POINTS + 1)})


def _beside_top(span: tuple[int, float, int, float], points: list[int],
                known: dict[int, float]) -> list[tuple[int, float, int, float]]:
    """The spans left to search once `points` inside `span` are judged: the two beside
    the highest of its ends and points (one at an end), those with lengths left inside."""
    a, fa, b, fb = span
    xs = [a, *points, b]
    ys = [fa, *(known[x] for x in points), fb]
    i = max(range(len(ys)), key=ys.__getitem__)  # the first of the highest
    return [(xs[j], ys[j], xs[j + 1], ys[j + 1]) for j in (i - 1, i)
            if 0 <= j < len(xs) - 1 and xs[j + 1] - xs[j] > 1
            and not all(x in known for x in range(xs[j] + 1, xs[j + 1]))]


def refine_toward(keys: np.ndarray, family: np.ndarray, worst_deg: np.ndarray) -> np.ndarray:
    """The dwells still to judge (`Dwells` keys), as `refine` finds them for
    move lengths, but on one side of each range's worst sample: the worst angle varies with
    the dwell as the ringing's phase at the step down, smooth over the eighth of a period
    between samples, so its peak lies between the worst sample and the larger of its two
    neighbours (both sides when they are not equally far), for the ranges within
    STOP_REFINE_DEG of the worst; and every dwell before a range's first sample past the
    90° peak. (Half of `refine`'s dwells, on fewer ranges: after tightening, most
    stages' stops come near the aim.) The PPMC-312's decel stops (`Dwells` keys of its
    stages) and the A-Link's stops along its ramp both refine so."""
    best = float(worst_deg.max())
    extra: list[np.ndarray] = []
    starts = np.flatnonzero(np.diff(family, prepend=-1))
    ends = np.append(starts[1:], len(family))
    top = np.maximum.reduceat(worst_deg, starts)
    wanted = (top >= best - STOP_REFINE_DEG) | (top >= PEAK_DEG)
    for a, b in zip(starts[wanted].tolist(), ends[wanted].tolist(), strict=True):
        w, at = worst_deg[a:b], keys[a:b]
        k = int(np.argmax(w))
        if w[k] >= best - STOP_REFINE_DEG:
            left = float(w[k - 1]) if k > 0 else -np.inf
            right = float(w[k + 1]) if k + 1 < len(w) else -np.inf
            even = 0 < k < len(w) - 1 and at[k] - at[k - 1] == at[k + 1] - at[k]
            lo = at[k - 1] + 1 if k > 0 and (left >= right or not even) else at[k]
            hi = at[k + 1] - 1 if k + 1 < len(w) and (right > left or not even) else at[k]
            extra.append(np.arange(lo, hi + 1))
        unstable = np.flatnonzero(w >= PEAK_DEG)
        if len(unstable) and unstable[0] > 0:
            extra.append(np.arange(at[unstable[0] - 1] + 1, at[unstable[0]]))
    if not extra:
        return np.zeros(0, dtype=np.int64)
    return np.setdiff1d(np.concatenate(extra), keys)


def judge(runs: MoveBatch, hz: float, rot: Rotors, *, max_step_s: float | None = None,
          families: bool = True, share_slipped: bool = False
          ) -> tuple[np.ndarray, np.ndarray]:
    """Every execution of `runs` for every rotor: (worst |lag| [pulses], slipped), each of
    shape (rotors, executions). A verdict that would take more than MAX_VERDICT_STEPS
    RK4 steps for one rotor is refused. `families`: the members of a family start from
    its longest member's state at the end of their own dwell (`shared_dwells`; False:
    from the reference's, integrating their dwell themselves: the same numbers, slower).
    `share_slipped`: executions start from a slipped reference's states before its slip
    too (the A-Link's stops at once, whose longest slips from H: the same numbers to
    rounding, a twentieth of the steps); without it they integrate from rest, as the
    PPMC-312's verdicts, whose planner's choices are pinned to those exact numbers, do."""
    from . import rotor_kernel as rk

    runs = dwells(runs, _SCRATCH)
    # the reference: the most segments (every stage), the longest of those (the longest
    # trapezoid, whose dwell at the top speed the others' are cut from)
    ref = int(np.lexsort((runs.pulses, np.diff(runs.offsets)))[-1])
    runs, source = shared_dwells(runs, ref, _SCRATCH)
    if not families:
        source[:] = -1
    steps = rot.step_s(max_step_s)
    settles = rot.settle_s(steps)
    n_rot, n_exec = len(rot), len(runs)
    m = int(runs.offsets[ref + 1] - runs.offsets[ref])
    ref_max, ref_lag, ref_s = (np.zeros((n_rot, m + 1)) for _ in range(3))
    suffix = np.zeros((n_rot, m + 2))
    limits = np.zeros((n_rot, 4))
    ref_status = np.zeros(n_rot, np.int64)
    ref_slipped = np.zeros(n_rot, np.bool_)
    ref_used = np.zeros(n_rot, np.int64)
    ref_valid = np.zeros(n_rot, np.int64)
    common = (rot.curve_v, rot.curve_t, rot.rows, steps, settles, runs.rate, runs.count)
    rk.references(*common, int(runs.offsets[ref]), int(runs.offsets[ref + 1]), hz, SLIP_DEG,
                  SETTLE_TOL_DEG, MAX_SETTLE_PERIODS, REJOIN_TOL_DEG, MAX_RK4_STEPS, ref_max,
                  ref_lag, ref_s, suffix, limits, ref_status, ref_slipped, ref_used,
                  ref_valid)
    if not share_slipped:
        ref_valid[ref_slipped] = 0
    ref_worst = np.maximum.accumulate(ref_max, axis=1)
    # the sources' states at the end of each of their segments, for their members
    sources = np.unique(source[source >= 0])
    slot = np.full(n_exec, -1, np.int64)
    size = np.diff(runs.offsets)[sources]
    slot[sources] = np.cumsum(size) - size
    kept = n_rot * int(size.sum())
    fam_lag, fam_s, fam_worst = _SCRATCH.take("sources", 3 * kept, np.dtype(float))[
        :3 * kept].reshape(3, n_rot, -1)
    fam_known = np.zeros((n_rot, n_exec), np.int64)
    lag = np.zeros((n_rot, n_exec))
    slipped = np.zeros((n_rot, n_exec), np.bool_)
    status = np.zeros((n_rot, n_exec), np.int64)
    used = np.zeros((n_rot, n_exec), np.int64)
    # each family together, its source first: a range of cells never splits one
    members = source >= 0
    family = np.where(members, source, np.arange(n_exec))
    order = np.lexsort((members, family))
    starts = np.flatnonzero(np.diff(family[order], prepend=-1))
    cuts = np.append((np.arange(n_rot)[:, None] * n_exec + starts).ravel(), n_rot * n_exec)

    def cells(first: int, last: int) -> None:
        rk.executions(*common, runs.offsets, ref, source, slot, hz, MAX_SETTLE_PERIODS,
                      MAX_RK4_STEPS, ref_worst, ref_lag, ref_s, suffix, limits, ref_status,
                      ref_slipped, ref_valid, fam_lag, fam_s, fam_worst, fam_known, order, first,
                      last, lag, slipped, status, used)

    _in_parallel(cells, cuts)
    used[:, ref] += ref_used
    bad = np.flatnonzero((status != rk.OK).any(axis=1) | (used.sum(axis=1) > MAX_VERDICT_STEPS))
    if len(bad):
        r = int(bad[0])
        raise too_stiff(MAX_VERDICT_STEPS, rot.rotor(r), float(steps[r]))
    return lag, slipped


SHARED_PIECES = 1_000_000   # cut pieces at most (a verdict makes a few thousand)


def dwells(runs: MoveBatch, scratch: Scratch | None = None) -> MoveBatch:
    """The same moves, neighbouring segments of one rate joined (`share_kernel.dwells`);
    in `scratch`'s buffers when given (valid until it is asked for them again)."""
    from . import share_kernel as sk

    phase, rate, count = _buffers(scratch, "dwells", len(runs.rate), runs)
    k, offsets = sk.dwells(runs.phase, runs.rate, runs.count, runs.offsets, phase, rate, count)
    return MoveBatch(runs.pulses, runs.shape, phase[:k], rate[:k], count[:k], offsets)


def shared_dwells(runs: MoveBatch, ref: int, scratch: Scratch | None = None
                  ) -> tuple[MoveBatch, np.ndarray]:
    """The same moves, each family's dwell cut alike, and each move's source: the move
    whose state at the end of its own dwell it starts from, −1 for the reference `ref`
    (`share_kernel.shared_dwells`); in `scratch`'s buffers when given."""
    from . import share_kernel as sk

    at, key, deepest = sk.parting(runs.rate, runs.count, runs.offsets, ref)
    parts = np.flatnonzero(at >= 0)
    parts = parts[np.argsort(key[parts], kind="stable")]  # by family, then by count
    cut_at, pieces, start, table, source = sk.families(runs.count, runs.offsets, ref, at, key,
                                                       parts, deepest)
    if int(pieces.sum()) > SHARED_PIECES:
        return runs, np.full(len(runs), -1, np.int64)  # cut alike, k moves make ~k²/2
    order = np.argsort(cut_at)
    size = len(runs.rate) + int(pieces.sum()) - len(pieces)
    phase, rate, count = _buffers(scratch, "shared", size, runs)
    k, offsets = sk.cut(runs.phase, runs.rate, runs.count, runs.offsets, cut_at[order],
                        pieces[order], start[order], table, phase, rate, count)
    return MoveBatch(runs.pulses, runs.shape, phase[:k], rate[:k], count[:k], offsets), source


class Scratch(threading.local):
    """Buffers the verdict reuses from one batch to the next on a thread. A fresh
    megabyte array faults its pages in one by one when first written (a few µs each on
    a virtual machine): a verdict's joined and cut batches did so for a tenth of it."""

    def __init__(self) -> None:
        self.arrays: dict[tuple[str, str], np.ndarray] = {}

    def take(self, name: str, size: int, dtype: np.dtype) -> np.ndarray:
        """A buffer of at least `size` (its contents undefined)."""
        key = (name, np.dtype(dtype).str)
        a = self.arrays.get(key)
        if a is None or len(a) < size:
            a = self.arrays[key] = np.empty(size + size // 4, dtype)
        return a


_SCRATCH = Scratch()


def _buffers(scratch: Scratch | None, name: str, size: int, like: MoveBatch
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Output buffers of `size` segments for phase, rate and count."""
    arrays = (like.phase, like.rate, like.count)
    if scratch is None:
        return tuple(np.empty(size, a.dtype) for a in arrays)  # type: ignore[return-value]
    return tuple(scratch.take(f"{name}.{i}", size, a.dtype)  # type: ignore[return-value]
                 for i, a in enumerate(arrays))


PARALLEL_MIN_CELLS = 32   # fewer (rotor, execution) pairs run on the calling thread


def _in_parallel(work: Callable[[int, int], None], cuts: np.ndarray) -> None:
    """`work(first, last)` over 0..cuts[-1] in ranges that start at some of `cuts`
    (ascending, from 0: where a range may start), a few per core, on threads (the
    kernel releases the GIL)."""
    cells = int(cuts[-1])
    threads = min(os.cpu_count() or 1, 8)
    if threads == 1 or cells < PARALLEL_MIN_CELLS:
        work(0, cells)
        return
    # a few ranges per thread: neighbouring executions cost alike, so each thread gets a
    # share of the short and the long ones
    bounds = np.unique(cuts[np.searchsorted(cuts, np.linspace(0, cells, threads * 4 + 1))])
    workers = pool("load-angle", threads)
    for future in [workers.submit(work, a, b) for a, b in
                   zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True)]:
        future.result()


def batch_sample_peaks(runs: MoveBatch, hz: float, motor: Motor, samples: int, seed: int
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each Monte Carlo sample's worst |load angle| over the executions of `runs` (both
    directions when the box or the motor has a load torque), the execution and the
    direction where it is worst."""
    params = sample_params(motor, samples, seed)
    lo, hi = motor.tolerance("load_torque_nm")
    ways = (1, -1) if (lo or hi) else (1,)
    rot = Rotors.stack([rotors(motor, params, direction=d) for d in ways])
    lag, _ = judge(runs, hz, rot)
    deg = np.degrees(lag * rot.c_e).reshape(len(ways), samples, len(runs))
    flat = deg.transpose(1, 0, 2).reshape(samples, -1)       # (samples, ways × runs)
    best = np.argmax(flat, axis=1)
    return (flat[np.arange(samples), best], best % len(runs),
            np.asarray(ways)[best // len(runs)])


__all__ = ["MAX_VERDICT_STEPS", "PARALLEL_MIN_CELLS", "PHASE_SAMPLES", "REFINE_DEG",
           "REJOIN_TOL_DEG", "SEARCH_POINTS", "SETTLE_CRUISE_PERIODS", "SHARED_PIECES", "Scratch",
           "batch_sample_peaks", "dwell_sampling", "dwells", "judge", "merged", "refine",
           "sample_grid",
           "shared_dwells"]

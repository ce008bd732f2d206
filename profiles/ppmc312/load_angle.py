"""The load angle over every move length the chip can run with a table.

The model is `profiles.motor.rotor`, integrated by its compiled kernel
(`profiles.motor.rotor_kernel`); this module hands it the chip's executions
(profiles.ppmc312.execution). Every move length is covered through the table's move
families (lengths that run the same segment rates; only partial stages and the
cruise change length): each family is sampled finely enough in its partial stages'
dwell that the ringing's phase at the next speed change is seen (`samples`), and the
families that come out worst are judged again at every length around their worst
sample (`refine`); a trapezoid's cruise long enough to settle stands for every
longer one. Both directions are judged when the motor has a load torque.

Executions share their accel prefix with a reference (the longest trapezoid) and
their decel tail with it too: each is integrated from a source's state where the
commands part, until its state rejoins the reference's on the common tail (within
`REJOIN_TOL_DEG`), where the reference's worst angle of the rest is taken, or until
what it has seen bounds the rest (`rotor_kernel.BOUND`). A constant command is one
dwell, and the dwells of a family (the trapezoids' at the top speed, the triangles'
at their peak) are cut alike, so each member starts from its family's longest
member's state at the end of its own dwell (`share_kernel`). Several motors (a
tolerance box's corners) are rows of one kernel call.
`verify.safety` turns the result into the verdict; planners use it to tighten.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import FieldRangeError
from ..motor import Motor
from ..motor.rotor import (
    MAX_RK4_STEPS,
    MAX_SETTLE_PERIODS,
    PEAK_DEG,
    SETTLE_TOL_DEG,
    SLIP_DEG,
    Rotor,
    Rotors,
    check_step,
    rotor_of,
    rotors,
    settle_s,
    too_stiff,
)
from ..remembered import Remembered
from ..threads import pool
from .execution import Execution
from .init_model import as_free_curve
from .move_batch import SHAPES, MoveBatch, families, moves
from .table import FreeCurveTable, InitTable

REJOIN_TOL_DEG = 0.05
MAX_VERDICT_STEPS = 8_000_000   # RK4 steps for every execution of one verdict, per rotor
SETTLE_CRUISE_PERIODS = 10
PHASE_SAMPLES = 8               # samples per natural period of a partial stage's dwell
REFINE_DEG = 3.0                # sampled families this close to the worst: every length


@dataclass(frozen=True)
class WorstAngle:
    """The worst |load angle| over the executions judged."""

    worst_angle_deg: float
    worst_pulses: int            # the move length where it happens
    worst_direction: int         # 1 forward, −1 backward
    first_unstable_pulses: int | None   # shortest move length past 90° (None: none)
    slipped: bool                # some execution slips a pole (≥ 180°)
    executions: int              # executions integrated (move lengths × rotors)


def worst_load_angle(table: FreeCurveTable | InitTable, motor: Motor, *,
                     pulses: Iterable[int] | None = None,
                     max_step_s: float | None = None) -> WorstAngle:
    """The load angle over every move length the chip can run with `table` (or over the
    moves of the given lengths), both directions when the motor has a load torque."""
    return worst_load_angles(table, [motor], pulses=pulses, max_step_s=max_step_s)[0]


def worst_load_angles(table: FreeCurveTable | InitTable, motors: Sequence[Motor], *,
                      pulses: Iterable[int] | None = None,
                      max_step_s: float | None = None) -> list[WorstAngle]:
    """`worst_load_angle` for each of `motors` (one motor's variants: a tolerance box's
    corners), judged on the same executions in one kernel call (two, when sampled
    families are refined)."""
    found = angles(table, motors, pulses=pulses, max_step_s=max_step_s)
    return [found.worst(m) for m in range(len(motors))]


@dataclass(frozen=True)
class Angles:
    """The worst |load angle| [electrical °] of every move judged (`lengths`) for every
    rotor row: `deg[row, move]`; row r is motor `owner[r]` moving `direction[r]`."""

    lengths: np.ndarray
    deg: np.ndarray
    slipped: np.ndarray
    owner: np.ndarray
    direction: np.ndarray

    def worst(self, motor: int) -> WorstAngle:
        mine = np.flatnonzero(self.owner == motor)
        d = self.deg[mine]
        r, e = np.unravel_index(int(np.argmax(d)), d.shape)
        unstable = self.lengths[np.any(d >= PEAK_DEG, axis=0)]
        return WorstAngle(float(d[r, e]), int(self.lengths[e]), int(self.direction[mine[r]]),
                          int(unstable.min()) if len(unstable) else None,
                          bool(self.slipped[mine].any()), len(self.lengths) * len(mine))


VERDICTS_KEPT = 32   # all-length verdicts remembered (a few KB each)
_verdicts: Remembered[Angles] = Remembered(VERDICTS_KEPT)


def angles(table: FreeCurveTable | InitTable, motors: Sequence[Motor], *,
           pulses: Iterable[int] | None = None, max_step_s: float | None = None) -> Angles:
    """The load angle of every move judged for every motor and direction: the given
    lengths, or every length through its family (`samples`, then `refine`).

    The last VERDICTS_KEPT all-length verdicts are remembered by table and motor values,
    and shared read-only: tightening judges a table, and the verdict that every command
    gives (verify.safety) judges the same table again; a duty cycle tightens candidate
    lengths whose tables coincide."""
    check_step(max_step_s)
    free = as_free_curve(table)
    if pulses is not None or max_step_s is not None:
        return _angles(free, motors, pulses, max_step_s)

    def judged() -> Angles:
        found = _angles(free, motors, None, None)
        for a in vars(found).values():
            a.flags.writeable = False  # shared by every caller that asks again
        return found

    return _verdicts.get((free, tuple(m.values_key() for m in motors)), judged)[0]


def forget_verdicts() -> None:
    """Forget the remembered verdicts (a benchmark times a table's first verdict)."""
    _verdicts.clear()


def _angles(free: FreeCurveTable, motors: Sequence[Motor], pulses: Iterable[int] | None,
            max_step_s: float | None) -> Angles:
    owner = np.asarray([m for m, motor in enumerate(motors) for _ in directions(motor)])
    rot = Rotors.stack([rotors(motor, direction=d) for motor in motors
                        for d in directions(motor)])
    hz = free.clock.hz
    if pulses is not None:
        lengths = np.asarray(sorted(set(int(n) for n in pulses)), dtype=np.int64)
        if not len(lengths):
            raise FieldRangeError("move lengths to judge", 0, 1, 0xFFFFFFFF)
        lag, slipped = judge(moves(free, lengths, compiled=True), hz, rot,
                             max_step_s=max_step_s)
    else:
        lengths, family, spacing = samples(free, motors)
        lag, slipped = judge(moves(free, lengths, compiled=True), hz, rot,
                             max_step_s=max_step_s)
        extra = refine(lengths, family, spacing, np.degrees(lag.max(axis=0) * rot.c_e))
        if len(extra):
            more_lag, more_slipped = judge(moves(free, extra, compiled=True), hz, rot,
                                           max_step_s=max_step_s)
            lengths = np.concatenate((lengths, extra))
            order = np.argsort(lengths, kind="stable")
            lengths = lengths[order]
            lag = np.concatenate((lag, more_lag), axis=1)[:, order]
            slipped = np.concatenate((slipped, more_slipped), axis=1)[:, order]
    return Angles(lengths, np.degrees(lag * rot.c_e), slipped, owner, rot.direction)


def samples(table: FreeCurveTable, motors: Sequence[Motor]
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The move lengths that stand for every length of every family: (lengths ascending,
    the family of each (its index), each family's spacing in pulses).

    Within a family only the partial stages (or the cruise) change length, a pulse at a
    time; the worst angle then varies with the phase of the ringing at the next speed
    change, so a family is sampled from its shortest move every `spacing` pulses, which
    moves those dwells by at most 1/PHASE_SAMPLES of the natural period at their speed
    (the stiffest motor's): fast stages need their two ends, slow ones many lengths.
    Once that stage (or the cruise) has lasted SETTLE_CRUISE_PERIODS natural periods
    for every motor the rotor has settled in it and a longer dwell repeats that state:
    the rest of the family is judged by its longest move alone (a trapezoid's by that
    settled cruise)."""
    rotor_list = [rotor_of(m) for m in motors]
    fams = families(table, compiled=True)
    lo, hi = fams.lo, fams.hi
    hz = table.clock.hz
    trapezoid = fams.shape == SHAPES.index("trapezoid")
    # what changes within a family: a trapezoid's cruise, else its slowest partial stage
    # (the largest step in dwell between two neighbouring lengths)
    short, long = (moves(table, n, compiled=True) for n in (lo, hi))
    changes = np.where(short.count != long.count, short.rate, 0)
    slowest = np.maximum.reduceat(np.append(changes, 0), short.offsets[:-1])
    slowest = np.where(np.diff(short.offsets) > 0, slowest, 0)
    slowest = np.where(trapezoid, fams.cruise_rate, slowest)
    spacing = np.maximum(hi - lo, 1)
    dense = hi.copy()  # the lengths sampled finely; the family's longest is judged too
    at = np.flatnonzero(slowest)
    # a cruise grows a pulse a length; two partial stages share the growth: twice it
    spacing[at], dense[at] = dwell_sampling(rotor_list, hz / slowest[at].astype(float),
                                            lo[at], hi[at], np.where(trapezoid[at], 1, 2))
    hi = np.where(trapezoid, dense, hi)  # a longer cruise repeats the settled one
    lengths, family = sample_grid(lo, spacing, dense, hi)
    lengths, first = np.unique(lengths, return_index=True)
    return lengths, family[first], spacing


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
           worst_deg: np.ndarray) -> np.ndarray:
    """The lengths still to judge around the sampled families that come out worst: every
    length within a spacing of a family's worst sample when that family is within
    REFINE_DEG of the worst of all (sampling may pass a peak's top by a little), and
    every length before a family's first sample past the 90° peak (so the shortest
    unstable move is named exactly)."""
    best = float(worst_deg.max())
    extra: list[np.ndarray] = []
    starts = np.flatnonzero(np.diff(family, prepend=-1))
    ends = np.append(starts[1:], len(family))
    top = np.maximum.reduceat(worst_deg, starts)  # each family's worst sample
    wanted = (spacing[family[starts]] > 1) & ((top >= best - REFINE_DEG) | (top >= PEAK_DEG))
    for a, b in zip(starts[wanted].tolist(), ends[wanted].tolist(), strict=True):
        sp = int(spacing[family[a]])
        w, at = worst_deg[a:b], lengths[a:b]
        k = int(np.argmax(w))
        if w[k] >= best - REFINE_DEG:
            extra.append(np.arange(max(at[0], at[k] - sp + 1), min(at[-1], at[k] + sp - 1) + 1))
        unstable = np.flatnonzero(w >= PEAK_DEG)
        if len(unstable) and unstable[0] > 0:
            extra.append(np.arange(at[unstable[0] - 1] + 1, at[unstable[0]]))
    if not extra:
        return np.zeros(0, dtype=np.int64)
    return np.setdiff1d(np.concatenate(extra), lengths)


def directions(motor: Motor) -> tuple[int, ...]:
    """Both directions when the motor has a load torque (it helps one of them)."""
    return (1, -1) if motor.load_torque_nm else (1,)


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
    from ..motor import rotor_kernel as rk

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


def spans_of(execution: Execution, rotor: Rotor, step: float) -> list[tuple[float, float]]:
    """The command as (duration_s, speed_pps) spans, then rest while the rotor settles.
    Neighbouring segments of one rate are one span, as the verdict judges them (`dwells`):
    a trace and the verdict integrate a move alike."""
    hz = execution.clock.hz
    spans: list[tuple[int, int]] = []  # (ticks, rate)
    for s in execution.segments:
        if spans and spans[-1][1] == s.rate:
            spans[-1] = (spans[-1][0] + s.ticks, s.rate)
        else:
            spans.append((s.ticks, s.rate))
    return [*((ticks / hz, hz / rate) for ticks, rate in spans),
            (settle_s(rotor, step), 0.0)]  # after the last pulse the command rests

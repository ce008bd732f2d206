"""The load angle over every move length the chip can run with a table.

The model is `profiles.motor.rotor`, integrated by its compiled kernel
(`profiles.motor.rotor_kernel`); this module hands it the chip's executions
(profiles.ppmc312.execution). Every move length is covered through the table's move
families (lengths that run the same segment rates; only partial stages and the
cruise change length): each family is sampled finely enough in its partial stages'
dwell that the ringing's phase at the next speed change is seen (`samples`), and the
families that come out worst are searched for their peak around their worst sample
(`refine`); a trapezoid's cruise long enough to settle stands for every
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
`safety.judge_table` turns the result into the verdict; planners use it to tighten.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from ..errors import FieldRangeError
from ..motor import Motor
from ..motor.batch_angle import (
    REFINE_DEG,
    dwell_sampling,
    judge,
    merged,
    refine,
    sample_grid,
)
from ..motor.rotor import (
    PEAK_DEG,
    Rotor,
    Rotors,
    check_step,
    rotor_of,
    rotors,
    settle_s,
)
from ..remembered import Remembered
from .execution import Execution
from .init_model import as_free_curve
from .move_batch import SHAPES, families, moves
from .table import FreeCurveTable, InitTable


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
    refined: bool = True   # False: the samples alone (`angles`' aim_deg), a lower bound

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
# and the samples' verdicts, which an all-length verdict goes on from (`aim_deg`)
_sampled: Remembered[tuple[np.ndarray, ...]] = Remembered(VERDICTS_KEPT)


def angles(table: FreeCurveTable | InitTable, motors: Sequence[Motor], *,
           pulses: Iterable[int] | None = None, max_step_s: float | None = None,
           aim_deg: float | None = None) -> Angles:
    """The load angle of every move judged for every motor and direction: the given
    lengths, or every length through its family (`samples`, then `refine`).

    `aim_deg`: the samples' verdict alone (`Angles.refined` False: its worst a lower
    bound) when it already says whether every move is within that aim: a sample is past
    it, or every sample is REFINE_DEG or more below it (refining raises a family's worst
    by less: the sampling's premise, on which it leaves the families further below the
    worst unrefined). Tightening asks so, and refines only the table it keeps.

    The last VERDICTS_KEPT all-length verdicts are remembered by table and motor values,
    and shared read-only: tightening judges a table, and the verdict that every command
    gives (safety.judge_table) judges the same table again; a duty cycle tightens candidate
    lengths whose tables coincide."""
    check_step(max_step_s)
    free = as_free_curve(table)
    owner, rot = _rows(motors)
    if pulses is not None:
        lengths = np.asarray(sorted(set(int(n) for n in pulses)), dtype=np.int64)
        if not len(lengths):
            raise FieldRangeError("move lengths to judge", 0, 1, 0xFFFFFFFF)
        return _found(lengths, *_judge(free, lengths, rot, max_step_s), owner, rot)
    if max_step_s is not None:
        return _found(*_refined(free, _sample(free, motors, rot, max_step_s), rot,
                                max_step_s), owner, rot)
    key = (free, tuple(m.values_key() for m in motors))
    known = _verdicts.peek(key)
    if known is not None:
        return known

    def sampled() -> tuple[np.ndarray, ...]:
        return _read_only(_sample(free, motors, rot, None))

    first = _sampled.get(key, sampled)[0]
    if aim_deg is not None and not (
            aim_deg - REFINE_DEG < float(np.degrees(first[3].max() * rot.c_e)) <= aim_deg):
        return _found(first[0], first[3], first[4], owner, rot, refined=False)
    return _verdicts.get(key, lambda: _read_only(
        _found(*_refined(free, first, rot, None), owner, rot)))[0]


def forget_verdicts() -> None:
    """Forget the remembered verdicts (a benchmark times a table's first verdict)."""
    _verdicts.clear()
    _sampled.clear()


T = TypeVar("T", Angles, tuple[np.ndarray, ...])


def _read_only(found: T) -> T:
    """`found` with its arrays read-only: shared by every caller that asks again."""
    for a in (found if isinstance(found, tuple) else vars(found).values()):
        if isinstance(a, np.ndarray):
            a.flags.writeable = False
    return found


def _rows(motors: Sequence[Motor]) -> tuple[np.ndarray, Rotors]:
    """The verdict's rotor rows: each motor in each direction judged, and whose it is."""
    owner = np.asarray([m for m, motor in enumerate(motors) for _ in directions(motor)])
    return owner, Rotors.stack([rotors(motor, direction=d) for motor in motors
                                for d in directions(motor)])


def _judge(free: FreeCurveTable, lengths: np.ndarray, rot: Rotors,
           max_step_s: float | None) -> tuple[np.ndarray, np.ndarray]:
    return judge(moves(free, lengths, compiled=True), free.clock.hz, rot,
                 max_step_s=max_step_s)


def _found(lengths: np.ndarray, lag: np.ndarray, slipped: np.ndarray, owner: np.ndarray,
           rot: Rotors, refined: bool = True) -> Angles:
    return Angles(lengths, np.degrees(lag * rot.c_e), slipped, owner, rot.direction,
                  refined)


def _sample(free: FreeCurveTable, motors: Sequence[Motor], rot: Rotors,
            max_step_s: float | None) -> tuple[np.ndarray, ...]:
    """The samples' verdict: (lengths, family, spacing, lag, slipped) (`samples`)."""
    lengths, family, spacing = samples(free, motors)
    return (lengths, family, spacing, *_judge(free, lengths, rot, max_step_s))


def _refined(free: FreeCurveTable, sampled: tuple[np.ndarray, ...], rot: Rotors,
             max_step_s: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The samples' verdict with the lengths `refine` asks for: (lengths ascending, lag,
    slipped)."""
    lengths, family, spacing, lag, slipped = sampled
    found = [(lengths, lag, slipped)]

    def judge_at(extra: np.ndarray) -> np.ndarray:
        found.append((extra, *_judge(free, extra, rot, max_step_s)))
        return np.degrees(found[-1][1].max(axis=0) * rot.c_e)

    refine(lengths, family, spacing, np.degrees(lag.max(axis=0) * rot.c_e), judge_at)
    lengths, lag, slipped = merged(found)
    return lengths, lag, slipped


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


def directions(motor: Motor) -> tuple[int, ...]:
    """Both directions when the motor has a load torque (it helps one of them)."""
    return (1, -1) if motor.load_torque_nm else (1,)


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

"""The load angle over every execution the chip can run with a table.

The model is `profiles.motor.rotor`, integrated by its compiled kernel
(`profiles.motor.rotor_kernel.judge_runs`); this module hands it the chip's
executions (profiles.ppmc312.execution). Every move length is covered the way the
criterion covers it, through the table's move families: each family's shortest and
longest move (a trapezoid's longest: a cruise long enough to settle; longer cruises
repeat that settled state), in both directions when the motor has a load torque.
Executions share their accel prefix with the longest-listed one (the reference)
and their decel tail with it too: each is integrated from the reference's state
where the commands part, until its state rejoins the reference's on the common
tail (within `REJOIN_TOL_DEG`), where the reference's worst angle of the rest is
taken. Several motors (a tolerance box's corners) are judged in one kernel call.
`verify.safety` turns the result into the verdict; planners use it to tighten.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
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
from .execution import Execution, MoveBatch, move_families, moves
from .init_model import as_free_curve
from .table import FreeCurveTable, InitTable

REJOIN_TOL_DEG = 0.05
MAX_VERDICT_STEPS = 8_000_000   # RK4 steps for every execution of one verdict, per rotor
SETTLE_CRUISE_PERIODS = 10


@dataclass(frozen=True)
class WorstAngle:
    """The worst |load angle| over the executions judged."""

    worst_angle_deg: float
    worst_pulses: int            # the move length where it happens
    worst_direction: int         # 1 forward, −1 backward
    first_unstable_pulses: int | None   # shortest move length past 90° (None: none)
    slipped: bool                # some execution slips a pole (≥ 180°)
    executions: int              # executions integrated


def runs_of(table: FreeCurveTable | InitTable, motors: Sequence[Motor],
            pulses: Iterable[int] | None = None) -> MoveBatch:
    """The executions judged: every family's representatives (the trapezoid's cruise long
    enough for each of `motors` to settle), or the given lengths."""
    free = as_free_curve(table)
    if pulses is not None:
        lengths = sorted(set(int(n) for n in pulses))
        if not lengths:
            raise FieldRangeError("move lengths to judge", 0, 1, 0xFFFFFFFF)
        return moves(free, lengths)
    rotor_list = [rotor_of(m) for m in motors]
    lengths = []
    for fam in move_families(free):
        lengths.append(fam.lo)
        if fam.hi == fam.lo:
            continue
        if fam.shape == "trapezoid":
            # a cruise long enough to settle: any longer one repeats its settled state
            top = free.clock.hz / fam.cruise_rate
            period = max(min(r.natural_period_s(top), 1.0) for r in rotor_list)
            extra = math.ceil(top * SETTLE_CRUISE_PERIODS * period)
            lengths.append(min(fam.hi, fam.lo + max(extra, 1)))
        else:
            lengths.append(fam.hi)
    return moves(free, lengths)


def worst_load_angle(table: FreeCurveTable | InitTable, motor: Motor, *,
                     pulses: Iterable[int] | None = None,
                     max_step_s: float | None = None) -> WorstAngle:
    """The load angle over every execution the chip can run with `table` (or over the
    moves of the given lengths), both directions when the motor has a load torque."""
    return worst_load_angles(table, [motor], pulses=pulses, max_step_s=max_step_s)[0]


def worst_load_angles(table: FreeCurveTable | InitTable, motors: Sequence[Motor], *,
                      pulses: Iterable[int] | None = None,
                      max_step_s: float | None = None) -> list[WorstAngle]:
    """`worst_load_angle` for each of `motors` (one motor's variants: a tolerance box's
    corners), judged on the same executions in one kernel call."""
    check_step(max_step_s)
    runs = runs_of(table, motors, pulses)
    owner = [m for m, motor in enumerate(motors) for _ in directions(motor)]
    rot = Rotors.stack([rotors(motor, direction=d) for motor in motors
                        for d in directions(motor)])
    lag, slipped = judge(runs, as_free_curve(table).clock.hz, rot, max_step_s=max_step_s)
    deg = np.degrees(lag * rot.c_e)
    out = []
    for m in range(len(motors)):
        mine = [i for i, o in enumerate(owner) if o == m]
        d = deg[mine]
        r, e = np.unravel_index(int(np.argmax(d)), d.shape)
        unstable = runs.pulses[np.any(d >= PEAK_DEG, axis=0)]
        out.append(WorstAngle(float(d[r, e]), int(runs.pulses[e]), int(rot.direction[mine[r]]),
                              int(unstable.min()) if len(unstable) else None,
                              bool(slipped[mine].any()), len(runs) * len(mine)))
    return out


def directions(motor: Motor) -> tuple[int, ...]:
    """Both directions when the motor has a load torque (it helps one of them)."""
    return (1, -1) if motor.load_torque_nm else (1,)


def judge(runs: MoveBatch, hz: float, rot: Rotors, *, max_step_s: float | None = None
          ) -> tuple[np.ndarray, np.ndarray]:
    """Every execution of `runs` for every rotor: (worst |lag| [pulses], slipped), each of
    shape (rotors, executions). A verdict that would take more than MAX_VERDICT_STEPS
    RK4 steps for one rotor is refused."""
    from ..motor import rotor_kernel as rk

    steps = rot.step_s(max_step_s)
    settles = np.asarray([settle_s(rot.rotor(i), h) for i, h in enumerate(steps)])
    n_rot, n_exec = len(rot), len(runs)
    ref = int(np.argmax(np.diff(runs.offsets)))  # the reference: the most segments
    m = int(runs.offsets[ref + 1] - runs.offsets[ref])
    ref_max, ref_lag, ref_s = (np.zeros((n_rot, m + 1)) for _ in range(3))
    suffix = np.zeros((n_rot, m + 2))
    limits = np.zeros((n_rot, 4))
    ref_status = np.zeros(n_rot, np.int64)
    ref_slipped = np.zeros(n_rot, np.bool_)
    ref_used = np.zeros(n_rot, np.int64)
    common = (rot.curve_v, rot.curve_t, rot.rows, steps, settles, runs.rate, runs.count)
    rk.references(*common, int(runs.offsets[ref]), int(runs.offsets[ref + 1]), hz, SLIP_DEG,
                  SETTLE_TOL_DEG, MAX_SETTLE_PERIODS, REJOIN_TOL_DEG, MAX_RK4_STEPS, ref_max,
                  ref_lag, ref_s, suffix, limits, ref_status, ref_slipped, ref_used)
    lag = np.zeros((n_rot, n_exec))
    slipped = np.zeros((n_rot, n_exec), np.bool_)
    status = np.zeros((n_rot, n_exec), np.int64)
    used = np.zeros((n_rot, n_exec), np.int64)

    def cells(first: int, last: int) -> None:
        rk.executions(*common, runs.offsets, ref, hz, MAX_SETTLE_PERIODS, MAX_RK4_STEPS,
                      ref_max, ref_lag, ref_s, suffix, limits, ref_status, ref_slipped, first,
                      last, lag, slipped, status, used)

    _in_parallel(cells, n_rot * n_exec)
    used[:, ref] += ref_used
    bad = np.flatnonzero((status != rk.OK).any(axis=1) | (used.sum(axis=1) > MAX_VERDICT_STEPS))
    if len(bad):
        r = int(bad[0])
        raise too_stiff(MAX_VERDICT_STEPS, rot.rotor(r), float(steps[r]))
    return lag, slipped


PARALLEL_MIN_CELLS = 32   # fewer (rotor, execution) pairs run on the calling thread


def _in_parallel(work: Callable[[int, int], None], cells: int) -> None:
    """`work(first, last)` over 0..cells in one range per core, on threads (the kernel
    releases the GIL)."""
    threads = min(os.cpu_count() or 1, 8)
    if threads == 1 or cells < PARALLEL_MIN_CELLS:
        work(0, cells)
        return
    # interleaved chunks: neighbouring executions cost alike, so each thread gets a share
    # of the short and the long ones
    bounds = np.linspace(0, cells, threads * 4 + 1).astype(int)
    chunks = list(zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True))
    with ThreadPoolExecutor(threads) as pool:
        for future in [pool.submit(work, a, b) for a, b in chunks]:
            future.result()


def spans_of(execution: Execution, rotor: Rotor, step: float) -> list[tuple[float, float]]:
    """The command as (duration_s, speed_pps) spans, then rest while the rotor settles."""
    hz = execution.clock.hz
    spans = [(s.ticks / hz, hz / s.rate) for s in execution.segments]
    return [*spans, (settle_s(rotor, step), 0.0)]  # after the last pulse the command rests

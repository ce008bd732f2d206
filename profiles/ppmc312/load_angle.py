"""The load angle over every execution the chip can run with a table.

The model is `profiles.motor.rotor`; this module runs it on the chip's executions
(profiles.ppmc312.execution): every move length is covered the way the criterion
covers it, through the table's move families: each family's shortest and longest
move (a trapezoid's longest: a cruise long enough to settle; longer cruises repeat
that settled state), in both directions when the motor has a load torque.
Executions share their accel prefix with the longest-listed one (the reference)
and their decel tail with it too: each is integrated from the reference's state
where the commands part, until its state rejoins the reference's on the common
tail (within `REJOIN_TOL_DEG`), where the reference's worst angle of the rest is
taken. `verify.physics` turns the result into verdicts; planners use it to tighten.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import FieldRangeError
from ..motor import Motor
from ..motor.rotor import (
    PEAK_DEG,
    Rotor,
    StepBudget,
    Trace,
    check_step,
    follow,
    rotor_of,
    settle_s,
)
from .execution import Execution, move_families, simulate_move
from .init_model import as_free_curve
from .table import FreeCurveTable, InitTable

REJOIN_TOL_DEG = 0.05
MAX_VERDICT_STEPS = 8_000_000   # RK4 steps for every execution of one verdict (≈ 40 s)
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


def worst_load_angle(table: FreeCurveTable | InitTable, motor: Motor, *,
                     pulses: Iterable[int] | None = None,
                     max_step_s: float | None = None) -> WorstAngle:
    """The load angle over every execution the chip can run with `table` (or over the
    moves of the given lengths), both directions when the motor has a load torque."""
    check_step(max_step_s)
    free = as_free_curve(table)
    runs = (_representatives(free, motor) if pulses is None
            else [simulate_move(free, int(n)) for n in sorted(set(pulses))])
    if not runs:
        raise FieldRangeError("move lengths to judge", 0, 1, 0xFFFFFFFF)
    directions = (1, -1) if motor.load_torque_nm else (1,)
    budget = StepBudget(MAX_VERDICT_STEPS)
    worst = (-1.0, 0, 1)
    unstable: list[int] = []
    slipped = False
    for direction in directions:
        rotor = rotor_of(motor, direction=direction)
        step = rotor.step_s() if max_step_s is None else min(rotor.step_s(), max_step_s)
        shared = _Shared(rotor, step, max(runs, key=lambda e: len(e.segments)), budget)
        for run in runs:
            peak_deg, slip = shared.worst_deg(run)
            slipped |= slip
            if peak_deg >= PEAK_DEG:
                unstable.append(run.pulses)
            if peak_deg > worst[0]:
                worst = (peak_deg, run.pulses, direction)
    return WorstAngle(worst[0], worst[1], worst[2], min(unstable) if unstable else None,
                      slipped, len(runs) * len(directions))


def _representatives(table: FreeCurveTable, motor: Motor) -> list[Execution]:
    out = []
    rotor = rotor_of(motor)
    for fam in move_families(table):
        first = fam.execution()
        out.append(first)
        if fam.shape == "trapezoid" and fam.hi > fam.lo:
            # a cruise long enough to settle: any longer one repeats its settled state
            top = table.clock.hz / first.high_rate
            extra = math.ceil(top * SETTLE_CRUISE_PERIODS * min(rotor.natural_period_s(top), 1.0))
            out.append(fam.execution(min(fam.hi, fam.lo + max(extra, 1))))
        elif fam.hi > fam.lo:
            out.append(fam.execution(fam.hi))
    return out


def spans_of(execution: Execution, rotor: Rotor, step: float) -> list[tuple[float, float]]:
    """The command as (duration_s, speed_pps) spans, then rest while the rotor settles."""
    hz = execution.clock.hz
    spans = [(s.ticks / hz, hz / s.rate) for s in execution.segments]
    return [*spans, (settle_s(rotor, step), 0.0)]  # after the last pulse the command rests


class _Shared:
    """A reference execution integrated once; others start where their commands part from
    it and stop where they rejoin it (same remaining commands, same state)."""

    def __init__(self, rotor: Rotor, step: float, reference: Execution,
                 budget: StepBudget) -> None:
        self.rotor, self.step, self.budget = rotor, step, budget
        self.ref_key = _key(reference)
        self.ref = self._follow(spans_of(reference, rotor, step))
        peaks = np.asarray([*self.ref.span_max, 0.0])
        self.suffix_max = np.maximum.accumulate(peaks[::-1])[::-1]  # worst from span k on
        self.tol_l = math.radians(REJOIN_TOL_DEG) / rotor.c_e
        period = rotor.natural_period_s(0.0)
        self.tol_s = self.tol_l * (2 * math.pi / period if math.isfinite(period) else 1.0)
        self.durations = [d for d, _ in spans_of(reference, rotor, step)]

    def worst_deg(self, run: Execution) -> tuple[float, bool]:
        key = _key(run)
        ref, rk = self.ref, self.ref_key
        if ref.slipped:
            full = self._follow(spans_of(run, self.rotor, self.step))
            return self._deg(max(full.span_max)), full.slipped
        head = 0
        while head < min(len(key), len(rk)) and key[head] == rk[head]:
            head += 1
        tail = 0
        while tail < min(len(key), len(rk)) - head and key[-1 - tail] == rk[-1 - tail]:
            tail += 1
        if head == len(key) == len(rk):
            return self._deg(float(self.suffix_max[0])), ref.slipped
        spans = spans_of(run, self.rotor, self.step)
        state = ref.boundary[head - 1] if head else (0.0, 0.0)
        before = float(np.max(ref.span_max[:head])) if head else 0.0
        rejoin: list[float] = []
        last = len(key)  # spans in `key`; the settle span follows

        def stop(i: int, lag: float, s: float) -> bool:
            j = head + i  # the span of `run` just finished
            remaining = last - 1 - j
            if remaining >= tail or remaining < 0:
                return False
            kb = len(rk) - 1 - remaining  # the reference's matching boundary
            rl, rs = ref.boundary[kb]
            if abs(lag - rl) <= self.tol_l and abs(s - rs) <= self.tol_s:
                rejoin.append(float(self.suffix_max[kb + 1]))
                return True
            return False

        prev = spans[head - 1][1] if head else 0.0
        part = self._follow(spans[head:], state=state, previous_pps=prev, stop=stop)
        worst = max([before, *part.span_max, *rejoin])
        return self._deg(worst), part.slipped

    def _follow(self, spans: list[tuple[float, float]], **kw: Any) -> Trace:
        """One execution's integration, counted against the verdict's step budget."""
        trace = follow(self.rotor, spans, step_s=self.step,
                       trace=Trace(record=False, budget=self.budget), **kw)
        self.budget.used += trace.steps
        return trace

    def _deg(self, lag_pulses: float) -> float:
        return math.degrees(lag_pulses * self.rotor.c_e)


def _key(run: Execution) -> list[tuple[int, int]]:
    return [(s.rate, s.pulses) for s in run.segments]



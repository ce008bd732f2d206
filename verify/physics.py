"""The physical verdict: the rotor's load angle in every execution the chip runs.

The model is `profiles.rotor` (load angle in electrical degrees: the restoring
torque peaks at 90° at the unscaled pull-out torque of the speed, the rotor slips
a pole at 180°). A move is physically safe when its worst |load angle| stays below
90° (the stable side of the torque–angle curve); planners aim at ≤ 75°.

`judge_executions` covers every move length the way the criterion does, through the
table's move families (profiles.ppmc312.execution.move_families): each family's
shortest and longest move (a trapezoid's longest: a cruise long enough to settle;
longer cruises repeat that settled state), in both directions when the motor has a
load torque. Executions share their accel prefix with the shortest trapezoid and
their decel tail with it too: each is integrated from the reference's state where
the commands part, until its state rejoins the reference's on the common tail
(within `REJOIN_TOL_DEG`), where the reference's worst angle of the rest is taken.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from profiles.errors import FieldRangeError
from profiles.motor import Motor
from profiles.ppmc312.execution import Execution, move_families, simulate_move
from profiles.ppmc312.init_model import as_free_curve
from profiles.ppmc312.table import FreeCurveTable, InitTable
from profiles.rotor import (
    PEAK_DEG,
    SLIP_DEG,
    Rotor,
    Trace,
    check_step,
    follow,
    rotor_of,
    settle_s,
)

TARGET_DEG = 75.0        # what the planner aims at (margin to the 90° peak)
REJOIN_TOL_DEG = 0.01
SETTLE_CRUISE_PERIODS = 10


@dataclass(frozen=True)
class PhysicsResult:
    """One execution: the signed load angle of largest magnitude (> 0: behind)."""

    worst_angle_deg: float
    worst_time_s: float
    slipped: bool
    slip_time_s: float | None
    lag_t_s: np.ndarray
    angle_deg: np.ndarray
    full_step_deg: float

    @property
    def margin_deg(self) -> float:
        """Distance of the worst angle to the 90° peak (negative: past it)."""
        return PEAK_DEG - abs(self.worst_angle_deg)

    @property
    def stable(self) -> bool:
        return abs(self.worst_angle_deg) < PEAK_DEG

    @property
    def worst_lag_full_steps(self) -> float:
        return self.worst_angle_deg / self.full_step_deg

    @property
    def lag_full_steps(self) -> np.ndarray:
        return self.angle_deg / self.full_step_deg

    def to_json(self) -> dict[str, object]:
        return {"worst_load_angle_deg": self.worst_angle_deg, "margin_deg": self.margin_deg,
                "stable": self.stable, "slipped": self.slipped,
                "worst_time_s": self.worst_time_s, "slip_time_s": self.slip_time_s}


def load_angle_check(execution: Execution, motor: Motor, *, max_step_s: float | None = None,
                     direction: int = 1) -> PhysicsResult:
    """Integrate the rotor against `execution`, then until it settles at rest."""
    check_step(max_step_s)
    rotor = rotor_of(motor, direction=direction)
    step = _step(rotor, execution, max_step_s)
    trace = follow(rotor, _spans(execution, rotor, step), step_s=step)
    t = np.asarray(trace.t_s)
    angle = np.degrees(np.asarray(trace.lag) * rotor.c_e)
    worst = int(np.argmax(np.abs(angle)))
    return PhysicsResult(float(angle[worst]), float(t[worst]), trace.slipped, trace.slip_time_s,
                         t, angle, motor.full_step_electrical_deg)


@dataclass(frozen=True)
class PhysicsVerdict:
    """The load angle over the executions judged (all move lengths, or the given ones)."""

    worst_angle_deg: float       # |angle|, the worst over every execution and direction
    worst_pulses: int            # the move length where it happens
    worst_direction: int
    first_unstable_pulses: int | None   # shortest move length past 90° (None: none)
    slipped: bool                # some execution slips a pole (≥ 180°)
    executions: int              # executions integrated

    @property
    def margin_deg(self) -> float:
        return PEAK_DEG - self.worst_angle_deg

    @property
    def safe(self) -> bool:
        return self.worst_angle_deg < PEAK_DEG

    def to_json(self) -> dict[str, object]:
        return {"worst_load_angle_deg": self.worst_angle_deg, "margin_deg": self.margin_deg,
                "worst_pulses": self.worst_pulses,
                "worst_direction": "forward" if self.worst_direction > 0 else "backward",
                "first_unstable_pulses": self.first_unstable_pulses, "slips": self.slipped,
                "safe": self.safe, "executions": self.executions}

    def describe(self) -> str:
        way = "forward" if self.worst_direction > 0 else "backward"
        text = (f"worst load angle {self.worst_angle_deg:.1f}° electrical ({way} move of "
                f"{self.worst_pulses} pulses), margin {self.margin_deg:+.1f}° to the 90° peak")
        if not self.safe:
            text += (f"; the rotor leaves the stable side of the torque–angle curve from moves "
                     f"of {self.first_unstable_pulses} pulses"
                     + (" and slips a pole" if self.slipped else ""))
        return text


def judge_executions(table: FreeCurveTable | InitTable, motor: Motor, *,
                     pulses: Iterable[int] | None = None,
                     max_step_s: float | None = None) -> PhysicsVerdict:
    """The load angle over every execution the chip can run with `table` (or over the
    moves of the given lengths), both directions when the motor has a load torque."""
    check_step(max_step_s)
    free = as_free_curve(table)
    runs = (_representatives(free, motor) if pulses is None
            else [simulate_move(free, int(n)) for n in sorted(set(pulses))])
    if not runs:
        raise FieldRangeError("move lengths to judge", 0, 1, 0xFFFFFFFF)
    directions = (1, -1) if motor.load_torque_nm else (1,)
    worst = (-1.0, 0, 1)
    unstable: list[int] = []
    slipped = False
    for direction in directions:
        rotor = rotor_of(motor, direction=direction)
        top = max(free.clock.hz / min(free.rates), 0.0)
        step = rotor.step_s(top) if max_step_s is None else min(rotor.step_s(top), max_step_s)
        shared = _Shared(rotor, step, max(runs, key=lambda e: len(e.segments)))
        for run in runs:
            peak_deg, slip = shared.worst_deg(run)
            slipped |= slip
            if peak_deg >= PEAK_DEG:
                unstable.append(run.pulses)
            if peak_deg > worst[0]:
                worst = (peak_deg, run.pulses, direction)
    return PhysicsVerdict(worst[0], worst[1], worst[2], min(unstable) if unstable else None,
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


def _step(rotor: Rotor, execution: Execution, max_step_s: float | None) -> float:
    hz = execution.clock.hz
    top = max((hz / s.rate for s in execution.segments), default=0.0)
    step = rotor.step_s(top)
    return step if max_step_s is None else min(step, max_step_s)


def _spans(execution: Execution, rotor: Rotor, step: float) -> list[tuple[float, float]]:
    hz = execution.clock.hz
    spans = [(s.ticks / hz, hz / s.rate) for s in execution.segments]
    return [*spans, (settle_s(rotor, step), 0.0)]  # after the last pulse the command rests


class _Shared:
    """A reference execution integrated once; others start where their commands part from
    it and stop where they rejoin it (same remaining commands, same state)."""

    def __init__(self, rotor: Rotor, step: float, reference: Execution) -> None:
        self.rotor, self.step = rotor, step
        self.ref_key = _key(reference)
        self.ref = follow(rotor, _spans(reference, rotor, step), step_s=step,
                          trace=Trace(record=False))
        peaks = np.asarray(self.ref.span_max + [0.0])
        self.suffix_max = np.maximum.accumulate(peaks[::-1])[::-1]  # worst from span k on
        self.tol_l = math.radians(REJOIN_TOL_DEG) / rotor.c_e
        period = rotor.natural_period_s(0.0)
        self.tol_s = self.tol_l * (2 * math.pi / period if math.isfinite(period) else 1.0)
        self.durations = [d for d, _ in _spans(reference, rotor, step)]

    def worst_deg(self, run: Execution) -> tuple[float, bool]:
        key = _key(run)
        ref, rk = self.ref, self.ref_key
        if ref.slipped:
            full = follow(self.rotor, _spans(run, self.rotor, self.step), step_s=self.step,
                          trace=Trace(record=False))
            return self._deg(max(full.span_max)), full.slipped
        head = 0
        while head < min(len(key), len(rk)) and key[head] == rk[head]:
            head += 1
        tail = 0
        while tail < min(len(key), len(rk)) - head and key[-1 - tail] == rk[-1 - tail]:
            tail += 1
        if head == len(key) == len(rk):
            return self._deg(float(self.suffix_max[0])), ref.slipped
        spans = _spans(run, self.rotor, self.step)
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
        part = follow(self.rotor, spans[head:], step_s=self.step, state=state,
                      previous_pps=prev, trace=Trace(record=False), stop=stop)
        worst = max([before, *part.span_max, *rejoin])
        return self._deg(worst), part.slipped

    def _deg(self, lag_pulses: float) -> float:
        return math.degrees(lag_pulses * self.rotor.c_e)


def _key(run: Execution) -> list[tuple[int, int]]:
    return [(s.rate, s.pulses) for s in run.segments]


__all__ = ["PEAK_DEG", "SLIP_DEG", "TARGET_DEG", "PhysicsResult", "PhysicsVerdict",
           "judge_executions", "load_angle_check"]

"""The physical verdict: the rotor's load angle in every execution the chip runs.

The model is `profiles.motor.rotor` (load angle in electrical degrees: the restoring
torque peaks at 90° at the unscaled pull-out torque of the speed, the rotor slips
a pole at 180°); `profiles.ppmc312.load_angle` runs it on every execution of a
table. A move is physically safe when its worst |load angle| stays below 90° (the
stable side of the torque–angle curve); planners aim at ≤ 75° (`TARGET_DEG`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from profiles.motor import Motor
from profiles.motor.rotor import PEAK_DEG, SLIP_DEG, TARGET_DEG, check_step, follow, rotor_of
from profiles.ppmc312.execution import Execution
from profiles.ppmc312.load_angle import WorstAngle, spans_of, worst_load_angle
from profiles.ppmc312.table import FreeCurveTable, InitTable


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
        return {"worst_load_angle_deg": abs(self.worst_angle_deg),
                "rotor": "behind the field" if self.worst_angle_deg >= 0 else "ahead of the field",
                "margin_deg": self.margin_deg, "stable": self.stable, "slipped": self.slipped,
                "worst_time_s": self.worst_time_s, "slip_time_s": self.slip_time_s}


def load_angle_check(execution: Execution, motor: Motor, *, max_step_s: float | None = None,
                     direction: int = 1) -> PhysicsResult:
    """Integrate the rotor against `execution`, then until it settles at rest."""
    check_step(max_step_s)
    rotor = rotor_of(motor, direction=direction)
    step = rotor.step_s() if max_step_s is None else min(rotor.step_s(), max_step_s)
    trace = follow(rotor, spans_of(execution, rotor, step), step_s=step)
    t = np.asarray(trace.t_s)
    angle = np.degrees(np.asarray(trace.lag) * rotor.c_e)
    worst = int(np.argmax(np.abs(angle)))
    return PhysicsResult(float(angle[worst]), float(t[worst]), trace.slipped, trace.slip_time_s,
                         t, angle, motor.full_step_electrical_deg)


@dataclass(frozen=True)
class PhysicsVerdict(WorstAngle):
    """The load angle over the executions judged (all move lengths, or the given ones):
    the model's `WorstAngle` read as a verdict."""

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
    return PhysicsVerdict(**vars(worst_load_angle(table, motor, pulses=pulses,
                                                  max_step_s=max_step_s)))


__all__ = ["PEAK_DEG", "SLIP_DEG", "TARGET_DEG", "PhysicsResult", "PhysicsVerdict",
           "judge_executions", "load_angle_check"]

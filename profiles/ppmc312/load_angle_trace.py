"""The rotor's load angle through one execution, step by step: what figures and the
designer draw.

The model is `profiles.motor.rotor` (load angle in electrical degrees: the restoring
torque peaks at 90° at the unscaled pull-out torque of the speed, the rotor slips a
pole at 180°). The verdict over every execution is `safety.judge_table`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from profiles.motor import Motor
from profiles.motor.angles import PEAK_DEG
from profiles.motor.rotor import check_step, follow, rotor_of
from profiles.ppmc312.execution import Execution
from profiles.ppmc312.load_angle import spans_of


@dataclass(frozen=True)
class LoadAngleTrace:
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


def trace_load_angle(execution: Execution, motor: Motor, *, max_step_s: float | None = None,
                     direction: int = 1) -> LoadAngleTrace:
    """Integrate the rotor against `execution`, then until it settles at rest."""
    check_step(max_step_s)
    rotor = rotor_of(motor, direction=direction)
    step = rotor.step_s() if max_step_s is None else min(rotor.step_s(), max_step_s)
    trace = follow(rotor, spans_of(execution, rotor, step), step_s=step)
    t = np.asarray(trace.t_s)
    angle = np.degrees(np.asarray(trace.lag) * rotor.c_e)
    worst = int(np.argmax(np.abs(angle)))
    return LoadAngleTrace(float(angle[worst]), float(t[worst]), trace.slipped, trace.slip_time_s,
                         t, angle, motor.full_step_electrical_deg)


__all__ = ["LoadAngleTrace", "trace_load_angle"]

"""What a synchronised table must pass before sync uses it: the judges `stepramp plan`
plans by, over every execution the chip can run with the table.

- the criterion over every move length (`criterion.all_length_safe`, the one
  `profiles.ppmc312.criterion.check_stall` reports), on the motor's worst case over its tolerance
  box when it has one (as `plan_free_curve` plans);
- the load angle over every execution (`load_angle.worst_load_angles`, at every corner
  of the tolerance box), a decel stop (81) at every pulse of the ramp under every
  reading among them (`stops.stop_angles`, as `plan` plans), within the aim
  (`profiles.motor.angles.AIM_DEG`, 75°: the one `plan` aims at), or, where nothing
  within the aim is found, below the 90° peak (`accepted_below_peak`, sync's fallback,
  which its plan's info then says). A table the model refuses to judge (its step
  budget) is not accepted.
"""

from __future__ import annotations

from ...errors import StepRampError
from ...motor import Motor
from ...motor.angles import AIM_DEG, PEAK_DEG
from ...motor.tolerance import corners, worst_case_motor
from ..criterion import all_length_safe
from ..load_angle import worst_load_angles
from ..stops import stop_angles
from ..table import FreeCurveTable


def worst_angle_deg(table: FreeCurveTable, motor: Motor) -> float:
    """The worst load angle [electrical °] over every execution of `table` (every move,
    every decel stop), at every corner of the motor's tolerance box (the motor itself
    when it has none)."""
    judges = [c.motor for c in corners(motor)] if motor.tolerances else [motor]
    return max(max(w.worst_angle_deg for w in worst_load_angles(table, judges)),
               stop_angles(table, judges).worst_deg())


def criterion_safe(table: FreeCurveTable, motor: Motor) -> bool:
    """The criterion over every move length, on the box's worst case."""
    return all_length_safe(table, worst_case_motor(motor) if motor.tolerances else motor)


def accepted(table: FreeCurveTable, motor: Motor) -> bool:
    """The criterion, and the load angle within the aim (see the module)."""
    return criterion_safe(table, motor) and judged_within(table, motor, AIM_DEG)


def accepted_below_peak(table: FreeCurveTable, motor: Motor) -> bool:
    """The criterion, and the load angle below the 90° peak: sync's fallback."""
    return criterion_safe(table, motor) and judged_within(table, motor, PEAK_DEG - 1e-9)


def judged_within(table: FreeCurveTable, motor: Motor, limit_deg: float) -> bool:
    """Whether the worst load angle is at most `limit_deg`; a table the load-angle model
    refuses to judge (its stages dwell too long for its step budget: padding a move of
    hours) is not accepted, so sync keeps a table it can judge."""
    try:
        return worst_angle_deg(table, motor) <= limit_deg
    except StepRampError:
        return False

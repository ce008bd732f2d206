"""A table that follows a continuous reference (ruckig, toppra) and is safe: `plan --from`.

Quantising a reference's samples pulse by pulse (profiles.ppmc312.planner.quantise) keeps its
timing but not the motor's rules: its stages jump by several times the jump limit, and
no scaling of the reference repairs that (bench-measured: every bundled motor, both
references, scales down to 0.44, still unsafe). So the reference is followed by its
*shape* instead: the table is planned (the planner's DP, chip limits, both LE variants)
with the reference's own acceleration as the capability, speed by speed, and its top
speed as the top, then tightened for the load angle by the planner's own tightening,
judged on the real motor (every corner of its tolerance box). The mean acceleration
from the start speed up to each speed (v² − v₀²)/2x, from the reference's positions, is
what it uses there: it is the reference's constant acceleration for ruckig without a
jerk limit, the torque curve's shape for toppra, and stays positive through a jerk
phase. It is never above the motor's own capability.

The summary sets the table's move time beside the reference's and the planner's own
plan for the same move: what following that reference costs.

The reference comes in as data (its speeds and positions, a `Trajectory`): profiles never
import verify, whose references solve it (`stepramp plan --from` solves it on
`reference_basis(motor)` and hands it here).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np

from profiles.errors import PlanError, StepRampError
from profiles.motor import Motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.planner import Plan, plan_free_curve
from profiles.ppmc312.planner.free_curve import plan
from profiles.ppmc312.planner.tightening import tighten

CURVE_POINTS = 64


class Trajectory(Protocol):
    """A continuous reference move as data (verify.references' `Reference` is one): its
    samples' speeds and positions, rest or the start speed at both ends, and its time."""

    @property
    def v_pps(self) -> np.ndarray: ...

    @property
    def x_pulses(self) -> np.ndarray: ...

    @property
    def duration_s(self) -> float: ...


def reference_basis(motor: Motor) -> Motor:
    """The motor a reference to follow is solved on: the tolerance box's worst case when
    `motor` has one (what the follower may ask of every motor of the box), else itself."""
    from profiles.motor.tolerance import worst_case_motor

    return worst_case_motor(motor) if motor.tolerances else motor


@dataclass(frozen=True)
class ReferencePlan:
    """A table following `source`'s shape, its verdict-ready plan and the times to compare."""

    source: str
    plan: Plan
    reference_s: float      # the continuous reference's move
    planner_s: float        # the planner's own table for the same move
    follower: Motor         # the motor whose capability is the reference's

    @property
    def move_time_s(self) -> float:
        return float(self.plan.duration_s or 0.0)

    def summary(self) -> dict[str, object]:
        return {"source": self.source, "reference_s": self.reference_s,
                "planner_s": self.planner_s, "move_time_s": self.move_time_s,
                "table/reference": self.move_time_s / self.reference_s,
                "table/planner": self.move_time_s / self.planner_s}


def plan_from_reference(motor: Motor, pulses: int, source: str, ref: Trajectory, *,
                        clock: Clock | None = None, max_stages: int = 127,
                        load_angle_deg: float) -> ReferencePlan:
    """The fastest safe table shaped like `ref`, `source`'s reference for a move of
    `pulses` solved on `reference_basis(motor)` (module docstring). PlanError when no
    table of that shape is safe."""
    from profiles.motor.tolerance import corners

    follower = reference_motor(reference_basis(motor), ref.v_pps, ref.x_pulses)
    judges = [c.motor for c in corners(motor)] if motor.tolerances else [motor]

    def make(m: Motor, shaping: object = None) -> Plan:
        return plan(m, clock, max_stages, pulses, None, shaping=shaping,  # type: ignore[arg-type]
                    label=f"following {source}")

    try:
        table_plan = tighten(follower, make, load_angle_deg, judges=judges)
    except PlanError as e:
        raise PlanError(f"no safe table follows the {source} reference of {pulses} pulses: {e}")\
            from None
    own = plan_free_curve(motor, clock=clock, max_stages=max_stages, pulses=pulses,
                          load_angle_deg=load_angle_deg)
    return ReferencePlan(source, table_plan, float(ref.duration_s), float(own.duration_s or 0.0),
                         follower)


def reference_motor(motor: Motor, v_pps: np.ndarray, x_pulses: np.ndarray) -> Motor:
    """`motor` with the reference's acceleration as its capability: at each speed the mean
    acceleration (v² − v₀²)/2x up to it (accelerating) and down from it (decelerating),
    the smaller as a torque curve (the same safety factor, friction and load), never
    above the motor's; its top speed the reference's."""
    v = np.asarray(v_pps, dtype=float)
    x = np.asarray(x_pulses, dtype=float)
    peak = int(np.argmax(v))
    top = float(v[peak])
    # the motor's own breakpoints too: between grid points both curves are then straight,
    # and the follower's, below the motor's at every point, stays below it between them
    speeds = np.union1d(np.linspace(0.0, top, CURVE_POINTS),
                        motor.curve_speed_pps[motor.curve_speed_pps < top])
    k = motor.pps2_per_nm
    load = abs(motor.load_torque_nm)
    accel = _mean_accel(v[: peak + 1], x[: peak + 1], speeds)
    decel = _mean_accel(v[peak:][::-1], (x[-1] - x[peak:])[::-1], speeds)
    t_acc = (accel / k + motor.friction_torque_nm + load) / motor.safety_factor
    t_dec = (decel / k - motor.friction_torque_nm + load) / motor.safety_factor
    # Friction helps a deceleration: where the reference brakes with less torque than it
    # takes to overcome friction and load, the decel side's torque would leave the
    # follower no acceleration at all (a long ruckig move on a motor with friction:
    # "cannot accelerate from rest"). There the accel side alone shapes the follower; its
    # deceleration is then the motor's own at that torque (never above the motor's),
    # and the table is judged on the real motor either way.
    moving = t_dec * motor.safety_factor > motor.friction_torque_nm + load
    torque = np.minimum(np.where(moving, np.minimum(t_acc, t_dec), t_acc),
                        motor.torque_nm(speeds))
    torque[-1] = min(torque[-1], torque[-2])  # `speeds` holds CURVE_POINTS speeds at least
    try:
        return replace(motor, curve_speed_pps=speeds, curve_torque_nm=np.maximum(torque, 0.0),
                       max_pps=top, name=f"{motor.name} (following a reference)")
    except StepRampError as e:  # the stand-in's fault, not the user's motor's: say so
        raise PlanError(f"the reference's acceleration makes no motor to follow ({e})") \
            from None


def _mean_accel(v: np.ndarray, x: np.ndarray, speeds: np.ndarray) -> np.ndarray:
    """(s² − v₀²)/2x(s) at each of `speeds`: x(s) the distance the ramp `v`, `x` (from
    rest or its start speed, speeds rising) takes to reach s; below v₀ the value at v₀."""
    rising = np.maximum.accumulate(v)
    keep = np.concatenate(([True], np.diff(rising) > 0))
    rv, rx = rising[keep], x[keep]
    v0 = float(rv[0])
    s = np.clip(speeds, v0, rv[-1])
    dist = np.interp(s, rv, rx)
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = (s * s - v0 * v0) / (2 * dist)
    first = mean[np.flatnonzero(np.isfinite(mean) & (dist > 0))]
    floor = float(first[0]) if len(first) else 0.0
    return np.where(np.isfinite(mean) & (dist > 0), mean, floor)

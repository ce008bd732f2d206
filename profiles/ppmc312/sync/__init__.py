"""Several PPMC-312 axes, one move: synchronised free-curve tables (issue 11).

Each axis is its own chip with its own table; the move commands carry the trigger bits
so every chip starts on one event input (`moves.move_command`). By algorithm:

- `moves`: the nouns (an axis's table and execution, the plan, the move command, the
  chips' pulse trains and the joint path's line deviation);
- `time_mode`: every axis finishes together (top-speed cap, then `padding`);
- `line_mode`: positions stay proportional (a straight joint path): the leader planned
  for the envelope motor of every axis, the followers on common stage boundaries
  (`joint_stages`: stage durations; `joint_rates`: rate choice; `joint_tables`: per-axis
  tables);
- `acceptance`: what every table must pass before sync uses it (the criterion and the
  load angle over every execution, as `stepramp plan` judges);
- `files`: every file of a plan, through the device's format table.

The device-neutral parts live in `profiles.joint` (a plan's times, the finish-spread
tolerance) and `profiles.motor.envelope` (the envelope motor).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

from ...errors import SyncError, echo
from ...joint import Mode, spread_tolerance_s
from ...motor import Motor
from ...motor.angles import AIM_DEG, PEAK_DEG
from ...motor.envelope import envelope_motor
from .acceptance import accepted, accepted_below_peak
from .files import check_axis_names, output_names, sync_files
from .joint_stages import clock_for
from .joint_tables import joint_tables
from .line_mode import cap_top, finish_together, plan_line_sync
from .moves import (
    TRIGGER_EVENT1,
    Accept,
    AxisMove,
    SyncPlan,
    line_deviation,
    move_command,
    move_commands,
    pulse_train,
)
from .padding import pad_to_ticks
from .time_mode import plan_time_sync, slow_to

_clock_for = clock_for  # bench/bench_sync.py's name for it (public: clock_for)


def plan_sync(axes: Sequence[tuple[str, Motor, int]], mode: Mode, *,
              accept: Accept | None = accepted) -> SyncPlan:
    """The synchronised plan of `axes` ((name, motor, signed pulses)) in `mode`, every
    table judged by `accept` (default: the criterion and the load angle within the aim;
    where line mode finds no such set, the load angle below the 90° peak, and the plan's
    info says so)."""
    if mode == "time":
        return plan_time_sync(axes, accept=accept)
    if mode != "line":
        raise SyncError(f"mode: {echo(mode)} is not 'time' or 'line'")
    try:
        return plan_line_sync(axes, accept=accept)
    except SyncError:
        if accept is not accepted:
            raise
    plan = plan_line_sync(axes, accept=accepted_below_peak)
    return replace(plan, info=plan.info + f"; no set within the {AIM_DEG:g}° load-angle aim: "
                                          f"every table below the {PEAK_DEG:g}° peak")


__all__ = ["TRIGGER_EVENT1", "Accept", "AxisMove", "SyncPlan", "accepted", "accepted_below_peak",
           "cap_top",
           "check_axis_names", "clock_for", "envelope_motor", "finish_together",
           "joint_tables", "line_deviation", "move_command", "move_commands",
           "output_names", "pad_to_ticks", "plan_line_sync", "plan_sync", "plan_time_sync",
           "pulse_train", "slow_to", "spread_tolerance_s", "sync_files"]

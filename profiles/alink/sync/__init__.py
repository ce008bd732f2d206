"""The A-Link ALUM's two axes, one move: synchronised settings (`plan`) and their files
(`files`). The device-neutral parts live in `profiles.joint` and
`profiles.motor.envelope`."""

from __future__ import annotations

from .files import check_axis_names, command_lists, move_commands, output_names, sync_files
from .plan import (
    MODE_SIG_STA,
    AlinkAxisMove,
    AlinkSyncPlan,
    is_stall_safe,
    plan_line_sync,
    plan_sync,
    plan_time_sync,
    pulse_times_s,
    pulse_train,
    slow_to,
)

__all__ = ["MODE_SIG_STA", "AlinkAxisMove", "AlinkSyncPlan", "check_axis_names",
           "command_lists", "is_stall_safe", "move_commands", "output_names",
           "plan_line_sync", "plan_sync", "plan_time_sync", "pulse_times_s", "pulse_train",
           "slow_to", "sync_files"]

"""An axes file planned by its device: verify/devices names each device's synchronised
moves (profiles/<device>/sync/), so no device is switched on here."""

from __future__ import annotations

from typing import Any

from profiles.axes import AxesFile
from profiles.errors import FormatError
from profiles.motor import Motor

from ..devices import get


def plan_axes(axes: AxesFile) -> Any:
    """The synchronised plan for an axes file (its device and mode)."""
    device = get(axes.device)
    sync = device.sync_module()
    sync.check_axis_names([a.name for a in axes.axes])
    # a device whose planner tightens on the one verdict gives the judge of each motor
    judge_for = getattr(device.judge_module(), "sync_judge_for", None)
    if judge_for is not None:
        plan_tightened: Any = sync.plan_sync  # the A-Link's takes the judge
        return plan_tightened(motor_axes(axes), axes.mode, judge_for)
    return sync.plan_sync(motor_axes(axes), axes.mode)


def motor_axes(axes: AxesFile) -> list[tuple[str, Motor, int]]:
    """(name, motor, signed pulses) of every axis; an axis that gives a table is refused:
    sync plans from motors."""
    out = []
    for a in axes.axes:
        if a.motor is None:
            raise FormatError(f"axis {a.name}: sync plans from motors; it gives a table "
                              "(use `stepramp simulate --axes` for a set of tables)")
        out.append((a.name, a.motor, a.pulses))
    return out

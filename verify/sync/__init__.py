"""Synchronised multi-axis moves (`stepramp sync`), one job a module:

- `dispatch`: an axes file planned by its device (verify/devices finds the device's
  synchronised moves);
- `files`: what sync writes into its folder (each device's files, report.json);
- `report`: report.json (durations, spread, deviation, each axis's safety verdict,
  ruckig's synchronised durations beside ours) and the problems it records;
- `figure`: the joint path, its deviation, each axis's speed;
- `timeline`: every axis's segment boundaries in time order (`simulate --axes`);
- ruckig's synchronised reference lives with the references
  (verify/references/ruckig_sync.py).

Definitions (docs/manual-notes.md, "Synchronised axes"):
- every axis starts at t = 0 (one trigger) and its pulses land at its device's instants
  (a PPMC-312 chip's exact ones, `Execution.pulse_times_s`; the A-Link's modelled);
- finish spread = latest minus earliest `duration_s`;
- line deviation = the largest distance, in pulses (each axis's pulse one unit), between
  the joint path as the devices emit it and the straight line from start to end, over
  every instant any axis pulses (`profiles.pulses.line_deviation`).
"""

from __future__ import annotations

from ..references.ruckig_sync import RuckigSync, ruckig_sync
from .dispatch import plan_axes
from .figure import sync_figure
from .files import REPORT_FILE, output_names
from .report import report_problems, sync_report
from .timeline import joint_timeline

__all__ = ["REPORT_FILE", "RuckigSync", "joint_timeline", "output_names", "plan_axes",
           "report_problems", "ruckig_sync", "sync_figure", "sync_report"]

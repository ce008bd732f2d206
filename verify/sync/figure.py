"""The figure of a synchronised move: the joint path against the straight line, the
distance to the line over time, each axis's speed against time (with ruckig's time- and
phase-synchronised speeds when given). Positions and speeds are signed (a CCW axis runs
negative); every line has a legend entry, except with many axes (more than
`MANY_AXES`): then each axis keeps its colour and name and the lines drawn for every axis
(the straight lines, ruckig's speeds) share one entry per kind, in grey, and the legends
take columns. Up to 16 axes fit the figure, which grows with them, without matplotlib
collapsing an axes (before: "constrained_layout not applied", twice)."""

from __future__ import annotations

from typing import Any

import numpy as np

from profiles.pulses import line_deviation

from ..plot import pyplot
from ..references.ruckig_sync import RuckigSync

MANY_AXES = 4            # more: one legend entry per kind of line drawn for every axis
LEGEND_ROWS = 8          # a legend's entries per column with many axes


def sync_figure(plan: Any, ruckig: RuckigSync | None = None) -> Any:
    """The figure (see the module docstring) of any device's synchronised plan."""
    plt = pyplot()
    trains = [a.pulse_train() for a in plan.axes]
    dev, t, d = line_deviation(trains)  # every instant, or a bounded trace
    axes = list(plan.axes)
    extra = max(0, len(axes) - MANY_AXES) * 0.25  # the legends' rows need room
    fig, (ax_p, ax_d, ax_v) = plt.subplots(3, 1, figsize=(8.0, 10.0 + extra),
                                           constrained_layout=True,
                                           gridspec_kw={"height_ratios": [4, 2, 3]})
    sign = [1 if a.pulses >= 0 else -1 for a in axes]
    lead = int(np.argmax([tr.count for tr in trains]))
    names = [a.name for a in axes]
    many = len(axes) > MANY_AXES
    x = [s * tr.emitted(t) for s, tr in zip(sign, trains, strict=True)]
    for i, name in enumerate(names):
        if i == lead and len(names) > 1:
            continue
        line = ax_p.step(x[lead], x[i], where="post", lw=1.2, color=f"C{i}",
                         label=name if many else f"{name} (executed)")[0]
        ax_p.plot([0, axes[lead].pulses], [0, axes[i].pulses], ls="--", lw=0.8,
                  color=line.get_color(), alpha=0.7,
                  label="_" if many else f"{name}: the straight line")
    if many:
        ax_p.plot([], [], ls="--", lw=0.8, color="0.4", label="dashed: each axis's straight line")
    ax_p.set(xlabel=f"{names[lead]} [pulses]", ylabel="other axes [pulses]",
             title=f"{plan.mode} mode: joint path against the straight line\n"
                   f"(max deviation {dev:.3g} pulses)")
    ax_p.legend(fontsize=7 if many else 8, ncols=_columns(len(axes)))
    ax_d.step(t * 1e3, d, where="post", color="tab:red", lw=1.0,
              label="distance of the joint path to the line")
    ax_d.set(xlabel="time [ms]", ylabel="distance to\nthe line [pulses]")
    ax_d.legend(fontsize=8, loc="upper right")
    speeds(ax_v, axes, sign, ruckig)
    for ax in (ax_p, ax_d, ax_v):
        ax.grid(alpha=0.3)
    return fig


def speeds(ax: Any, axes: list[Any], sign: list[int], ruckig: RuckigSync | None) -> None:
    """Each axis's signed speed against time [ms] (a device's staircase as steps, a modelled
    speed as a line), with ruckig's synchronised speeds."""
    for i, a in enumerate(axes):
        label = f"{a.name} ({a.duration_s * 1e3:.2f} ms)"
        t, v, stepped = a.speed_steps()
        if stepped:
            ax.step(t * 1e3, sign[i] * v, where="post", lw=1.4, color=f"C{i}", label=label)
        else:
            ax.plot(t * 1e3, sign[i] * v, lw=1.4, color=f"C{i}", label=label)
    many = len(axes) > MANY_AXES
    if ruckig is not None:
        for key, ls, dur in (("time", "--", ruckig.time_feasible_s),
                             ("phase", ":", ruckig.phase_feasible_s)):
            tr, _, vr = ruckig.trajectories[key]
            for i, a in enumerate(axes):
                ax.plot(tr * 1e3, sign[i] * vr[:, i], ls=ls, lw=1.0, color=f"C{i}",
                        label="_" if many else f"ruckig {key}-sync {a.name} ({dur * 1e3:.2f} ms)")
            if many:  # one entry for the kind; each axis's colour is its own
                ax.plot([], [], ls=ls, lw=1.0, color="0.4",
                        label=f"ruckig {key}-sync, every axis ({dur * 1e3:.2f} ms)")
    ax.axhline(0.0, color="0.3", lw=0.6, label="standstill")
    ax.set(xlabel="time [ms]", ylabel="speed [pps]\n(negative: CCW)")
    ax.legend(fontsize=6 if many else 7, ncols=max(2, _columns(len(axes))), loc="best")


def _columns(n_axes: int) -> int:
    """Legend columns for `n_axes` axes: one up to MANY_AXES, then LEGEND_ROWS a column."""
    return 1 if n_axes <= MANY_AXES else -(-(n_axes + 3) // LEGEND_ROWS)

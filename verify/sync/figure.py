"""The figure of a synchronised move: the joint path against the straight line, the
distance to the line over time, each axis's speed against time (with ruckig's time- and
phase-synchronised speeds when given). Positions and speeds are signed (a CCW axis runs
negative); every line has a legend entry."""

from __future__ import annotations

from typing import Any

import numpy as np

from profiles.pulses import line_deviation

from ..plot import pyplot
from ..references.ruckig_sync import RuckigSync


def sync_figure(plan: Any, ruckig: RuckigSync | None = None) -> Any:
    """The figure (see the module docstring) of any device's synchronised plan."""
    plt = pyplot()
    trains = [a.pulse_train() for a in plan.axes]
    dev, t, d = line_deviation(trains)  # every instant, or a bounded trace
    fig, (ax_p, ax_d, ax_v) = plt.subplots(3, 1, figsize=(8.0, 10.0), constrained_layout=True,
                                           gridspec_kw={"height_ratios": [4, 2, 3]})
    axes = list(plan.axes)
    sign = [1 if a.pulses >= 0 else -1 for a in axes]
    lead = int(np.argmax([tr.count for tr in trains]))
    names = [a.name for a in axes]
    x = [s * tr.emitted(t) for s, tr in zip(sign, trains, strict=True)]
    for i, name in enumerate(names):
        if i == lead and len(names) > 1:
            continue
        line = ax_p.step(x[lead], x[i], where="post", lw=1.2, label=f"{name} (executed)")[0]
        ax_p.plot([0, axes[lead].pulses], [0, axes[i].pulses], ls="--", lw=0.8,
                  color=line.get_color(), alpha=0.7, label=f"{name}: the straight line")
    ax_p.set(xlabel=f"{names[lead]} [pulses]", ylabel="other axes [pulses]",
             title=f"{plan.mode} mode: joint path against the straight line\n"
                   f"(max deviation {dev:.3g} pulses)")
    ax_p.legend(fontsize=8)
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
    if ruckig is not None:
        for key, ls, dur in (("time", "--", ruckig.time_feasible_s),
                             ("phase", ":", ruckig.phase_feasible_s)):
            tr, _, vr = ruckig.trajectories[key]
            for i, a in enumerate(axes):
                ax.plot(tr * 1e3, sign[i] * vr[:, i], ls=ls, lw=1.0, color=f"C{i}",
                        label=f"ruckig {key}-sync {a.name} ({dur * 1e3:.2f} ms)")
    ax.axhline(0.0, color="0.3", lw=0.6, label="standstill")
    ax.set(xlabel="time [ms]", ylabel="speed [pps]\n(negative: CCW)")
    ax.legend(fontsize=7, ncols=2, loc="best")

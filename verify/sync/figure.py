"""The figure of a synchronised move: the joint path against the straight line, the
distance to the line over time (an envelope: its least and largest per time bin, the
worst marked), each axis's speed against time (with ruckig's time- and
phase-synchronised speeds when given). Positions and speeds are signed (a CCW axis runs
negative); every line has a legend entry, except with many axes (more than
`MANY_AXES`): then each axis keeps its colour and name and the lines drawn for every axis
(the straight lines, ruckig's speeds) share one entry per kind, in grey, and the legends
take columns. Up to 16 axes fit the figure, which grows with them, without matplotlib
collapsing an axes (before: "constrained_layout not applied", twice). Where every axis's
motor has the same real units (`profiles.motor.travel`), positions and speeds get a second
scale in them (mm and mm/s, else rev and rpm)."""

from __future__ import annotations

from typing import Any

import numpy as np

from profiles.pulses import line_deviation

from ..plot import motor_units, pyplot, real_axis
from ..references.ruckig_sync import RuckigSync

MANY_AXES = 4            # more: one legend entry per kind of line drawn for every axis
LEGEND_ROWS = 8          # a legend's entries per column with many axes
DEVIATION_BINS = 400     # time bins of the deviation's envelope (a figure ~1200 px wide)


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
        ax_p.step(x[lead], x[i], where="post", lw=1.2, color=f"C{i}",
                  label=name if many else f"{name} (executed)")
        ax_p.plot([0, axes[lead].pulses], [0, axes[i].pulses], ls="--", lw=0.8,
                  color="k", alpha=0.7, zorder=3,  # on the executed path, not under it
                  label="_" if many else f"{name}: the straight line")
    if many:
        ax_p.plot([], [], ls="--", lw=0.8, color="0.4", label="dashed: each axis's straight line")
    ax_p.set(xlabel=f"{names[lead]} [pulses]", ylabel="other axes [pulses]",
             title=f"{plan.mode} mode: joint path against the straight line\n"
                   f"(max deviation {dev:.3g} pulses)")
    ax_p.legend(fontsize=7 if many else 8, ncols=_columns(len(axes)))
    deviation_panel(ax_d, t, d)
    speeds(ax_v, axes, sign, ruckig)
    units = {motor_units(a.motor) for a in axes if hasattr(a, "motor")}
    if len(units) == 1 and None not in units:  # one scale fits every axis: mm (or rev)
        [u] = units
        real_axis(ax_p, u, "distance", "top")
        real_axis(ax_p, u, "distance", "right")
        real_axis(ax_v, u, "speed", "right")
    for ax in (ax_p, ax_d, ax_v):
        ax.grid(alpha=0.3)
    return fig


def deviation_panel(ax: Any, t: np.ndarray, d: np.ndarray) -> None:
    """The distance to the line as an envelope: its least and largest value in each of
    DEVIATION_BINS time bins, filled (it swings between 0 and its peak at every pulse, so a
    line of every instant is a solid block), and the worst instant marked."""
    t_bin, lo, hi = binned_envelope(t, d, DEVIATION_BINS)
    ax.fill_between(t_bin * 1e3, lo, hi, step="post", color="tab:red", alpha=0.35, lw=0,
                    label="distance to the line: least to largest per "
                          f"{(t_bin[1] - t_bin[0]) * 1e3:.3g} ms" if len(t_bin) > 1 else
                          "distance to the line")
    ax.step(t_bin * 1e3, hi, where="post", color="tab:red", lw=0.8,
            label="its largest per time bin")
    worst = int(np.argmax(d)) if len(d) else 0
    if len(d):
        ax.plot([t[worst] * 1e3], [d[worst]], "o", color="k", ms=5,
                label=f"worst {d[worst]:.3g} pulses at {t[worst] * 1e3:.4g} ms")
    ax.set(xlabel="time [ms]", ylabel="distance to\nthe line [pulses]")
    ax.set_ylim(0, 1.45 * max(float(np.max(d)) if len(d) else 0.0, 1e-9))  # room: legend
    ax.legend(fontsize=7, loc="upper right", ncols=3)


def binned_envelope(t: np.ndarray, d: np.ndarray, bins: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(bin starts plus the end, least, largest) of a step trace `d` (each value holds from
    its instant to the next) over `bins` equal time bins: a bin's values are those that
    hold at some instant of it (the one held at its start included); the last value is
    repeated for a step drawing. A trace of at most `bins` instants: its own steps."""
    if len(t) <= bins or t[-1] <= t[0]:
        return t, d, d
    edges = np.linspace(float(t[0]), float(t[-1]), bins + 1)
    first = np.maximum(np.searchsorted(t, edges[:-1], side="right") - 1, 0)
    lo = np.minimum.reduceat(d, first)
    hi = np.maximum.reduceat(d, first)
    # a value that starts inside a bin holds at the next bin's start too (first[i + 1])
    lo[:-1] = np.minimum(lo[:-1], d[first[1:]])
    hi[:-1] = np.maximum(hi[:-1], d[first[1:]])
    return edges, np.append(lo, lo[-1]), np.append(hi, hi[-1])


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

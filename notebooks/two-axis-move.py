# %% [markdown]
# # Two axes, one move
#
# An XY table: x moves 12 000 pulses on a NEMA17, y 5 000 pulses (backwards) on a
# 5-phase PK566, each axis its own PPMC-312. Either both axes **finish together**
# (`time` mode), or their positions stay **proportional** so the tool moves on a
# straight line (`line` mode). Each chip runs one integer-rate staircase, so the
# straight line is kept only as well as integer rates allow: how well, and at what
# cost in time, against ruckig's time- and phase-synchronised moves.

# %%
import matplotlib.pyplot as plt
import numpy as np

from profiles import load_motor
from profiles.motor import bundled_motor_paths
from profiles.ppmc312 import FreeCurveTable, simulate_move
from profiles.ppmc312.sync import (line_deviation, plan_line_sync, plan_time_sync,
                                   spread_tolerance_s)
from profiles.ppmc312.criterion import check_stall
from verify.sync import ruckig_sync, sync_figure

motors = {p.stem: load_motor(p) for p in bundled_motor_paths()}
x_motor, y_motor = motors["motor-nema17-1600"], motors["motor-pk566-5phase-half"]
AXES = [("x", x_motor, 12_000), ("y", y_motor, -5_000)]

# %% [markdown]
# ## Time mode: finish together
#
# Each axis alone: its fastest stall-safe table. The slower one (x) keeps it; y is
# slowed as little as needed: its top speed capped, then pulses moved from the
# cruise into the stages next to the top until it ends with x to a clock tick or
# so.

# %%
timed = plan_time_sync(AXES)
for a in timed.axes:
    print(f"{a.name}: alone {a.fastest_s * 1e3:8.3f} ms, synchronised "
          f"{a.duration_s * 1e3:8.3f} ms, {len(a.table.rates):3d} stages, "
          f"stall findings {len(check_stall(a.table, a.motor))}: {a.how}")
print(f"finish spread {timed.spread_s * 1e6:.3f} µs "
      f"(allowed {spread_tolerance_s(timed.duration_s) * 1e6:.0f} µs)")
print(f"distance from the straight line: {line_deviation([a.execution for a in timed.axes])[0]:.1f} pulses")

# %% [markdown]
# Finishing together is not moving on a line: y reaches its cruise earlier and
# cruises slower, so the path bows away from the diagonal by tens of pulses.
#
# ## Line mode: a straight joint path
#
# x leads with a table planned for both motors at once (y's capability scaled by
# the pulse ratio); y follows stage by stage, choosing at each of x's stage
# boundaries the integer rate that keeps it closest to the line, and the top-rate
# pair whose ratio matches 12 000 : 5 000 best.

# %%
lined = plan_line_sync(AXES)
runs = [a.execution for a in lined.axes]
dev, t, d = line_deviation(runs)
for a in lined.axes:
    print(f"{a.name}: {a.duration_s * 1e3:8.3f} ms, top {a.table.clock.hz / a.table.rates[0]:9.1f} pps "
          f"(rate {a.table.rates[0]}), stall findings {len(check_stall(a.table, a.motor))}")
print(f"largest distance from the line: {dev:.3f} pulses; finish spread {lined.spread_s * 1e6:.3f} µs")
print(f"top-rate ratio {lined.axes[1].table.rates[0] / lined.axes[0].table.rates[0]:.5f} "
      f"vs pulse ratio {12_000 / 5_000:.5f}")

# %% [markdown]
# ## Against naive rate rounding
#
# The plain way to make y follow x: divide x's rates by the pulse ratio and round,
# scale the counts and round. The rounding errors add up into a drift.

# %%

lead = lined.axes[0].table
ratio = 5_000 / 12_000
rates, acc, dec = [], [], []
for r, a, dd in zip(lead.rates, lead.accel_pulses, lead.decel):
    rr = round(r / ratio)
    if rates and rr <= rates[-1]:
        acc[-1] += max(2, round(a * ratio)); dec[-1] += max(2, round(dd * ratio)); continue
    rates.append(rr); acc.append(max(2, round(a * ratio))); dec.append(max(2, round(dd * ratio)))
naive = FreeCurveTable(lead.clock, tuple(rates), tuple(acc), tuple(dec))
naive_run = simulate_move(naive, 5_000)
naive_dev, tn, dn = line_deviation([runs[0], naive_run])
print(f"naive: {naive_dev:.2f} pulses from the line, ends {abs(naive_run.duration_s - runs[0].duration_s) * 1e3:.3f} ms apart")
print(f"ours:  {dev:.2f} pulses, {lined.spread_s * 1e6:.3f} µs apart")
fig, ax = plt.subplots(figsize=(8, 3))
ax.plot(tn * 1e3, dn, lw=0.6, label="naive rounding")
ax.plot(t * 1e3, d, lw=0.6, label="line mode")
ax.set(xlabel="time [ms]", ylabel="distance to the line [pulses]")
ax.legend(); ax.grid(alpha=0.3)

# %% [markdown]
# ## Against ruckig
#
# ruckig takes constant limits, so against a torque curve it brackets the optimum
# (REFERENCES.md): the least capability over each axis's speeds gives a feasible
# move, the largest an infeasible one. Time synchronisation ends both axes
# together; phase synchronisation keeps them on the line.

# %%
rk = ruckig_sync([x_motor, y_motor], [12_000, -5_000])
print(f"{'':28s}{'ours':>10s}{'ruckig':>10s}{'optimistic':>12s}")
print(f"{'time-synchronised [ms]':28s}{timed.duration_s * 1e3:10.2f}"
      f"{rk.time_feasible_s * 1e3:10.2f}{rk.time_optimistic_s * 1e3:12.2f}")
print(f"{'on the line [ms]':28s}{lined.duration_s * 1e3:10.2f}"
      f"{rk.phase_feasible_s * 1e3:10.2f}{rk.phase_optimistic_s * 1e3:12.2f}")

# %%
fig = sync_figure(lined, rk)

# %% [markdown]
# The same figure comes from `stepramp sync AXES.json -o DIR --plot OUT.png`,
# which also writes every axis's table, upload files, move command (with the
# trigger bits: all chips start on event input 1) and one C header for all axes;
# `stepramp simulate --axes DIR/axes.json` prints the joint timeline.

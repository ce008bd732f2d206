# %% [markdown]
# # Designing a free curve
#
# From a motor's pull-out torque curve to the fastest stall-safe PPMC-312
# free-curve table for one move, how it compares with the continuous time
# optimum, and what the safety factor and the stage budget cost in move time.

# %%
import dataclasses

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import FuncFormatter

from profiles import load_motor, plan_free_curve
from profiles.motor import bundled_motor_paths
from verify import compare_table
from verify.plot import motor_figure
from verify.references import exact_optimum
from profiles.ppmc312.criterion import stall_margins

PULSES = 10_000
for path in bundled_motor_paths():
    print(f"{path.name:32s} {load_motor(path).name}")

# %% [markdown]
# ## The motor
#
# Left: pull-out torque, and the share of it the planner may use (× safety
# factor). Right: the acceleration that torque gives against the load inertia,
# speeding up (friction works against the motor) and slowing down (friction
# helps).

# %%
motor_path = next(p for p in bundled_motor_paths() if "nema17" in p.name)
motor = load_motor(motor_path)
print(motor.name)
print(f"start {motor.start_pps:g} pps, top {motor.top_pps:g} pps, "
      f"safety factor {motor.safety_factor:g}, inertia {motor.inertia_kgm2:g} kg·m²")
motor_figure(motor)
plt.show()

# %% [markdown]
# ## The optimal table for one move
#
# `plan_free_curve` searches the stall-safe staircase (at most 127 stages) with
# the shortest move of `PULSES` pulses, as the chip runs it.

# %%
plan = plan_free_curve(motor, pulses=PULSES)
table = plan.table
print(plan.info)
print(f"clock {table.clock.name}, {len(table.rates)} stages, "
      f"separate decel counts (LE=1): {table.separate}")
print(f"move of {PULSES} pulses: {plan.duration_s * 1e3:.3f} ms")

# %% [markdown]
# ## Against the time-optimal references
#
# The staircase (red steps) against the continuous references: the exact
# optimum, toppra and casadi (which should agree with it) and ruckig (constant
# acceleration limits, so slower). Top: speed against time; middle: speed
# against position; bottom: the stall margin of every stage.

# %%
comparison = compare_table(table, motor, PULSES)
print(comparison.to_text())
comparison.figure()
plt.show()

# %% [markdown]
# ## Stall margin per stage
#
# Margin = the acceleration the motor can give over the stage's speed step
# ÷ the acceleration the step needs (≥ 1 is stall-safe; `inf`: no speed
# change). The fastest and slowest stages, and the tightest one:

# %%
margins = stall_margins(table, motor)
accel_m, decel_m = margins["accel"], margins["decel"]
rows = []
for i, rate in enumerate(table.rates):
    acc = table.accel_pulses[i] if i < len(table.accel_pulses) else None
    dec = table.decel[i] if i < len(table.decel) else None
    rows.append((i, rate, table.clock.hz / rate, acc, dec,
                 accel_m[i] if i < len(accel_m) else None,
                 decel_m[i] if i < len(decel_m) else None))


def fmt(x, spec):
    return "-" if x is None else format(x, spec)


print(f"{'stage':>5} {'rate':>6} {'speed pps':>10} {'accel n':>8} {'decel n':>8} "
      f"{'accel margin':>13} {'decel margin':>13}")
tightest = min(range(len(rows)),
               key=lambda k: min(x for x in (rows[k][5], rows[k][6], np.inf) if x is not None))
shown = sorted(set(range(6)) | set(range(len(rows) - 4, len(rows))) | {tightest})
last = -1
for k in shown:
    if k != last + 1:
        print(f"{'…':>5}")
    i, rate, speed, acc, dec, am, dm = rows[k]
    mark = "  ← tightest" if k == tightest else ""
    print(f"{i:5d} {rate:6d} {speed:10.1f} {fmt(acc, '8d')} {fmt(dec, '8d')} "
          f"{fmt(am, '13.4f')} {fmt(dm, '13.4f')}{mark}")
    last = k
print(f"\nsmallest margin {margins['min']:.4f}")
assert margins["min"] >= 1.0, "the planned table breaks the stall-safety criterion"


# %% [markdown]
# ## What the safety factor costs
#
# A smaller safety factor leaves more torque in reserve and gives a slower
# move. Each variant is a new `Motor` (`dataclasses.replace`); its table is
# checked against that motor, and compared with that motor's exact optimum.

# %%
def study(m, **kwargs):
    p = plan_free_curve(m, pulses=PULSES, **kwargs)
    optimum_s = float(exact_optimum(m, PULSES).duration_s)
    margin = stall_margins(p.table, m)["min"]
    assert margin >= 1.0, f"{kwargs}: stall margin {margin}"
    return p, optimum_s, margin


sf_rows = []
for sf in (0.4, 0.5, 0.6, 0.7):
    p, optimum_s, margin = study(dataclasses.replace(motor, safety_factor=sf))
    sf_rows.append((sf, len(p.table.rates), p.duration_s, optimum_s, margin))

print(f"{'safety':>6} {'stages':>6} {'table ms':>9} {'optimum ms':>11} {'ratio':>6} "
      f"{'margin':>7}")
for sf, n, t, opt, margin in sf_rows:
    print(f"{sf:6.2f} {n:6d} {t * 1e3:9.2f} {opt * 1e3:11.2f} {t / opt:6.3f} {margin:7.3f}")

# %% [markdown]
# ## What the stage budget costs
#
# Fewer stages force coarser speed steps; each step must still be stall-safe,
# so the ramp gets longer.

# %%
stage_rows = []
for budget in (8, 16, 32, 64, 127):
    p, optimum_s, margin = study(motor, max_stages=budget)
    assert len(p.table.rates) <= budget
    stage_rows.append((budget, len(p.table.rates), p.duration_s, optimum_s, margin))

print(f"{'budget':>6} {'used':>5} {'table ms':>9} {'ratio':>6} {'margin':>7}")
for budget, used, t, opt, margin in stage_rows:
    print(f"{budget:6d} {used:5d} {t * 1e3:9.2f} {t / opt:6.3f} {margin:7.3f}")

# %%
fig, (ax_sf, ax_n) = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
sfs = [r[0] for r in sf_rows]
ax_sf.plot(sfs, [r[2] * 1e3 for r in sf_rows], "o-", color="tab:red", label="table")
ax_sf.plot(sfs, [r[3] * 1e3 for r in sf_rows], "s--", color="0.4", label="exact optimum")
ax_sf.set(xlabel="safety factor", ylabel="move time [ms]",
          title=f"{PULSES} pulses, 127-stage budget")
budgets = [r[0] for r in stage_rows]
ax_n.plot(budgets, [r[2] * 1e3 for r in stage_rows], "o-", color="tab:red", label="table")
ax_n.axhline(stage_rows[0][3] * 1e3, ls="--", color="0.4", label="exact optimum")
ax_n.set_xscale("log", base=2)
ax_n.set_yscale("log")  # 8 stages cost several times the optimum; 64 vs 127 is close
plain = FuncFormatter(lambda y, _pos: f"{y:g}")
ax_n.yaxis.set_major_formatter(plain)
ax_n.yaxis.set_minor_formatter(plain)
ax_n.set_xticks(budgets, [str(b) for b in budgets])
ax_n.set(xlabel="stage budget (max_stages)", ylabel="move time [ms]",
         title=f"{PULSES} pulses, safety factor {motor.safety_factor:g}")
for ax in (ax_sf, ax_n):
    ax.grid(alpha=0.3)
    ax.legend()
plt.show()

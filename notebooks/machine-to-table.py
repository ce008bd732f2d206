# %% [markdown]
# # From a machine to a table
#
# A stepper motor known only from its datasheet, lifting a carriage on a
# vertical lead screw: the motor file (pull-out curve from the electrical model of
# `profiles/datasheet.py`, inertia and friction reflected from the screw, every
# number with its source, the carriage's weight as a load torque), the fastest
# stall-safe PPMC-312 free curve for a 100 mm move, and the upload file the chip
# takes.

# %%
import json
import math
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from profiles.motor.datasheet import Datasheet, Drive, motor_from_datasheet, pullout_torque_nm
from profiles.motor.loads import lead_screw
from profiles import Motor, decode_upload, load_motor, plan_free_curve, render
from profiles.ppmc312 import encode_free_curve, parse_upload
from profiles.motor.units import machine_to_pps, pps_to_machine

# The datasheet (SI units) and the drive's settings.
datasheet = Datasheet(step_angle_deg=1.8, holding_torque_nm=0.45, rated_current_a=1.5,
                      resistance_ohm=1.8, inductance_h=3.2e-3, rotor_inertia_kgm2=57e-7,
                      detent_torque_nm=0.02, name="NEMA17 0.45 N·m on an 8 mm lead screw")
drive = Drive(supply_v=24, current_a=1.5, microstep=8)
# The mechanism: a 2 kg carriage lifted by a vertical Ø8 × 300 mm steel screw, 8 mm lead
# (incline 90°: positive moves go up, the weight is a load torque).
LEAD_MM = 8.0
screw = lead_screw(LEAD_MM * 1e-3, 2.0, screw_diameter_m=0.008, screw_length_m=0.3,
                   efficiency=0.9, incline_deg=90)

obj = motor_from_datasheet(datasheet, drive, screw, safety_factor=0.6)
motor = Motor.from_json(obj)
print(json.dumps({k: v for k, v in obj.items() if k not in ("pullout_torque", "sources")},
                 ensure_ascii=False, indent=1))
for field, parts in obj["sources"].items():
    print(f"\n{field}:")
    for part in parts:
        print(f"  {part['value']:.4g}  {part['from']}")

# %% [markdown]
# ## The pull-out curve
#
# The model is a lower bound of the ideal circuit: torque is flat up to where the
# supply can no longer push the set current through the winding's impedance and
# against back-EMF, then falls to 0 where back-EMF reaches the supply. The file
# keeps a few points that never lie above the model. For scale, the bundled
# NEMA17 (a hand-typed curve for the same class of motor) is drawn too.

# %%
spr = motor.steps_per_rev
speeds = np.linspace(0, motor.top_curve_pps * 1.05, 600)
model = pullout_torque_nm(datasheet, drive, speeds * 2 * math.pi / spr)
bundled = load_motor("nema17-1600")

fig, ax = plt.subplots(figsize=(8, 4.2))
ax.plot(speeds, model, color="0.6", lw=3, label="model (profiles/datasheet.py)")
ax.plot(motor.curve_speed_pps, motor.curve_torque_nm, "o-", color="C0", ms=4,
        label="motor file curve")
ax.plot(bundled.curve_speed_pps, bundled.curve_torque_nm, "--", color="C1",
        label=f"bundled: {bundled.name}")
ax.set_xlabel("speed [pps, 1/8 step]")
ax.set_ylabel("pull-out torque [N·m]")
top = ax.secondary_xaxis("top", functions=(
    lambda v: pps_to_machine(v, "mm/s", steps_per_rev=spr, mm_per_rev=LEAD_MM),
    lambda v: machine_to_pps(v, "mm/s", steps_per_rev=spr, mm_per_rev=LEAD_MM)))
top.set_xlabel("carriage speed [mm/s]")
ax.set_ylim(bottom=0)
ax.grid(alpha=0.3)
ax.legend()
fig.tight_layout()
plt.show()

# %% [markdown]
# ## The table for a 100 mm move
#
# 100 mm on an 8 mm lead at 1600 pulses per revolution is 20 000 pulses. The
# planner finds the fastest stall-safe staircase the chip runs for that move; the
# chip runs one table both ways, so the weight counts against the motor in both
# (up it opposes the motor accelerating, down it opposes the motor braking).

# %%
MOVE_MM = 100.0
pulses = round(MOVE_MM / LEAD_MM * spr)
plan = plan_free_curve(motor, pulses=pulses)
table = plan.table
top_pps = float(table.speeds_pps()[0])   # stages are listed fastest first
print(plan.info)
print(f"{pulses} pulses = {MOVE_MM:g} mm in {plan.duration_s * 1e3:.1f} ms; top speed "
      f"{top_pps:.0f} pps = "
      f"{pps_to_machine(top_pps, 'mm/s', steps_per_rev=spr, mm_per_rev=LEAD_MM):.1f} mm/s")

# %%
# The acceleration side as the carriage sees it: each stage's speed over the travel it takes.
# Stages are listed fastest first; the carriage meets them slowest first.
stage_speeds = table.speeds_pps()[:len(table.accel_pulses)][::-1]
ends = np.cumsum(table.accel_pulses[::-1]) * LEAD_MM / spr
starts = np.concatenate([[0.0], ends[:-1]])
mm_s = [pps_to_machine(v, "mm/s", steps_per_rev=spr, mm_per_rev=LEAD_MM) for v in stage_speeds]

fig, ax = plt.subplots(figsize=(8, 4))
ax.hlines(mm_s, starts, ends, color="C0", lw=2, label="stage speed")
ax.set_xlabel("carriage travel while accelerating [mm]")
ax.set_ylabel("speed [mm/s]")
ax.set_title(f"{len(stage_speeds)} accel stages, {plan.duration_s * 1e3:.1f} ms "
             f"for {MOVE_MM:g} mm")
ax.grid(alpha=0.3)
fig.tight_layout()
plt.show()

# %% [markdown]
# ## The upload file
#
# The free-curve blocks as a hex file, read back and decoded to the same table.

# %%
workdir = tempfile.TemporaryDirectory(prefix="stepramp-machine-")
path = Path(workdir.name) / "axis.upload.hex"
blocks = encode_free_curve(table)
path.write_bytes(render(blocks, "hex"))
text = path.read_text().splitlines()
print(f"{path.name}: {len(blocks)} blocks, {path.stat().st_size} bytes")
print("\n".join(text[:4] + ["…"]))
assert decode_upload(parse_upload(path.read_bytes())) == table
print("decoded back: equal")
workdir.cleanup()

# %% [markdown]
# # Designing a free curve interactively
#
# One call, `designer(motor)`, gives sliders for the move and the load and
# redraws, at every change, the staircase the PPMC-312 runs against the exact
# continuous optimum, the stall margin of every stage and the rotor's load
# angle. The slow references (toppra, ruckig, casadi) are solved on a button;
# another button writes the table and its upload files into the working
# folder.
#
# - **move** — pulses of the accel/decel move the table is planned for;
# - **safety factor** — the share of the pull-out torque the plan may use;
# - **load inertia** — added to the motor's own (rotor + coupling) inertia;
# - **load torque** — a load that opposes the motor, counted with the friction;
# - **clock** — the chip's reference clock (`auto` picks the finest that
#   reaches the start speed);
# - **stage budget** — at most this many stages (the chip takes 127).

# %%
from profiles import load_motor
from verify.designer import designer

motor = load_motor("nema17-1600")
design = designer(motor, pulses=10_000)
design

# %% [markdown]
# ## The same controls from code
#
# Every control is in `design.controls`; setting one recomputes as dragging it
# does, and `design.result` holds the latest plan, execution, references,
# margins and load angle.

# %%
design.controls["safety_factor"].value = 0.5
design.controls["load_inertia_kgm2"].value = 4 * motor.inertia_kgm2
print(design.result.summary())

# %% [markdown]
# ## A static copy
#
# The widget needs a live kernel; this copy of the figure and the numbers stays
# readable in any notebook viewer.

# %%
design.snapshot()

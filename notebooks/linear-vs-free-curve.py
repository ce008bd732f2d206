# %% [markdown]
# # Init tables against the free curve
#
# The PPMC-312 builds its own linear or S-curve staircase from the init
# command's few parameters; the free-curve command takes every stage. For each
# bundled motor and move length: the best stall-safe linear and S-curve init
# tables (`plan_init`) against the optimal free curve (`plan_free_curve`).

# %%
import html
import math

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import HTML, display

from profiles import load_motor, plan_free_curve, plan_init
from profiles.motor import bundled_motor_paths
from profiles.ppmc312.planner.init_planner import init_candidates

LENGTHS = (300, 2_000, 10_000, 100_000)
SHAPES = ("linear", "s_curve")
motors = [load_motor(p) for p in bundled_motor_paths()]
for m in motors:
    print(m.name)

# %% [markdown]
# The smallest stall-safe pulse counts for each candidate high speed do not
# depend on the move, so `init_candidates` runs once per motor and shape and
# `plan_init` only simulates each move over them.

# %%
results = []  # (motor, pulses, free plan, {shape: init plan})
for m in motors:
    candidates = {shape: init_candidates(m, shape) for shape in SHAPES}
    for pulses in LENGTHS:
        free = plan_free_curve(m, pulses=pulses)
        inits = {shape: plan_init(m, shape, pulses, candidates=candidates[shape])
                 for shape in SHAPES}
        results.append((m, pulses, free, inits))
        for shape, ip in inits.items():
            # The free curve is optimal over every staircase, the init ones included.
            assert free.duration_s <= ip.duration_s * (1 + 1e-9), (m.name, pulses, shape)
print(f"{len(results)} cases planned")


# %%
def cell(value, bold=False):
    text = html.escape(str(value))
    return f"<td style='text-align:right'>{'<b>' + text + '</b>' if bold else text}</td>"


head = ("<tr><th>motor</th><th>pulses</th><th>free curve ms</th><th>linear ms</th>"
        "<th>S-curve ms</th><th>linear / free</th><th>S-curve / free</th>"
        "<th>best init table</th></tr>")
body = []
for m, pulses, free, inits in results:
    lin, s = inits["linear"], inits["s_curve"]
    best = min(inits.values(), key=lambda ip: ip.duration_s)
    body.append(
        f"<tr><td>{html.escape(m.name)}</td>{cell(f'{pulses:,}')}"
        + cell(f"{free.duration_s * 1e3:.2f}", bold=True)
        + cell(f"{lin.duration_s * 1e3:.2f}") + cell(f"{s.duration_s * 1e3:.2f}")
        + cell(f"{lin.duration_s / free.duration_s:.3f}")
        + cell(f"{s.duration_s / free.duration_s:.3f}")
        + f"<td style='font-size:85%'>{html.escape(best.info)}</td></tr>")
display(HTML("<table>" + head + "".join(body) + "</table>"))

# %% [markdown]
# Move time of the best init table ÷ the free curve's (1 = as fast as the free
# curve). Long moves are mostly cruise, so the ramps matter less.

# %%
fig, axes = plt.subplots(1, len(motors), figsize=(4.2 * len(motors), 3.8),
                         constrained_layout=True, sharey=True)
for ax, m in zip(np.atleast_1d(axes), motors, strict=True):
    rows = [r for r in results if r[0] is m]
    xs = [r[1] for r in rows]
    for shape, style, label in (("linear", "o-", "best linear init"),
                                ("s_curve", "s--", "best S-curve init")):
        ax.plot(xs, [r[3][shape].duration_s / r[2].duration_s for r in rows], style,
                label=label)
    ax.axhline(1.0, color="k", lw=1, label="free curve")
    ax.set_xscale("log")
    ax.set_xticks(xs, [f"{x:,}" for x in xs])
    ax.set(xlabel="move [pulses]", title=m.name.split(",")[0])
    ax.grid(alpha=0.3, which="both")
np.atleast_1d(axes)[0].set_ylabel("move time / free-curve time")
np.atleast_1d(axes)[0].legend()
plt.show()

# %%
for m in motors:
    ratios = [r[3][shape].duration_s / r[2].duration_s
              for r in results if r[0] is m for shape in SHAPES]
    gmean = math.exp(sum(math.log(x) for x in ratios) / len(ratios))
    print(f"{m.name}: init tables take {min(ratios):.2f}–{max(ratios):.2f}× the free curve "
          f"(geometric mean {gmean:.2f}×)")

"""How interactive the notebook designer is: milliseconds per slider change.

    python bench/bench_designer.py [--changes 12]

For each bundled motor, a run of slider changes (safety factor and move length
varied, so every change is a new plan) on settings that give 120–127-stage
tables. Per change: the recomputation (`verify.designer.design`: plan, chip
execution, exact optimum, stall margins, load angle) and the figure redraw
(`DesignFigure.update`, PNG). Printed against the goal (≤ 100 ms per
recomputation) and against a reference measured in the same run: the planner
alone (`plan_free_curve`) on the same settings, the least a change can cost.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from profiles.ppmc312.planner import plan_free_curve  # noqa: E402
from verify.designer import DesignFigure, Settings, bundled_motors, design, loaded_motor  # noqa: E402

GOAL_MS = 100.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--changes", type=int, default=12, help="slider changes per motor")
    args = parser.parse_args()
    print(f"{'motor':24s} {'stages':>7s} {'plan ms':>8s} {'recompute ms':>13s} "
          f"{'(load angle)':>13s} {'draw ms':>8s} {'recompute/goal':>15s} "
          f"{'recompute/plan':>15s}")
    worst = 0.0
    for name, motor in bundled_motors().items():
        figure = DesignFigure()
        plan_ms, total_ms, angle_ms, draw_ms, stages = [], [], [], [], []
        for k in range(args.changes):
            settings = Settings(pulses=10_000 + 1_000 * k,
                                safety_factor=round(motor.safety_factor * (1 - 0.02 * k), 3))
            t0 = time.perf_counter()
            plan_free_curve(loaded_motor(motor, settings), pulses=settings.pulses)
            plan_ms.append((time.perf_counter() - t0) * 1e3)
            t0 = time.perf_counter()
            result = design(motor, settings)
            total_ms.append((time.perf_counter() - t0) * 1e3)
            angle_ms.append(result.timings_ms["load_angle"])
            stages.append(len(result.plan.table.rates))
            t0 = time.perf_counter()
            figure.update(result)
            draw_ms.append((time.perf_counter() - t0) * 1e3)
        med = statistics.median
        worst = max(worst, med(total_ms) / GOAL_MS)
        print(f"{name:24s} {min(stages):3d}–{max(stages):3d} {med(plan_ms):8.1f} "
              f"{med(total_ms):13.1f} {med(angle_ms):13.1f} {med(draw_ms):8.1f} "
              f"{med(total_ms) / GOAL_MS:15.2f} {med(total_ms) / med(plan_ms):15.2f}")
    print(f"worst median recompute / {GOAL_MS:g} ms goal: {worst:.2f} "
          f"({'met' if worst <= 1 else 'NOT met'}); medians of {args.changes} changes")


if __name__ == "__main__":
    main()

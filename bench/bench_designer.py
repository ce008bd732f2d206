"""How interactive the notebook designer is: milliseconds per slider change.

    python bench/bench_designer.py [--changes 12]

For each bundled motor, a run of slider changes (safety factor and move length
varied, so every change is a new plan) on settings that give 100–127-stage
tables. Per change: the recomputation (`verify.designer.design`: plan, chip
execution, exact optimum, stall margins, load angle) and the figure redraw
(`DesignFigure.update`, PNG). Against the goal (≤ 50 ms per
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

from benchlib import Results, forget, verdict  # noqa: E402

from profiles.ppmc312.planner import plan_free_curve  # noqa: E402
from verify.designer import DesignFigure, Settings, bundled_motors, design, loaded_motor  # noqa: E402

GOAL_MS = 50.0  # issue #17: the designer recomputes in ≤ 50 ms


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--changes", type=int, default=12, help="slider changes per motor")
    args = parser.parse_args()
    res = Results("designer")
    rows, out = [], []
    med = statistics.median
    for name, motor in bundled_motors().items():
        figure = DesignFigure()
        design(motor, Settings(pulses=9_000))  # warm: the compiled kernels
        plan_ms, total_ms, angle_ms, draw_ms, stages, plans = [], [], [], [], [], []
        for k in range(args.changes):
            settings = Settings(pulses=10_000 + 1_000 * k,
                                safety_factor=round(motor.safety_factor * (1 - 0.02 * k), 3))
            t0 = time.perf_counter()
            plan_free_curve(loaded_motor(motor, settings), pulses=settings.pulses)
            plan_ms.append((time.perf_counter() - t0) * 1e3)
            forget()  # as if this table had not been judged before
            t0 = time.perf_counter()
            result = design(motor, settings)
            total_ms.append((time.perf_counter() - t0) * 1e3)
            angle_ms.append(result.timings_ms["load_angle"])
            stages.append(len(result.plan.table.rates))
            plans.append(int(result.plan.extras.get("plans", 1)))
            t0 = time.perf_counter()
            figure.update(result)
            draw_ms.append((time.perf_counter() - t0) * 1e3)
        one = [t for t, n in zip(total_ms, plans, strict=True) if n == 1]
        out.append({"motor": name, "stages": [min(stages), max(stages)],
                    "plan_ms": med(plan_ms), "recompute_ms": med(total_ms),
                    "plans_mean": statistics.mean(plans), "one_plan": len(one),
                    "one_plan_ms": med(one) if one else None,
                    "load_angle_ms": med(angle_ms), "draw_ms": med(draw_ms)})
        rows.append([name, f"{min(stages)}–{max(stages)}", f"{med(plan_ms):.0f} ms",
                     f"{med(total_ms):.0f} ms", f"{med(angle_ms):.0f} ms",
                     f"{statistics.mean(plans):.1f}",
                     f"{med(one):.0f} ms ({len(one)} of {len(plans)})" if one else
                     f"— (0 of {len(plans)})", f"{med(draw_ms):.0f} ms",
                     f"{med(total_ms) / med(plan_ms):.2f}",
                     f"≤ {GOAL_MS:g} ms: {verdict(med(total_ms) <= GOAL_MS)}"])
    res.values["motors"] = out
    res.values["changes"] = args.changes
    res.section("designer", ["motor", "stages", "planner alone", "recompute",
                             "(of which the final verdict and trace: tightening judged the "
                             "table already)",
                             "plans a change (tightening to the aim; mean)",
                             "recompute when the first plan was within the aim",
                             "figure redraw",
                             "recompute / planner", "goal"], rows,
                note=f"Medians of {args.changes} slider changes (move length and safety "
                     "factor varied, so each is a new plan), wall time, warm. A change whose "
                     "plain table is past the load-angle aim takes several plans, each judged "
                     "over every move (profiles.ppmc312.planner.tightening).")
    res.write()


if __name__ == "__main__":
    main()

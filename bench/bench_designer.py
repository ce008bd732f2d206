"""How interactive the designer is: milliseconds from a slider change to its tables.

    python bench/bench_designer.py [--changes 12]

For each bundled motor, a run of slider changes (safety factor and move length
varied, so every change is a new plan) on settings that give 100–127-stage
tables, each timed as a view shows it (`verify.designer.design_steps` and
`DesignFigure.update`, PNG included, on one figure kept across the changes):

- first table: the plain criterion's plan, its execution, exact optimum and stall
  margins, drawn over the kept frames (verify/designer/figure.py: the time axes' numbers
  change under fixed ticks; only a design outside the fixed scales redraws a panel) and
  marked as being tightened. Goal (issue #32 item 9): ≤ 50 ms.
- final table: then the table tightened to the load-angle aim, judged for the moves
  and decel stops it was planned for and drawn over the kept frames.
  Goal: ≤ 150 ms from the change.
- judged in full: then its verdict over every motion command (`judge_safety`, as
  `check --motor` gives it); the figure is unchanged. No goal of its own: shown.

Medians and the worst change, against the goals and against a reference
measured in the same run: the planner alone (`plan_free_curve`, plain criterion,
the same settings), the least a change can cost. What the library remembers is
forgotten before every change, as if that table had never been planned.
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

from profiles.motor import Motor  # noqa: E402
from profiles.motor.reserve import parse_cruise_reserve  # noqa: E402
from profiles.ppmc312.planner import plan_free_curve  # noqa: E402
from verify.designer import (  # noqa: E402
    DesignFigure,
    Settings,
    bundled_motors,
    design_steps,
    loaded_motor,
)

FIRST_GOAL_MS = 50.0    # issue #32 item 9: the first table within 50 ms, marked
FINAL_GOAL_MS = 150.0   # and the final one within 150 ms


def change(motor: Motor, settings: Settings, figure: DesignFigure) -> dict[str, float]:
    """One slider change as a view shows it: milliseconds to the first and final PNG."""
    out: dict[str, float] = {}
    t0 = time.perf_counter()
    for result in design_steps(motor, settings):
        figure.update(result)
        at = (time.perf_counter() - t0) * 1e3
        if result.complete:
            out.update(complete_ms=at, commands_ms=result.timings_ms["commands"])
        elif result.final:
            out.update(final_ms=at, tighten_ms=result.timings_ms["plan"],
                       judge_ms=result.timings_ms["load_angle"],
                       plans=float(result.plan.extras.get("plans", 1)),
                       stages=float(len(result.plan.table.rates)),
                       final_over=float(figure.last_drawing == "over"))
        else:
            out.update(first_ms=at, over=float(figure.last_drawing == "over"))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--changes", type=int, default=12, help="slider changes per motor")
    args = parser.parse_args()
    res = Results("designer")
    rows, out = [], []
    med = statistics.median
    for name, motor in bundled_motors().items():
        figure = DesignFigure()
        change(motor, Settings(pulses=9_000, safety_factor=motor.safety_factor),
               figure)  # warm: the compiled kernels, the figure's first full drawing
        runs, plan_ms = [], []
        for k in range(args.changes):
            settings = Settings(pulses=10_000 + 1_000 * k,
                                safety_factor=round(motor.safety_factor * (1 - 0.02 * k), 3))
            reserve = parse_cruise_reserve(settings.cruise_reserve)
            forget()
            t0 = time.perf_counter()
            plan_free_curve(reserve.applied(loaded_motor(motor, settings)),
                            pulses=settings.pulses)
            plan_ms.append((time.perf_counter() - t0) * 1e3)
            forget()  # as if this table had not been planned or judged before
            runs.append(change(motor, settings, figure))
        first = [r["first_ms"] for r in runs]
        final = [r["final_ms"] for r in runs]
        complete = [r["complete_ms"] for r in runs]
        stages = [int(r["stages"]) for r in runs]
        over = sum(int(r["over"]) for r in runs)
        final_over = sum(int(r["final_over"]) for r in runs)
        row = {"motor": name, "stages": [min(stages), max(stages)], "plan_ms": med(plan_ms),
               "first_ms": med(first), "first_worst_ms": max(first),
               "final_ms": med(final), "final_worst_ms": max(final),
               "complete_ms": med(complete), "complete_worst_ms": max(complete),
               "tighten_ms": med(r["tighten_ms"] for r in runs),
               "judge_ms": med(r["judge_ms"] for r in runs),
               "commands_ms": med(r["commands_ms"] for r in runs),
               "plans_mean": statistics.mean(r["plans"] for r in runs),
               "first_drawn_over": over, "final_drawn_over": final_over}
        out.append(row)
        ok_first, ok_final = max(first) <= FIRST_GOAL_MS, max(final) <= FINAL_GOAL_MS
        rows.append([
            name, f"{min(stages)}–{max(stages)}", f"{med(plan_ms):.0f} ms",
            f"{med(first):.0f} ms (worst {max(first):.0f})",
            f"{med(first) / med(plan_ms):.1f}",
            f"{med(final):.0f} ms (worst {max(final):.0f})",
            f"{med(final) / med(plan_ms):.1f}",
            f"{row['tighten_ms']:.0f} ms, {row['plans_mean']:.1f} plans",
            f"{over}, {final_over} of {len(runs)}",
            f"{med(complete):.0f} ms (worst {max(complete):.0f}; other commands "
            f"{row['commands_ms']:.0f} ms)",
            f"first ≤ {FIRST_GOAL_MS:g} ms: {verdict(ok_first)}; "
            f"final ≤ {FINAL_GOAL_MS:g} ms: {verdict(ok_final)}"])
    res.values["motors"] = out
    res.values["changes"] = args.changes
    res.values["goals_ms"] = {"first": FIRST_GOAL_MS, "final": FINAL_GOAL_MS}
    res.section("designer", [
        "motor", "stages", "planner alone (reference)", "first table shown (marked)",
        "first / planner", "final table shown", "final / planner",
        "of which: tightening (plans a change)", "first, final drawn over the kept frames",
        "judged over every command", "goal (every change)"], rows,
        note=f"Medians and the worst of {args.changes} slider changes (move length and "
             "safety factor varied, so each is a new plan), wall time from the change to the "
             "PNG, warm, nothing remembered between changes. The first table is the plain "
             "criterion's, shown marked as being tightened; the final one is tightened to the "
             "load-angle aim as `stepramp plan` plans it and shown judged for moves and decel "
             "stops, then judged over every command (`check --motor`'s verdict; downloads "
             "are offered from then). The figure keeps its frames and draws a change's data "
             "over them (the time axes' numbers change under fixed ticks); 'drawn over' "
             "counts the changes that redrew no panel.")
    res.write()


if __name__ == "__main__":
    main()

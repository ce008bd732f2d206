"""Planner quality and speed, printed as ratios measured in one run.

    python bench/bench_planner.py [--quick]

Quality, for the three bundled motors and moves of 300 … 100 000 pulses:
- table time / continuous optimum (exact jerk-free oracle, verify.references),
  with what binds the gap (the jump limit at the start, the 2-pulse minimum of
  a stage, rate quantisation, the stage budget);
- table time / baseline (shortest path over a 600-point geometric rate grid
  with minimal pulse counts): goal never > 1, geometric mean ≤ 0.99;
- the best stall-safe linear and S-curve init tables / the free curve: what
  the free curve buys.
Speed: plan time against toppra's solve time for the same motor and move
(goal ≤ 0.5×), and the 127-stage plan time (goal ≤ 50 ms).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from profiles.motor import Motor, bundled_motor_paths, load_motor  # noqa: E402
from profiles.ppmc312.execution import simulate_move  # noqa: E402
from profiles.ppmc312.init_planner import init_candidates, plan_init  # noqa: E402
from profiles.ppmc312.planner import plan_baseline, plan_free_curve  # noqa: E402
from profiles.ppmc312.table import FreeCurveTable  # noqa: E402
from verify.references import exact_optimum, toppra_reference  # noqa: E402

MOVES = (300, 2_000, 10_000, 100_000)


def what_binds(motor: Motor, table: FreeCurveTable, ratio: float) -> str:
    """Which limit shapes the staircase most, read off the table itself and weighted
    by the time spent in each stage: the stage budget (all 127 used), the jump limit
    (speed steps at max_jump_pps), the chip's minimum stage (counts at
    max(2, ceil(256/rate))), else the criterion itself: each stage holds its speed
    while the feasible ramp through the stage starts climbs on."""
    if ratio < 1.02:
        return "-"
    if len(table.rates) >= 127:
        return "stage budget"
    rates = np.asarray(table.rates, dtype=float)
    speeds = table.clock.hz / rates
    # Stages below the top (fastest first): the step to the next faster stage, the
    # count against the chip's minimum, and the time spent there, which weighs them.
    steps = speeds[:-1] - speeds[1:]
    counts = np.asarray(table.accel_pulses[1:], dtype=float)
    at_jump = steps >= 0.9 * motor.jump_pps
    at_min = counts <= np.maximum(2, np.ceil(256 / rates[1:]))
    time_s = counts / speeds[1:]
    share = {k: float(time_s[m].sum() / time_s.sum()) for k, m in
             (("both", at_jump & at_min), ("jump", at_jump), ("min", at_min))}
    if share["both"] > 0.5:
        return "jump limit at 2-pulse stages"
    if share["jump"] > 0.5:
        return "jump limit"
    if share["min"] > 0.5:
        return "2-pulse minimum"
    return "steps below the ramp (criterion)"


def best_of(n: int, fn: object) -> tuple[float, object]:
    assert callable(fn)
    best, out = math.inf, None
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def setup() -> tuple[int, tuple[int, ...], list[tuple[str, Motor]]]:
    """The command line every planner bench takes: (timing repeats, moves, motors)."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="one timing repeat, fewer moves")
    args = ap.parse_args()
    repeats = 1 if args.quick else 3
    moves = MOVES[1:3] if args.quick else MOVES
    motors = [(p.stem.removeprefix("motor-"), load_motor(p)) for p in bundled_motor_paths()]
    return repeats, moves, motors


def main() -> None:
    repeats, moves, motors = setup()

    print("quality: move time ratios (lower is better)")
    print(f"{'motor':22s} {'pulses':>7s} {'stages':>6s} {'table/opt':>9s} "
          f"{'tab/base':>8s} {'lin/free':>8s} {'S/free':>8s}  gap mostly from")
    base_ratios = []
    for name, motor in motors:
        cands = {s: init_candidates(motor, s) for s in ("linear", "s_curve")}
        for pulses in moves:
            plan = plan_free_curve(motor, pulses=pulses)
            table_s = simulate_move(plan.table, pulses).duration_s
            opt = exact_optimum(motor, pulses).duration_s
            base = plan_baseline(motor, pulses=pulses)
            base_s = simulate_move(base.table, pulses).duration_s
            lin = plan_init(motor, "linear", pulses, candidates=cands["linear"]).duration_s
            s = plan_init(motor, "s_curve", pulses, candidates=cands["s_curve"]).duration_s
            base_ratios.append(table_s / base_s)
            print(f"{name:22s} {pulses:7d} {len(plan.table.rates):6d} {table_s / opt:9.3f} "
                  f"{table_s / base_s:8.4f} {lin / table_s:8.3f} {s / table_s:8.3f}  "
                  f"{what_binds(motor, plan.table, table_s / opt)}")
    geo = math.exp(sum(map(math.log, base_ratios)) / len(base_ratios))
    worst = max(base_ratios)
    print(f"table/baseline: geometric mean {geo:.4f} (goal ≤ 0.99 "
          f"{'OK' if geo <= 0.99 else 'MISSED'}), worst {worst:.4f} (goal ≤ 1 "
          f"{'OK' if worst <= 1.0 + 1e-12 else 'MISSED'})")

    print("\nspeed: plan time against toppra's solve time, same motor and move (10 000 pulses)")
    for name, motor in motors:
        plan_s, plan = best_of(repeats, lambda m=motor: plan_free_curve(m, pulses=10_000))
        top_s, _ = best_of(repeats, lambda m=motor: toppra_reference(m, 10_000))
        stages = len(plan.table.rates)  # type: ignore[attr-defined]
        print(f"{name:22s} plan {plan_s * 1e3:7.1f} ms ({stages} stages)  toppra "
              f"{top_s * 1e3:7.1f} ms  ratio {plan_s / top_s:.3f} (goal ≤ 0.5 "
              f"{'OK' if plan_s / top_s <= 0.5 else 'MISSED'}; ≤ 50 ms "
              f"{'OK' if plan_s <= 0.05 else 'MISSED'})")


if __name__ == "__main__":
    main()

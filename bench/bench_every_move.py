"""One table, every move: what judging every execution costs and what safety costs.

    python bench/bench_every_move.py [--quick]

- judge time: the criterion over every move length of a 127-stage table (goal
  ≤ 50 ms) and the load angle over every execution (goal ≤ 2 s), each also as a
  ratio to one `simulate_move` of the same table measured in the same run;
- the price of all-length safety: the planned move's time with today's planner
  (every move length safe by the criterion, LE=1 only when its triangle switches
  are safe, load angle ≤ 75°) against last release's single-length LE=1 plan (the
  DP alone), per motor and move, with whether that old table was safe at all;
- the duty-cycle gain: the weighted time of one table for a mix of short and long
  moves against the plan for any single length of the mix;
- the worst load angle of every planned table.
"""

from __future__ import annotations

import random
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench_planner import best_of, setup  # noqa: E402

from profiles.ppmc312 import planner  # noqa: E402
from profiles.ppmc312.clock import Clock  # noqa: E402
from profiles.ppmc312.criterion import all_length_problems  # noqa: E402
from profiles.ppmc312.execution import move_families, simulate_move  # noqa: E402
from profiles.ppmc312.table import FreeCurveTable  # noqa: E402
from verify.load_angle import TARGET_DEG, judge_executions  # noqa: E402

MIX = [(200, 10.0), (1_000, 5.0), (5_000, 2.0), (50_000, 1.0)]


def random_le1(rng: random.Random, stages: int = 127) -> FreeCurveTable:
    """A 127-stage LE=1 table with uneven decel counts: every family must be judged."""
    clock = Clock.internal("8MHz")
    rates = sorted(rng.sample(range(40, 40_000), stages))
    acc = tuple(rng.randint(2, 400) for _ in rates)
    dec = tuple(rng.randint(2, 400) for _ in rates)
    return FreeCurveTable(clock, tuple(rates), acc, dec)


def old_plan_s(motor: object, pulses: int) -> tuple[float, FreeCurveTable]:
    """Last release's plan: the LE=1 DP for one move length, nothing else."""
    clock = planner.choose_clock(motor)  # type: ignore[arg-type]
    ev = planner.plan_staircase(motor, clock, 127, pulses, True)  # type: ignore[arg-type]
    return ev.time_s, planner.table_of(clock, ev, True)


def main() -> None:
    repeats, moves, motors = setup()

    print("judge time over every move length (127 stages)")
    rng = random.Random(7)
    for label, table, motor in (
            [("random LE=1, uneven", random_le1(rng), motors[0][1])]
            + [(f"planned {name}", planner.plan_free_curve(m, pulses=10_000).table, m)
               for name, m in motors]):
        fams = len(move_families(table))
        one_s, _ = best_of(repeats, lambda t=table: simulate_move(t, 10_000))
        crit_s, _ = best_of(repeats, lambda t=table, m=motor: all_length_problems(t, m))
        line = (f"{label:28s} {len(table.rates):3d} stages {fams:4d} families  criterion "
                f"{crit_s * 1e3:7.1f} ms ({crit_s / one_s:6.0f}× one simulate; goal ≤ 50 ms "
                f"{'OK' if crit_s <= 0.05 else 'MISSED'})")
        if label.startswith("planned"):
            phys_s, verdict = best_of(1, lambda t=table, m=motor: judge_executions(t, m))
            line += (f"  load angle {phys_s:5.2f} s over {verdict.executions} executions "  # type: ignore[attr-defined]
                     f"(goal ≤ 2 s {'OK' if phys_s <= 2 else 'MISSED'})")
        print(line)

    print("\nprice of all-length safety: planned move time, today / last release's "
          "single-length LE=1 plan")
    print(f"{'motor':22s} {'pulses':>7s} {'old ms':>9s} {'new ms':>9s} {'new/old':>8s} "
          f"{'LE':>3s}  old table safe for every length?  new worst angle")
    for name, motor in motors:
        for pulses in moves:
            old_s, old_table = old_plan_s(motor, pulses)
            new = planner.plan_free_curve(motor, pulses=pulses, load_angle_deg=TARGET_DEG)
            old_ok = not all_length_problems(old_table, motor)
            worst = judge_executions(new.table, motor).worst_angle_deg
            print(f"{name:22s} {pulses:7d} {old_s * 1e3:9.2f} {new.duration_s * 1e3:9.2f} "
                  f"{new.duration_s / old_s:8.4f} {int(new.table.separate):3d}  "
                  f"{'yes' if old_ok else 'NO':>33s}  {worst:6.1f}°")

    print(f"\nduty cycle: mix {MIX} (pulses, weight)")
    for name, motor in motors:
        plan, _ = planner.plan_duty_cycle(motor, MIX, load_angle_deg=TARGET_DEG)
        singles = {}
        for n, _ in MIX:
            table = planner.plan_free_curve(motor, pulses=n, load_angle_deg=TARGET_DEG).table
            singles[n] = sum(w * simulate_move(table, m).duration_s for m, w in MIX)
        best_single = min(singles.values())
        longest = singles[max(n for n, _ in MIX)]
        print(f"{name:22s} weighted {plan.duration_s * 1e3:9.2f} ms; / best single-length "
              f"plan {plan.duration_s / best_single:.4f}; / plan for the longest move "
              f"{plan.duration_s / longest:.4f} (goal ≤ 1)")


if __name__ == "__main__":
    main()

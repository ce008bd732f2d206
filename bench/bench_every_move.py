"""One table, every move: what all-length safety costs, and one table for a duty cycle.

    python bench/bench_every_move.py [--quick]

- the price of all-length safety: the planned move's time with today's planner (every
  move length safe by the criterion, LE=1 only when its triangle switches are safe,
  load angle ≤ 75° over every execution) against last release's single-length LE=1
  plan (the DP alone), per motor and move, with whether that old table was safe at all
  by the criterion over every move length, and the new table's worst load angle;
- the duty-cycle gain: the weighted time of one table for a mix of short and long
  moves against the plan for any single length of the mix.
(What judging every execution costs: bench_safety.py.)
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench_planner import setup  # noqa: E402
from benchlib import Results, verdict  # noqa: E402

from profiles.motor import Motor  # noqa: E402
from profiles.ppmc312 import planner  # noqa: E402
from profiles.ppmc312.criterion import all_length_problems  # noqa: E402
from profiles.ppmc312.execution import simulate_move  # noqa: E402
from profiles.ppmc312.load_angle import worst_load_angle  # noqa: E402
from profiles.ppmc312.table import FreeCurveTable  # noqa: E402

AIM_DEG = 75.0
MIX = [(200, 10.0), (1_000, 5.0), (5_000, 2.0), (50_000, 1.0)]


def old_plan_s(motor: object, pulses: int) -> tuple[float, FreeCurveTable]:
    """Last release's plan: the LE=1 DP for one move length, nothing else."""
    clock = planner.choose_clock(motor)  # type: ignore[arg-type]
    ev = planner.plan_staircase(motor, clock, 127, pulses, True)  # type: ignore[arg-type]
    table = planner.table_of(clock, ev, True)
    return simulate_move(table, pulses).duration_s, table


def price(res: Results, moves: tuple[int, ...], motors: list[tuple[str, Motor]]) -> None:
    rows, out = [], []
    for name, motor in motors:
        for pulses in moves:
            old_s, old_table = old_plan_s(motor, pulses)
            new = planner.plan_free_curve(motor, pulses=pulses, load_angle_deg=AIM_DEG)
            new_s = simulate_move(new.table, pulses).duration_s
            old_ok = not all_length_problems(old_table, motor)
            worst = worst_load_angle(new.table, motor).worst_angle_deg
            out.append({"motor": name, "pulses": pulses, "old_s": old_s, "new_s": new_s,
                        "ratio": new_s / old_s, "LE": int(new.table.separate),
                        "old_safe_every_length": old_ok, "new_worst_deg": worst})
            rows.append([name, f"{pulses}", f"{old_s * 1e3:.2f}", f"{new_s * 1e3:.2f}",
                         f"{new_s / old_s:.3f}", f"{int(new.table.separate)}",
                         "yes" if old_ok else "no", f"{worst:.1f}°"])
    res.values["price_of_all_length_safety"] = out
    ratios = [r["ratio"] for r in out]
    angles = [r["new_worst_deg"] for r in out]
    unsafe = sum(not r["old_safe_every_length"] for r in out)
    res.values["price_range"] = [min(ratios), max(ratios)]
    res.section("price", ["motor", "pulses", "last release ms", "today ms", "today / then",
                          "LE", "old table safe for every length (criterion)",
                          "today's worst load angle"], rows,
                note=f"Today / last release's single-length LE=1 plan: {min(ratios):.3f}–"
                     f"{max(ratios):.3f}; the old tables were unsafe for some move length in "
                     f"{unsafe} of {len(out)} cases; today's worst load angles "
                     f"{min(angles):.1f}–{max(angles):.1f}°.")


def duty_cycle(res: Results, motors: list[tuple[str, Motor]]) -> None:
    rows, out = [], []
    for name, motor in motors:
        plan, _ = planner.plan_duty_cycle(motor, MIX, load_angle_deg=AIM_DEG)
        singles = {}
        for n, _ in MIX:
            table = planner.plan_free_curve(motor, pulses=n, load_angle_deg=AIM_DEG).table
            singles[n] = sum(w * simulate_move(table, m).duration_s for m, w in MIX)
        best = min(singles.values())
        longest = singles[max(n for n, _ in MIX)]
        out.append({"motor": name, "weighted_s": plan.duration_s, "best_single_s": best,
                    "longest_s": longest, "ratio": plan.duration_s / best})
        rows.append([name, f"{plan.duration_s * 1e3:.2f} ms", f"{plan.duration_s / best:.4f}",
                     f"{plan.duration_s / longest:.4f}",
                     f"≤ 1: {verdict(plan.duration_s <= best * (1 + 1e-12))}"])
    res.values["duty_cycle"] = {"mix": MIX, "motors": out}
    mix = ", ".join(f"{n} × {w:g}" for n, w in MIX)
    res.section("duty_cycle", ["motor", "weighted time, one table", "/ best single-length "
                               "plan", "/ plan for the longest move", "goal"], rows,
                note=f"Mix (pulses × weight): {mix}; load angle ≤ 75° for every table.")


def summary(res: Results) -> None:
    price = res.values["price_of_all_length_safety"]
    ratios = [r["ratio"] for r in price]
    angles = [r["new_worst_deg"] for r in price]
    unsafe = sum(not r["old_safe_every_length"] for r in price)
    duty = [r["ratio"] for r in res.values["duty_cycle"]["motors"]]
    res.section("summary", ["what", "measured", "goal"], [
        [f"price of all-length safety: planned move / last release's single-length LE=1 plan "
         f"({len(price)} moves of the 3 bundled motors)",
         f"{min(ratios):.3f}–{max(ratios):.3f} (the old tables were unsafe for some move "
         f"length in {unsafe} of {len(price)} cases); today's worst load angles "
         f"{min(angles):.1f}–{max(angles):.1f}°", "—"],
        ["duty cycle (" + ", ".join(f"{n}" for n, _ in MIX) + " pulses): one table / the "
         "best single-length plan", f"{min(duty):.4f}–{max(duty):.4f} (3 motors)",
         f"≤ 1: {verdict(max(duty) <= 1 + 1e-12)}"]])


def main() -> None:
    _, moves, motors = setup()
    res = Results("every_move")
    price(res, moves, motors)
    duty_cycle(res, motors)
    summary(res)
    res.write()


if __name__ == "__main__":
    main()

"""Planner quality and speed, as ratios measured in one run.

    python bench/bench_planner.py [--quick]

Quality, for the three bundled motors and moves of 300 … 100 000 pulses:
- the table `stepramp plan` writes (load angle ≤ 75° over every move length) / the
  continuous optimum (exact jerk-free oracle, verify.references), with what binds the
  gap (the jump limit at the start, the 2-pulse minimum of a stage, rate quantisation,
  the stage budget); and the criterion-only plan / the optimum;
- the criterion-only plan / the baseline (shortest path over a 600-point geometric rate
  grid with minimal pulse counts, criterion only as well): goal never > 1, geometric
  mean ≤ 0.99;
- the best stall-safe linear and S-curve init tables / the free curve: what the free
  curve buys.
Speed: the criterion-only planner's time (the DP and the refinement, no load angle)
against toppra's solve of the same move in the same run (`bench_plantime.py` times
the whole `stepramp plan` with the load angle).
The figure docs/img/compare-nema17.png (`python bench/readme.py` draws it) is the NEMA17
table for 10 000 pulses as `stepramp plan` writes it against its references, as
`stepramp compare --plot` draws it; its data are in the results.
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
from benchfigures import comparison_data  # noqa: E402
from benchlib import Results, forget, gmean, verdict  # noqa: E402

from profiles.motor import Motor, bundled_motor_paths, load_motor  # noqa: E402
from profiles.ppmc312.execution import simulate_move  # noqa: E402
from profiles.ppmc312.planner import plan_baseline, plan_free_curve  # noqa: E402
from profiles.ppmc312.planner.init_planner import init_candidates, plan_init  # noqa: E402
from profiles.ppmc312.table import FreeCurveTable  # noqa: E402
from verify.compare import compare_table  # noqa: E402
from verify.references import exact_optimum, toppra_reference  # noqa: E402

MOVES = (300, 2_000, 10_000, 100_000)
AIM_DEG = 75.0


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
        forget()
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


def quality_row(name: str, motor: Motor, pulses: int, cands: dict[str, object]
                ) -> dict[str, object]:
    safe = plan_free_curve(motor, pulses=pulses, load_angle_deg=AIM_DEG)
    plain = plan_free_curve(motor, pulses=pulses)
    table_s = simulate_move(safe.table, pulses).duration_s
    plain_s = simulate_move(plain.table, pulses).duration_s
    opt = exact_optimum(motor, pulses).duration_s
    base = plan_baseline(motor, pulses=pulses)
    base_s = simulate_move(base.table, pulses).duration_s
    lin = plan_init(motor, "linear", pulses, candidates=cands["linear"]).duration_s
    s = plan_init(motor, "s_curve", pulses, candidates=cands["s_curve"]).duration_s
    assert lin is not None and s is not None
    return {"motor": name, "pulses": pulses, "stages": len(safe.table.rates),
            "planned_over_optimum": table_s / opt, "criterion_only_over_optimum": plain_s / opt,
            "criterion_only_over_baseline": plain_s / base_s, "linear_over_free": lin / table_s,
            "s_curve_over_free": s / table_s,
            "binds": what_binds(motor, safe.table, table_s / opt)}


def span(xs: list[float]) -> str:
    return f"{min(xs):.3f}–{max(xs):.3f}"


def quality(res: Results, moves: tuple[int, ...], motors: list[tuple[str, Motor]]) -> None:
    rows = []
    for name, motor in motors:
        cands = {s: init_candidates(motor, s) for s in ("linear", "s_curve")}
        rows += [quality_row(name, motor, pulses, cands) for pulses in moves]
    res.values["quality"] = rows
    res.section("quality", ["motor", "pulses", "stages", "planned / optimum",
                            "criterion-only / optimum", "criterion-only / baseline",
                            "linear / free", "S-curve / free", "gap mostly from"],
                [[r["motor"], f"{r['pulses']}", f"{r['stages']}",
                  *(f"{r[k]:.3f}" for k in ("planned_over_optimum",
                                            "criterion_only_over_optimum",
                                            "criterion_only_over_baseline", "linear_over_free",
                                            "s_curve_over_free")), str(r["binds"])]
                 for r in rows])
    base = [float(r["criterion_only_over_baseline"]) for r in rows]  # type: ignore[arg-type]
    geo, worst = gmean(base), max(base)

    def at(key: str, pulses: int) -> list[float]:
        return [float(r[key]) for r in rows if r["pulses"] == pulses]  # type: ignore[arg-type]

    summary = [["table as `stepramp plan` writes it (load angle ≤ 75°) / continuous optimum, "
                f"{len(motors)} motors", "; ".join(
                    f"{p:,} pulses: {span(at('planned_over_optimum', p))}".replace(",", " ")
                    for p in moves), "≥ 1 by construction (tested)"],
               ["criterion-only plan / continuous optimum", "; ".join(
                   f"{p:,} pulses: {span(at('criterion_only_over_optimum', p))}"
                   .replace(",", " ") for p in moves), "≥ 1"],
               [f"criterion-only plan / 600-point geometric-grid baseline, geometric mean of "
                f"{len(base)} moves", f"{geo:.4f} (worst {worst:.4f})",
                f"≤ 0.99: {verdict(geo <= 0.99)}; never > 1: {verdict(worst <= 1 + 1e-12)}"]]
    if 10_000 in moves:
        summary.append(["best linear / S-curve init table / free curve (10 000 pulses)",
                        f"{span(at('linear_over_free', 10_000))} / "
                        f"{span(at('s_curve_over_free', 10_000))}", "—"])
    res.values["baseline_gmean"], res.values["baseline_worst"] = geo, worst
    res.section("summary", ["what", "measured", "goal"], summary)


def speed(res: Results, repeats: int, motors: list[tuple[str, Motor]]) -> None:
    rows, out = [], []
    for name, motor in motors:
        plan_free_curve(motor, pulses=10_000)  # warm: the DP's compiled layers, toppra
        toppra_reference(motor, 10_000)
        plan_s, plan = best_of(repeats, lambda m=motor: plan_free_curve(m, pulses=10_000))
        top_s, _ = best_of(repeats, lambda m=motor: toppra_reference(m, 10_000))
        stages = len(plan.table.rates)  # type: ignore[attr-defined]
        out.append({"motor": name, "plan_s": plan_s, "toppra_s": top_s, "stages": stages})
        rows.append([name, f"{stages}", f"{plan_s * 1e3:.1f} ms", f"{top_s * 1e3:.0f} ms",
                     f"{plan_s / top_s:.3f}"])
    res.values["speed"] = out
    res.section("speed", ["motor (10 000 pulses)", "stages", "criterion-only plan",
                          "toppra (1 000 gridpoints)", "plan / toppra"], rows,
                note=f"Best of {repeats} runs each, warm, in one process.")


def figure(res: Results) -> None:
    """The README's figure: the NEMA17 table for 10 000 pulses as `stepramp plan` writes
    it against its references (drawn by bench/readme.py from these data)."""
    motor = load_motor(bundled_motor_paths()[0])
    plan = plan_free_curve(motor, pulses=10_000, load_angle_deg=AIM_DEG)
    cmp = compare_table(plan.table, motor, 10_000)
    res.values["figures"] = {"compare-nema17": comparison_data(cmp)}


def main() -> None:
    repeats, moves, motors = setup()
    res = Results("planner")
    quality(res, moves, motors)
    speed(res, repeats, motors)
    figure(res)
    res.write()


if __name__ == "__main__":
    main()

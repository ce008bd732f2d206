"""Issue 31 items 3–5: what judging and planning for decel stops from any pulse of the ramp
costs, each against a reference measured in the same run.

    python bench/bench_stops.py [--quick]

- the price of decel-stop safety: per bundled motor and move of 300 / 2 000 / 10 000 /
  100 000 pulses, the move time of the table `stepramp plan` writes now (every move and a
  decel stop (81) at every pulse of the ramp under every reading within the 75° aim) /
  that of the plan tightened for the moves alone (`plan_free_curve(decel_stops=False)`,
  the plans before issue 31); goal: geometric mean ≤ 1.03. Beside it, each table's worst
  stop (compiled model) and which reading drove it, and the worst stop of the moves-only
  plan (what the stops found there);
- the judge time: `stepramp check TABLE --motor M` in-process, warm (kernels compiled,
  every remembered verdict, plan and move model forgotten before each call), with the
  stops judged (the default) against `--commands 82` (moves only), on the bundled motors'
  10 000-pulse plans and the NEMA17 with its tolerance box (corners and 1 000 Monte Carlo
  samples); goal ≤ 2×.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from benchlib import Results, count, gmean, timed, verdict  # noqa: E402

from profiles.motor import Motor, bundled_motor_paths, load_motor  # noqa: E402
from profiles.ppmc312.execution import simulate_move  # noqa: E402
from profiles.ppmc312.planner import plan_free_curve  # noqa: E402
from profiles.ppmc312.stops import dwell_ranges, stop_angles  # noqa: E402
from profiles.ppmc312.table import FreeCurveTable, dump_table  # noqa: E402
from verify import cli  # noqa: E402

AIM_DEG = 75.0
MOVES = (300, 2_000, 10_000, 100_000)
PRICE_GOAL = 1.03
JUDGE_GOAL = 2.0
TOLERANCED = ROOT / "examples" / "motor-nema17-tolerances.json"


def bundled() -> dict[str, Motor]:
    return {p.stem.removeprefix("motor-"): load_motor(p) for p in bundled_motor_paths()}


def worst_stop(table: FreeCurveTable, motor: Motor) -> dict[str, Any]:
    """The worst decel stop (sampled and refined), and every dwell of every stage judged:
    what the sampling is checked against."""
    w = stop_angles(table, [motor]).worst(0)
    assert w is not None
    r = dwell_ranges(table)
    every = [(s, d) for s, lo, hi in zip(r.stage.tolist(), r.lo.tolist(), r.hi.tolist(),
                                         strict=True) for d in range(lo, hi + 1)]
    return {"deg": w.worst_angle_deg, "stage": w.stage, "dwell": w.dwell,
            "readings": [r for r, _ in w.readings], "stops_judged": w.executions,
            "every_dwell": len(every),
            "every_dwell_deg": stop_angles(table, [motor], stops=every).worst_deg()}


def price_case(name: str, motor: Motor, pulses: int) -> dict[str, Any]:
    both = plan_free_curve(motor, pulses=pulses, load_angle_deg=AIM_DEG)
    moves = plan_free_curve(motor, pulses=pulses, load_angle_deg=AIM_DEG, decel_stops=False)
    t_both = simulate_move(both.table, pulses).duration_s
    t_moves = simulate_move(moves.table, pulses).duration_s
    return {"motor": name, "pulses": pulses, "move_s": t_both, "moves_only_move_s": t_moves,
            "price": t_both / t_moves, "worst_deg": both.extras["worst_load_angle_deg"],
            "stop": worst_stop(both.table, motor),
            "moves_only_stop": worst_stop(moves.table, motor)}


def price(res: Results, quick: bool) -> None:
    moves = MOVES[1:3] if quick else MOVES
    rows = []
    for name, motor in bundled().items():
        for pulses in moves:
            rows.append(price_case(name, motor, pulses))
            r = rows[-1]
            print(f"{name:20s} {pulses:7d} price {r['price']:.4f} stop {r['stop']['deg']:.1f}° "
                  f"(moves-only plan's stop {r['moves_only_stop']['deg']:.1f}°)", flush=True)
    res.values["price"] = rows
    geo = gmean([r["price"] for r in rows])
    res.values["price_gmean"] = geo
    stops = [s for r in rows for s in (r["stop"], r["moves_only_stop"])]
    agree = max(abs(s["every_dwell_deg"] - s["deg"]) for s in stops)
    res.values["sampled_vs_every_dwell_deg"] = agree
    names = list(dict.fromkeys(r["motor"] for r in rows))

    def cell(n: str, p: int) -> str:
        r = next(r for r in rows if r["motor"] == n and r["pulses"] == p)
        s, o = r["stop"], r["moves_only_stop"]
        return (f"{r['price']:.4f} (stop {s['deg']:.1f}° ({'/'.join(s['readings'])}); "
                f"was {o['deg']:.1f}° ({'/'.join(o['readings'])}))")

    head = ["motor", *(f"{p:,} pulses".replace(",", " ") for p in moves)]
    res.section("price", head, [[n, *(cell(n, p) for p in moves)] for n in names],
                note="Move time of the table `stepramp plan` writes (every move and every "
                     "decel stop within 75°) / the plan tightened for the moves alone; in "
                     "brackets the worst decel stop of each (its reading), by the compiled "
                     f"model. Geometric mean {geo:.4f} (goal ≤ {PRICE_GOAL}: "
                     f"{verdict(geo <= PRICE_GOAL)}). The sampled stops "
                     f"({count(sum(s['stops_judged'] for s in stops))} judged) against every "
                     f"dwell of every stage ({count(sum(s['every_dwell'] for s in stops))}): "
                     f"the same worst within {agree:.3f}°.")


def check_in_process(table: Path, motor: str, *extra: str) -> int:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        return cli.main(["check", str(table), "--motor", motor, "--format", "json", *extra])


def judge_case(label: str, table: FreeCurveTable, motor: str, folder: Path,
               repeats: int) -> dict[str, Any]:
    path = folder / f"{label.split(',')[0].replace(' ', '-')}.table.json"
    path.write_text(dump_table(table))
    check_in_process(path, motor)  # warm: compiled kernels, imports
    with_stops, cpu_with, _ = timed(lambda: check_in_process(path, motor), repeats)
    without, cpu_without, _ = timed(lambda: check_in_process(path, motor, "--commands", "82"),
                                    repeats)
    return {"label": label, "with_stops_s": with_stops, "moves_only_s": without,
            "with_stops_cpu_s": cpu_with, "moves_only_cpu_s": cpu_without,
            "ratio": with_stops / without}


def judge_time(res: Results, quick: bool) -> None:
    repeats = 3 if quick else 7
    cases = [(f"{name}, planned for 10 000 pulses",
              plan_free_curve(m, pulses=10_000, load_angle_deg=AIM_DEG).table,
              str(bundled_motor_paths()[i]))
             for i, (name, m) in enumerate(bundled().items())]
    tol = load_motor(TOLERANCED)
    cases.append(("NEMA17 with its tolerance box (4 corners, 1 000 samples), planned for "
                  "3 200 pulses", plan_free_curve(tol, pulses=3200, load_angle_deg=AIM_DEG)
                  .table, str(TOLERANCED)))
    with tempfile.TemporaryDirectory() as tmp:
        rows = [judge_case(label, table, motor, Path(tmp), repeats)
                for label, table, motor in cases]
    res.values["judge"] = rows
    worst = max(r["ratio"] for r in rows)
    res.values["judge_worst_ratio"] = worst
    res.section("judge", ["table", "`check --motor`, warm (stops judged)",
                          "`--commands 82` (moves only)", "ratio", "goal"],
                [[r["label"], f"{r['with_stops_s'] * 1e3:.0f} ms (CPU "
                  f"{r['with_stops_cpu_s'] * 1e3:.0f})", f"{r['moves_only_s'] * 1e3:.0f} ms "
                  f"(CPU {r['moves_only_cpu_s'] * 1e3:.0f})", f"{r['ratio']:.2f}×",
                  f"≤ {JUDGE_GOAL:g}×: {verdict(r['ratio'] <= JUDGE_GOAL)}"] for r in rows],
                note="`stepramp check TABLE --motor M --format json` in-process, median of "
                     f"{repeats} calls, each with every remembered verdict, plan and move "
                     "model forgotten (kernels compiled).")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="moves of 2 000 and 10 000 only, fewer repeats")
    quick = ap.parse_args().quick
    res = Results("stops")
    judge_time(res, quick)
    price(res, quick)
    res.write()


if __name__ == "__main__":
    main()

"""Synchronised axes (issue 11): durations and line deviation, as ratios.

    python bench/bench_sync.py [--quick]

For pairs of bundled motors and pulse ratios, one line each:
- time mode: synchronised duration / the unsynchronised slowest axis (its fastest
  table alone, the least any synchronised move can take) and / ruckig's
  time-synchronised duration for the same per-axis limits (constant limits: the
  feasible bound, verify.sync.ruckig_sync); the finish spread;
- line mode: the same duration ratios against ruckig's phase-synchronised duration, the
  line deviation achieved [pulses] and that of naive rate rounding measured in the same
  run (the leader's fastest table for the axes' envelope motor, the follower's rates =
  the leader's divided by the pulse ratio and rounded, counts scaled and rounded), and
  their ratio.

    python bench/bench_sync.py --long

The line deviation of long moves (issue #20 item 13): two planned tables run for up to
0xFFFFFFFF pulses, the time `line_deviation` takes and the trace it keeps (before pulse
trains, more than 10 M pulses an axis were refused).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchlib import Results, forget, gmean  # noqa: E402

from profiles.motor import bundled_motor_paths, load_motor  # noqa: E402
from profiles.ppmc312.clock import INTERNAL_HZ, Clock  # noqa: E402
from profiles.ppmc312.execution import simulate_move  # noqa: E402
from profiles.ppmc312.limits import RATE_MAX  # noqa: E402
from profiles.ppmc312.planner import plan_free_curve  # noqa: E402
from profiles.ppmc312.sync import (  # noqa: E402
    envelope_motor,
    line_deviation,
    plan_line_sync,
    plan_time_sync,
)
from profiles.ppmc312.table import FreeCurveTable  # noqa: E402
from verify.sync import ruckig_sync  # noqa: E402

CASES = ((0, 0, 12_000, 7_001), (0, 2, 12_000, 5_000), (2, 2, 20_000, 19_003),
         (1, 0, 3_000, 1_234), (0, 1, 40_000, 3_001), (2, 0, 6_000, 611))


def clock_for(slowest_pps: float) -> Clock:
    """The fastest internal clock whose rate for `slowest_pps` fits the rate field."""
    return next(Clock.internal(name) for name, hz in INTERNAL_HZ.items()
                if math.ceil(hz / slowest_pps) <= RATE_MAX)


def naive_follower(lead: FreeCurveTable, scale: float) -> FreeCurveTable:
    """The plain way: the leader's rates divided by the pulse ratio and rounded, counts
    multiplied by it and rounded (≥ 2); stages whose rounded rates collide are merged."""
    clock = clock_for(lead.clock.hz / lead.rates[-1] * scale)
    rates: list[int] = []
    acc: list[int] = []
    dec: list[int] = []
    for r, a, d in zip(lead.rates, lead.accel_pulses, lead.decel, strict=True):
        rr = max(2, round(r * clock.hz / (lead.clock.hz * scale)))
        na, nd = max(2, round(a * scale)), max(2, round(d * scale))
        if rates and rr <= rates[-1]:
            acc[-1] += na
            dec[-1] += nd
            continue
        rates.append(rr)
        acc.append(na)
        dec.append(nd)
    return FreeCurveTable(clock, tuple(rates), tuple(acc), tuple(dec))


def long_moves(res: Results) -> None:
    nema17, _, pk566 = (load_motor(p) for p in bundled_motor_paths())
    lead = plan_free_curve(nema17, pulses=10**6).table
    follow = plan_free_curve(pk566, pulses=10**6).table
    rows, out = [], []
    for nx in (10**6, 10**7, 10**8, 10**9, 0xFFFFFFFF):
        ny = int(nx * 0.37)
        runs = [simulate_move(lead, nx), simulate_move(follow, ny)]
        t0 = time.perf_counter()
        dev, t, _ = line_deviation(runs)
        took = time.perf_counter() - t0
        out.append({"x": nx, "y": ny, "deviation_pulses": dev, "s": took, "trace": len(t)})
        rows.append([f"{nx}", f"{ny}", f"{dev:.6g}", f"{took:.2f} s", f"{len(t)}"])
    res.values["long"] = out
    res.section("long", ["x pulses", "y pulses", "line deviation [pulses]", "time",
                         "trace points"], rows,
                note="Two planned tables (NEMA17 and 5-phase, each for 10⁶ pulses) run for up "
                     "to 0xFFFFFFFF pulses: `line_deviation`'s time and the trace it keeps.")


def case(motors: list, i: int, j: int, nx: int, ny: int) -> dict[str, float]:
    axes = [("x", motors[i], nx), ("y", motors[j], -ny)]
    forget()  # each solve plans from scratch, as `stepramp sync` does
    t0 = time.perf_counter()
    tp = plan_time_sync(axes)
    t1 = time.perf_counter()
    forget()
    t2 = time.perf_counter()
    lp = plan_line_sync(axes)
    solve = (t1 - t0) + (time.perf_counter() - t2)
    rk = ruckig_sync([motors[i], motors[j]], [nx, ny])
    # naive: the leader's fastest table for both motors' envelope, the follower rounded
    lead = plan_free_curve(envelope_motor([motors[i], motors[j]], [1.0, ny / nx]),
                           pulses=nx).table
    naive = naive_follower(lead, ny / nx)
    ours = line_deviation([a.execution for a in lp.axes])[0]
    plain = line_deviation([simulate_move(lead, nx), simulate_move(naive, ny)])[0]
    return {"t_alone": tp.duration_s / tp.unsynchronised_s,
            "t_ruckig": tp.duration_s / rk.time_feasible_s, "spread_us": tp.spread_s * 1e6,
            "l_alone": lp.duration_s / lp.unsynchronised_s,
            "l_ruckig": lp.duration_s / rk.phase_feasible_s, "dev": ours, "naive_dev": plain,
            "naive_over_ours": plain / max(ours, 1e-9), "solve_s": solve}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="the first two cases only")
    ap.add_argument("--long", action="store_true",
                    help="only the line deviation of long moves (up to 0xFFFFFFFF pulses)")
    args = ap.parse_args()
    if args.long:
        res = Results("sync_long")
        long_moves(res)
        res.write()
        return
    res = Results("sync")
    motors = [load_motor(p) for p in bundled_motor_paths()]
    rows, out = [], []
    for i, j, nx, ny in CASES[:2] if args.quick else CASES:
        r = case(motors, i, j, nx, ny)
        out.append({"x": motors[i].name, "y": motors[j].name, "nx": nx, "ny": ny, **r})
        rows.append([f"{motors[i].name[:6]}/{motors[j].name[:6]}", f"{nx}:{ny}",
                     f"{r['t_alone']:.3f}", f"{r['t_ruckig']:.3f}", f"{r['spread_us']:.2f}",
                     f"{r['l_alone']:.3f}", f"{r['l_ruckig']:.3f}", f"{r['dev']:.2f}",
                     f"{r['naive_dev']:.1f}", f"{r['naive_over_ours']:.1f}",
                     f"{r['solve_s']:.1f} s"])
    res.values["cases"] = out
    g = {k: gmean([r[k] for r in out]) for k in ("t_alone", "t_ruckig", "l_alone", "l_ruckig",
                                                 "naive_over_ours")}
    res.values["geometric_means"] = g
    res.section("sync", ["motors", "pulses", "time: T / alone", "T / ruckig", "spread µs",
                         "line: T / alone", "T / ruckig phase", "deviation [pulses]",
                         "naive [pulses]", "naive / ours", "plan"], rows,
                note=f"Geometric means: time mode T / alone {g['t_alone']:.3f}, T / ruckig "
                     f"(time-synchronised) {g['t_ruckig']:.3f}; line mode T / alone "
                     f"{g['l_alone']:.3f}, T / ruckig (phase-synchronised) "
                     f"{g['l_ruckig']:.3f}; naive rate rounding's line deviation / ours "
                     f"{g['naive_over_ours']:.1f}.")
    res.section("summary", ["what (geometric mean of the cases)", "measured"], [
        ["time mode: synchronised duration / the slowest axis alone", f"{g['t_alone']:.3f}"],
        ["time mode: / ruckig's time-synchronised duration (same per-axis limits)",
         f"{g['t_ruckig']:.3f}"],
        ["line mode: synchronised duration / the slowest axis alone", f"{g['l_alone']:.3f}"],
        ["line mode: / ruckig's phase-synchronised duration", f"{g['l_ruckig']:.3f}"],
        ["line deviation of naive rate rounding / ours", f"{g['naive_over_ours']:.1f}×"]])
    res.write()


if __name__ == "__main__":
    main()

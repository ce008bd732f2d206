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

from profiles.motor import bundled_motor_paths, load_motor  # noqa: E402
from profiles.ppmc312.execution import simulate_move  # noqa: E402
from profiles.ppmc312.planner import plan_free_curve  # noqa: E402
from profiles.ppmc312.sync import (  # noqa: E402
    _clock_for,
    envelope_motor,
    line_deviation,
    plan_line_sync,
    plan_time_sync,
)
from profiles.ppmc312.table import FreeCurveTable  # noqa: E402
from verify.sync import ruckig_sync  # noqa: E402

CASES = ((0, 0, 12_000, 7_001), (0, 2, 12_000, 5_000), (2, 2, 20_000, 19_003),
         (1, 0, 3_000, 1_234), (0, 1, 40_000, 3_001), (2, 0, 6_000, 611))


def naive_follower(lead: FreeCurveTable, scale: float) -> FreeCurveTable:
    """The plain way: the leader's rates divided by the pulse ratio and rounded, counts
    multiplied by it and rounded (≥ 2); stages whose rounded rates collide are merged."""
    clock = _clock_for(lead.clock.hz / lead.rates[-1] * scale)
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


def long_moves() -> None:
    nema17, _, pk566 = (load_motor(p) for p in bundled_motor_paths())
    lead = plan_free_curve(nema17, pulses=10**6).table
    follow = plan_free_curve(pk566, pulses=10**6).table
    print("pulses (x, y)             | line deviation [pulses] | s     | trace points")
    for nx in (10**6, 10**7, 10**8, 10**9, 0xFFFFFFFF):
        ny = int(nx * 0.37)
        runs = [simulate_move(lead, nx), simulate_move(follow, ny)]
        t0 = time.perf_counter()
        dev, t, _ = line_deviation(runs)
        took = time.perf_counter() - t0
        print(f"{nx:>12d} {ny:>12d} | {dev:23.6g} | {took:5.2f} | {len(t)}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="the first two cases only")
    ap.add_argument("--long", action="store_true",
                    help="only the line deviation of long moves (up to 0xFFFFFFFF pulses)")
    args = ap.parse_args()
    if args.long:
        long_moves()
        return
    motors = [load_motor(p) for p in bundled_motor_paths()]
    cases = CASES[:2] if args.quick else CASES
    print("motors          pulses         | time: T/alone T/ruckig spread[µs] | line: T/alone "
          "T/ruckig-phase dev[p] naive[p] naive/ours | plan s")
    ratios: dict[str, list[float]] = {"t_alone": [], "t_ruckig": [], "l_alone": [],
                                      "l_ruckig": [], "dev": []}
    for i, j, nx, ny in cases:
        axes = [("x", motors[i], nx), ("y", motors[j], -ny)]
        t0 = time.perf_counter()
        tp = plan_time_sync(axes)
        lp = plan_line_sync(axes)
        solve = time.perf_counter() - t0
        rk = ruckig_sync([motors[i], motors[j]], [nx, ny])
        # naive: the leader's fastest table for both motors' envelope, the follower rounded
        lead = plan_free_curve(envelope_motor([motors[i], motors[j]], [1.0, ny / nx]),
                               pulses=nx).table
        naive = naive_follower(lead, ny / nx)
        ours = line_deviation([a.execution for a in lp.axes])[0]
        plain = line_deviation([simulate_move(lead, nx), simulate_move(naive, ny)])[0]
        row = {"t_alone": tp.duration_s / tp.unsynchronised_s,
               "t_ruckig": tp.duration_s / rk.time_feasible_s,
               "l_alone": lp.duration_s / lp.unsynchronised_s,
               "l_ruckig": lp.duration_s / rk.phase_feasible_s,
               "dev": plain / max(ours, 1e-9)}
        for k, v in row.items():
            ratios[k].append(v)
        names = f"{motors[i].name[:6]}/{motors[j].name[:6]}"
        print(f"{names:15s} {nx:6d}:{ny:<6d}  | {row['t_alone']:6.3f} {row['t_ruckig']:8.3f} "
              f"{tp.spread_s * 1e6:9.2f}  | {row['l_alone']:6.3f} {row['l_ruckig']:8.3f}       "
              f"{ours:6.2f} {plain:8.1f} {row['dev']:10.1f} | {solve:5.1f}")

    def gmean(xs: list[float]) -> float:
        return math.exp(sum(math.log(x) for x in xs) / len(xs))

    print(f"geometric means: time T/alone {gmean(ratios['t_alone']):.3f}, T/ruckig-time "
          f"{gmean(ratios['t_ruckig']):.3f}; line T/alone {gmean(ratios['l_alone']):.3f}, "
          f"T/ruckig-phase {gmean(ratios['l_ruckig']):.3f}; naive deviation / ours "
          f"{gmean(ratios['dev']):.1f}")


if __name__ == "__main__":
    main()

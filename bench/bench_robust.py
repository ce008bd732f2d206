"""Robust tables: what a tolerance box costs, how fast the load angle is judged, sweeps.

    python bench/bench_robust.py [--quick]

- price of robustness: on each bundled motor with a box of ±30 % inertia and
  −20 % torque (torque_scale 0.8..1), the robust table's move time over the
  nominal table's (both planned with the load angle ≤ 75°, both for the same
  move), and whether the nominal table survives the box;
- load-angle simulations per second: the scalar model (profiles.motor.rotor, one
  motor at a time) against the batched one (profiles.motor.rotor_batch, 1000 samples
  in one numpy RK4) on the same execution, measured in the same run;
- sweep throughput: jobs per second in-process and on 2 local worker processes
  (per worker), on the same catalogue.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from profiles.errors import PlanError  # noqa: E402
from profiles.motor import Motor, bundled_motor_paths  # noqa: E402
from profiles.motor.tolerance import corners, samples  # noqa: E402
from profiles.ppmc312.criterion import all_length_problems  # noqa: E402
from profiles.ppmc312.execution import simulate_move  # noqa: E402
from profiles.ppmc312.load_angle import worst_load_angle  # noqa: E402
from profiles.ppmc312.planner import plan_free_curve  # noqa: E402
from verify.sweep import jobs_of, run_sweep  # noqa: E402
from verify.tolerance_box import sample_peaks  # noqa: E402


def boxed(path: Path) -> tuple[Motor, Motor]:
    obj = json.loads(path.read_text())
    nominal = Motor.from_json(obj)
    j = obj["inertia_kgm2"]
    obj["tolerances"] = {"inertia_kgm2": [0.7 * j, 1.3 * j], "torque_scale": [0.8, 1.0]}
    return nominal, Motor.from_json(obj)


def price(pulses: int) -> None:
    print(f"\nprice of robustness (±30 % inertia, −20 % torque; {pulses}-pulse move, "
          "load angle ≤ 75° at every corner)")
    print(f"{'motor':<28} {'nominal s':>10} {'robust s':>10} {'ratio':>7} "
          f"{'nominal safe over box':>22} {'robust solve s':>15}")
    for path in bundled_motor_paths():
        nominal, robust = boxed(path)
        try:
            p_nom = plan_free_curve(nominal, pulses=pulses, load_angle_deg=75)
            p_rob = plan_free_curve(robust, pulses=pulses, load_angle_deg=75)
        except PlanError as e:
            print(f"{path.stem:<28} refused: {e}")
            continue
        t_nom = simulate_move(p_nom.table, pulses).duration_s
        t_rob = simulate_move(p_rob.table, pulses).duration_s
        survives = all(not all_length_problems(p_nom.table, c.motor)
                       and worst_load_angle(p_nom.table, c.motor).worst_angle_deg < 90
                       for c in corners(robust))
        print(f"{path.stem:<28} {t_nom:>10.4f} {t_rob:>10.4f} {t_rob / t_nom:>7.3f} "
              f"{'yes' if survives else 'no':>22} {p_rob.solve_s:>15.1f}")


def simulations(n_samples: int) -> None:
    path = bundled_motor_paths()[0]
    _, robust = boxed(path)
    table = plan_free_curve(robust, pulses=5000).table
    n = 300
    scalar_motors = samples(robust, 50, seed=1)
    t0 = time.perf_counter()
    for s in scalar_motors:
        worst_load_angle(table, s.motor, pulses=[n])
    scalar = len(scalar_motors) / (time.perf_counter() - t0)
    t0 = time.perf_counter()
    sample_peaks(table, robust, [n], n_samples, seed=1)
    batched = n_samples / (time.perf_counter() - t0)
    print(f"\nload-angle simulations per second ({path.stem}, the {n}-pulse move)")
    print(f"scalar model  {scalar:10.0f} /s   (50 samples)")
    print(f"batched model {batched:10.0f} /s   ({n_samples} samples)   ratio "
          f"{batched / scalar:.2f}× the scalar model")


def throughput(lengths: list[int]) -> None:
    motors = [(p.stem, json.loads(p.read_text())) for p in bundled_motor_paths()]
    jobs = jobs_of(motors, lengths, samples=0, load_angle_deg=None)
    rates = {}
    for workers in (1, 2):
        t0 = time.perf_counter()
        run_sweep(jobs, workers=workers)
        rates[workers] = len(jobs) / (time.perf_counter() - t0)
    print(f"\nsweep throughput ({len(jobs)} jobs: {len(motors)} motors × {len(lengths)} lengths, "
          "no load-angle tightening)")
    print(f"in-process       {rates[1]:6.2f} jobs/s")
    print(f"2 local workers  {rates[2]:6.2f} jobs/s = {rates[2] / 2:.2f} per worker, "
          f"speed-up {rates[2] / rates[1]:.2f}× (2 cores shared with other work)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one move, fewer samples")
    quick = ap.parse_args().quick
    price(2000 if quick else 20000)
    simulations(200 if quick else 1000)
    throughput([2000, 20000] if quick else [1000, 3000, 10000, 30000])


if __name__ == "__main__":
    main()

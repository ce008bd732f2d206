"""Robust tables: what a tolerance box costs, how fast the load angle is judged, sweeps.

    python bench/bench_robust.py [--quick]

- price of robustness: on each bundled motor with a box of ±30 % inertia and
  −20 % torque (torque_scale 0.8..1), the robust table's move time over the
  nominal table's (both planned with the load angle ≤ 75°, both for the same
  move), and whether the nominal table survives the box (`judge_safety`);
- load-angle simulations per second (CPU time): one motor per call of the compiled
  model against 1 000 samples as rows of one call (`sample_peaks`), on the same
  execution, measured in the same run;
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

from benchlib import Results, count, forget  # noqa: E402

from profiles.errors import PlanError  # noqa: E402
from profiles.motor import Motor, bundled_motor_paths  # noqa: E402
from profiles.motor.tolerance import samples  # noqa: E402
from profiles.ppmc312.execution import simulate_move  # noqa: E402
from profiles.ppmc312.load_angle import worst_load_angle  # noqa: E402
from profiles.ppmc312.planner import plan_free_curve  # noqa: E402
from profiles.ppmc312.tolerance_box import sample_peaks  # noqa: E402
from verify.safety import judge_safety  # noqa: E402
from verify.sweep import jobs_of, run_sweep  # noqa: E402


def boxed(path: Path) -> tuple[Motor, Motor]:
    obj = json.loads(path.read_text())
    nominal = Motor.from_json(obj)
    j = obj["inertia_kgm2"]
    obj["tolerances"] = {"inertia_kgm2": [0.7 * j, 1.3 * j], "torque_scale": [0.8, 1.0]}
    return nominal, Motor.from_json(obj)


def price(res: Results, pulses: int) -> None:
    rows, out = [], []
    for path in bundled_motor_paths():
        name = path.stem.removeprefix("motor-")
        nominal, robust = boxed(path)
        try:
            p_nom = plan_free_curve(nominal, pulses=pulses, load_angle_deg=75)
            p_rob = plan_free_curve(robust, pulses=pulses, load_angle_deg=75)
        except PlanError as e:
            out.append({"motor": name, "refused": str(e)})
            rows.append([name, "refused", "", "", "", ""])
            continue
        t_nom = simulate_move(p_nom.table, pulses).duration_s
        t_rob = simulate_move(p_rob.table, pulses).duration_s
        over_box = judge_safety(p_nom.table, robust)  # the one verdict, over the box
        out.append({"motor": name, "nominal_s": t_nom, "robust_s": t_rob,
                    "ratio": t_rob / t_nom, "nominal_safe_over_box": over_box.safe,
                    "robust_solve_s": p_rob.solve_s})
        rows.append([name, f"{t_nom:.4f}", f"{t_rob:.4f}", f"{t_rob / t_nom:.3f}",
                     "yes" if over_box.safe else "no", f"{p_rob.solve_s:.1f}"])
    res.values["price_of_robustness"] = {"pulses": pulses, "motors": out}
    ratios = [r["ratio"] for r in out if "ratio" in r]
    unsafe = sum(not r.get("nominal_safe_over_box", True) for r in out)
    res.section("price", ["motor", "nominal table s", "robust table s", "robust / nominal",
                          "nominal table safe over the box", "robust plan s"], rows,
                note=f"{pulses}-pulse move, box of ±30 % inertia and −20 % torque, load angle "
                     f"≤ 75° at every corner: robust / nominal {min(ratios):.3f}–"
                     f"{max(ratios):.3f}; {unsafe} of {len(out)} nominal tables unsafe "
                     "somewhere in the box (judge_safety: corners and 1 000 samples).")


def simulations(res: Results, n_samples: int) -> None:
    path = bundled_motor_paths()[0]
    _, robust = boxed(path)
    table = plan_free_curve(robust, pulses=5000).table
    n = 300
    scalar_motors = samples(robust, 50, seed=1)
    worst_load_angle(table, scalar_motors[0].motor, pulses=[n])  # warm
    t0 = time.process_time()
    for s in scalar_motors:
        worst_load_angle(table, s.motor, pulses=[n])
    scalar = len(scalar_motors) / (time.process_time() - t0)
    sample_peaks(table, robust, [n], 10, seed=1)
    t0 = time.process_time()
    sample_peaks(table, robust, [n], n_samples, seed=1)
    batched = n_samples / (time.process_time() - t0)
    res.values["simulations_per_s"] = {"one_call_per_motor": scalar, "rows_of_one_call": batched,
                                       "samples": n_samples, "pulses": n}
    res.section("simulations", ["load-angle simulations of one move (CPU time)", "per second",
                                "ratio"], [
        ["one motor per call (`worst_load_angle`, 50 samples)", count(scalar), "1"],
        [f"{n_samples} samples as rows of one kernel call (`sample_peaks`)", count(batched),
         f"{batched / scalar:.1f}×"]],
        note=f"{path.stem}, the {n}-pulse move of its robust 5 000-pulse table.")


def throughput(res: Results, lengths: list[int]) -> None:
    motors = [(p.stem, json.loads(p.read_text())) for p in bundled_motor_paths()]
    jobs = jobs_of(motors, lengths, samples=0, load_angle_deg=None)
    run_sweep(jobs[:1])  # warm
    rates = {}
    for workers in (1, 2):
        forget()  # no plan of the warm-up or the run before is reused
        t0 = time.perf_counter()
        run_sweep(jobs, workers=workers)
        rates[workers] = len(jobs) / (time.perf_counter() - t0)
    res.values["sweep_jobs_per_s"] = {"in_process": rates[1], "two_workers": rates[2],
                                      "jobs": len(jobs)}
    res.section("sweep", ["sweep, criterion-only plans (wall time)", "jobs per second",
                          "speed-up"], [
        ["in-process", f"{rates[1]:.2f}", "1"],
        ["2 local workers", f"{rates[2]:.2f}", f"{rates[2] / rates[1]:.2f}×"]],
        note=f"{len(jobs)} jobs: {len(motors)} motors × {len(lengths)} lengths "
             f"({', '.join(map(str, lengths))}), no load-angle tightening, each judged; "
             "2 cores shared with other work.")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one move, fewer samples")
    quick = ap.parse_args().quick
    res = Results("robust")
    price(res, 2000 if quick else 20000)
    simulations(res, 200 if quick else 1000)
    throughput(res, [2000, 20000] if quick else [1000, 3000, 10000, 30000])
    summary(res)
    res.write()


def summary(res: Results) -> None:
    price = res.values["price_of_robustness"]
    ratios = [r["ratio"] for r in price["motors"] if "ratio" in r]
    unsafe = sum(not r.get("nominal_safe_over_box", True) for r in price["motors"])
    sims = res.values["simulations_per_s"]
    sweep = res.values["sweep_jobs_per_s"]
    res.section("summary", ["what", "measured"], [
        [f"price of robustness: robust / nominal table's move time ({len(ratios)} motors, "
         f"{count(price['pulses'])} pulses, ±30 % inertia and −20 % torque box, load angle "
         "≤ 75° at every corner)", f"{min(ratios):.3f}–{max(ratios):.3f} ({unsafe} of "
         f"{len(price['motors'])} nominal tables unsafe somewhere in the box)"],
        [f"load-angle simulations per second (CPU time): {sims['samples']} samples as rows of "
         "one kernel call / one motor per call",
         f"{count(sims['rows_of_one_call'])}/s vs {count(sims['one_call_per_motor'])}/s: "
         f"{sims['rows_of_one_call'] / sims['one_call_per_motor']:.1f}×"],
        [f"sweep throughput ({sweep['jobs']} jobs, criterion-only plans): 2 local workers / "
         "in-process", f"{sweep['two_workers'] / sweep['in_process']:.2f}× "
         f"({sweep['two_workers']:.2f} vs {sweep['in_process']:.2f} jobs/s)"]])


if __name__ == "__main__":
    main()

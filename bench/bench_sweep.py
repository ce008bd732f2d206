"""Bounded duty cycles and the sweep's local workers.

    python bench/bench_sweep.py [--quick]

- plan --moves at scale: `plan_duty_cycle` on a mix of 1 000 distinct lengths, on
  100 000 rows of those lengths, and on 100 000 distinct lengths (each bundled motor,
  load angle ≤ 75°): wall time, candidate tables planned; goal: seconds, not minutes
  (planning one table per length took more than 300 s for 1 000 lengths);
- what bounding costs: on a mix of 30 lengths, the weighted time of the bounded plan
  (≤ 16 candidates, the default) against a plan for every length (and 32 geometric
  ones: `candidates=64`, a superset of the old method's), and the time each took;
- local workers: 2 workers on 4 jobs from a forkserver (the first sweep in a process
  starts and warms it, later ones fork from it) against plain fork (unsafe once the
  parent runs threads, measured for its cost only).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from profiles.motor import bundled_motor_paths, load_motor  # noqa: E402
from profiles.ppmc312.planner import plan_duty_cycle  # noqa: E402
from verify.sweep import jobs_of, run_job, run_sweep  # noqa: E402

TARGET_DEG = 75.0


def mixes(rng: np.random.Generator, quick: bool) -> dict[str, list[tuple[int, float]]]:
    lengths = np.unique(np.round(np.exp(rng.uniform(np.log(20), np.log(200_000), 1400))))
    lengths = rng.choice(lengths, 1000, replace=False).astype(int)
    out = {"1 000 lengths": [(int(n), float(rng.uniform(0.1, 5))) for n in lengths],
           "100 000 rows, 1 000 lengths": [(int(n), 1.0) for n in rng.choice(lengths, 100_000)]}
    if not quick:
        wide = rng.integers(8, 10**6, 100_000)
        out["100 000 distinct lengths"] = [(int(n), 1.0) for n in np.unique(wide)]
    return out


def at_scale(quick: bool) -> None:
    rng = np.random.default_rng(0)
    print("plan --moves at scale (load angle ≤ 75°; goal: seconds, not minutes)")
    for label, mix in mixes(rng, quick).items():
        for path in bundled_motor_paths():
            motor = load_motor(path)
            t0 = time.perf_counter()
            plan, times = plan_duty_cycle(motor, mix, load_angle_deg=TARGET_DEG)
            took = time.perf_counter() - t0
            print(f"{label:28s} {path.stem:26s} {len(times):6d} lengths "
                  f"{len(plan.extras['candidates']):2d} candidates {took:6.1f} s")


def price_of_bounding() -> None:
    rng = np.random.default_rng(1)
    mix = [(int(n), float(rng.uniform(0.1, 5)))
           for n in np.round(np.exp(rng.uniform(np.log(50), np.log(50_000), 30)))]
    print("\nwhat bounding costs (30 lengths): bounded plan / a plan for every length")
    for path in bundled_motor_paths():
        motor = load_motor(path)
        t0 = time.perf_counter()
        bounded, _ = plan_duty_cycle(motor, mix, load_angle_deg=TARGET_DEG)
        t1 = time.perf_counter()
        every, _ = plan_duty_cycle(motor, mix, load_angle_deg=TARGET_DEG, candidates=64)
        t2 = time.perf_counter()
        print(f"{path.stem:26s} weighted time {bounded.duration_s / every.duration_s:.4f}× "
              f"({len(bounded.extras['candidates'])} vs {len(every.extras['candidates'])} "
              f"tables, {t1 - t0:.1f} s vs {t2 - t1:.1f} s)")


def workers() -> None:
    path = next(p for p in bundled_motor_paths() if "nema17" in p.name)
    jobs = jobs_of([("m", json.loads(path.read_text()))], [1000, 2000, 3000, 5000],
                   samples=0, load_angle_deg=None)
    print("\nlocal workers: 2 workers, 4 jobs (wall time of a sweep)")
    for label in ("forkserver, first sweep", "forkserver, again"):
        t0 = time.perf_counter()
        run_sweep(jobs, workers=2)
        print(f"{label:28s} {time.perf_counter() - t0:5.2f} s")
    run_job(jobs[0])  # fork copies a warm parent: the cheapest it can be
    t0 = time.perf_counter()
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork")) as pool:
        list(pool.map(run_job, jobs))
    print(f"{'fork (not used: unsafe)':28s} {time.perf_counter() - t0:5.2f} s")
    t0 = time.perf_counter()
    run_sweep(jobs)
    print(f"{'in-process':28s} {time.perf_counter() - t0:5.2f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="skip the 100 000-length mix")
    quick = ap.parse_args().quick
    workers()
    at_scale(quick)
    price_of_bounding()


if __name__ == "__main__":
    main()

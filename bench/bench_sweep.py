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

from benchlib import Results, forget  # noqa: E402

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


def at_scale(res: Results, quick: bool) -> None:
    rng = np.random.default_rng(0)
    rows, out = [], []
    for label, mix in mixes(rng, quick).items():
        for path in bundled_motor_paths():
            motor = load_motor(path)
            forget()  # each mix planned as a run of its own
            t0 = time.perf_counter()
            plan, times = plan_duty_cycle(motor, mix, load_angle_deg=TARGET_DEG)
            took = time.perf_counter() - t0
            name = path.stem.removeprefix("motor-")
            cands = len(plan.extras["candidates"])
            out.append({"mix": label, "motor": name, "lengths": len(times),
                        "candidates": cands, "s": took})
            rows.append([label, name, f"{len(times)}", f"{cands}", f"{took:.1f} s"])
            print(f"{label}: {name} {took:.1f} s", flush=True)
    res.values["at_scale"] = out
    res.section("at_scale", ["mix", "motor", "distinct lengths", "candidate tables",
                             "time"], rows,
                note="`plan_duty_cycle` (what `plan --moves` runs), load angle ≤ 75°; goal: "
                     "seconds, not minutes (one table per length took more than 300 s for "
                     "1 000 lengths).")


def price_of_bounding(res: Results) -> None:
    rng = np.random.default_rng(1)
    mix = [(int(n), float(rng.uniform(0.1, 5)))
           for n in np.round(np.exp(rng.uniform(np.log(50), np.log(50_000), 30)))]
    rows, out = [], []
    for path in bundled_motor_paths():
        motor = load_motor(path)
        forget()
        t0 = time.perf_counter()
        bounded, _ = plan_duty_cycle(motor, mix, load_angle_deg=TARGET_DEG)
        t1 = time.perf_counter()
        forget()  # no verdict of the bounded run reused
        every, _ = plan_duty_cycle(motor, mix, load_angle_deg=TARGET_DEG, candidates=64)
        t2 = time.perf_counter()
        name = path.stem.removeprefix("motor-")
        ratio = bounded.duration_s / every.duration_s
        out.append({"motor": name, "ratio": ratio, "bounded_s": t1 - t0, "every_s": t2 - t1,
                    "bounded_tables": len(bounded.extras["candidates"]),
                    "every_tables": len(every.extras["candidates"])})
        rows.append([name, f"{ratio:.4f}", f"{len(bounded.extras['candidates'])} in "
                     f"{t1 - t0:.1f} s", f"{len(every.extras['candidates'])} in {t2 - t1:.1f} s"])
    res.values["bounding"] = out
    res.section("bounding", ["motor", "weighted time, bounded / every length",
                             "bounded: tables, time", "every length: tables, time"], rows,
                note="A mix of 30 lengths: the bounded plan (≤ 16 candidates, the default) "
                     "against a plan for every length and 32 geometric ones (`candidates=64`).")


def workers(res: Results) -> None:
    path = next(p for p in bundled_motor_paths() if "nema17" in p.name)
    jobs = jobs_of([("m", json.loads(path.read_text()))], [1000, 2000, 3000, 5000],
                   samples=0, load_angle_deg=None)
    took = {}
    for label in ("forkserver, first sweep", "forkserver, again"):
        t0 = time.perf_counter()
        run_sweep(jobs, workers=2)
        took[label] = time.perf_counter() - t0
    run_job(jobs[0])  # fork copies a warm parent: the cheapest it can be
    t0 = time.perf_counter()
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork")) as pool:
        list(pool.map(run_job, jobs))
    took["fork (not used: unsafe once the parent runs threads)"] = time.perf_counter() - t0
    forget()
    t0 = time.perf_counter()
    run_sweep(jobs)
    took["in-process"] = time.perf_counter() - t0
    res.values["workers"] = took
    res.section("workers", ["2 local workers, 4 jobs", "wall time of the sweep"],
                [[k, f"{v:.2f} s"] for k, v in took.items()])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="skip the 100 000-length mix")
    quick = ap.parse_args().quick
    res = Results("sweep")
    workers(res)
    at_scale(res, quick)
    price_of_bounding(res)
    summary(res)
    res.write()


def summary(res: Results) -> None:
    rows = []
    for mix in dict.fromkeys(r["mix"] for r in res.values["at_scale"]):
        runs = [r for r in res.values["at_scale"] if r["mix"] == mix]
        rows.append([f"`plan --moves` on {mix} (3 motors, load angle ≤ 75°)",
                     f"{min(r['s'] for r in runs):.1f}–{max(r['s'] for r in runs):.1f} s "
                     f"({max(r['candidates'] for r in runs)} candidate tables at most)",
                     "seconds, not minutes"])
    bound = res.values["bounding"]
    rows.append(["what bounding costs (30 lengths): weighted time, bounded plan / a plan for "
                 "every length", f"{min(r['ratio'] for r in bound):.4f}–"
                 f"{max(r['ratio'] for r in bound):.4f}, in "
                 f"{min(r['bounded_s'] / r['every_s'] for r in bound):.2f}–"
                 f"{max(r['bounded_s'] / r['every_s'] for r in bound):.2f} of the time", "—"])
    took = res.values["workers"]
    rows.append(["2 local workers, 4 jobs: first sweep (starts the forkserver) / later ones",
                 f"{took['forkserver, first sweep']:.2f} s / {took['forkserver, again']:.2f} s "
                 f"(in-process {took['in-process']:.2f} s)", "—"])
    res.section("summary", ["what", "measured", "goal"], rows)


if __name__ == "__main__":
    main()

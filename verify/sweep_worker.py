"""Imported by the forkserver of `verify.sweep`'s local worker processes before any
worker is forked from it (multiprocessing's preload): it imports the planner and the
judges and runs one small job, so the compiled load-angle kernels are loaded once, in
the forkserver, instead of once in every worker (about 1.5 s each when cold). Nothing
else imports it.
"""

from __future__ import annotations

from profiles.motor.model import bundled_motor_paths
from profiles.reading import read_json
from verify.sweep import jobs_of, run_job


def _warm() -> None:
    paths = [p for p in bundled_motor_paths() if "nema17" in p.name]
    if not paths:
        return
    # a tolerance box and samples: the same kernels a sweep's jobs call
    motor = dict(read_json(paths[0]), tolerances={"torque_scale": [0.9, 1.0]})
    run_job(jobs_of([("warm", motor)], [200], samples=2, load_angle_deg=None)[0])


try:
    _warm()
except Exception:  # a warm-up only saves time: its failure must not stop the pool
    pass

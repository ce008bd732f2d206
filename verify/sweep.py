"""Sweeps: plan and verify a catalogue of motors × move lengths (× tolerance samples).

One job per (motor, move length): plan the robust table (profiles.ppmc312.planner:
over the motor's tolerance box when it has one, tightened to the load-angle
target), then judge it as `stepramp check --motor` does (the criterion at the
box's worst case, the load angle at every corner and over `samples` seeded Monte
Carlo samples; a motor without tolerances: on every execution). Jobs are
independent and take their motor as JSON, so they run in-process, on local
processes (concurrent.futures) or on a Dask cluster (distributed's executor),
with the same rows in the same order.
"""

from __future__ import annotations

import csv
import io
import time
from collections.abc import Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from typing import Any

from profiles.errors import FormatError, StepRampError
from profiles.progress import Progress, report

COLUMNS = ("motor", "pulses", "move_time_s", "worst_load_angle_deg", "safe", "failed",
           "margin_deg", "worst_pulses", "stages", "LE", "clock", "top_pps", "binds",
           "solve_s", "judge_s", "corners", "samples", "sample_failures",
           "stall_probability_upper", "error", "safety")


@dataclass(frozen=True)
class Job:
    motor: str                  # the name in the results (the file's name or stem)
    motor_json: dict[str, Any]
    pulses: int
    samples: int
    seed: int
    load_angle_deg: float | None


def run_job(job: Job) -> dict[str, Any]:
    """One row: the plan and both verdicts for one motor and move length. A request no
    table can meet is a row with `error` set and `safe` False, not an exception."""
    from profiles.motor import Motor
    from profiles.ppmc312.planner import plan_free_curve

    row: dict[str, Any] = dict.fromkeys(COLUMNS)
    row.update(motor=job.motor, pulses=job.pulses, safe=False, error="")
    try:
        motor = Motor.from_json(job.motor_json)
        plan = plan_free_curve(motor, pulses=job.pulses, load_angle_deg=job.load_angle_deg)
    except StepRampError as e:
        row["error"] = str(e)
        return row
    table = plan.table
    row.update(move_time_s=plan.duration_s, stages=len(table.rates), LE=int(table.separate),
               clock=table.clock.name, top_pps=table.clock.hz / table.rates[0],
               binds=plan.binds, solve_s=plan.solve_s)
    t0 = time.perf_counter()
    row.update(judge(table, motor, job.samples, job.seed,
                     None if job.load_angle_deg is None else min(job.load_angle_deg, 90.0)))
    row["judge_s"] = time.perf_counter() - t0
    return row


def judge(table: Any, motor: Any, samples: int, seed: int,
          aim_deg: float | None = None) -> dict[str, Any]:
    """The safety verdict (verify.safety) as a row's columns; `safety` holds its whole
    JSON object, as `check --motor --format json` shows it."""
    import json

    from profiles.motor.angles import AIM_DEG
    from verify.safety import judge_safety

    verdict = judge_safety(table, motor, samples=samples, seed=seed,
                           aim_deg=AIM_DEG if aim_deg is None else aim_deg)
    j = verdict.to_json()
    box = j["tolerance_box"]
    return {"worst_load_angle_deg": j["worst_load_angle_deg"], "safe": verdict.safe,
            "failed": ";".join(verdict.failed), "margin_deg": j["margin_deg"],
            "worst_pulses": j["worst_pulses"], "corners": box["corners"] if box else 1,
            "samples": box["samples"] if box else 0,
            "sample_failures": box["sample_failures"] if box else 0,
            "stall_probability_upper": box["stall_probability_upper"] if box and samples
            else None, "safety": json.dumps(j, sort_keys=True)}


def jobs_of(motors: Sequence[tuple[str, dict[str, Any]]], pulses: Sequence[int], *,
            samples: int, seed: int = 0, load_angle_deg: float | None = 75.0) -> list[Job]:
    return [Job(name, obj, int(n), samples, seed, load_angle_deg)
            for name, obj in motors for n in pulses]


def run_sweep(jobs: Sequence[Job], *, workers: int = 1, scheduler: str | None = None,
              progress: Progress | None = None) -> list[dict[str, Any]]:
    """Every job's row, in job order: in this process (workers 1, no scheduler), on
    `workers` local processes, or on the Dask cluster at `scheduler`."""
    total = len(jobs)
    report(progress, 0, total)
    if scheduler is None and workers <= 1:
        rows = []
        for i, job in enumerate(jobs, start=1):
            rows.append(run_job(job))
            report(progress, i, total)
        return rows
    if scheduler is not None:
        try:
            from distributed import Client
        except ImportError:
            raise FormatError("--scheduler needs Dask: pip install 'stepramp[cluster]'") from None
        try:
            client = Client(scheduler, timeout=10, set_as_default=False)
        except (OSError, TimeoutError) as e:
            raise FormatError(f"--scheduler {scheduler}: no Dask scheduler answers ({e})") \
                from None
        with client:
            return _collect(client.get_executor(pure=False), jobs, progress)
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return _collect(pool, jobs, progress)


def _collect(executor: Executor, jobs: Sequence[Job],
             progress: Progress | None) -> list[dict[str, Any]]:
    futures: dict[Future[dict[str, Any]], int] = {executor.submit(run_job, job): i
                                                  for i, job in enumerate(jobs)}
    rows: list[dict[str, Any] | None] = [None] * len(jobs)
    for done, future in enumerate(as_completed(futures), start=1):
        rows[futures[future]] = future.result()
        report(progress, done, len(jobs))
    return [r for r in rows if r is not None]


def encode_rows(rows: Sequence[dict[str, Any]], path: str) -> bytes | str:
    """The rows as CSV text, or Parquet bytes when `path` ends in .parquet (pyarrow)."""
    if str(path).endswith(".parquet"):
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            raise FormatError("Parquet output needs pyarrow: pip install 'stepramp[cluster]'") \
                from None
        buf = io.BytesIO()
        pq.write_table(pa.Table.from_pylist([{k: r.get(k) for k in COLUMNS} for r in rows]), buf)
        return buf.getvalue()
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    for r in rows:
        writer.writerow({k: _cell(r.get(k)) for k in COLUMNS})
    return out.getvalue()


def _cell(v: Any) -> Any:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    return v


def sweep_figure(rows: Sequence[dict[str, Any]]) -> Any:
    """Move time and worst load angle against move length, one line per motor."""
    from verify.plot import _plt

    plt = _plt()
    fig, (ax_t, ax_a) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    for name in dict.fromkeys(r["motor"] for r in rows):
        mine = sorted((r for r in rows if r["motor"] == name and not r["error"]),
                      key=lambda r: r["pulses"])
        if not mine:
            continue
        n = [r["pulses"] for r in mine]
        ax_t.plot(n, [r["move_time_s"] for r in mine], marker="o", label=name)
        ax_a.plot(n, [r["worst_load_angle_deg"] for r in mine], marker="o", label=name)
    ax_a.axhline(90.0, color="red", lw=1, ls="--", label="90° peak")
    ax_a.axhline(75.0, color="orange", lw=1, ls=":", label="75° target")
    ax_t.set(xscale="log", yscale="log", ylabel="move time [s]",
             title="stepramp sweep: robust tables")
    ax_a.set(xscale="log", xlabel="move length [pulses]",
             ylabel="worst load angle [° electrical]")
    ax_t.legend(fontsize=7)
    ax_a.legend(fontsize=7)
    fig.tight_layout()
    return fig

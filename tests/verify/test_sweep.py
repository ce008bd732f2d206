"""`stepramp sweep`: the same rows in-process, on local processes and on a Dask cluster."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from profiles.errors import ClusterError
from profiles.motor import load_motor
from profiles.motor.tolerance import worst_case_motor
from profiles.ppmc312.criterion import all_length_problems
from profiles.ppmc312.planner import plan_free_curve
from tests.support.figures import close
from tests.support.motor_folders import LEAD_MM, screw_motor_file
from tests.support.paths import ROOT
from verify.sweep import COLUMNS, jobs_of, run_sweep

NEMA17 = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


TIMING = {"solve_s", "judge_s"}


def catalogue() -> list[tuple[str, dict[str, Any]]]:
    plain = json.loads(NEMA17.read_text())
    boxed = dict(plain, tolerances={"torque_scale": [0.85, 1.0]})
    return [("plain", plain), ("boxed", boxed)]


def stable(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k not in TIMING} for r in rows]


@pytest.fixture(scope="module")
def local_rows() -> list[dict[str, Any]]:
    jobs = jobs_of(catalogue(), [3000], samples=20, load_angle_deg=None)
    return run_sweep(jobs)


def test_rows_are_the_plans_and_verdicts(local_rows: list[dict[str, Any]]) -> None:
    assert [(r["motor"], r["pulses"]) for r in local_rows] == [("plain", 3000), ("boxed", 3000)]
    for r, (_, obj) in zip(local_rows, catalogue(), strict=True):
        assert set(r) == set(COLUMNS) and r["error"] == ""
        from profiles.motor import Motor
        from profiles.motor.reserve import CruiseReserve
        motor = Motor.from_json(obj)
        # planned to the default cruise reserve's top speed, as `stepramp plan` does
        plan = plan_free_curve(CruiseReserve().applied(motor), pulses=3000)
        assert r["move_time_s"] == plan.duration_s and r["stages"] == len(plan.table.rates)
        assert r["binds"] == plan.binds
        criterion_ok = not all_length_problems(plan.table, worst_case_motor(motor))
        assert r["safe"] == (criterion_ok and r["worst_load_angle_deg"] < 90)
    plain, boxed = local_rows
    assert plain["corners"] == 1 and plain["samples"] == 0
    assert boxed["corners"] == 2 and boxed["samples"] == 20
    assert boxed["move_time_s"] > plain["move_time_s"]  # the price of robustness


@pytest.mark.slow  # two workers from a forkserver that loads the planner: ~3 s on 2 cores
def test_local_processes_give_the_same_rows(local_rows: list[dict[str, Any]]) -> None:
    jobs = jobs_of(catalogue(), [3000], samples=20, load_angle_deg=None)
    seen: list[tuple[int, int]] = []
    rows = run_sweep(jobs, workers=2, progress=lambda d, t: seen.append((d, t)))
    assert stable(rows) == stable(local_rows)
    assert seen[0] == (0, 2) and seen[-1] == (2, 2)


@pytest.mark.slow  # a Dask cluster; CI runs it
def test_dask_cluster_gives_the_same_rows(local_rows: list[dict[str, Any]]) -> None:
    import distributed
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        jobs = jobs_of(catalogue(), [3000], samples=20, load_angle_deg=None)
        rows = run_sweep(jobs, scheduler=cluster.scheduler_address)
    assert stable(rows) == stable(local_rows)


def test_a_cluster_without_workers_times_out() -> None:
    import distributed

    with distributed.LocalCluster(n_workers=0, processes=False,
                                  dashboard_address=None) as cluster:
        jobs = jobs_of(catalogue()[:1], [3000], samples=0, load_angle_deg=None)
        with pytest.raises(ClusterError, match=r"has no workers: no job finished in 0\.5 s"):
            run_sweep(jobs, scheduler=cluster.scheduler_address, timeout_s=0.5)


@pytest.mark.slow  # a stepramp process and its forkserver start (~5 s on 2 cores)
@pytest.mark.usefixtures("terminal_sigint")
def test_ctrl_c_stops_local_workers_and_writes_nothing(tmp_path: Path) -> None:
    import psutil

    out = tmp_path / "r.csv"
    sweep = subprocess.Popen(
        [sys.executable, "-m", "verify.cli", "sweep", "--motors", str(NEMA17), "--pulses",
         # 400 lengths: the workers are certainly still busy when the Ctrl-C comes
         ",".join(str(n) for n in range(1000, 401000, 1000)), "--workers", "2",
         "-o", str(out)], stderr=subprocess.PIPE, text=True, start_new_session=True)
    parent = psutil.Process(sweep.pid)
    deadline = time.monotonic() + 60
    workers: list[psutil.Process] = []
    while len(workers) < 2:  # the workers are the forkserver's children
        assert time.monotonic() < deadline and sweep.poll() is None
        servers = [p for p in parent.children() if "forkserver" in " ".join(p.cmdline())]
        workers = [w for s in servers for w in s.children()]
        time.sleep(0.1)
    time.sleep(1.0)  # the workers run jobs
    os.killpg(sweep.pid, signal.SIGINT)  # what a terminal's Ctrl-C does
    _, err = sweep.communicate(timeout=60)
    assert sweep.returncode == 128 + signal.SIGINT
    assert err.strip() == "stepramp sweep: interrupted"  # no worker's traceback
    assert not out.exists()
    _, alive = psutil.wait_procs([*servers, *workers], timeout=10)
    assert not alive


@pytest.mark.parametrize(("aim", "lines"), [(75.0, {90.0: "90° peak", 75.0: "75° aim"}),
                                            (60.0, {90.0: "90° peak", 60.0: "60° aim"}),
                                            (90.0, {90.0: "90° peak"}),
                                            (None, {90.0: "90° peak"})])
def test_the_sweep_figure_draws_the_aim_the_tables_were_tightened_to(
        aim: float | None, lines: dict[float, str]) -> None:
    """Two panels over move length (time, worst angle; one line a motor), the peak, and the
    sweep's own aim (--load-angle), not a fixed 75°."""
    from verify.sweep import PLANNED, sweep_figure

    rows = [{"motor": "m", "pulses": n, "move_time_s": n * 1e-4, "worst_load_angle_deg": 50.0,
             "worst_pulses": 40, "error": None} for n in (1000, 3000)]
    fig = sweep_figure(rows, aim)
    ax_t, ax_a = fig.axes
    assert (ax_t.get_ylabel(), ax_a.get_ylabel()) == ("move time [s]",
                                                      "worst load angle [° electrical]")
    drawn = {line.get_ydata()[0]: line.get_label() for line in ax_a.get_lines()
             if not line.get_label().startswith("m: ") and line.get_label() != PLANNED}
    assert drawn == lines


def test_jobs_aim_at_the_planners_aim_unless_told() -> None:
    """jobs_of's default aim is the one every planner and verdict uses (AIM_DEG; kept as a
    literal there so that importing verify.sweep stays light)."""
    import inspect

    from profiles.motor.angles import AIM_DEG
    from verify.sweep import jobs_of

    assert inspect.signature(jobs_of).parameters["load_angle_deg"].default == AIM_DEG


def sweep_jobs() -> list[Any]:
    plain = json.loads(NEMA17.read_text())
    boxed = dict(plain, tolerances={"torque_scale": [0.85, 1.0]})
    return jobs_of([("plain", plain), ("boxed", boxed)], [1000, 2000, 3000, 5000],
                   samples=20, load_angle_deg=None)


class Cluster:
    """A scheduler and single-threaded workers, each a process of its own (no nanny, so a
    killed worker stays dead)."""

    def __init__(self, tmp: Path, workers: int) -> None:
        file = tmp / "scheduler.json"
        quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
        self.scheduler = subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
             "--port", "0", "--no-dashboard", "--scheduler-file", str(file)], **quiet)
        deadline = time.monotonic() + 60
        while not file.exists() or not file.read_text().strip():
            assert time.monotonic() < deadline and self.scheduler.poll() is None
            time.sleep(0.1)
        self.address = json.loads(file.read_text())["address"]
        self.workers = [subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", self.address, "--nthreads",
             "1", "--no-nanny", "--no-dashboard", "--name", f"w{i}"], **quiet)
            for i in range(workers)]
        import distributed

        with distributed.Client(self.address, timeout=30, set_as_default=False) as client:
            client.wait_for_workers(workers, timeout=60)

    def stop(self) -> None:
        for p in [*self.workers, self.scheduler]:
            if p.poll() is None:
                p.kill()
            p.wait(timeout=30)


@pytest.fixture
def cluster(tmp_path: Path) -> Iterator[Cluster]:
    c = Cluster(tmp_path, workers=2)
    try:
        yield c
    finally:
        c.stop()


@pytest.mark.slow  # three Python processes start (about 10 s on 2 cores)
def test_a_worker_killed_mid_sweep_is_survived_with_the_same_rows(cluster: Cluster) -> None:
    jobs = sweep_jobs()
    local = run_sweep(jobs)
    victim = cluster.workers[0]
    seen: list[int] = []

    def progress(done: int, total: int) -> None:
        seen.append(done)
        if done == 1:  # both single-threaded workers hold jobs: 7 of 8 are not done
            victim.send_signal(signal.SIGKILL)

    rows = run_sweep(jobs, scheduler=cluster.address, timeout_s=30, progress=progress)
    assert victim.wait(timeout=30) == -signal.SIGKILL
    assert seen[0] == 0 and seen[-1] == len(jobs) and 1 in seen
    assert stable(rows) == stable(local)


@pytest.mark.slow  # three Python processes start (about 10 s on 2 cores)
@pytest.mark.usefixtures("terminal_sigint")
def test_ctrl_c_cancels_the_cluster_jobs_and_writes_nothing(cluster: Cluster,
                                                            tmp_path: Path) -> None:
    import distributed

    out = tmp_path / "rows.csv"
    sweep = subprocess.Popen(
        [sys.executable, "-m", "verify.cli", "sweep", "--motors", str(NEMA17), "--pulses",
         ",".join(str(n) for n in range(1000, 801000, 1000)), "--scheduler", cluster.address,
         "-o", str(out)], stderr=subprocess.PIPE, text=True, start_new_session=True)
    with distributed.Client(cluster.address, timeout=30, set_as_default=False) as client:
        deadline = time.monotonic() + 60
        while not any(client.processing().values()):  # the sweep's jobs are running
            assert time.monotonic() < deadline and sweep.poll() is None
            time.sleep(0.1)
        os.killpg(sweep.pid, signal.SIGINT)  # what a terminal's Ctrl-C does
        _, err = sweep.communicate(timeout=60)
        assert sweep.returncode == 128 + signal.SIGINT
        assert err.strip() == "stepramp sweep: interrupted"
        assert not out.exists()
        # the sweep's jobs are cancelled: no worker is given them any more (800 jobs
        # would keep the 2 workers busy for more than 20 s)
        deadline = time.monotonic() + 5
        while any(client.processing().values()):
            assert time.monotonic() < deadline
            time.sleep(0.2)


def sweep_row(motor: str, pulses: int, worst_pulses: int, angle: float) -> dict[str, Any]:
    return {"motor": motor, "pulses": pulses, "worst_pulses": worst_pulses, "error": "",
            "worst_load_angle_deg": angle, "move_time_s": 1e-5 * pulses}


def test_sweep_draws_each_angle_at_the_length_where_it_occurs() -> None:
    from profiles.motor.travel import AxisUnits
    from verify.sweep import PLANNED, sweep_figure

    rows = [sweep_row("a", 400, 21, 72.5), sweep_row("a", 3200, 40, 70.0),
            sweep_row("b", 3200, 3200, 60.0)]
    fig = sweep_figure(rows, 75.0)
    ax = fig.axes[1]
    worst = {ln.get_label(): list(zip(ln.get_xdata(), ln.get_ydata(), strict=True))
             for ln in ax.get_lines() if ln.get_label().endswith("each table's worst")}
    assert worst == {"a: each table's worst": [(21, 72.5), (40, 70.0)],
                     "b: each table's worst": [(3200, 60.0)]}
    joins = [list(ln.get_xdata()) for ln in ax.get_lines() if ln.get_label() == PLANNED]
    assert joins == [[400, 21], [3200, 40], [3200, 3200]]
    assert "[pulses]" in ax.get_xlabel()
    close(fig)
    units = {"a": AxisUnits(200, 8.0), "b": AxisUnits(1000, 8.0)}
    fig = sweep_figure(rows, 75.0, units=units)
    ax = fig.axes[1]
    b = next(ln for ln in ax.get_lines() if ln.get_label() == "b: each table's worst")
    assert list(b.get_xdata()) == [pytest.approx(3200 * 8.0 / 1000)]
    assert "[mm]" in ax.get_xlabel() and "[mm]" in fig.axes[0].get_xlabel()
    close(fig)


@pytest.fixture
def screw(tmp_path: Path) -> str:
    """The bundled nema17-1600 with an 8 mm lead screw's travel."""
    return screw_motor_file(tmp_path)


def test_sweep_rows_give_rev_and_rpm_always_and_mm_with_a_travel(screw: str) -> None:
    from verify.sweep import real_units

    rotary = real_units(load_motor("nema17-1600"), 3200, 20000.0)
    assert rotary == {"move_rev": 2.0, "top_rpm": 750.0, "travel_mm_per_rev": None,
                      "move_mm": None, "top_mm_s": None}
    linear = real_units(load_motor(screw), 3200, 20000.0)
    assert linear["move_mm"] == pytest.approx(16.0)
    assert linear["top_mm_s"] == pytest.approx(100.0)
    assert linear["travel_mm_per_rev"] == LEAD_MM and linear["top_rpm"] == 750.0
    # before a plan (a row whose plan failed): the lengths, no speeds
    assert set(real_units(load_motor(screw), 3200)) == {"move_rev", "travel_mm_per_rev",
                                                        "move_mm"}

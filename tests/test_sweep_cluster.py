"""The distributed sweep as a real client: a Dask scheduler and two workers in their own
processes; a worker killed (SIGKILL) mid-sweep is survived with the in-process rows,
and Ctrl-C on `stepramp sweep --scheduler` cancels the cluster's jobs and writes
nothing."""

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

from tests.support.paths import ROOT
from verify.sweep import jobs_of, run_sweep

pytestmark = pytest.mark.slow  # three Python processes start (about 10 s on 2 cores)

NEMA17 = ROOT / "profiles" / "data" / "motor-nema17-1600.json"
TIMING = {"solve_s", "judge_s"}


def stable(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k not in TIMING} for r in rows]


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

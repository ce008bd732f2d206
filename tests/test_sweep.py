"""`stepramp sweep`: the same rows in-process, on local processes and on a Dask cluster."""

from __future__ import annotations

import csv
import json
import os
import signal
import socket
import subprocess
import sys
import threading
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
from verify import cli
from verify.sweep import COLUMNS, jobs_of, run_sweep

NEMA17 = Path(__file__).resolve().parents[1] / "profiles" / "data" / "motor-nema17-1600.json"
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


@pytest.mark.slow  # end-to-end; CI runs it
def test_sweep_cli_csv_parquet_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.csv"
    fig = tmp_path / "r.png"
    args = ["sweep", "--motors", str(NEMA17), "--pulses", "3000", "--load-angle", "90"]
    assert cli.main([*args, "--plot", str(fig), "-o", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == 1 and rows[0]["motor"] == "motor-nema17-1600"
    assert rows[0]["safe"] == "True" and float(rows[0]["worst_load_angle_deg"]) < 90
    assert fig.stat().st_size > 1000
    assert "1 safe, 0 not safe" in capsys.readouterr().err
    import pyarrow.parquet as pq
    pout = tmp_path / "r.parquet"
    assert cli.main([*args, "-o", str(pout)]) == 0
    table = pq.read_table(pout).to_pylist()
    assert table[0]["pulses"] == 3000
    assert table[0]["move_time_s"] == pytest.approx(float(rows[0]["move_time_s"]), rel=1e-15)


def test_sweep_cli_refusals(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.csv"
    # a motor whose tolerance box cannot start is a row with its reason, and exit 1
    weak = tmp_path / "weak.json"
    weak.write_text(json.dumps(dict(json.loads(NEMA17.read_text()),
                                    tolerances={"friction_torque_nm": [0.0, 0.5]})))
    assert cli.main(["sweep", "--motors", str(weak), "--pulses", "3000", "-o", str(out)]) == 1
    row = next(csv.DictReader(out.open()))
    assert row["safe"] == "False" and "cannot start" in row["error"]
    capsys.readouterr()
    bad = tmp_path / "bad.csv"
    assert cli.main(["sweep", "--motors", str(NEMA17), "--pulses", "3000", "--workers", "2",
                     "--scheduler", "tcp://127.0.0.1:1", "-o", str(bad)]) == 2
    assert "one or the other" in capsys.readouterr().err and not bad.exists()
    assert load_motor(NEMA17)  # the bundled file was not touched


@pytest.mark.parametrize("address, says", [
    ("garbage", "'garbage': not a Dask scheduler address"),
    ("", "'': not a Dask scheduler address"),
    ("udp://10.0.0.5:8786", "not a Dask scheduler address"),
    ("http://10.0.0.5:8787", "http:// is the dashboard's"),
    ("tcp://10.0.0.5", "not a Dask scheduler address"),
    ("tcp://10.0.0.5:0", "--scheduler port: 0 is outside the allowed range 1..65535"),
    ("tcp://" + "h" * 100_000 + ":1", "… (100008 characters)"),
])
def test_a_malformed_scheduler_address_is_refused_at_once(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch,
        address: str, says: str) -> None:
    import distributed

    def no_client(*args: object, **kwargs: object) -> None:
        raise AssertionError("a malformed address never reaches Dask")

    monkeypatch.setattr(distributed, "Client", no_client)
    out = tmp_path / "r.csv"
    code = cli.main(["sweep", "--motors", str(NEMA17), "--pulses", "3000", "--scheduler",
                     address, "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and says in err and err.startswith("stepramp sweep: --scheduler ")
    assert len(err.splitlines()) == 1 and len(err) < 300 and not out.exists()


@pytest.fixture
def silent_scheduler() -> Iterator[tuple[str, list[socket.socket]]]:
    """A listener that accepts connections and never says a word."""
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(0.05)
    accepted: list[socket.socket] = []
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            try:
                accepted.append(server.accept()[0])
            except TimeoutError:
                pass

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}", accepted
    finally:
        stop.set()
        thread.join()
        for conn in accepted:
            conn.close()
        server.close()


def test_a_scheduler_that_never_answers_times_out(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        silent_scheduler: tuple[str, list[socket.socket]]) -> None:
    address, accepted = silent_scheduler
    out = tmp_path / "r.csv"
    code = cli.main(["sweep", "--motors", str(NEMA17), "--pulses", "3000", "--scheduler",
                     address, "--timeout", "0.5", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and accepted  # it connected, then waited 0.5 s for an answer
    assert err.startswith(f"stepramp sweep: no Dask scheduler answered at {address} within "
                          "0.5 s") and len(err.splitlines()) == 1
    assert not out.exists()


def test_a_cluster_without_workers_times_out() -> None:
    import distributed

    with distributed.LocalCluster(n_workers=0, processes=False,
                                  dashboard_address=None) as cluster:
        jobs = jobs_of(catalogue()[:1], [3000], samples=0, load_angle_deg=None)
        with pytest.raises(ClusterError, match=r"has no workers: no job finished in 0\.5 s"):
            run_sweep(jobs, scheduler=cluster.scheduler_address, timeout_s=0.5)


@pytest.mark.parametrize("options, says", [
    (["--load-angle", "nan"], "--load-angle: nan is outside the allowed range 1.0..90.0"),
    (["--load-angle", "inf"], "--load-angle: inf is outside the allowed range 1.0..90.0"),
    (["--load-angle", "-1"], "--load-angle: -1.0 is outside the allowed range 1.0..90.0"),
    (["--workers", "0"], "--workers: 0 is outside the allowed range 1..256"),
    (["--scheduler", "h:1", "--timeout", "nan"], "--timeout: nan is outside the allowed "
                                                 "range above 0.0 up to 3600.0"),
    (["--scheduler", "h:1", "--timeout", "-1"], "--timeout: -1.0 is outside"),
    (["--scheduler", "h:1", "--timeout", "inf"], "--timeout: inf is outside"),
    (["--timeout", "5"], "--timeout bounds the waits on a Dask scheduler"),
    (["--samples", "-1"], "argument --samples: '-1' is negative"),
])
def test_sweep_numbers_are_checked_first(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                         options: list[str], says: str) -> None:
    out = tmp_path / "r.csv"
    code = cli.main(["sweep", "--motors", str(NEMA17), "--pulses", "3000", *options,
                     "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and says in err and len(err.splitlines()) == 1 and not out.exists()


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

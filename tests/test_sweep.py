"""`stepramp sweep`: the same rows in-process, on local processes and on a Dask cluster."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import pytest

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
        motor = Motor.from_json(obj)
        plan = plan_free_curve(motor, pulses=3000)
        assert r["move_time_s"] == plan.duration_s and r["stages"] == len(plan.table.rates)
        assert r["binds"] == plan.binds
        criterion_ok = not all_length_problems(plan.table, worst_case_motor(motor))
        assert r["safe"] == (criterion_ok and r["worst_load_angle_deg"] < 90)
    plain, boxed = local_rows
    assert plain["corners"] == 1 and plain["samples"] == 0
    assert boxed["corners"] == 2 and boxed["samples"] == 20
    assert boxed["move_time_s"] > plain["move_time_s"]  # the price of robustness


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

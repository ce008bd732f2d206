"""One table and one motor get one verdict, whichever command asks (issue #18): check,
compare (every move the table can run), sweep's rows, sync's report and the designer all
show `verify.safety.judge_safety(...).to_json()`, equal to the key, for safe, unsafe,
toleranced and loaded motors."""

from __future__ import annotations

import contextlib
import io
import json
import shutil
from dataclasses import replace
from pathlib import Path

import pytest

from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import dump_table, load_table
from tests.support.paths import ROOT
from verify import cli
from verify.safety import judge_safety

EXAMPLES = ROOT / "examples"


NEMA17 = next(p for p in bundled_motor_paths() if "nema17" in p.name)


NEMA23 = next(p for p in bundled_motor_paths() if "nema23" in p.name)


def run(*argv: str | Path) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        code = cli.main([str(a) for a in argv])
    return code, out.getvalue()


def check_verdict(table: Path, motor: Path) -> tuple[int, dict[str, object]]:
    code, out = run("check", table, "--motor", motor, "--format", "json")
    return code, json.loads(out)["files"][0]["safety"]


def compare_verdict(table: Path, motor: Path, pulses: int) -> tuple[int, dict[str, object]]:
    code, out = run("compare", table, "--motor", motor, "--pulses", str(pulses),
                    "--references", "ruckig", "--format", "json")
    return code, json.loads(out)["safety"]["every_move"]


def cases(tmp: Path) -> list[tuple[str, Path, Path]]:
    """(label, table file, motor file): safe, unsafe, toleranced, with a load torque."""
    loaded = replace(load_motor(NEMA17), load_torque_nm=0.03)
    loaded_path = tmp / "loaded.motor.json"
    loaded_path.write_text(json.dumps(loaded.to_json()))
    safe = tmp / "safe.table.json"
    safe.write_text(dump_table(plan_free_curve(load_motor(NEMA17), pulses=3000,
                                               load_angle_deg=75).table))
    loaded_table = tmp / "loaded.table.json"
    loaded_table.write_text(dump_table(plan_free_curve(loaded, pulses=3000).table))
    return [("safe", safe, NEMA17), ("unsafe", EXAMPLES / "free-curve-nema17.json", NEMA23),
            ("toleranced", safe, EXAMPLES / "motor-nema17-tolerances.json"),
            ("loaded", loaded_table, loaded_path)]


@pytest.mark.slow  # four cases through four commands and 1 000 samples: ~20 s
def test_check_compare_sweep_and_the_designer_give_one_verdict(tmp_path: Path) -> None:
    from verify.designer import Settings, design
    from verify.sweep import judge

    seen = set()
    for label, table_path, motor_path in cases(tmp_path):
        table, motor = load_table(table_path), load_motor(motor_path)
        key = judge_safety(table, motor).to_json()
        seen.add(key["safe"])
        code, checked = check_verdict(table_path, motor_path)
        assert checked == key, label
        assert code == (0 if key["safe"] else 1), label
        code, compared = compare_verdict(table_path, motor_path, 3000)
        assert compared == key, label
        row = judge(table, motor, 1000, 0)
        assert json.loads(row["safety"]) == key and row["safe"] == key["safe"], label
        if label == "loaded":  # both directions judged: the load hinders one
            assert key["worst_direction"] in ("forward", "backward")
        if label == "toleranced":
            assert key["tolerance_box"]["samples"] == 1000
    assert seen == {True, False}
    # the designer judges the table it planned as check does
    result = design(load_motor(NEMA17), Settings(pulses=3000))
    designed = tmp_path / "designed.table.json"
    designed.write_text(dump_table(result.plan.table))
    assert result.verdict is not None
    assert check_verdict(designed, NEMA17)[1] == result.verdict.to_json()


@pytest.mark.slow
def test_sync_reports_the_verdict_check_gives_its_tables(tmp_path: Path) -> None:
    shutil.copytree(EXAMPLES, tmp_path / "examples")
    (tmp_path / "profiles" / "data").mkdir(parents=True)
    for p in bundled_motor_paths():
        shutil.copy(p, tmp_path / "profiles" / "data" / p.name)
    out = tmp_path / "out"
    code, _ = run("sync", tmp_path / "examples" / "axes-xy.json", "-o", out)
    assert code in (0, 1)
    report = json.loads((out / "report.json").read_text())
    axes = json.loads((tmp_path / "examples" / "axes-xy.json").read_text())["axes"]
    for item, axis in zip(report["axes"], axes, strict=True):
        motor = (tmp_path / "examples" / axis["motor"]).resolve()
        assert check_verdict(out / f"{item['name']}.table.json", motor)[1] == item["safety"]

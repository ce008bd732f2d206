"""verify.resonance: `resonance-dwell` findings."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from profiles.motor import Motor
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import FreeCurveTable, dump_table
from tests.support.nominal_table import NEMA17, PULSES, nominal_plan, speeds
from verify import cli
from verify.resonance import resonance_findings


@pytest.fixture(scope="module")
def nominal() -> tuple[Motor, FreeCurveTable]:
    return nominal_plan()


def test_check_reports_resonance_dwell(tmp_path: Path, nominal: tuple[Motor, FreeCurveTable],
                                       capsys: pytest.CaptureFixture[str]) -> None:
    _, table = nominal
    v = speeds(table)
    obj = json.loads(NEMA17.read_text())
    obj["resonance_bands_pps"] = [[float(v[5]) - 150, float(v[5]) + 150],
                                  [float(v[-1]) - 3000, float(v[-1]) + 3000]]
    motor_path = tmp_path / "m.json"
    motor_path.write_text(json.dumps(obj))
    table_path = tmp_path / "t.json"
    table_path.write_text(dump_table(table))
    found = resonance_findings(table, Motor.from_json(obj))
    assert {f.severity for f in found} == {"warning"}
    assert len(found) == 2 and all(f.rule == "resonance-dwell" for f in found)
    # the top band holds the cruise, the narrow one a dwell of the ramp: each its own advice
    cruise, dwell = sorted(found, key=lambda f: f.stage or 0)
    assert re.fullmatch(r"moves of \d+\.\.4294967295 pulses cruise at [\d.]+ pps, inside the "
                        r"resonance band \[[\d.]+, [\d.]+\] pps: choose a top speed outside it",
                        cruise.message), cruise.message
    assert re.fullmatch(r"moves of \d+\.\.4294967295 pulses dwell at [\d.]+ pps, inside the "
                        r"resonance band \[[\d.]+, [\d.]+\] pps, which is narrower than the "
                        r"jump limit [\d.]+ pps: step over it from below [\d.]+ to above [\d.]+",
                        dwell.message), dwell.message
    base = ["check", "--motor", str(motor_path), "--no-physics", str(table_path)]
    assert cli.main(base) == 0
    out = capsys.readouterr().out
    assert out.count("warning [resonance-dwell]") == 2 and "cruise at" in out
    assert cli.main([*base, "--strict"]) == 1
    assert capsys.readouterr().out.count("error [resonance-dwell]") == 2
    # the planner's own table for these bands passes --strict
    banded = Motor.from_json(obj)
    fixed = tmp_path / "fixed.json"
    fixed.write_text(dump_table(plan_free_curve(banded, pulses=PULSES).table))
    assert cli.main(["check", "--motor", str(motor_path), "--no-physics", "--strict",
                     str(fixed)]) == 0

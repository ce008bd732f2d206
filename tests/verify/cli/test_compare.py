"""`stepramp compare` (verify/cli/compare.py): every move length judged."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from profiles.motor import bundled_motor_paths
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.table import FreeCurveTable, dump_table, load_table
from tests.support.cli import run
from tests.support.paths import ROOT

MOTORS = {p.stem: p for p in bundled_motor_paths()}


NEMA23 = MOTORS["motor-nema23-heavy"]


def switching_table(tmp_path: Path) -> Path:
    # LE=1, decel counts heavy at the slow end: short triangles switch down
    table = FreeCurveTable(Clock.internal("8MHz"), (1455, 1873, 2500), (40, 40, 40), (2, 2, 200))
    path = tmp_path / "switch.table.json"
    path.write_text(dump_table(table))
    return path


def test_compare_exits_1_on_an_unsafe_move(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    path = switching_table(tmp_path)
    table = load_table(path)
    code, out, _ = run(capsys, "compare", path, "--motor", NEMA23, "--pulses",
                       str(table.accel_total + table.decel_total + 500), "--references",
                       "ruckig", "--format", "json")
    doc = json.loads(out)
    assert code == (0 if doc["safe"] else 1)
    assert doc["failed_judges"] == ([] if doc["safe"] else doc["failed_judges"])
    example = ROOT / "examples" / "free-curve-nema17.json"
    code, out, _ = run(capsys, "compare", example, "--motor", NEMA23, "--pulses", "5000",
                       "--references", "ruckig")
    assert code == 1 and ("verdict: UNSAFE (failed: criterion, load angle, decel-stop, "
                          "constant, origin-search, origin-return, stop, set-speed)") in out

"""`stepramp compare` (verify/cli/compare.py): every move length judged."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from profiles.motor import bundled_motor_paths
from profiles.ppmc312.table import load_table
from tests.support.cli import run
from tests.support.motor_folders import LEAD_MM, screw_motor_file
from tests.support.paths import ROOT
from tests.support.switching_table import switching_table
from verify.cli import main

MOTORS = {p.stem: p for p in bundled_motor_paths()}


NEMA23 = MOTORS["motor-nema23-heavy"]


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


@pytest.fixture
def screw(tmp_path: Path) -> str:
    """The bundled nema17-1600 with an 8 mm lead screw's travel."""
    return screw_motor_file(tmp_path)


def test_compare_gives_mm_beside_pulses(screw: str, capsys: pytest.CaptureFixture[str]) -> None:
    table = str(ROOT / "examples" / "free-curve-nema17.json")
    argv = ["compare", table, "--motor", screw, "--pulses", "5000", "--references", "ruckig",
            "--no-physics"]
    main([*argv, "--format", "json"])
    out = json.loads(capsys.readouterr().out)
    assert out["pulses"] == 5000 and "table_s" in out                # the pulse keys stay
    per_pulse = LEAD_MM / 1600
    assert out["move_mm"] == pytest.approx(25.0)
    assert out["table_mean_mm_s"] == pytest.approx(5000 / out["table_s"] * per_pulse)
    assert out["optimum_mean_mm_s"] == pytest.approx(5000 / out["optimum_s"] * per_pulse)
    assert out["table_top_mm_s"] == pytest.approx(out["table_top_pps"] * per_pulse)
    assert out["table_top_pps"] == pytest.approx(20000.0)   # the example's fastest stage
    main(argv)
    [line] = [x for x in capsys.readouterr().out.splitlines() if x.startswith("in mm: ")]
    assert line.startswith("in mm: a move of 25 mm; the table's top 100 mm/s, its mean ")

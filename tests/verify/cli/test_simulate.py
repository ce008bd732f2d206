"""`stepramp simulate` (verify/cli/simulate.py): pulse times and samples."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from profiles.ppmc312.table import load_table
from tests.support.alink_oracle import stepped
from tests.support.cli import run
from tests.support.paths import ROOT

GOOD = ROOT / "examples" / "free-curve-nema17.json"


def test_simulate_pulse_times_and_samples(capsys: pytest.CaptureFixture[str],
                                          tmp_path: Path) -> None:
    from profiles.ppmc312.execution import simulate_move

    run_ = simulate_move(load_table(GOOD), 3000)
    pt, sm = tmp_path / "pt.csv", tmp_path / "s.csv"
    code, out, _ = run(capsys, "simulate", GOOD, "--pulses", "3000", "--pulse-times", pt,
                       "--samples", sm)
    assert code == 0 and "trapezoid" in out
    rows = pt.read_text().splitlines()
    assert rows[0] == "pulse,time_s" and len(rows) == 3001
    assert float(rows[-1].split(",")[1]) == pytest.approx(run_.duration_s, abs=1e-9)
    samples = sm.read_text().splitlines()
    assert samples[0] == "t_s,x_pulses,v_pps,a_pps2" and len(samples) == 1001
    assert float(samples[-1].split(",")[1]) == 3000


def test_too_many_pulse_times_speaks_of_pulses(capsys: pytest.CaptureFixture[str],
                                               tmp_path: Path) -> None:
    code, _, err = run(capsys, "simulate", ROOT / "examples" / "free-curve-nema17.json",
                       "--pulses", "10000001", "--pulse-times", tmp_path / "p.csv")
    assert code == 2 and "pulses (one CSV row per pulse)" in err
    assert "limit=" not in err and "_s:" not in err
    assert not (tmp_path / "p.csv").exists()


def test_simulate_settings_shows_the_units_move(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """`simulate SETTINGS --pulses N`: the model's move, its pulse times in the CSV."""
    path = tmp_path / "s.txt"
    assert run(capsys, "alink", "settings", "--start-pps", "800", "--high-pps", "20000",
               "--accel-ms-per-kpps", "5", "-o", str(path))[0] == 0
    times = tmp_path / "t.csv"
    code, out, _ = run(capsys, "simulate", str(path), "--pulses", "101", "--pulse-times",
                       str(times))
    assert code == 0 and "shape: triangle" in out and "up 51" in out and "down 50" in out
    rows = times.read_text().splitlines()
    assert rows[0] == "pulse,time_s" and len(rows) == 102
    speeds = stepped(800, 20000, 200_000.0, 10, "linear", 101)
    # 1920 speed steps judged as 241 stages: the stepped unit's time within 0.1 %
    assert float(rows[-1].split(",")[1]) == pytest.approx(sum(1 / v for v in speeds), rel=1e-3)
    code, out, _ = run(capsys, "simulate", str(path), "--pulses", "5000", "--format", "json")
    doc = json.loads(out)
    assert code == 0 and doc["shape"] == "trapezoid" and doc["peak_pps"] == pytest.approx(20000)
    assert sum(s["pulses"] for s in doc["segments"]) == 5000
    code, _, err = run(capsys, "simulate", str(path), "--pulses", "10", "--samples", "x.csv")
    assert code == 2 and "--samples" in err

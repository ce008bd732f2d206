"""`stepramp show` (verify/cli/show.py): a table's stages as JSON, CSV and text."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest

from profiles.ppmc312.clock import Clock
from profiles.ppmc312.init_model import expand_init
from profiles.ppmc312.table import FreeCurveTable, load_table
from tests.support.cli import run
from tests.support.motor_folders import LEAD_MM, screw_motor_file
from tests.support.paths import ROOT
from verify.cli import main

MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


INIT = ROOT / "examples" / "init-linear.json"


# 1 MHz, rates 100..400 (10 000 .. 2 500 pps); accel 10/20/30/40 pulses, decel 5/5/5 on
# the three fastest stages. By hand: accel stage k lasts pulses × rate µs.
SHOWN = FreeCurveTable(Clock.internal("1MHz"), (100, 200, 300, 400), (10, 20, 30, 40),
                       (5, 5, 5))


BY_HAND = [  # slowest first: stage, speed_pps, accel ms, accel cum ms, decel ms, decel cum ms
    (3, 2500.0, 16.0, 16.0, None, None),
    (2, 1e6 / 300, 9.0, 25.0, 1.5, 1.5),
    (1, 5000.0, 4.0, 29.0, 1.0, 2.5),
    (0, 10000.0, 1.0, 30.0, 0.5, 3.0),
]


def _shown_file(tmp_path: Path) -> Path:
    path = tmp_path / "shown.json"
    path.write_text(json.dumps(SHOWN.to_json()))
    return path


def test_show_json_matches_hand_numbers(capsys: pytest.CaptureFixture[str],
                                        tmp_path: Path) -> None:
    code, out, _ = run(capsys, "show", _shown_file(tmp_path), "--format", "json",
                       "--motor", MOTOR)
    assert code == 0
    doc = json.loads(out)
    assert doc["modelled"] is False and doc["kind"] == "free_curve"
    assert doc["accel_s"] == pytest.approx(0.030) and doc["decel_s"] == pytest.approx(0.003)
    rows = doc["stages"]
    assert [r["stage"] for r in rows] == [3, 2, 1, 0]
    for row, (stage, v, acc, acc_cum, dec, dec_cum) in zip(rows, BY_HAND, strict=True):
        assert row["rate"] == SHOWN.rates[stage]
        assert row["speed_pps"] == pytest.approx(v)
        assert row["speed_rpm"] == pytest.approx(v * 60 / 1600)  # nema17: 1600 steps/rev
        assert row["accel_pulses"] == SHOWN.accel_pulses[stage]
        assert row["accel_s"] == pytest.approx(acc / 1e3)
        assert row["accel_cum_s"] == pytest.approx(acc_cum / 1e3)
        if dec is None:
            assert row["decel_pulses"] is None and row["decel_s"] is None
        else:
            assert row["decel_s"] == pytest.approx(dec / 1e3)
            assert row["decel_cum_s"] == pytest.approx(dec_cum / 1e3)


def test_show_csv_and_text(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = _shown_file(tmp_path)
    code, out, _ = run(capsys, "show", path, "--format", "csv")
    assert code == 0
    rows = list(csv.DictReader(io.StringIO(out)))
    assert [int(r["stage"]) for r in rows] == [3, 2, 1, 0]
    assert rows[0]["speed_rpm"] == "" and rows[0]["decel_pulses"] == ""
    assert float(rows[1]["accel_cum_s"]) == pytest.approx(0.025)
    code, out, _ = run(capsys, "show", path)
    lines = out.splitlines()
    assert "clock 1MHz, 4 stages" in lines[0] and "accel 100 pulses in 30 ms" in lines[0]
    assert "decel 15 pulses in 3 ms" in lines[0]
    assert "speed [pps]" in lines[1] and "accel cum [ms]" in lines[1]
    assert lines[2].split() == ["3", "400", "2500", "40", "16", "16", "-", "-", "-"]
    assert lines[-1].split() == ["0", "100", "10000", "10", "1", "30", "5", "0.5", "3"]


def test_show_init_table_lists_the_model_and_says_so(capsys: pytest.CaptureFixture[str]
                                                     ) -> None:
    code, out, _ = run(capsys, "show", INIT, "--format", "json")
    assert code == 0
    doc = json.loads(out)
    model = expand_init(load_table(INIT))  # type: ignore[arg-type]
    assert doc["modelled"] is True and doc["init"]["shape"] == "linear"
    assert [r["rate"] for r in doc["stages"]] == list(model.rates[::-1])
    _, text, _ = run(capsys, "show", INIT)
    assert "modelled" in text.splitlines()[2]


def test_show_bad_input_is_one_line(capsys: pytest.CaptureFixture[str], tmp_path: Path
                                    ) -> None:
    code, _, err = run(capsys, "show", tmp_path / "none.json")
    assert code == 2 and len(err.strip().splitlines()) == 1


def test_safety_factor_range_in_words(capsys: pytest.CaptureFixture[str],
                                      tmp_path: Path) -> None:
    doc = json.loads(MOTOR.read_text())
    doc["safety_factor"] = 0
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc))
    code, _, err = run(capsys, "show", INIT, "--motor", path)
    assert code == 2
    assert "safety_factor: 0.0 is outside the allowed range above 0 up to 1" in err


def test_show_reports_it_and_takes_the_tables_own(capsys: pytest.CaptureFixture[str],
                                                  tmp_path: Path) -> None:
    out = tmp_path / "t.json"
    run(capsys, "plan", "--motor", "nema23-heavy", "--pulses", "4000", "--cruise-reserve",
        "3x,20%", "-o", str(out))
    code, said, _ = run(capsys, "show", str(out), "--motor", "nema23-heavy")
    assert code == 0 and said.splitlines()[-1].endswith(
        "kept (3x,20%: pull-out ≥ 3× what cruising needs and ≥ 20 % of standstill)")
    code, said, _ = run(capsys, "show", str(out), "--motor", "nema23-heavy", "--format", "json")
    assert json.loads(said)["cruise_reserve"]["reserve"] == "3x,20%"
    code, _, err = run(capsys, "show", str(out), "--cruise-reserve", "3x")
    assert code == 2 and "--cruise-reserve holds the table's top speed" in err


@pytest.fixture
def screw(tmp_path: Path) -> str:
    """The bundled nema17-1600 with an 8 mm lead screw's travel."""
    return screw_motor_file(tmp_path)


def test_show_gives_mm_with_a_linear_motor_and_rev_with_a_rotary_one(
        screw: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    table = tmp_path / "t.json"
    assert main(["plan", "--motor", screw, "--pulses", "3200", "-o", str(table)]) == 0
    capsys.readouterr()
    obj = json.loads(table.read_text())
    accel = sum(obj["accel_pulses"])
    assert main(["show", str(table), "--motor", screw, "--format", "json"]) == 0
    listing = json.loads(capsys.readouterr().out)
    assert listing["accel_pulses"] == accel                      # the pulse keys stay
    assert listing["accel_mm"] == pytest.approx(accel * LEAD_MM / 1600)
    assert listing["travel_mm_per_rev"] == LEAD_MM
    row = listing["stages"][0]
    assert row["speed_mm_s"] == pytest.approx(row["speed_pps"] * LEAD_MM / 1600)
    assert main(["show", str(table), "--motor", screw]) == 0
    text = capsys.readouterr().out
    assert f"accel {accel} pulses ({accel * LEAD_MM / 1600:.4g} mm) in " in text
    assert "speed [mm/s]" in text.splitlines()[1]
    assert main(["show", str(table), "--motor", "nema17-1600", "--format", "json"]) == 0
    listing = json.loads(capsys.readouterr().out)
    assert listing["accel_rev"] == pytest.approx(accel / 1600)
    assert "speed_mm_s" not in listing["stages"][0] and "travel_mm_per_rev" not in listing


def test_show_takes_mm_from_the_motor_a_table_was_planned_for_when_unchanged(
        screw: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    table = tmp_path / "t.json"
    assert main(["plan", "--motor", screw, "--pulses", "3200", "-o", str(table)]) == 0
    capsys.readouterr()
    assert main(["show", str(table)]) == 0
    text = capsys.readouterr().out
    assert "speed [mm/s]" in text and "mm from the motor it was planned for: " in text
    assert main(["show", str(table), "--format", "csv"]) == 0
    assert capsys.readouterr().out.splitlines()[0].endswith(",speed_mm_s")
    # the motor file changed since: its hash is not the one planned with, no mm
    obj = json.loads(Path(screw).read_text())
    Path(screw).write_text(json.dumps({**obj, "travel_mm_per_rev": 5.0}))
    assert main(["show", str(table)]) == 0
    text = capsys.readouterr().out
    assert "mm/s" not in text and "planned for" not in text
    assert main(["show", str(table), "--format", "csv"]) == 0
    assert "speed_mm_s" not in capsys.readouterr().out

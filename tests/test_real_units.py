"""Real units in the text and JSON outputs (issue 32 item 5): `plan` (and `plan
--distance-mm` / `--distance-rev`), `show`, `compare` and `sweep` give mm, mm/s and mm/s²
beside pulses when the motor file has `travel_mm_per_rev`, else rev and rpm."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from profiles.motor.catalogue import resolve
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.table import FreeCurveTable
from verify.cli import main
from verify.plan_text import ramp

LEAD_MM = 8.0   # nema17-1600 (1600 pulses/rev) on an 8 mm lead: 0.005 mm per pulse


@pytest.fixture
def screw(tmp_path: Path) -> str:
    """The bundled nema17-1600 with an 8 mm lead screw's travel."""
    obj = json.loads(resolve("nema17-1600").read_text())
    path = tmp_path / "screw.json"
    path.write_text(json.dumps({**obj, "travel_mm_per_rev": LEAD_MM}))
    return str(path)


def test_a_tables_ramp_is_its_speed_gain_over_its_time_below_the_top() -> None:
    # 1 MHz: stages at 1000, 2000, 4000 pps (rates 1000, 500, 250), 10 pulses each: below
    # the top it spends 10·1000 + 10·500 ticks = 15 ms gaining 3000 pps: 200 000 pps²
    table = FreeCurveTable(Clock.internal("1MHz"), (250, 500, 1000), (10, 10, 10))
    start, top, accel = ramp(table)
    assert (start, top) == (1000.0, 4000.0)
    assert accel == pytest.approx(3000 / 0.015)


def test_plan_gives_mm_beside_pulses(screw: str, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "t.json"
    assert main(["plan", "--motor", screw, "--pulses", "3200", "-o", str(out),
                 "--format", "json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["pulses"] == 3200 and "move_time_s" in summary   # the pulse keys stay
    assert summary["travel_mm_per_rev"] == LEAD_MM
    assert summary["move_mm"] == pytest.approx(16.0)
    per_pulse = LEAD_MM / 1600
    table = json.loads(out.read_text())
    top = 8e6 / table["rates"][0] if table["clock"] == "8MHz" else None
    if top is not None:
        assert summary["top_speed_pps"] == pytest.approx(top)
    for key in ("top_speed", "start_speed"):
        assert summary[f"{key}_mm_s"] == pytest.approx(summary[f"{key}_pps"] * per_pulse)
    assert summary["ramp_accel_mm_s2"] == pytest.approx(summary["ramp_accel_pps2"] * per_pulse)
    assert "top_speed_rpm" not in summary


def test_plan_text_says_mm_and_a_rotary_motor_rev_and_rpm(
        screw: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--motor", screw, "--pulses", "3200", "-o",
                 str(tmp_path / "t.json")]) == 0
    lines = capsys.readouterr().out.splitlines()
    [line] = [x for x in lines if x.startswith("in mm: top ")]
    assert " mm/s (from " in line and " mm/s² on average" in line
    assert "a move of 3200 pulses = 16 mm (0.005 mm per pulse)" in line
    assert main(["plan", "--motor", "nema17-1600", "--pulses", "3200", "-o",
                 str(tmp_path / "r.json"), "--format", "json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["travel_mm_per_rev"] is None and summary["move_rev"] == 2.0
    assert summary["top_speed_rpm"] == pytest.approx(summary["top_speed_pps"] * 60 / 1600)
    assert summary["ramp_accel_rev_s2"] == pytest.approx(summary["ramp_accel_pps2"] / 1600)


def test_plan_distance_mm_is_the_nearest_pulse_said_when_rounded(
        screw: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "t.json"
    assert main(["plan", "--motor", screw, "--distance-mm", "10.0012", "-o", str(out),
                 "--format", "json"]) == 0
    got = capsys.readouterr()
    summary = json.loads(got.out)
    # 10.0012 mm / 0.005 mm = 2000.24 pulses → 2000, 10 mm
    assert summary["pulses"] == 2000 and summary["move_mm"] == pytest.approx(10.0)
    assert summary["asked_move_mm"] == 10.0012
    assert ("--distance-mm 10.0012 mm is 2000 pulses (rounded to the nearest pulse): 10 mm, "
            "-0.0012 mm") in got.err
    assert json.loads(out.read_text())["provenance"]["pulses"] == [2000]
    assert main(["plan", "--motor", screw, "--distance-mm", "10", "-o", str(out)]) == 0
    assert "rounded" not in capsys.readouterr().err


def test_plan_distance_rev_on_any_motor(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--motor", "nema17-1600", "--distance-rev", "2.5", "-o",
                 str(tmp_path / "t.json"), "--format", "json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["pulses"] == 4000 and summary["asked_move_rev"] == 2.5


@pytest.mark.parametrize("argv, text", [
    (["--motor", "nema17-1600", "--distance-mm", "10"],
     "--distance-mm [mm]: motor nema17-1600 has no travel_mm_per_rev"),
    (["--motor", "SCREW", "--distance-mm", "0"],
     "--distance-mm [mm]: 0 mm is 0 pulses, outside 1..4294967295 pulses (0.005..2.14748e+07 "
     "mm at 0.005 mm per pulse)"),
    (["--motor", "SCREW", "--distance-mm", "-3"], "--distance-mm [mm]: -3 mm is -600 pulses"),
    (["--motor", "SCREW", "--distance-mm", "inf"], "--distance-mm [mm]: inf mm is not a "
                                                   "finite length"),
    (["--motor", "SCREW", "--distance-mm", "3e7"], "--distance-mm [mm]: 3e+07 mm is 6e+09"),
    (["--motor", "SCREW", "--distance-mm", "10", "--pulses", "2000"],
     "--pulses, --distance-mm and --distance-rev each give the move's length"),
    (["--motor", "SCREW", "--distance-mm", "10", "--distance-rev", "2"],
     "--pulses, --distance-mm and --distance-rev each give the move's length"),
    (["--motor", "nema17-1600", "--distance-rev", "0.0001"], "--distance-rev [rev]: 0.0001 rev"),
])
def test_plan_distance_refusals_name_the_flag_and_unit(
        argv: list[str], text: str, screw: str, capsys: pytest.CaptureFixture[str]) -> None:
    argv = [screw if a == "SCREW" else a for a in argv]
    assert main(["plan", *argv]) == 2
    err = capsys.readouterr().err
    assert text in err and len(err.splitlines()) == 1


# --- show ---------------------------------------------------------------------------------

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


# --- compare and sweep --------------------------------------------------------------------

def test_compare_gives_mm_beside_pulses(screw: str, capsys: pytest.CaptureFixture[str]) -> None:
    table = str(Path(__file__).parent.parent / "examples" / "free-curve-nema17.json")
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


def test_sweep_rows_give_rev_and_rpm_always_and_mm_with_a_travel(screw: str) -> None:
    from profiles.motor import load_motor
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

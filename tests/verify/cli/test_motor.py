"""`stepramp motor new` and `stepramp motor check` through the entry point."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from profiles.motor import bundled_motor_paths, load_motor
from profiles.motor.catalogue import (
    ENV_VAR,
)
from profiles.motor.travel import axis_units
from tests.support.motor_folders import motor_file, motor_folders
from verify import cli
from verify.cli import main

DATASHEET = ["--holding-torque-nm", "0.45", "--rated-current-a", "1.5", "--resistance-ohm",
             "1.8", "--inductance-mh", "3.2", "--supply-v", "24", "--microstep", "8",
             "--rotor-inertia-gcm2", "57", "--detent-torque-nm", "0.02"]


def run_argv(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = cli.main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_new_from_datasheet_with_a_lead_screw(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    out_file = tmp_path / "m.json"
    code, out, err = run_argv(["motor", "new", *DATASHEET, "--load",
                          "screw:lead_mm=8,mass_kg=2,screw_diameter_mm=8,screw_length_mm=300,"
                          "friction_coeff=0", "--name", "axis", "-o", str(out_file)], capsys)
    assert (code, err) == (0, "")
    assert out.startswith(f"{out_file}: 1600 steps/rev")
    motor = load_motor(out_file)
    assert motor.name == "axis" and motor.steps_per_rev == 1600
    # rotor 57 g·cm² = 5.7e-6, screw 9.470e-7, carriage 2·(0.008/2π)² = 3.2423e-6
    assert motor.inertia_kgm2 == pytest.approx(5.7e-6 + 9.470e-7 + 3.24228e-6, rel=1e-4)
    assert motor.friction_torque_nm == 0.02
    assert motor.torque_nm(0.0) == pytest.approx(0.45)
    code, out, _ = run_argv(["motor", "check", str(out_file)], capsys)
    assert (code, out) == (0, f"{out_file}: ok\n")


def test_new_from_a_vendor_curve(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    csv = tmp_path / "curve.csv"
    csv.write_text("speed_rpm,torque_ozin\n30,60\n300,50\n900,20\n1500,8\n")
    code, out, err = run_argv(["motor", "new", "--curve", str(csv), "--speed-unit", "rpm",
                          "--torque-unit", "oz-in", "--microstep", "8",
                          "--rotor-inertia-gcm2", "57", "--start-pps", "500",
                          "--detent-torque-nm", "0"], capsys)
    assert (code, err) == (0, "")
    obj = json.loads(out)
    # 30 rpm × 1600 / 60 = 800 pps; 60 oz·in = 0.42369 N·m; a point at 0 takes it too
    assert obj["pullout_torque"][:2] == [[0.0, pytest.approx(0.423693)],
                                         [800.0, pytest.approx(0.423693)]]
    assert obj["pullout_torque"][-1][0] == pytest.approx(40000)
    assert obj["start_pps"] == 500 and obj["inertia_kgm2"] == pytest.approx(5.7e-6)
    assert "vendor curve" in obj["sources"]["pullout_torque"][0]["from"]


@pytest.mark.parametrize("argv, text", [
    (["--curve", "c.csv", "--rotor-inertia-gcm2", "57"], "--speed-unit and --torque-unit"),
    (["--holding-torque-nm", "0.45", "--rotor-inertia-gcm2", "57"], "needs --rated-current-a"),
    ([*DATASHEET, "--curve", "c.csv", "--speed-unit", "rpm", "--torque-unit", "N·m"],
     "--curve replaces"),
    ([*DATASHEET, "--load", "wheel:mass_kg=1"], "unknown kind"),
    ([*DATASHEET, "--step-angle", "1.7"], "does not divide"),
    ([*DATASHEET, "--safety-factor", "0.01"], "cannot"),
    (["--curve", "missing.csv", "--speed-unit", "rpm", "--torque-unit", "N·m",
      "--rotor-inertia-gcm2", "57"], "no such file"),
    (["--curve", "c.csv", "--speed-unit", "furlong", "--torque-unit", "N·m",
      "--rotor-inertia-gcm2", "57"], "speed unit"),
])
def test_unusable_input_is_one_line_exit_2(argv: list[str], text: str, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str],
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "c.csv").write_text("0,1\n100,0.5\n")
    code, out, err = run_argv(["motor", "new", *argv, "-o", "m.json"], capsys)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and text in err, err
    assert not (tmp_path / "m.json").exists()


def test_check_names_the_field(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.json"
    obj = json.loads(bundled_motor_paths()[0].read_text())
    obj["safety_factor"] = 1.5
    obj["pullout_torque"][1][1] = -0.4
    bad.write_text(json.dumps(obj))
    good = bundled_motor_paths()[0]
    code, out, _ = run_argv(["motor", "check", str(good), str(bad)], capsys)
    assert code == 1  # findings: a verdict, not unusable input
    assert out.splitlines() == [
        f"{good}: ok",
        f"{bad}: /pullout_torque/1/1: -0.4 is less than the minimum of 0",
        f"{bad}: /safety_factor: 1.5 is greater than the maximum of 1",
    ]


def test_check_unreadable_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "x.json").write_text("{nope")
    code, out, err = run_argv(["motor", "check", str(tmp_path / "x.json")], capsys)
    assert code == 2 and "not valid JSON" in out
    assert err.startswith("stepramp motor: ") and err.count("\n") == 1 and "x.json" in err


def test_vertical_axis_load_torque_is_written(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "lift.json"
    code, _, _ = run_argv(["motor", "new", *DATASHEET, "--load",
                      "screw:lead_mm=10,mass_kg=3,efficiency=0.8,incline_deg=90", "-o",
                      str(path)], capsys)
    assert code == 0
    obj = json.loads(path.read_text())
    assert obj["load_torque_nm"] == pytest.approx(3 * 9.80665 * 0.01 / (2 * math.pi * 0.8))
    assert "m·g·sin(90°)·lead/2π/η" in obj["sources"]["load_torque_nm"][0]["from"]
    assert load_motor(path).load_torque_nm == obj["load_torque_nm"]
    assert run_argv(["motor", "check", str(path)], capsys)[:2] == (0, f"{path}: ok\n")


@pytest.fixture
def folders(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path, Path]:
    return motor_folders(tmp_path, monkeypatch)


def test_motor_list_text_and_json(folders: tuple[Path, Path, Path],
                                  capsys: pytest.CaptureFixture[str]) -> None:
    env_a, env_b, config = folders
    motor_file(env_a, "nema17-1600.json", name="my NEMA17")
    (config / "broken.json").parent.mkdir(parents=True)
    (config / "broken.json").write_text('{"format": "stepramp.motor/2"}')
    (config / "settings.json").write_text('{"editor.tabSize": 4}')  # another tool's: unlisted
    assert cli.main(["motor", "list"]) == 0
    out, err = capsys.readouterr()
    assert err == f"stepramp motor: warning: {ENV_VAR} folder {env_b} is not a folder\n"
    lines = out.splitlines()
    assert lines[0].split() == ["name", "steps/rev", "holding", "[N·m]", "top", "[pps]",
                                "[rpm]", "source", "description"]
    rows = {(line.split()[0], line.split()[5]): line for line in lines[1:]}
    assert rows[("nema17-1600", ENV_VAR)].split()[1:5] == ["400", "≈0.4", "48000", "7200"]
    assert "bundled (shadowed by STEPRAMP_MOTORS)" in rows[("nema17-1600", "bundled")]
    assert rows[("nema17-1600", "bundled")].split()[1:5] == ["1600", "0.45", "48000", "1800"]
    assert "unreadable: format: expected" in next(v for k, v in rows.items() if k[0] == "broken")
    assert not any(k[0] == "settings" for k in rows)
    assert lines[-1].startswith("≈: the pull-out torque at 0 pps")
    for column in ("steps/rev", "holding [N·m]", "top [pps]", "[rpm]"):  # numbers: right
        end = lines[0].index(column) + len(column)
        assert all(line[end - 1] != " " and line[end] == " " for line in lines[1:-1]), column
    assert cli.main(["motor", "list", "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    first = doc["motors"][0]
    assert (first["name"], first["source"], first["steps_per_rev"]) == ("nema17-1600", ENV_VAR,
                                                                        400)
    assert first["holding_from"] == "pullout_torque at 0 pps"


def test_motor_show_text(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["motor", "show", "nema23-heavy"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "nema23-heavy: NEMA23 1.9 N·m, half step, heavy rotary table"
    assert lines[1].startswith("file: ") and lines[1].endswith("motor-nema23-heavy.json "
                                                                "(bundled)")
    assert lines[4] == ("axis: rotary (no travel_mm_per_rev): lengths in rev, speeds in rpm; "
                        "top 1800 rpm")
    assert lines[5].split() == ["speed", "[pps]", "[rpm]", "pull-out", "[N·m]", "×", "0.6",
                                "[N·m]", "a_acc", "[pps²]", "a_dec", "[pps²]"]
    motor = load_motor("nema23-heavy")
    rows = [line.split() for line in lines[6:]]
    assert [float(r[0]) for r in rows] == list(motor.curve_speed_pps)
    # a_acc(0) = (0.6·1.9 − 0.2) / 4.8e-4 · 400 / 2π = 124 680 pps²
    assert float(rows[0][4]) == pytest.approx(124_680, rel=1e-3)
    assert float(rows[-1][1]) == pytest.approx(12000 * 60 / 400)


@pytest.mark.parametrize("motor", ["nema17-1600", "nema23-heavy", "pk566-5phase-half"])
def test_plan_summary_is_short_lines_each_said_once(motor: str, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    # issue 32 item 10: what was planned, what holds it back, the reserve, the verdict,
    # the other commands: a few lines of at most 120 characters, no reason said twice
    from verify.plan_text import LINE_MAX

    monkeypatch.chdir(tmp_path)  # the last line names the table as given: a short path
    out = "t.json"
    assert main(["plan", "--motor", motor, "--pulses", "2000", "-o", out]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert 4 <= len(lines) <= 8
    assert all(len(line) <= LINE_MAX for line in lines), lines
    assert lines[0].startswith("planned: ") and " pps; a move of 2000 pulses takes " in lines[0]
    assert any(line.startswith("cruise reserve at the top speed kept (") for line in lines)
    assert any(line.startswith("verdict: SAFE for every move length: worst load angle ")
               for line in lines)
    assert lines[-1].strip() == f"stepramp check {out} --motor {motor}"
    clauses = [c.strip() for line in lines for c in line.split(";")]
    assert len(clauses) == len(set(clauses)), lines
    # the planner's jargon stays in --format json ("info")
    assert not any(word in "\n".join(lines) for word in ("info:", "×0.", "tightened where"))


MOTORS = {p.stem: p for p in bundled_motor_paths()}


NEMA23 = MOTORS["motor-nema23-heavy"]


def test_motor_new_writes_the_screws_travel_with_its_source(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_file = tmp_path / "m.json"
    code, out, _ = run_argv(["motor", "new", *DATASHEET, "--load", "gear:ratio=2", "--load",
                        "screw:lead_mm=8,mass_kg=2,friction_coeff=0.01,efficiency=0.4",
                        "-o", str(out_file)], capsys)
    assert code == 0 and "travel 4 mm/rev" in out
    obj = json.loads(out_file.read_text())
    assert obj["travel_mm_per_rev"] == pytest.approx(4.0)
    assert obj["sources"]["travel_mm_per_rev"][0]["from"] == ("lead screw lead 8 mm / gear 2 "
                                                              "= 4 mm/rev")
    code, out, _ = run_argv(["motor", "show", str(out_file)], capsys)
    assert code == 0
    assert "axis: 4 mm/rev, 1600 pulses/rev: 0.0025 mm per pulse" in out
    assert "[mm/s]" in out


def test_motor_new_takes_the_travel_given_and_a_rotary_load_none(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_argv(["motor", "new", *DATASHEET, "--travel-mm-per-rev", "12.5"], capsys)
    assert code == 0 and json.loads(out)["travel_mm_per_rev"] == 12.5
    code, out, _ = run_argv(["motor", "new", *DATASHEET, "--load", "disc:mass_kg=0.1,"
                        "diameter_mm=40"], capsys)
    assert code == 0 and "travel_mm_per_rev" not in json.loads(out)


@pytest.mark.parametrize("argv, text", [
    (["--travel-mm-per-rev", "8000"], "--travel-mm-per-rev: 8000 mm is outside"),
    (["--travel-mm-per-rev", "0"], "--travel-mm-per-rev: 0 mm is outside"),
    (["--load", "screw:lead_mm=8,mass_kg=1", "--load", "belt:pulley_diameter_mm=20,"
      "mass_kg=1"], "--load: the mechanisms travel 62.8318531, 8 mm per motor revolution"),
])
def test_motor_new_refuses_a_travel_naming_flag_and_unit(
        argv: list[str], text: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_argv(["motor", "new", *DATASHEET, *argv], capsys)
    assert code == 2 and text in err and "mm" in err and len(err.splitlines()) == 1


def test_a_bundled_motor_reads_in_rev(capsys: pytest.CaptureFixture[str]) -> None:
    assert not axis_units(load_motor("nema17-1600")).linear
    code, out, _ = run_argv(["motor", "show", "nema17-1600"], capsys)
    assert code == 0 and "axis: rotary (no travel_mm_per_rev)" in out
    assert "top 1800 rpm" in out

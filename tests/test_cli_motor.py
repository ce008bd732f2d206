"""`stepramp motor new` and `stepramp motor check` through the entry point."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from profiles.motor import bundled_motor_paths, load_motor
from verify import cli

DATASHEET = ["--holding-torque-nm", "0.45", "--rated-current-a", "1.5", "--resistance-ohm",
             "1.8", "--inductance-mh", "3.2", "--supply-v", "24", "--microstep", "8",
             "--rotor-inertia-gcm2", "57", "--detent-torque-nm", "0.02"]


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = cli.main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_new_from_datasheet_with_a_lead_screw(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    out_file = tmp_path / "m.json"
    code, out, err = run(["motor", "new", *DATASHEET, "--load",
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
    code, out, _ = run(["motor", "check", str(out_file)], capsys)
    assert (code, out) == (0, f"{out_file}: ok\n")


def test_new_from_a_vendor_curve(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    csv = tmp_path / "curve.csv"
    csv.write_text("speed_rpm,torque_ozin\n30,60\n300,50\n900,20\n1500,8\n")
    code, out, err = run(["motor", "new", "--curve", str(csv), "--speed-unit", "rpm",
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
    code, out, err = run(["motor", "new", *argv, "-o", "m.json"], capsys)
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
    code, out, _ = run(["motor", "check", str(good), str(bad)], capsys)
    assert code == 1  # findings: a verdict, not unusable input
    assert out.splitlines() == [
        f"{good}: ok",
        f"{bad}: /pullout_torque/1/1: -0.4 is less than the minimum of 0",
        f"{bad}: /safety_factor: 1.5 is greater than the maximum of 1",
    ]


def test_check_unreadable_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "x.json").write_text("{nope")
    code, out, err = run(["motor", "check", str(tmp_path / "x.json")], capsys)
    assert code == 2 and "not valid JSON" in out
    assert err.startswith("stepramp motor: ") and err.count("\n") == 1 and "x.json" in err


def test_vertical_axis_load_torque_is_written(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "lift.json"
    code, _, _ = run(["motor", "new", *DATASHEET, "--load",
                      "screw:lead_mm=10,mass_kg=3,efficiency=0.8,incline_deg=90", "-o",
                      str(path)], capsys)
    assert code == 0
    obj = json.loads(path.read_text())
    assert obj["load_torque_nm"] == pytest.approx(3 * 9.80665 * 0.01 / (2 * math.pi * 0.8))
    assert "m·g·sin(90°)·lead/2π/η" in obj["sources"]["load_torque_nm"][0]["from"]
    assert load_motor(path).load_torque_nm == obj["load_torque_nm"]
    assert run(["motor", "check", str(path)], capsys)[:2] == (0, f"{path}: ok\n")

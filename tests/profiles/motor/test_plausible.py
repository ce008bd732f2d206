"""Plausible inputs (issue 32 item 3, and item 11's near-zero `motor new`): `motor new` and
`motor check` refuse, naming the option (or JSON pointer) and its unit, what no stepper's
datasheet has; N·cm is taken wherever a torque is typed; a holding torque goes with a
vendor curve. The issue's new user's motor (a 17HS19-2004S1-like NEMA17) is the example."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from profiles.motor import bundled_motor_paths, load_motor
from profiles.motor.plausible import (
    QUANTITIES,
    Label,
    curve_problem,
    file_problems,
    slip_hint,
    value_problem,
)
from profiles.motor.units import torque_to_nm
from tests.support.cli import run
from tests.support.paths import ROOT

# 0.59 N·m, 2 A, 1.4 Ω, 3.0 mH, 82 g·cm², at 24 V, 1/8 step, 1.5 A
NEMA17 = {"--holding-torque-nm": "0.59", "--rated-current-a": "2", "--resistance-ohm": "1.4",
          "--inductance-mh": "3.0", "--rotor-inertia-gcm2": "82", "--supply-v": "24",
          "--microstep": "8", "--current-a": "1.5"}


def argv(**change: str | None) -> list[str]:
    """The NEMA17's `motor new` arguments, an option changed (None: left out)."""
    given = dict(NEMA17)
    for key, value in change.items():
        given.pop("--" + key.replace("_", "-"), None)
        if value is not None:
            given["--" + key.replace("_", "-")] = value
    return ["motor", "new", *[a for kv in given.items() for a in kv]]


def said_only_assumptions(err: str) -> bool:
    """stderr holds only what `motor new` assumed (issue 32 item 1: the detent torque
    these datasheets leave out) and the friction range it writes."""
    return all(line.startswith("stepramp motor: friction") for line in err.splitlines())


def refused(capsys: pytest.CaptureFixture[str], *args: str) -> str:
    code, out, err = run(capsys, *args)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    return err.removeprefix("stepramp motor: ").rstrip("\n")


def test_the_new_users_motor_is_accepted(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, *argv())
    assert code == 0 and said_only_assumptions(err), err
    obj = json.loads(out)
    assert obj["holding_torque_nm"] == 0.59 and obj["steps_per_rev"] == 1600
    assert obj["pullout_torque"][0][1] == pytest.approx(0.59 * 1.5 / 2, rel=1e-3)


@pytest.mark.parametrize("change, says", [
    ({"current_a": "15"}, "--current-a: 15 A is above the motor's rated 2 A (--rated-current-a)"
                          ": the motor overheats and its torque is not the datasheet's "
                          "(--allow-overcurrent if the datasheet allows it)"),
    ({"inductance_mh": "0.003"}, "--inductance-mh: 0.003 mH is outside any stepper's phase "
                                 "inductance (0.05..500 mH); H typed as mH? 0.003 H = 3 mH"),
    ({"inductance_mh": "3000"}, "--inductance-mh: 3000 mH is outside any stepper's phase "
                                "inductance (0.05..500 mH); µH typed as mH? 3000 µH = 3 mH"),
    ({"holding_torque_nm": "59"}, "--holding-torque-nm: 59 N·m is outside any stepper's "
                                  "holding torque (0.001..50 N·m); N·cm typed as N·m? 59 N·cm "
                                  "= 0.59 N·m"),
    ({"rotor_inertia_gcm2": "8.2e-6"}, "--rotor-inertia-gcm2: 8.2e-06 g·cm² is outside any "
                                       "stepper's rotor inertia (0.01..1e+05 g·cm²); kg·m² "
                                       "typed as g·cm²? 8.2e-06 kg·m² = 82 g·cm²"),
    ({"resistance_ohm": "1e-300"}, "--resistance-ohm: 1e-300 Ω is outside any stepper's phase "
                                   "resistance (0.05..1000 Ω)"),
    ({"rated_current_a": "1e-6", "current_a": None},
     "--rated-current-a: 1e-06 A is outside any stepper's rated current (0.05..15 A)"),
    ({"rated_current_a": "2000", "current_a": None},
     "--rated-current-a: 2000 A is outside any stepper's rated current (0.05..15 A); mA typed "
     "as A? 2000 mA = 2 A"),
    ({"supply_v": "0.5"}, "--supply-v: 0.5 V is outside any stepper's supply voltage (1..400 V)"),
    ({"step_angle": "7"}, "--step-angle [°]: 7 does not divide 360° (1.8, 0.9, 0.72, 0.36, …; "
                          "at most 90)"),
    ({"step_angle": "nan"}, "--step-angle [°]: nan does not divide 360° (1.8, 0.9, 0.72, 0.36, "
                            "…; at most 90)"),
    ({"safety_factor": "0"}, "--safety-factor [1]: 0.0 is outside the allowed range above 0 "
                             "up to 1"),
    ({"start_pps": "0"}, "--start-pps [pps]: 0.0 is outside the allowed range above 0 up to "
                         "27214.822"),
    ({"holding_torque_nm": "5", "rotor_inertia_gcm2": "0.5"},
     "--holding-torque-nm 5 N·m against --rotor-inertia-gcm2 0.5 g·cm²: 1e+08 rad/s² of torque "
     "per inertia, where steppers' datasheets give 3e+03..1e+06 (one of the two in another "
     "unit?)"),
])
def test_implausible_values_are_refused_naming_option_and_unit(
        change: dict[str, str | None], says: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert refused(capsys, *argv(**change)) == says


def test_near_zero_blames_the_right_input(capsys: pytest.CaptureFixture[str]) -> None:
    """Before: --rated-current-a 1e-6 said "pullout_torque: speeds must start at 0",
    --start-pps 1e-6 was rounded to 0 before its check, --safety-factor 0 said "cannot
    start" (test above); a supply the back-EMF eats names --supply-v."""
    code, out, _ = run(capsys, *argv(start_pps="1e-6"))
    assert code == 0 and json.loads(out)["start_pps"] == 1e-6
    says = refused(capsys, "motor", "new", "--rotor-inertia-gcm2", "3000",
                   "--holding-torque-nm", "20", "--rated-current-a", "0.5", "--resistance-ohm",
                   "10", "--inductance-mh", "50", "--supply-v", "1")
    assert says == ("--supply-v [V] (no usable speed below it, for this back-EMF): 1.0 is "
                    "outside the allowed range 37.4..10000.0")


def test_overcurrent_when_allowed(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, *argv(current_a="2.5"), "--allow-overcurrent")
    assert code == 0 and said_only_assumptions(err), err
    assert json.loads(out)["pullout_torque"][0][1] == pytest.approx(0.59 * 2.5 / 2, rel=1e-3)


def test_ncm_wherever_torque_is_typed(capsys: pytest.CaptureFixture[str],
                                      tmp_path: Path) -> None:
    nm = run(capsys, *argv(detent_torque_nm="0.02"))[1]
    ncm = run(capsys, *argv(holding_torque_nm=None, holding_torque_ncm="59",
                            detent_torque_ncm="2"))[1]
    assert json.loads(nm) == json.loads(ncm)
    assert refused(capsys, *argv(holding_torque_nm=None, holding_torque_ncm="0.59")) == (
        "--holding-torque-ncm 0.59 N·cm against --rotor-inertia-gcm2 82 g·cm²: 7.2e+02 rad/s² "
        "of torque per inertia, where steppers' datasheets give 3e+03..1e+06 (one of the two "
        "in another unit?)")
    assert refused(capsys, *argv(holding_torque_nm=None, holding_torque_ncm="0.01")) == (
        "--holding-torque-ncm: 0.01 N·cm is outside any stepper's holding torque (0.1..5000 "
        "N·cm); N·m typed as N·cm? 0.01 N·m = 1 N·cm")
    assert refused(capsys, *argv(detent_torque_ncm="80")) == (
        "--detent-torque-ncm [N·cm]: 80.0 is outside the allowed range 0.0..59.0")
    for spelling in ("N·cm", "Ncm", "N.cm", "n cm"):
        assert torque_to_nm(59, spelling) == pytest.approx(0.59)
    code, _, err = run(capsys, *argv(), "--holding-torque-nm", "0.5", "--holding-torque-ncm",
                       "50")
    assert code == 2 and "not allowed with argument" in err
    by_nm = json.loads(run(capsys, *argv(), "--load", "inertia:friction_nm=0.03")[1])
    by_ncm = json.loads(run(capsys, *argv(), "--load", "inertia:friction_ncm=3")[1])
    assert by_nm["friction_torque_nm"] == pytest.approx(by_ncm["friction_torque_nm"])
    assert "friction_ncm gives a value given already" in refused(
        capsys, *argv(), "--load", "inertia:friction_nm=0.03,friction_ncm=3")


def curve_args(csv: Path, unit: str, *extra: str) -> list[str]:
    return ["motor", "new", "--curve", str(csv), "--speed-unit", "rpm", "--torque-unit", unit,
            "--microstep", "8", "--rotor-inertia-gcm2", "82", *extra]


def test_a_holding_torque_goes_with_a_curve(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    csv = tmp_path / "curve.csv"
    csv.write_text("speed_rpm,torque_ncm\n30,55\n300,45\n900,20\n1500,8\n")
    code, out, err = run(capsys, *curve_args(csv, "N·cm", "--holding-torque-ncm", "59"))
    assert code == 0 and said_only_assumptions(err), err
    obj = json.loads(out)
    assert obj["holding_torque_nm"] == 0.59 and obj["pullout_torque"][0][1] == 0.55
    # the same curve declared in N·m: 100× the holding torque
    says = refused(capsys, *curve_args(csv, "N·m", "--holding-torque-nm", "0.59"))
    assert says.startswith(f"--curve {csv} (--torque-unit N·m): pull-out torque up to 55 N·m "
                           "is 93.2× the holding torque 0.59 N·m (--holding-torque-nm)")
    # without a holding torque the curve is held against the rotor's inertia
    assert "rad/s² of torque per inertia" in refused(capsys, *curve_args(csv, "N·m"))
    assert "drop --resistance-ohm" in refused(capsys, *curve_args(
        csv, "N·cm", "--resistance-ohm", "1.4"))


def test_a_lead_in_metres_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    says = refused(capsys, *argv(), "--load", "screw:lead_mm=0.008,mass_kg=4")
    assert says == ("load 'screw:lead_mm=0.008,mass_kg=4': lead_mm: 0.008 mm is outside any "
                    "lead screw's lead (0.1..500 mm); m typed as mm? 0.008 m = 8 mm")
    assert "pulley_diameter_mm: 0.012 mm" in refused(
        capsys, *argv(), "--load", "belt:pulley_diameter_mm=0.012,mass_kg=1")


def test_motor_check_refuses_implausible_files(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    obj = json.loads(run(capsys, *argv())[1])
    cases = {"holding": {"holding_torque_nm": 59},
             "curve": {"pullout_torque": [[v, t * 1000] for v, t in obj["pullout_torque"]],
                       "holding_torque_nm": None},
             "inertia": {"inertia_kgm2": 5e-10}}
    for name, change in cases.items():
        changed = {k: v for k, v in {**obj, **change}.items() if v is not None}
        (tmp_path / f"{name}.json").write_text(json.dumps(changed))
    code, out, _ = run(capsys, "motor", "check", *sorted(str(p) for p in tmp_path.iterdir()))
    lines = out.splitlines()
    assert code == 1 and len(lines) == 3, out
    assert lines[0].endswith("curve.json: /inertia_kgm2: /pullout_torque/0/1 442.5 N·m against "
                             "/inertia_kgm2 8.2e-06 kg·m²: 5.4e+07 rad/s² of torque per inertia,"
                             " where steppers' datasheets give 3e+03..1e+06 (one of the two in "
                             "another unit?)")
    assert lines[1].endswith("holding.json: /holding_torque_nm: 59 N·m is outside any stepper's "
                             "holding torque (0.001..50 N·m); N·cm typed as N·m? 59 N·cm = "
                             "0.59 N·m")
    assert lines[2].endswith("inertia.json: /inertia_kgm2: 5e-10 kg·m² is below any stepper's "
                             "rotor alone (1e-09 kg·m² = 0.01 g·cm²)")
    for path in [*bundled_motor_paths(), ROOT / "examples" / "motor-nema17-tolerances.json"]:
        assert file_problems(json.loads(path.read_text())) == [], path
        load_motor(path)


def test_the_helpers() -> None:
    mh = Label("--inductance-mh", "mH", 1e3)
    assert value_problem("inductance_h", 3e-3, mh) is None
    assert value_problem("inductance_h", float("nan"), mh) is not None
    q = QUANTITIES["holding_torque_nm"]
    assert slip_hint(q, 59, Label("x", "N·m")) == "; N·cm typed as N·m? 59 N·cm = 0.59 N·m"
    assert slip_hint(q, 1e9, Label("x", "N·m")) == "" and slip_hint(q, -1, Label("x", "N·m")) == ""
    n = Label("h", "N·m")
    assert curve_problem(0.885, 0.59, n, n) is None  # 1.5×: a drive a little above the rating
    assert curve_problem(0.9, 0.59, n, n) is not None

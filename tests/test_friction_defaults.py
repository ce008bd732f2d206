"""Friction by default (issue 32 item 1): a load spec that leaves out an efficiency or the
guide's friction, and a datasheet without a detent torque, get values from vendor sizing
guides, written with their provenance ("assumed"), said on stderr, planned over a range
(friction helps a deceleration) and replaced by any value given; a motor without friction
draws a warning from `plan` and `check --motor`. The issue's new user as a test: a
17HS19-2004S1-like NEMA17 moving 4 kg on a T8 lead screw, planned with the default
friction, stays safe on the machine whose screw really has 0.032 N·m."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from profiles.errors import FormatError
from profiles.motor import load_motor
from profiles.motor.loads import (
    BALL_SCREW_EFFICIENCY,
    BELT_EFFICIENCY,
    GEAR_EFFICIENCY,
    GUIDE_FRICTION_COEFF,
    LEAD_SCREW_EFFICIENCY,
    belt,
    combine,
    lead_screw,
    loads_from_specs,
    through_gear,
)
from profiles.motor.reserve import CruiseReserve
from profiles.ppmc312.table import load_table
from tests.support.paths import ROOT
from verify import cli

G = 9.80665
R8 = 0.008 / (2 * math.pi)  # a T8 screw's 8 mm lead, per radian
# 0.59 N·m, 2 A, 1.4 Ω, 3.0 mH, 82 g·cm², at 24 V, 1/8 step, 1.5 A
NEMA17 = ["motor", "new", "--holding-torque-nm", "0.59", "--rated-current-a", "2",
          "--resistance-ohm", "1.4", "--inductance-mh", "3.0", "--rotor-inertia-gcm2", "82",
          "--supply-v", "24", "--microstep", "8", "--current-a", "1.5"]


def run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = cli.main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def friction(contributions):  # type: ignore[no-untyped-def]
    return [c for c in contributions if c.field == "friction_torque_nm"]


def test_a_lead_screw_assumes_its_efficiency_and_the_guides_friction() -> None:
    # 4 kg, T8: μ·m·g·lead/(2π·η) = 0.1 · 4 · 9.80665 · 0.0012732 / 0.35 = 0.01427 N·m
    (c,) = friction(lead_screw(0.008, 4.0))
    assert c.value == pytest.approx(GUIDE_FRICTION_COEFF * 4 * G * R8 / LEAD_SCREW_EFFICIENCY)
    assert c.value == pytest.approx(0.01427, rel=1e-3)
    assert c.low == 0 and c.assumed  # an assumed coefficient may be nothing
    assert "μ = 0.1 (assumed: " in c.source and "η = 0.35 (assumed: a trapezoidal" in c.source
    (ball,) = friction(lead_screw(0.008, 4.0, ball=True))
    assert ball.value == pytest.approx(0.1 * 4 * G * R8 / BALL_SCREW_EFFICIENCY)
    assert ball.source.startswith("ball screw: ")


def test_a_given_coefficient_with_an_assumed_efficiency_is_at_least_its_lossless_torque() -> None:
    (c,) = friction(lead_screw(0.008, 4.0, friction_coeff=0.05))
    assert c.value == pytest.approx(0.05 * 4 * G * R8 / LEAD_SCREW_EFFICIENCY)
    assert c.low == pytest.approx(0.05 * 4 * G * R8)  # η = 1
    (given,) = friction(lead_screw(0.008, 4.0, friction_coeff=0.05, efficiency=0.4))
    assert given.low is None and not given.assumed and "assumed" not in given.source


def test_friction_at_the_shaft_replaces_the_coefficient() -> None:
    (c,) = friction(lead_screw(0.008, 4.0, friction_torque_nm=0.012))
    assert (c.value, c.low) == (0.012, None) and "(given)" in c.source
    with pytest.raises(FormatError, match="not both"):
        lead_screw(0.008, 4.0, friction_torque_nm=0.012, friction_coeff=0.1)
    got = loads_from_specs(["screw:lead_mm=8,mass_kg=4,friction_ncm=1.2"])
    assert [c.value for c in friction(got)] == [pytest.approx(0.012)]


def test_a_vertical_axis_has_no_guide_friction_and_its_load_takes_the_assumed_efficiency() -> None:
    got = lead_screw(0.010, 3.0, incline_deg=90)
    assert friction(got) == []
    (load,) = [c for c in got if c.field == "load_torque_nm"]
    assert load.value == pytest.approx(3 * G * 0.01 / (2 * math.pi * LEAD_SCREW_EFFICIENCY))
    assert load.low is None  # more load torque is the safe side both ways: no range


def test_belts_and_gears_assume_theirs() -> None:
    (c,) = friction(belt(0.012732, 1.5))
    assert c.value == pytest.approx(0.1 * 1.5 * G * 0.006366 / BELT_EFFICIENCY, rel=1e-4)
    geared = through_gear(5, lead_screw(0.008, 4.0, friction_coeff=0.05, efficiency=0.4))
    (g,) = friction(geared)
    t = 0.05 * 4 * G * R8 / 0.4
    assert g.value == pytest.approx(t / (5 * GEAR_EFFICIENCY))
    assert g.low == pytest.approx(t / 5) and "assumed" in g.source
    totals = combine(geared)
    assert totals.friction_low_nm == pytest.approx(t / 5)
    assert totals.friction_torque_nm == pytest.approx(t / (5 * GEAR_EFFICIENCY))


def test_motor_new_writes_says_and_lets_the_user_override(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    out = tmp_path / "t8.json"
    code, said, err = run(capsys, *NEMA17, "--load", "screw:lead_mm=8,mass_kg=4", "-o", str(out))
    assert code == 0
    obj = json.loads(out.read_text("utf-8"))
    detent, screw = obj["sources"]["friction_torque_nm"]
    assert detent["value"] == pytest.approx(0.05 * 0.59)
    assert detent["from"].startswith("detent torque (assumed: 5 % of the holding torque 0.59")
    assert screw["value"] == pytest.approx(0.01427, rel=1e-3) and "assumed" in screw["from"]
    total = 0.0295 + screw["value"]
    assert obj["friction_torque_nm"] == pytest.approx(total)
    assert obj["tolerances"] == {"friction_torque_nm": [0.0, pytest.approx(total)]}
    assert f"friction 0..{total:.4g} N·m" in said
    lines = err.splitlines()
    assert lines[0].startswith("stepramp motor: friction_torque_nm 0.0295: detent torque "
                               "(assumed: 5 % of the holding torque")
    assert "η = 0.35 (assumed: a trapezoidal lead screw's" in lines[1]
    assert lines[2].startswith(f"stepramp motor: friction 0..{total:.4g} N·m planned over "
                               "that range (tolerances)")
    # everything given: nothing assumed, nothing said, no range
    code, said, err = run(capsys, *NEMA17, "--detent-torque-ncm", "2", "--load",
                          "screw:lead_mm=8,mass_kg=4,efficiency=0.4,friction_coeff=0.1",
                          "-o", str(out))
    obj = json.loads(out.read_text("utf-8"))
    assert (code, err) == (0, "") and "tolerances" not in obj
    assert obj["friction_torque_nm"] == pytest.approx(0.02 + 0.1 * 4 * G * R8 / 0.4)
    assert obj["friction_torque_nm"] == pytest.approx(0.032, abs=1e-3)


def new_motor(capsys: pytest.CaptureFixture[str], path: Path, *args: str) -> Path:
    code, _, err = run(capsys, *NEMA17, *args, "-o", str(path))
    assert code == 0, err
    return path


@pytest.mark.parametrize("pulses", [4000, 40000])
def test_the_new_users_tables_stay_safe_on_the_real_screw(pulses: int, tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    planned = new_motor(capsys, tmp_path / "t8.json", "--load", "screw:lead_mm=8,mass_kg=4")
    # the machine: detent 0.02 N·m, the screw's efficiency 0.4 (guide μ 0.1): 0.032 N·m
    real = new_motor(capsys, tmp_path / "real.json", "--detent-torque-nm", "0.02", "--load",
                     "screw:lead_mm=8,mass_kg=4,efficiency=0.4,friction_coeff=0.1")
    assert load_motor(real).friction_torque_nm == pytest.approx(0.032, abs=1e-3)
    table = tmp_path / "table.json"
    code, _, err = run(capsys, "plan", "--motor", str(planned), "--pulses", str(pulses),
                       "-o", str(table))
    assert code == 0, err
    code, said, _ = run(capsys, "check", str(table), "--motor", str(real))
    assert code == 0, said
    assert "error" not in said.splitlines()[-1].replace("(0 errors", "")
    # its top speed keeps the reserve, for the friction it planned with and the real one
    t = load_table(table)
    top = t.clock.hz / t.rates[0]
    assert CruiseReserve().at(load_motor(planned), top).kept
    assert CruiseReserve().at(load_motor(real), top).kept


def test_without_friction_the_same_table_fails_on_the_real_screw(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # the contrast: what friction 0 planned (the report) slips on the real screw
    zero = new_motor(capsys, tmp_path / "zero.json", "--detent-torque-nm", "0", "--load",
                     "screw:lead_mm=8,mass_kg=4,friction_coeff=0")
    real = new_motor(capsys, tmp_path / "real.json", "--detent-torque-nm", "0.02", "--load",
                     "screw:lead_mm=8,mass_kg=4,efficiency=0.4,friction_coeff=0.1")
    table = tmp_path / "table.json"
    code, _, err = run(capsys, "plan", "--motor", str(zero), "--pulses", "4000", "-o",
                       str(table))
    assert code == 0 and "warning: " in err and "friction_torque_nm is 0" in err
    code, said, _ = run(capsys, "check", str(table), "--motor", str(real))
    assert code == 1 and "stall-accel" in said


def test_a_motor_without_friction_draws_a_warning(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    root = ROOT
    obj = json.loads((root / "profiles/data/motor-nema17-1600.json").read_text("utf-8"))
    zero = tmp_path / "zero.json"
    zero.write_text(json.dumps({**obj, "friction_torque_nm": 0}), encoding="utf-8")
    code, said, _ = run(capsys, "check", str(root / "examples/free-curve-nema17.json"),
                        "--motor", str(zero), "--no-physics")
    assert code == 0 and "warning [motor-friction-zero]: friction_torque_nm is 0" in said
    boxed = tmp_path / "boxed.json"
    boxed.write_text(json.dumps({**obj, "friction_torque_nm": 0,
                                 "tolerances": {"friction_torque_nm": [0, 0.02]}}),
                     encoding="utf-8")
    code, said, _ = run(capsys, "check", str(root / "examples/free-curve-nema17.json"),
                        "--motor", str(boxed), "--no-physics")
    assert "motor-friction-zero" not in said  # a range up to some friction is friction


def test_the_designers_friction_slider_sets_it_exactly(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    from verify.designer import Settings, loaded_motor

    motor = load_motor(new_motor(capsys, tmp_path / "t8.json", "--load",
                                 "screw:lead_mm=8,mass_kg=4"))
    assert motor.tolerance("friction_torque_nm")[0] == 0  # the range `motor new` wrote
    slid = loaded_motor(motor, Settings(friction_torque_nm=0.2))  # above it: no refusal
    assert slid.friction_torque_nm == 0.2 and slid.tolerances == ()
    assert loaded_motor(motor, Settings()).tolerances == motor.tolerances

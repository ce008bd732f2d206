"""profiles/loads.py: every builder against a hand calculation (numbers worked in comments)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from profiles.errors import FieldRangeError, FormatError
from profiles.motor import load_motor
from profiles.motor.loads import (
    BALL_SCREW_EFFICIENCY,
    BELT_EFFICIENCY,
    GEAR_EFFICIENCY,
    GUIDE_FRICTION_COEFF,
    LEAD_SCREW_EFFICIENCY,
    belt,
    combine,
    direct,
    disc,
    lead_screw,
    loads_from_specs,
    mechanisms_from_specs,
    parse_load,
    through_gear,
)
from profiles.motor.reserve import CruiseReserve
from profiles.ppmc312.table import load_table
from tests.support.cli import run
from tests.support.paths import ROOT

G = 9.80665


def total(contribs, field):  # type: ignore[no-untyped-def]
    return sum(c.value for c in contribs if c.field == field)


def test_disc_is_m_d2_over_8() -> None:
    # 0.5 kg, Ø80 mm: 0.5 · 0.08² / 8 = 4.0e-4 kg·m²
    (c,) = disc(0.5, 0.080)
    assert c.field == "inertia_kgm2" and c.value == pytest.approx(4.0e-4)
    assert "0.5 kg" in c.source and "Ø80 mm" in c.source
    # a tube Ø80/Ø60: 0.5 · (0.0064 + 0.0036) / 8 = 6.25e-4
    assert disc(0.5, 0.080, 0.060)[0].value == pytest.approx(6.25e-4)


def test_lead_screw_inertia_is_m_lead_over_2pi_squared() -> None:
    # 2 kg carriage, 5 mm lead: 2 · (0.005/2π)² = 1.2665e-6 kg·m²
    got = lead_screw(0.005, 2.0, efficiency=0.9)
    assert total(got, "inertia_kgm2") == pytest.approx(2 * (0.005 / (2 * math.pi)) ** 2)
    assert total(got, "inertia_kgm2") == pytest.approx(1.26651e-6, rel=1e-5)
    assert total(got, "load_torque_nm") == 0   # horizontal


def test_screw_own_inertia_from_its_size() -> None:
    # steel Ø8 × 300 mm: 7850 · π · 0.3 · 0.008⁴ / 32 = 9.470e-7 kg·m²
    got = lead_screw(0.008, 0.0, screw_diameter_m=0.008, screw_length_m=0.3)
    assert total(got, "inertia_kgm2") == pytest.approx(9.4700e-7, rel=1e-4)
    # the same as a solid cylinder m·d²/8 with m = ρ·π·d²/4·len
    m = 7850 * math.pi * 0.008 ** 2 / 4 * 0.3
    assert total(got, "inertia_kgm2") == pytest.approx(m * 0.008 ** 2 / 8)
    assert total(lead_screw(0.008, 0.0, screw_inertia_kgm2=3e-6), "inertia_kgm2") == 3e-6


def test_vertical_screw_gravity_torque() -> None:
    # 3 kg lifted on a 10 mm lead at η = 0.8: 3 · 9.80665 · 0.01 / (2π · 0.8) = 0.058533 N·m
    got = lead_screw(0.010, 3.0, efficiency=0.8, incline_deg=90)
    assert total(got, "load_torque_nm") == pytest.approx(3 * G * 0.01 / (2 * math.pi * 0.8))
    assert total(got, "load_torque_nm") == pytest.approx(0.058533, rel=1e-4)
    assert total(got, "friction_torque_nm") == 0
    # pointing down the other way (−90°): the weight helps positive moves
    assert total(lead_screw(0.010, 3.0, efficiency=0.8, incline_deg=-90),
                 "load_torque_nm") == pytest.approx(-0.058533, rel=1e-4)


def test_incline_and_friction_split() -> None:
    # 30° incline, μ = 0.1, 4 kg, 5 mm lead, η 0.9
    got = lead_screw(0.005, 4.0, efficiency=0.9, incline_deg=30, friction_coeff=0.1, force_n=10)
    r = 0.005 / (2 * math.pi)
    assert total(got, "load_torque_nm") == pytest.approx((4 * G * 0.5 + 10) * r / 0.9)
    assert total(got, "friction_torque_nm") == pytest.approx(0.1 * 4 * G * math.cos(
        math.radians(30)) * r / 0.9)


def test_belt_and_pulley() -> None:
    # 1.5 kg on a Ø12.73 mm (GT2 20 T) pulley: J = 1.5 · 0.006366² = 6.079e-5
    got = belt(0.012732, 1.5, pulley_inertia_kgm2=2e-7, incline_deg=90, efficiency=0.95)
    assert total(got, "inertia_kgm2") == pytest.approx(1.5 * 0.006366 ** 2 + 2e-7, rel=1e-4)
    assert total(got, "load_torque_nm") == pytest.approx(1.5 * G * 0.006366 / 0.95, rel=1e-4)


def test_gear_reflects_inertia_by_n_squared_and_torque_by_n_eta() -> None:
    out = disc(2.0, 0.2) + lead_screw(0.01, 3.0, efficiency=0.8, incline_deg=90)
    j_out = total(out, "inertia_kgm2")
    t_out = total(out, "load_torque_nm")
    geared = through_gear(5, out, efficiency=0.9, gear_inertia_kgm2=1e-6)
    assert total(geared, "inertia_kgm2") == pytest.approx(j_out / 25 + 1e-6)
    assert total(geared, "load_torque_nm") == pytest.approx(t_out / (5 * 0.9))
    assert all("gear" in c.source for c in geared)


def test_direct_values_and_combine_sources() -> None:
    parts = direct(1e-5, 0.02, -0.1, name="CAD") + disc(0.5, 0.08)
    totals = combine(parts)
    assert totals.inertia_kgm2 == pytest.approx(1e-5 + 4e-4)
    assert totals.friction_torque_nm == 0.02 and totals.load_torque_nm == -0.1
    assert [s["value"] for s in totals.sources["inertia_kgm2"]] == [1e-5, pytest.approx(4e-4)]
    assert totals.sources["load_torque_nm"][0]["from"].startswith("CAD")


@pytest.mark.parametrize("call", [
    lambda: disc(0, 0.1), lambda: disc(1, -0.1), lambda: disc(1, 0.1, 0.2),
    lambda: lead_screw(0, 1), lambda: lead_screw(0.005, 1, efficiency=0),
    lambda: lead_screw(0.005, 1, efficiency=1.2), lambda: lead_screw(0.005, 1, incline_deg=120),
    lambda: through_gear(0, []), lambda: belt(0.01, -1),
])
def test_bad_values_name_the_field(call) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(FieldRangeError):
        call()


def test_screw_inertia_given_twice_is_refused() -> None:
    with pytest.raises(FormatError, match="not both"):
        lead_screw(0.005, 1, screw_inertia_kgm2=1e-6, screw_diameter_m=0.008,
                   screw_length_m=0.3)
    with pytest.raises(FormatError, match="both diameter and length"):
        lead_screw(0.005, 1, screw_diameter_m=0.008)


def test_specs_parse_in_named_units() -> None:
    kind, args = parse_load("screw:lead_mm=5,mass_kg=2,incline_deg=90,efficiency=0.85")
    assert kind == "screw"
    assert args == {"lead_m": pytest.approx(0.005), "mass_kg": 2.0, "incline_deg": 90.0,
                    "efficiency": 0.85}
    assert parse_load("cylinder:mass_kg=1,diameter_mm=50")[0] == "disc"
    for bad, msg in [("wheel:mass_kg=1", "unknown kind"), ("disc:mass_kg=1", "missing"),
                     ("disc:mass_kg=x,diameter_mm=5", "not a number"),
                     ("disc:mass=1,diameter_mm=5", "is not one of")]:
        with pytest.raises(FormatError, match=msg):
            parse_load(bad)


def test_specs_after_a_gear_are_on_its_output() -> None:
    # motor → 0.1 kg·m²-class disc directly, then a 10:1 gear driving a 2 kg Ø200 disc
    got = loads_from_specs(["inertia:j_kgm2=1e-5", "gear:ratio=10,efficiency=0.9",
                            "disc:mass_kg=2,diameter_mm=200"])
    assert total(got, "inertia_kgm2") == pytest.approx(1e-5 + 2 * 0.2 ** 2 / 8 / 100)
    # two gears multiply: 2 × 3 = 6
    got = loads_from_specs(["gear:ratio=2", "gear:ratio=3", "inertia:j_kgm2=36e-4"])
    assert total(got, "inertia_kgm2") == pytest.approx(1e-4)


def test_a_belt_of_zero_efficiency_is_refused() -> None:
    """Efficiency 0 would reflect an infinite load: the range is open at 0."""
    with pytest.raises(FieldRangeError, match=r"efficiency"):
        belt(0.02, 1.0, efficiency=0.0)
    assert belt(0.02, 1.0, efficiency=1e-3)


R8 = 0.008 / (2 * math.pi)  # a T8 screw's 8 mm lead, per radian


# 0.59 N·m, 2 A, 1.4 Ω, 3.0 mH, 82 g·cm², at 24 V, 1/8 step, 1.5 A
NEMA17 = ["motor", "new", "--holding-torque-nm", "0.59", "--rated-current-a", "2",
          "--resistance-ohm", "1.4", "--inductance-mh", "3.0", "--rotor-inertia-gcm2", "82",
          "--supply-v", "24", "--microstep", "8", "--current-a", "1.5"]


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


@pytest.mark.parametrize("specs, mm, source", [
    (["screw:lead_mm=8,mass_kg=4"], 8.0, "lead screw lead 8 mm = 8 mm/rev"),
    (["ballscrew:lead_mm=5,mass_kg=4"], 5.0, "ball screw lead 5 mm"),
    (["belt:pulley_diameter_mm=20,mass_kg=1"], 20 * math.pi, "belt pulley π·Ø20 mm"),
    # a 3:1 gear before a 10 mm lead: 10/3 mm per motor revolution; gears multiply
    (["gear:ratio=3", "screw:lead_mm=10,mass_kg=1"], 10 / 3, "/ gear 3"),
    (["gear:ratio=2", "gear:ratio=5", "belt:pulley_diameter_mm=30,mass_kg=1"],
     30 * math.pi / 10, "/ gear 2 / gear 5"),
])
def test_a_screw_a_belt_and_a_gear_give_their_travel(specs: list[str], mm: float,
                                                     source: str) -> None:
    (m,) = mechanisms_from_specs(specs)
    assert m.travel_mm_per_rev == pytest.approx(mm) and source in m.source


def test_rotary_loads_have_no_travel() -> None:
    assert mechanisms_from_specs(["disc:mass_kg=1,diameter_mm=50", "gear:ratio=3",
                                  "inertia:j_kgm2=1e-5"]) == []


def test_a_lead_in_metres_typed_as_mm_is_refused_saying_so() -> None:
    with pytest.raises(FormatError, match=r"m typed as mm\? 0\.005 m = 5 mm"):
        parse_load("screw:lead_mm=0.005,mass_kg=2")
    with pytest.raises(FormatError, match=r"outside any lead screw's lead \(0\.1\.\.500 mm\)$"):
        parse_load("screw:lead_mm=900,mass_kg=2")


def test_direct_values_refuse_a_negative_inertia() -> None:
    with pytest.raises(FieldRangeError, match="inertia_kgm2"):
        direct(inertia_kgm2=-1e-9)
    assert direct(inertia_kgm2=0.0) is not None

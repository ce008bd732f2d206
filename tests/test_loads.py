"""profiles/loads.py: every builder against a hand calculation (numbers worked in comments)."""

from __future__ import annotations

import math

import pytest

from profiles.errors import FieldRangeError, FormatError
from profiles.motor.loads import (
    belt,
    combine,
    direct,
    disc,
    lead_screw,
    loads_from_specs,
    parse_load,
    through_gear,
)

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

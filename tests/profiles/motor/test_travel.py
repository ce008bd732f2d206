"""Real units (issue 32 item 5): the motor file's travel per motor revolution, where `motor
new` takes it from, and profiles/motor/travel.py's conversions (pulses, pps, pps² ↔ mm,
mm/s, mm/s², or rev, rpm, rev/s²)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from profiles.errors import FieldRangeError, FormatError
from profiles.motor import Motor
from profiles.motor.travel import AxisUnits, axis_units, pulses_of


def motor_obj(**extra: object) -> dict[str, object]:
    return {"format": "stepramp.motor/1", "steps_per_rev": 1600,
            "pullout_torque": [[0, 0.4], [40000, 0.1]], "inertia_kgm2": 1e-5,
            "safety_factor": 0.6, "start_pps": 800, **extra}


def test_a_lead_screw_reads_in_mm() -> None:
    u = AxisUnits(1600, 8.0)          # 8 mm lead, 1600 pulses/rev: 0.005 mm per pulse
    assert u.linear and (u.distance_unit, u.speed_unit, u.accel_unit) == ("mm", "mm/s",
                                                                          "mm/s²")
    assert (u.distance_key, u.speed_key, u.accel_key) == ("mm", "mm_s", "mm_s2")
    assert u.distance(3200) == pytest.approx(16.0)
    assert u.speed(20000) == pytest.approx(100.0)       # 12.5 rev/s × 8 mm
    assert u.accel(2e5) == pytest.approx(1000.0)
    assert u.speed_text(20000) == "100 mm/s" and u.distance_text(3200) == "16 mm"


def test_a_rotary_axis_reads_in_rev_and_rpm() -> None:
    u = AxisUnits(200)
    assert not u.linear and (u.distance_unit, u.speed_unit, u.accel_unit) == ("rev", "rpm",
                                                                              "rev/s²")
    assert (u.distance_key, u.speed_key, u.accel_key) == ("rev", "rpm", "rev_s2")
    assert u.distance(500) == pytest.approx(2.5)
    assert u.speed(1000) == pytest.approx(300.0)        # 5 rev/s
    assert u.accel(400) == pytest.approx(2.0)
    assert "rotary" in u.describe()


def test_a_motor_without_travel_is_rotary_and_with_it_linear() -> None:
    assert not axis_units(Motor.from_json(motor_obj())).linear
    u = axis_units(Motor.from_json(motor_obj(travel_mm_per_rev=40.0)))
    assert u.mm_per_rev == 40.0 and u.distance(1600) == pytest.approx(40.0)


@given(st.integers(1, 10_000_000), st.floats(1e-3, 5000),
       st.integers(0, 2**32 - 1))
def test_pulses_to_mm_and_back_is_the_same_pulses(steps: int, mm_per_rev: float,
                                                   pulses: int) -> None:
    u = AxisUnits(steps, mm_per_rev)
    assert round(u.pulses(u.distance(pulses))) == pulses
    assert u.speed_pps(u.speed(float(pulses))) == pytest.approx(pulses, rel=1e-12, abs=1e-9)
    assert u.accel_pps2(u.accel(float(pulses))) == pytest.approx(pulses, rel=1e-12, abs=1e-9)
    rounded = pulses_of(u, u.distance(pulses), flag="--distance-mm", lo_pulses=0,
                        hi_pulses=2**32 - 1)
    assert rounded.pulses == pulses and rounded.exact


@given(st.integers(1, 100_000), st.floats(1e-3, 1e6))
def test_rpm_and_back(steps: int, speed_pps: float) -> None:
    u = AxisUnits(steps)
    assert u.speed(speed_pps) == pytest.approx(speed_pps * 60 / steps)
    assert u.speed_pps(u.speed(speed_pps)) == pytest.approx(speed_pps)


def test_a_length_rounds_to_the_nearest_pulse_and_says_so() -> None:
    u = AxisUnits(200, 8.0)             # 0.04 mm per pulse
    r = pulses_of(u, 10.01, flag="--distance-mm", lo_pulses=1, hi_pulses=10**6)
    assert (r.pulses, r.exact) == (250, False)            # 250.25 pulses → 250
    assert r.distance == pytest.approx(10.0)
    assert r.note("--distance-mm") == ("--distance-mm 10.01 mm is 250 pulses (rounded to "
                                       "the nearest pulse): 10 mm, -0.01 mm")
    exact = pulses_of(u, 10.0, flag="--distance-mm", lo_pulses=1, hi_pulses=10**6)
    assert exact.exact and exact.note("--distance-mm") == ""


@pytest.mark.parametrize("value", [0.0, -5.0, 1e9, math.inf, math.nan])
def test_a_length_out_of_range_is_refused_naming_flag_and_unit(value: float) -> None:
    u = AxisUnits(200, 8.0)
    with pytest.raises(FormatError, match=r"^--distance-mm: .*mm") as e:
        pulses_of(u, value, flag="--distance-mm", lo_pulses=1, hi_pulses=10**6)
    if math.isfinite(value):
        assert "0.04..40000 mm" in str(e.value)


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf])
def test_axis_units_refuse_a_travel_no_axis_has(bad: float) -> None:
    with pytest.raises(FieldRangeError, match="travel_mm_per_rev"):
        AxisUnits(200, bad)


def test_the_motor_file_keeps_its_travel_and_its_hash_sees_it() -> None:
    from profiles.provenance import content_sha256

    m = Motor.from_json(motor_obj(travel_mm_per_rev=8.0))
    assert m.to_json()["travel_mm_per_rev"] == 8.0
    assert Motor.from_json(m.to_json()).travel_mm_per_rev == 8.0
    assert "travel_mm_per_rev" not in Motor.from_json(motor_obj()).to_json()
    # the physics never reads it: one remembered plan or verdict for both
    assert m.values_key() == Motor.from_json(motor_obj()).values_key()
    # the file's identity does: a table planned before it was added names another motor
    assert content_sha256(m.to_json()) != content_sha256(motor_obj())


@pytest.mark.parametrize("bad", [0, -8, 1e7, "8"])
def test_the_loader_refuses_a_travel_no_axis_has(bad: object) -> None:
    with pytest.raises((FieldRangeError, FormatError), match="travel_mm_per_rev"):
        Motor.from_json(motor_obj(travel_mm_per_rev=bad))

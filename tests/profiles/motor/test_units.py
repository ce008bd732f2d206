"""profiles/units.py against hand conversions (values worked out in the comments)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from profiles.errors import FieldRangeError, FormatError
from profiles.motor.units import (
    OZF_IN_NM,
    curve_speed_to_pps,
    machine_to_pps,
    nm_to_torque,
    pps_to_curve_speed,
    pps_to_machine,
    speed_unit,
    torque_to_nm,
    torque_unit,
)


def test_torque_units_by_hand() -> None:
    # 1 oz·in = 0.028349523125 kg · 9.80665 m/s² · 0.0254 m = 7.0615518e-3 N·m
    assert torque_to_nm(1, "oz·in") == pytest.approx(7.0615518e-3, rel=1e-7)
    assert torque_to_nm(100, "oz-in") == pytest.approx(0.70615518, rel=1e-7)
    # 1 kgf·cm = 9.80665 N × 0.01 m
    assert torque_to_nm(10, "kgf·cm") == pytest.approx(0.980665)
    assert torque_to_nm(10, "kg-cm") == pytest.approx(0.980665)
    assert torque_to_nm(450, "mN·m") == pytest.approx(0.45)
    assert torque_to_nm(0.45, "N.m") == 0.45
    assert torque_to_nm(0.45, "Nm") == 0.45
    assert OZF_IN_NM == pytest.approx(1 / 141.6119, rel=1e-6)


@pytest.mark.parametrize("name", ["N·m", "N.m", "Nm", "n*m", "mN·m", "mNm", "oz·in", "ozin",
                                  "oz.in", "kgf·cm", "kgfcm", "kg·cm"])
def test_torque_unit_spellings(name: str) -> None:
    assert torque_unit(name) in ("N·m", "mN·m", "oz·in", "kgf·cm")


@pytest.mark.parametrize("bad", ["lbf·ft", "", "N"])
def test_unknown_torque_unit_is_a_one_line_error(bad: str) -> None:
    with pytest.raises(FormatError, match="torque unit"):
        torque_to_nm(1, bad)


def test_curve_speeds_by_hand() -> None:
    # 1.8° motor at 1/8: 1600 pps per rev
    kw = {"steps_per_rev": 1600, "microstep": 8}
    assert curve_speed_to_pps(600, "rpm", **kw) == pytest.approx(16000)   # 10 rev/s × 1600
    assert curve_speed_to_pps(10, "rps", **kw) == pytest.approx(16000)
    assert curve_speed_to_pps(2000, "Hz", **kw) == pytest.approx(16000)   # full steps × 8
    assert curve_speed_to_pps(16000, "pps", **kw) == 16000
    assert speed_unit("RPM") == "rpm" and speed_unit("hz") == "Hz"
    with pytest.raises(FormatError, match="speed unit"):
        curve_speed_to_pps(1, "deg/s", **kw)


@given(st.floats(0, 1e6), st.sampled_from(["rpm", "rps", "Hz", "pps"]),
       st.integers(1, 100_000), st.integers(1, 256))
def test_curve_speed_round_trip(value: float, unit: str, spr: int, micro: int) -> None:
    pps = curve_speed_to_pps(value, unit, steps_per_rev=spr, microstep=micro)
    back = pps_to_curve_speed(pps, unit, steps_per_rev=spr, microstep=micro)
    assert back == pytest.approx(value, rel=1e-12, abs=1e-9)


def test_machine_speeds_by_hand() -> None:
    # 8 mm lead, 1600 pps/rev: 100 mm/s = 12.5 rev/s = 20000 pps
    assert machine_to_pps(100, "mm/s", steps_per_rev=1600, mm_per_rev=8) == pytest.approx(20000)
    assert machine_to_pps(6, "m/min", steps_per_rev=1600, mm_per_rev=8) == pytest.approx(20000)
    assert machine_to_pps(0.1, "m/s", steps_per_rev=1600, mm_per_rev=8) == pytest.approx(20000)
    assert machine_to_pps(750, "rpm", steps_per_rev=1600) == pytest.approx(20000)
    assert pps_to_machine(20000, "mm/s", steps_per_rev=1600, mm_per_rev=8) == pytest.approx(100)
    assert pps_to_machine(20000, "rpm", steps_per_rev=1600) == pytest.approx(750)
    # a GT2 20-tooth pulley: 40 mm per rev
    assert pps_to_machine(3200, "mm/s", steps_per_rev=3200, mm_per_rev=40) == pytest.approx(40)


def test_linear_speed_needs_travel_per_rev() -> None:
    with pytest.raises(FormatError, match="mm_per_rev"):
        machine_to_pps(1, "mm/s", steps_per_rev=200)
    with pytest.raises(FormatError, match="mm_per_rev"):
        machine_to_pps(1, "mm/s", steps_per_rev=200, mm_per_rev=math.nan)
    with pytest.raises(FormatError, match="speed unit"):
        machine_to_pps(1, "in/s", steps_per_rev=200, mm_per_rev=5)


def test_torque_round_trip() -> None:
    for unit in ("N·m", "mN·m", "oz·in", "kgf·cm"):
        assert nm_to_torque(torque_to_nm(12.5, unit), unit) == pytest.approx(12.5)


def test_a_curve_in_hz_needs_a_microstep_of_at_least_one() -> None:
    """A driver's step frequency is pps only with the microstep it counts in: 0 is refused,
    naming the range that is allowed."""
    with pytest.raises(FieldRangeError, match=r"^microstep: 0 is outside the allowed range "
                                              r"1\.\.1048576"):
        curve_speed_to_pps(1000, "Hz", steps_per_rev=200, microstep=0)


@pytest.mark.parametrize("mm_per_rev", [0.0, -5.0, math.nan, None])
def test_a_linear_speed_needs_a_positive_travel_per_rev(mm_per_rev: float | None) -> None:
    with pytest.raises(FormatError, match=r"needs the travel per motor revolution"):
        machine_to_pps(10, "mm/s", steps_per_rev=200, mm_per_rev=mm_per_rev)


@pytest.mark.parametrize("bad", ["rpx", "zzz", "rps "])
def test_an_unknown_machine_speed_unit_is_a_one_line_error(bad: str) -> None:
    with pytest.raises(FormatError, match="speed unit"):
        machine_to_pps(1.0, bad, steps_per_rev=200)

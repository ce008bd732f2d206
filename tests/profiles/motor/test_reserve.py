"""A torque reserve at the top speed (issue 32 item 2): every plan keeps the pull-out
torque at its top speed ≥ 2× what cruising needs and ≥ 10 % of standstill by default;
`--cruise-reserve` changes it; `plan` and `show --motor` report it; init tables, sweeps,
the designer and A-Link settings keep it too."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from profiles.errors import FormatError, PlanError
from profiles.motor import Motor, load_motor
from profiles.motor.catalogue import resolve
from profiles.motor.reserve import CruiseReserve, parse_cruise_reserve
from tests.support.cli import run

NEMA23 = load_motor(resolve("nema23-heavy"))


NEMA23_CAP = 10666.6667  # where its curve falls to 2 × its 0.2 N·m friction (0.4 N·m)


def toy(friction_nm: float = 0.1, **tolerances: tuple[float, float]) -> Motor:
    return Motor(1000, np.array([0.0, 1000.0, 2000.0]), np.array([1.0, 0.5, 0.1]),
                 inertia_kgm2=1e-5, safety_factor=0.6, start_pps=100.0,
                 friction_torque_nm=friction_nm,
                 tolerances=tuple((k, lo, hi) for k, (lo, hi) in tolerances.items()))


@pytest.mark.parametrize("text, spec", [("2x,10%", "2x,10%"), ("3x", "3x,10%"),
                                        ("15%", "2x,15%"), ("1.5×, 5 %", "1.5x,5%"),
                                        ("off", "off"), ("1x,0%", "off")])
def test_the_option_reads(text: str, spec: str) -> None:
    assert parse_cruise_reserve(text).spec == spec


@pytest.mark.parametrize("text, says", [
    ("3", "--cruise-reserve: expected FACTORx,SHARE% (e.g. 2x,10%; a factor of what cruising "
          "needs, a share of the standstill torque) or off, got '3'"),
    ("0.5x", "--cruise-reserve: 0.5× what cruising needs is outside 1..100×"),
    ("100%", "--cruise-reserve: 100 % of the standstill torque is outside 0..100 % "
             "(100 excluded)"),
])
def test_a_bad_option_is_one_line_naming_it(text: str, says: str) -> None:
    with pytest.raises(FormatError) as e:
        parse_cruise_reserve(text)
    assert str(e.value) == says


def test_the_top_speed_by_hand() -> None:
    # floor max(2 × 0.1, 10 % × 1) = 0.2 N·m: on the segment 0.5 → 0.1 N·m over 1000..2000
    assert CruiseReserve().top_pps(toy()) == pytest.approx(1000 + 0.3 / 0.4 * 1000)
    # no friction: 10 % of 1 N·m = 0.1 N·m, the curve's last point
    assert CruiseReserve().top_pps(toy(0.0)) == pytest.approx(2000)
    assert CruiseReserve.off().top_pps(toy()) == 2000
    capped = CruiseReserve().applied(toy())
    assert capped.max_pps == pytest.approx(1750) and capped.top_pps == pytest.approx(1750)
    assert CruiseReserve.off().applied(toy()) is not None
    plain = toy(0.0)
    assert CruiseReserve().applied(plain) is plain  # nothing to cap: the same motor
    kept = CruiseReserve().at(toy(), 1750)
    assert kept.kept and kept.times_need == pytest.approx(2) and kept.share == pytest.approx(0.2)
    assert not CruiseReserve().at(toy(), 1800).kept


def test_over_a_tolerance_box_the_worst_case_counts() -> None:
    # friction 0.05..0.15: the most friction, 0.15 N·m, needs 0.3 N·m: 1000 + 0.2/0.4 × 1000
    boxed = toy(0.1, friction_torque_nm=(0.05, 0.15))
    assert CruiseReserve().top_pps(boxed) == pytest.approx(1500)


def test_a_reserve_no_speed_keeps_is_one_line() -> None:
    with pytest.raises(PlanError, match=r"^--cruise-reserve 20x,10% \(pull-out ≥ 20× what "
                                        r"cruising needs and ≥ 10 % of standstill\): the "
                                        r"pull-out torque never reaches 2 N·m"):
        CruiseReserve(20.0).applied(toy())
    # 96 % of 1 N·m: (1 − 0.96) / 0.5 N·m per 1000 pps = 80 pps, under the start speed
    with pytest.raises(PlanError, match=r"keeps 0.96 N·m only up to 80 pps, not above the "
                                        r"start speed 100 pps"):
        CruiseReserve(1.0, 0.96).applied(toy())


def test_a_sweep_and_the_designer_plan_to_it() -> None:
    from verify.designer import Settings, design
    from verify.sweep import jobs_of, run_job

    [job] = jobs_of([("nema23", NEMA23.to_json())], [40000], samples=0, load_angle_deg=None,
                    cruise_reserve="3x")
    row = run_job(job)
    assert row["top_pps"] <= CruiseReserve(3.0).top_pps(NEMA23) + 1e-6
    result = design(NEMA23, Settings(pulses=40000, cruise_reserve="3x", plan_to_aim=False),
                    load_angle=False)
    table = result.plan.table
    assert table.clock.hz / table.rates[0] <= CruiseReserve(3.0).top_pps(NEMA23) + 1e-6
    assert result.motor.max_pps is None  # judged on the motor as loaded, uncapped


def test_alink_settings_keep_it(capsys: pytest.CaptureFixture[str]) -> None:
    strict = CruiseReserve(6.0)
    top = strict.top_pps(NEMA23)
    code, said, err = run(capsys, "alink", "settings", "--motor", "nema23-heavy", "--pulses",
                          "200000", "--cruise-reserve", "6x", "--format", "json")
    assert code == 0, err
    doc = json.loads(said)
    assert doc["high_pps"] <= top
    assert doc["provenance"]["cruise_reserve"] == "6x,10%"
    code, said, _ = run(capsys, "alink", "settings", "--motor", "nema23-heavy", "--pulses",
                        "200000", "--cruise-reserve", "off", "--format", "json")
    assert json.loads(said)["high_pps"] > top  # the reserve is what held it


def test_the_bundled_motors_caps() -> None:
    # the light motors keep the reserve to their curve's end; the heavy NEMA23 does not
    assert CruiseReserve().top_pps(load_motor(resolve("nema17-1600"))) == 48000
    assert CruiseReserve().top_pps(NEMA23) == pytest.approx(NEMA23_CAP, rel=1e-6)
    assert dataclasses.replace(NEMA23).max_pps is None

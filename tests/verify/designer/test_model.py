"""What the designer computes (verify/designer/model.py): settings to plans, a change in
steps, the one verdict, the sliders' ranges."""

from __future__ import annotations

from dataclasses import replace as dataclasses_replace
from pathlib import Path

import pytest

from profiles.errors import StepRampError
from profiles.motor import bundled_motor_paths, load_motor
from profiles.motor.reserve import parse_cruise_reserve
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import load_table
from tests.support.designer_settings import NEMA17, NEMA17_PATH, RINGS
from verify.designer import (
    JUDGING,
    TIGHTENING,
    Settings,
    control_specs,
    design,
    design_steps,
    loaded_motor,
    verdict,
)


def test_verdict_is_the_one_safety_verdict_over_every_move() -> None:
    from profiles.ppmc312.table import FreeCurveTable
    from verify.safety import judge_safety

    result = design(NEMA17, Settings(pulses=3_000))
    assert result.verdict is not None and result.physics is not None
    assert result.verdict.to_json() == judge_safety(
        result.plan.table, result.motor, aim_deg=result.settings.load_angle_aim_deg).to_json()
    assert result.verdict.moves is None  # every move the table can run, not only this one
    worst = result.verdict.load_angle.worst_deg  # type: ignore[union-attr]
    assert worst >= abs(result.physics.worst_angle_deg) - 0.1
    level = "safe" if worst <= result.settings.load_angle_aim_deg else "past-aim"
    assert verdict(result).level == level and verdict(result).safe

    tight = design(NEMA17, dataclasses_replace(result.settings, load_angle_aim_deg=worst - 1,
                                               plan_to_aim=False))
    assert verdict(tight).level == "past-aim" and verdict(tight).safe
    violent = FreeCurveTable(result.plan.table.clock, (200, 10_000), (400, 400))
    unsafe = dataclasses_replace(result, verdict=judge_safety(violent, result.motor))
    assert verdict(unsafe).level == "unsafe" and not verdict(unsafe).safe
    assert "criterion" in verdict(unsafe).text
    stalls = dataclasses_replace(result, verdict=None, margins={**result.margins, "min": 0.97})
    assert verdict(stalls).level == "unsafe" and "0.970 < 1" in verdict(stalls).text
    assert f"verdict: {verdict(result).text}" in result.summary()

def test_friction_reaches_the_plan() -> None:
    base = Settings(pulses=3_000)
    plain = design(NEMA17, base, load_angle=False)
    rough = design(NEMA17, dataclasses_replace(base, friction_torque_nm=0.06), load_angle=False)
    assert rough.motor.friction_torque_nm == 0.06
    assert rough.execution.duration_s > plain.execution.duration_s
    with pytest.raises(StepRampError, match="load_angle_aim_deg"):
        design(NEMA17, dataclasses_replace(base, load_angle_aim_deg=120.0))

@pytest.mark.slow
def test_plan_to_aim_plans_as_stepramp_plan_does() -> None:
    from profiles.ppmc312.planner import plan_free_curve

    base = Settings(pulses=3_000, load_angle_aim_deg=40.0)
    aimed = design(NEMA17, dataclasses_replace(base, plan_to_aim=True))
    assert aimed.plan.table == plan_free_curve(loaded_motor(NEMA17, base), pulses=3_000,
                                               load_angle_deg=40.0).table
    assert aimed.plan.table != design(NEMA17, dataclasses_replace(base, plan_to_aim=False),
                                      load_angle=False).plan.table
    assert aimed.physics is not None and abs(aimed.physics.worst_angle_deg) <= 40.0

def test_control_specs_hold_the_motors_values_within_their_ranges() -> None:
    specs = control_specs(NEMA17, 5_000)
    assert specs["pulses"].value == 5_000 and specs["pulses"].integer
    assert specs["safety_factor"].value == NEMA17.safety_factor
    assert specs["friction_torque_nm"].value == NEMA17.friction_torque_nm
    for spec in specs.values():
        assert spec.lo <= spec.value <= spec.hi and spec.step > 0
    with pytest.raises(StepRampError, match="pulses"):
        control_specs(NEMA17, 5)

def test_a_change_shows_a_marked_first_table_then_the_final_one() -> None:
    first, final, judged = design_steps(NEMA17, RINGS)
    assert (first.final, final.final, judged.final) == (False, True, True)
    assert (first.complete, final.complete, judged.complete) == (False, False, True)
    # the first is the plain criterion's table for the same loaded motor and reserve
    plain = plan_free_curve(parse_cruise_reserve(RINGS.cruise_reserve).applied(
        loaded_motor(NEMA17, RINGS)), pulses=RINGS.pulses)
    assert first.plan.table == plain.table
    assert first.verdict is None and first.physics is None
    said = verdict(first)
    assert said.level == "tightening" and not said.safe and TIGHTENING in said.text
    assert first.summary().startswith(TIGHTENING)
    # the tightening changed it; the final one is judged, safe and said so
    assert final.plan.table != first.plan.table
    assert final.verdict is not None and verdict(final).level == "safe"
    assert TIGHTENING not in final.summary() and TIGHTENING not in verdict(final).text
    # judged for the moves and decel stops first, saying the other commands are judged
    assert [name for name, _ in final.verdict.commands] == ["decel-stop"]
    assert verdict(final).text.endswith(JUDGING)
    # then the same table with the verdict over every command: design()'s
    whole = design(NEMA17, RINGS)
    assert judged.plan is final.plan and judged.plan.table == whole.plan.table
    assert judged.verdict.to_json() == whole.verdict.to_json()
    assert verdict(judged) == verdict(whole) and JUDGING not in verdict(judged).text

def test_without_the_aim_or_the_load_angle_a_change_is_one_step() -> None:
    plain = Settings(pulses=3_000, plan_to_aim=False)
    assert [r.final for r in design_steps(NEMA17, plain, load_angle=False)] == [True]
    assert [r.final for r in design_steps(NEMA17, plain)] == [False, True, True]  # judged

def test_the_final_table_is_the_one_stepramp_plan_writes(tmp_path: Path) -> None:
    from verify import cli

    out = tmp_path / "plan.table.json"
    assert cli.main(["plan", "--motor", str(NEMA17_PATH), "--pulses", str(RINGS.pulses),
                     "-o", str(out)]) == 0
    _, final, judged = design_steps(NEMA17, RINGS)
    assert final.plan.table == judged.plan.table == load_table(out)

@pytest.mark.slow  # NEMA23: a few tightening plans and two verdicts, about 1.5 s
def test_the_verdict_on_the_motor_as_planned_is_the_loaded_motors() -> None:
    """The final design is judged on the motor the planner had (the loaded motor with its
    top speed capped for the cruise reserve), so the tightening's verdicts are reused;
    the verdict is the one `check --motor` gives on the loaded motor."""
    from verify.safety import judge_safety

    nema23 = load_motor(next(p for p in bundled_motor_paths() if "nema23" in p.name))
    settings = Settings(pulses=12_000, safety_factor=nema23.safety_factor)
    loaded = loaded_motor(nema23, settings)
    capped = parse_cruise_reserve(settings.cruise_reserve).applied(loaded)
    assert capped.top_pps < loaded.top_pps  # the reserve binds on this motor
    final = design(nema23, settings)
    assert final.verdict is not None
    assert final.verdict.to_json() == judge_safety(final.plan.table, loaded).to_json()

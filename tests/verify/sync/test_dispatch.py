"""verify.sync.dispatch: an A-Link axes file in time mode is planned tightened on the one
verdict (each axis's settings as `alink settings --motor` tightens them), both axes still
ending together."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from profiles.alink import move_time_s
from profiles.alink.sync import plan_sync
from tests.support.cli import run
from tests.support.paths import ROOT
from verify.devices import load_axes
from verify.devices.alink import sync_judge_for
from verify.sync.dispatch import motor_axes, plan_axes


@pytest.mark.slow
def test_time_sync_tightens_a_datasheet_axis_and_keeps_the_axes_together(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    motor = tmp_path / "17hs19.json"
    assert run(capsys, "motor", "new", "--name", "17hs19", "--holding-torque-nm", "0.59",
               "--rated-current-a", "2", "--current-a", "1.5", "--resistance-ohm", "1.4",
               "--inductance-mh", "3.0", "--rotor-inertia-gcm2", "82", "--supply-v", "24",
               "--microstep", "8", "--load", "screw:lead_mm=8,mass_kg=4", "-o", motor)[0] == 0
    axes_path = tmp_path / "axes.json"
    axes_path.write_text(json.dumps({
        "format": "stepramp.axes/1", "mode": "time", "device": "alink", "axes": [
            {"name": "a", "motor": str(ROOT / "profiles/data/motor-nema17-1600.json"),
             "pulses": 8000},
            {"name": "b", "motor": str(motor), "pulses": 3000}]}))
    axes = load_axes(axes_path)
    untightened = plan_sync(motor_axes(axes), "time")
    judges = [sync_judge_for(a.motor) for a in untightened.axes]
    assert not all(j(a.settings).within_aim for j, a in zip(judges, untightened.axes,
                                                             strict=True))
    plan = plan_axes(axes)
    assert all(j(a.settings).within_aim for j, a in zip(judges, plan.axes, strict=True))
    ends = [move_time_s(a.settings, abs(a.pulses)).duration_s for a in plan.axes]
    assert max(ends) - min(ends) <= 1e-3 * max(ends)


def test_line_sync_of_the_example_is_planned_as_before() -> None:
    """Line mode is not tightened (its axes are proportional): the bundled example plans
    the same settings with or without the judge."""
    axes = load_axes(ROOT / "examples/axes-alink.json")
    with_judge = plan_axes(axes)
    without = plan_sync(motor_axes(axes), "line")
    assert [a.settings for a in with_judge.axes] == [a.settings for a in without.axes]

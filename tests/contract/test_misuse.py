"""Misuse is an error (issue #19): options that need another one exit 2 naming it, and no
command prints a comparison that cannot differ."""

from __future__ import annotations

import json

import pytest

from tests.support.paths import ROOT
from verify import cli

TABLE = str(ROOT / "examples" / "free-curve-nema17.json")


@pytest.mark.parametrize("option", [["--strict"], ["--no-physics"], ["--pulses", "100"]])
def test_check_options_of_the_stall_verdict_need_a_motor(
        option: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["check", TABLE, *option]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err == (f"stepramp check: {option[0]} applies to the stall verdict: it needs "
                   "--motor\n")
    # with the motor it is a verdict
    assert cli.main(["check", TABLE, *option, "--motor", "nema17-1600", "--no-physics"]) == 0


def test_alink_settings_prints_no_comparison_equal_by_construction(
        capsys: pytest.CaptureFixture[str]) -> None:
    from profiles import alink
    from profiles.motor import load_motor

    # the reason: the unit's move-time model does not depend on the ramp shape
    plan = alink.plan_settings(load_motor("nema17-1600"), pulses=3200, s_curve=False)
    s = plan.table
    both = [alink.move_time_s(alink.AlinkSettings(s.start_pps, s.high_pps, s.accel_para,
                                                  s.max_pps, shape), 3200).duration_s
            for shape in (False, True)]
    assert both[0] == both[1]
    for shape in ([], ["--s-curve"]):
        assert cli.main(["alink", "settings", "--motor", "nema17-1600", "--pulses", "3200",
                         *shape]) == 0
        out = capsys.readouterr().out
        assert "predicted_time_s" in out
        assert "linear_time_s" not in out and "s_curve_time_s" not in out
        assert cli.main(["alink", "settings", "--motor", "nema17-1600", "--pulses", "3200",
                         "--format", "json", *shape]) == 0
        doc = json.loads(capsys.readouterr().out)
        assert "predicted_time_s" in doc
        assert "linear_time_s" not in doc and "s_curve_time_s" not in doc

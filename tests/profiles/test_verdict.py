"""profiles.verdict: the one verdict's nouns, which every device's judge speaks."""

from __future__ import annotations

import subprocess
import sys

import pytest

from profiles.errors import FieldRangeError
from profiles.verdict import (
    DEFAULT_SAMPLES,
    LoadAngle,
    SafetyVerdict,
    envelope_findings,
    require_aim,
)
from tests.support.paths import ROOT


def test_the_nouns_load_without_numpy() -> None:
    """The CLI reads DEFAULT_SAMPLES for its --help: importing the nouns must not load numpy."""
    code = "import sys, profiles.verdict; print('numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, check=True).stdout.strip()
    assert out == "False" and DEFAULT_SAMPLES > 0


@pytest.mark.parametrize("aim", [0.5, 90.5, float("nan")])
def test_an_aim_outside_1_to_90_degrees_is_refused(aim: float) -> None:
    with pytest.raises(FieldRangeError, match="load angle aim"):
        require_aim(aim)


def test_the_aim_s_ends_are_taken() -> None:
    require_aim(1.0)
    require_aim(90.0)


def test_an_envelope_finding_by_how_far_the_use_goes() -> None:
    args = ("rule-x", "runs at 5000 pps", "this table")
    assert envelope_findings(*args, safe=True, within_aim=True, aim_deg=75) == []
    (warn,) = envelope_findings(*args, safe=True, within_aim=False, aim_deg=60)
    assert (warn.severity, warn.rule) == ("warning", "rule-x") and "60° aim" in warn.message
    (err,) = envelope_findings(*args, safe=False, within_aim=False, aim_deg=60)
    assert err.severity == "error" and err.message.endswith("with this table")


def test_a_verdict_past_the_peak_fails_the_load_angle() -> None:
    la = LoadAngle(95.0, 120, -1, "nominal", 100, False, 10)
    verdict = SafetyVerdict(None, 75.0, (), la, None, ())
    assert not la.stable and la.margin_deg == -5.0
    assert verdict.failed == ("load angle",) and not verdict.within_aim
    (found,) = verdict.findings()
    assert found.rule == "load-angle" and "backward move of 120 pulses" in found.message
    assert verdict.to_json()["worst_direction"] == "backward"

"""verify.sync.report: the line deviation it reports, recomputed here independently."""

from __future__ import annotations

import pytest

from profiles.ppmc312.sync import (
    plan_line_sync,
)
from tests.support.sync_checks import NEMA17, independent_deviation, independent_spread
from verify.sync import sync_report


# --------------------------------------------------------------------------- line mode
@pytest.fixture(scope="module")
def line_plan():
    return plan_line_sync([("x", NEMA17, 12_000), ("y", NEMA17, -7_001)])


@pytest.mark.slow  # a line sync (~2 s); CI runs it
def test_line_deviation_recomputed_equals_the_report(line_plan) -> None:
    a, b = (x.execution for x in line_plan.axes)
    ours = independent_deviation(a, b)
    report = sync_report(line_plan, device="ppmc312")
    assert report["max_line_deviation_pulses"] == pytest.approx(ours, rel=1e-9, abs=1e-9)
    assert report["finish_spread_s"] == pytest.approx(independent_spread([a, b]), abs=1e-12)

"""profiles.alink.sync.plan: A-Link synchronised plans, as `stepramp sync` writes them."""

from __future__ import annotations

import pytest

from profiles import alink
from profiles.alink.sync import (
    is_stall_safe,
    plan_line_sync,
    plan_time_sync,
    pulse_times_s,
)
from profiles.joint import spread_tolerance_s
from tests.support.sync_checks import NEMA17, PK566


# --------------------------------------------------------------------------- A-Link
def test_alink_time_sync_ends_together_with_quantised_safe_settings() -> None:
    plan = plan_time_sync([("a", NEMA17, 12_000), ("b", PK566, -3_000)])
    times = [pulse_times_s(a.settings, abs(a.pulses)) for a in plan.axes]
    ends = [float(t[-1]) for t in times]
    assert max(ends) - min(ends) == pytest.approx(plan.spread_s, abs=1e-9)
    assert plan.spread_s <= spread_tolerance_s(plan.duration_s)
    for a in plan.axes:
        s = a.settings
        m = s.multiplier
        assert s.start_pps % m == 0 and s.high_pps % m == 0 and s.accel_para % m == 0
        assert is_stall_safe(s, a.motor)
        # the unit runs them unchanged
        run = alink.unit_applies(s.start_pps, s.high_pps, s.accel_para)
        assert not run.corrections and run.nak is None


def test_alink_line_sync_keeps_the_line() -> None:
    plan = plan_line_sync([("a", NEMA17, 8_000), ("b", NEMA17, 3_000)])
    a, b = (pulse_times_s(x.settings, abs(x.pulses)) for x in plan.axes)
    # independent: positions counted by bisection per instant, 2-D cross product
    import numpy as np

    t = np.union1d(a, b)
    xa = np.array([np.count_nonzero(a <= ti) for ti in t], dtype=float)
    xb = np.array([np.count_nonzero(b <= ti) for ti in t], dtype=float)
    dev = float(np.max(np.abs(xa * 3_000 - xb * 8_000)) / np.hypot(8_000, 3_000))
    from profiles.pulses import line_deviation as line_deviation_times

    assert line_deviation_times([a, b])[0] == pytest.approx(dev, rel=1e-9)
    assert dev < 3
    assert all(is_stall_safe(x.settings, x.motor) for x in plan.axes)

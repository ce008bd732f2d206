"""profiles.joint: the finish spread synchronised axes are allowed."""

from __future__ import annotations

import pytest

from profiles.joint import spread_tolerance_s


@pytest.mark.parametrize(("duration_s", "allowed_s"),
                         [(1.0, 1e-3), (10.0, 1e-2), (0.2, 200e-6), (0.05, 200e-6)])
def test_finish_spread_allowed_is_a_tenth_of_a_percent_or_200_us(duration_s: float,
                                                                 allowed_s: float) -> None:
    """docs/manual-notes.md, "Synchronised axes": max(0.1 % of the move, 200 µs)."""
    assert spread_tolerance_s(duration_s) == pytest.approx(allowed_s)

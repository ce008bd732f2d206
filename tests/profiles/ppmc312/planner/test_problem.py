"""profiles.ppmc312.planner.problem: the planning problem (shaping scales capability and
jump band by band)."""

from __future__ import annotations

import numpy as np
import pytest

from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.planner import Shaping

MOTORS = {p.stem.removeprefix("motor-"): load_motor(p) for p in bundled_motor_paths()}


NEMA23 = MOTORS["nema23-heavy"]


def test_shaping_scales_capability_and_jump_band_by_band() -> None:
    from profiles.ppmc312.planner import choose_clock, make_problem

    clock = choose_clock(NEMA23)
    bands = Shaping.bands(NEMA23)
    shaping = bands.scaled({bands.band(5000.0): 0.5})
    plain = make_problem(NEMA23, clock, True)
    gentle = make_problem(NEMA23, clock, True, shaping)
    for f_slow, in_band in ((5000.0, True), (310.0, False)):  # the gentler band, another
        r_slow = np.array([round(clock.hz / f_slow)])
        r_fast = np.array([round(clock.hz / (f_slow + 100.0))])  # a step of 100 pps
        n0, d0, ok0 = plain.counts(r_slow, r_fast)
        n1, d1, ok1 = gentle.counts(r_slow, r_fast)
        assert ok0[0] and ok1[0]
        if in_band:  # half the torque share: about twice the accel pulses for the step
            # (decel less: friction, which helps it, is not scaled)
            assert n1[0] >= 2 * n0[0] - 1 > n0[0] and d1[0] > d0[0]
        else:
            assert n1[0] == n0[0] and d1[0] == d0[0]
    assert float(gentle.jump_at(5000.0)) == pytest.approx(0.5 * NEMA23.jump_pps)
    assert float(gentle.jump_at(300.0)) == pytest.approx(NEMA23.jump_pps)

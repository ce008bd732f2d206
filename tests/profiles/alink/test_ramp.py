"""profiles.alink.ramp: the A-Link unit's ramp as stages, against a plain-Python stepping
of the unit (multiplier, decel stops, triangles, resonance dwells)."""

from __future__ import annotations

import numpy as np
import pytest

from profiles.alink.model import quantise_settings
from profiles.alink.ramp import RAMP_HZ, build_ramp, parts, ramp_of, segments
from profiles.motor import load_motor
from profiles.motor.catalogue import resolve
from tests.support.alink_oracle import stepped
from verify.safety import judge_safety


@pytest.mark.parametrize("shape", ["linear", "s_curve"])
def test_stages_are_the_stepped_unit(shape: str) -> None:
    """A ramp of at most 250 speed steps: the model's pulses are the stepped unit's, pulse
    for pulse, for triangles, the move just reaching the top and a trapezoid."""
    ramp = build_ramp(400, 2000, 40_000.0, 10, shape)  # 160 steps
    assert ramp.steps == 160
    for n in (1, 2, 7, 30, 2 * ramp.ramp_pulses - 1, 2 * ramp.ramp_pulses,
              2 * ramp.ramp_pulses + 13):
        rate, count, _ = segments(ramp, parts(ramp, "move", np.array([n])))
        model = np.repeat(RAMP_HZ / rate.astype(float), count)
        unit = stepped(400, 2000, 40_000.0, 10, shape, n)
        assert len(model) == n == len(unit)
        np.testing.assert_allclose(model, unit, rtol=1e-6)


def test_decel_stop_runs_the_ramp_down_from_its_stage() -> None:
    ramp = build_ramp(400, 2000, 40_000.0, 10, "linear")
    ends = np.cumsum(ramp.pulses)
    x = int(ends[5]) + 1   # the first pulse of stage 6
    p = parts(ramp, "stop", np.array([x]))
    assert (int(p.up[0]), int(p.middle[0]), int(p.down[0])) == (x, 0, int(ends[6]))


def test_ramp_of_settings_uses_the_multiplier() -> None:
    ramp = ramp_of(quantise_settings(800, 20000, 5.0, s_curve=True))
    assert ramp.multiplier == 10 and ramp.shape == "s_curve"
    assert ramp.speeds_pps[0] == 800 and ramp.speeds_pps[-1] < 20000


def test_triangle_avoidance_runs_a_third_at_the_speed_reached() -> None:
    ramp = build_ramp(400, 20000, 40_000.0, 10, "linear", triangle_avoidance=True)
    p = parts(ramp, "move", np.array([31, 3 * ramp.ramp_pulses + 5]))
    assert (p.up.tolist(), p.middle.tolist(), p.down.tolist()) == (
        [10, ramp.ramp_pulses], [11, ramp.ramp_pulses + 5], [10, ramp.ramp_pulses])


def test_a_cruise_in_a_resonance_band_is_a_dwell() -> None:
    from dataclasses import replace

    motor = replace(load_motor(resolve("nema17-1600")),
                    resonance_bands_pps=((19000.0, 21000.0),))
    inside = judge_safety(ramp_of(quantise_settings(800, 20000, 5.0)), motor,
                          load_angle=False)
    assert [f.rule for f in inside.resonance] == ["resonance-dwell"]
    assert inside.resonance[0].severity == "warning"
    strict = judge_safety(ramp_of(quantise_settings(800, 20000, 5.0)), motor,
                          load_angle=False, strict=True)
    assert not strict.safe
    outside = judge_safety(ramp_of(quantise_settings(800, 25000, 5.0)), motor,
                           load_angle=False)
    assert not outside.resonance   # the ramp crosses the band: no finding


@pytest.mark.parametrize("shape", ["linear", "s_curve"])
def test_ramps_to_several_tops_are_each_ramp(shape: str) -> None:
    """build_ramps (the linear ones' pulses counted once, on the ramp to the highest top)
    gives each ramp build_ramp does: fine ones grouped into 250 stages, exact ones, none."""
    from profiles.alink.ramp import build_ramps

    tops = [800.0, 900.5, 4000.0, 24_000.0, 48_000.0]
    for top, ramp in zip(tops, build_ramps(800, tops, 147_059.0, 20, shape), strict=True):
        alone = build_ramp(800, top, 147_059.0, 20, shape)
        assert ramp.steps == alone.steps and ramp.high_pps == top
        np.testing.assert_array_equal(ramp.pulses, alone.pulses)
        np.testing.assert_array_equal(ramp.speeds_pps, alone.speeds_pps)


def test_a_ramps_key_tells_its_multiplier() -> None:
    """Two ramps of no steps (L = H) differ by their multiplier only, which sets the speed
    changes' and limit runs' grid: their keys (what a verdict is remembered by) differ."""
    assert build_ramp(1000, 1000, 1e5, 1).key() != build_ramp(1000, 1000, 1e5, 2).key()

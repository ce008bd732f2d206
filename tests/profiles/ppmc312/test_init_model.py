"""profiles.ppmc312.init_model: the documented model of the staircase the chip builds."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from profiles.errors import FieldRangeError, InitBuildError, StepRampError
from profiles.ppmc312.chip_rules import check_table
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.init_model import (
    expand_init,
    init_parameter_problem,
    init_stage_problem,
)
from profiles.ppmc312.table import FreeCurveTable, InitTable

C8 = Clock.internal("8MHz")


def side(f: FreeCurveTable, which: str) -> tuple[np.ndarray, np.ndarray]:
    """(rates, pulses) of one side, slowest stage first."""
    pulses = f.accel_pulses if which == "accel" else f.decel
    n = len(pulses)
    return (np.asarray(f.rates[:n], dtype=float)[::-1],
            np.asarray(pulses, dtype=float)[::-1])


def law_deviation(f: FreeCurveTable, which: str, shape: str) -> tuple[float, float]:
    """Largest |speed − law(start time)| over the stages, and the bound pulse rounding allows.

    Stage k starts at Σ_{j<k} pulses_j · rate_j / f; the law runs from the side's end
    speed at t = 0 to the high speed at the start of the high stage.
    """
    hz = f.clock.hz
    rates, pulses = side(f, which)
    speeds = hz / rates
    starts = np.concatenate([[0.0], np.cumsum(pulses * rates / hz)[:-1]])
    t_top = starts[-1]
    v0, vh = speeds[0], speeds[-1]
    if shape == "linear":
        law = v0 + (vh - v0) * starts / t_top
        slope = (vh - v0) / t_top
    else:
        law = v0 + (vh - v0) * (1 - np.cos(np.pi * starts / t_top)) / 2
        slope = (vh - v0) * np.pi / (2 * t_top)
    # Each count is within 1 of its ideal value, so each start time is off by at most
    # Σ rate_j / f; the top point's own error tilts the law by as much again.
    bound = 2 * slope * float(np.sum(rates[:-1])) / hz + 1e-6 * vh
    return float(np.max(np.abs(speeds - law))), bound


@st.composite
def init_tables(draw: st.DrawFn) -> InitTable:
    shape = draw(st.sampled_from(["linear", "s_curve"]))
    clock = draw(st.sampled_from([C8, Clock.internal("1MHz"), Clock.extck(4e6)]))
    # Within 2 Mpps, so that the only possible chip complaint is the model's 0x05.
    high = draw(st.integers(max(2, int(np.ceil(clock.hz / 2e6))), 3000))
    start = draw(st.integers(high + 0x80, min(0xFFFF, high + 60000)))
    accel = draw(st.integers(0x100, 0xFFFFF))
    if draw(st.booleans()):
        stop = draw(st.integers(high + 0x80, min(0xFFFF, high + 60000)))
        decel = draw(st.integers(0x100, 0xFFFFF))
        return InitTable(clock, shape, start, high, accel, stop, decel)
    return InitTable(clock, shape, start, high, accel)


@pytest.mark.slow  # 2–4 s: the quick suite's budget; CI runs it
@settings(max_examples=120, deadline=None)
@given(init_tables())
def test_expansion_keeps_totals_ends_and_order(t: InitTable) -> None:
    problem = init_stage_problem(t)
    assume(problem is None)
    f = expand_init(t)
    assert f.accel_total == t.accel_pulses
    assert f.decel_total == t.effective_decel_pulses
    assert f.separate == t.separate
    assert f.rates[0] == t.high_rate                       # fastest stage at the high rate
    assert f.rates[len(f.accel_pulses) - 1] == t.start_rate  # accel starts at the start rate
    assert f.rates[len(f.decel) - 1] == t.effective_stop_rate
    assert all(a < b for a, b in zip(f.rates, f.rates[1:], strict=False))  # monotone speeds
    assert 2 <= len(f.rates) <= 127
    assert min(f.accel_pulses) >= 3 and min(f.decel) >= 3   # no 0x05 stage
    assert [x for x in check_table(f) if x.severity == "error"] == []


@pytest.mark.slow  # 2–4 s: the quick suite's budget; CI runs it
@settings(max_examples=80, deadline=None)
@given(init_tables())
def test_stage_speeds_follow_the_law_in_time(t: InitTable) -> None:
    assume(init_stage_problem(t) is None)
    f = expand_init(t)
    for which in ("accel", "decel"):
        dev, bound = law_deviation(f, which, t.shape)
        assert dev <= bound


def test_linear_points_on_a_line_and_s_curve_on_the_cosine() -> None:
    for shape in ("linear", "s_curve"):
        t = InitTable(C8, shape, 10000, 400, 20000)
        f = expand_init(t)
        dev, bound = law_deviation(f, "accel", shape)
        vh = C8.hz / 400
        assert dev <= bound and dev < 0.02 * vh
        # And not on the other law: the two shapes are really different.
        other = "s_curve" if shape == "linear" else "linear"
        dev_other, _ = law_deviation(f, "accel", other)
        assert dev_other > 0.1 * vh


def test_s_curve_changes_speed_slowly_at_both_ends() -> None:
    f = expand_init(InitTable(C8, "s_curve", 10000, 400, 20000))
    rates, pulses = side(f, "accel")
    speeds = C8.hz / rates
    starts = np.concatenate([[0.0], np.cumsum(pulses * rates / C8.hz)[:-1]])
    accel = np.diff(speeds) / np.diff(starts)
    k = len(accel)
    mid = accel[k // 3: 2 * k // 3].mean()
    assert accel[:3].mean() < 0.3 * mid and accel[-3:].mean() < 0.3 * mid


def test_generous_pulses_give_the_stage_limit() -> None:
    t = InitTable(C8, "linear", 10000, 400, 100_000)
    assert len(expand_init(t).rates) == 127
    assert len(expand_init(t, max_stages=10).rates) == 10
    assert len(expand_init(t, max_stages=2).rates) == 2
    with pytest.raises(FieldRangeError, match="max_stages"):
        expand_init(t, max_stages=1)
    with pytest.raises(FieldRangeError, match="max_stages"):
        expand_init(t, max_stages=128)


def test_few_pulses_give_fewer_stages_each_of_three_or_more() -> None:
    rich = expand_init(InitTable(C8, "linear", 10000, 400, 100_000))
    poor = expand_init(InitTable(C8, "linear", 10000, 400, 300))
    assert len(poor.rates) < len(rich.rates)
    assert min(poor.accel_pulses) >= 3


def test_separate_sides_share_one_rate_list() -> None:
    t = InitTable(C8, "linear", 10000, 400, 5000, 2000, 3000)
    f = expand_init(t)
    assert f.decel_pulses is not None
    assert len(f.accel_pulses) == len(f.rates) > len(f.decel_pulses)
    assert f.rates[len(f.decel_pulses) - 1] == 2000
    # Stop slower than start: decel is the longer side.
    g = expand_init(replace(t, start_rate=2000, stop_rate=10000))
    assert g.decel_pulses is not None and len(g.decel_pulses) > len(g.accel_pulses)
    assert g.rates[len(g.accel_pulses) - 1] == 2000 and g.rates[-1] == 10000


def test_codes_for_tables_that_cannot_be_built() -> None:
    ok = InitTable(C8, "linear", 10000, 400, 2000)
    assert init_stage_problem(ok) is None and init_parameter_problem(ok) is None
    cases = {
        0x01: replace(ok, high_rate=1),
        0x03: replace(ok, start_rate=400),
        0x02: replace(ok, start_rate=527),
        0x04: replace(ok, stop_rate=500, decel_pulses=2000),
        0x05: replace(ok, start_rate=1000, high_rate=4, accel_pulses=256),
    }
    for code, t in cases.items():
        problem = init_stage_problem(t)
        assert problem is not None and problem[0] == code, (code, problem)
        with pytest.raises(InitBuildError) as e:
            expand_init(t)
        assert isinstance(e.value, StepRampError) and e.value.chip_code == code
        assert f"0x{code:02X}" in str(e.value) and "\n" not in str(e.value)
    assert init_stage_problem(replace(ok, start_rate=528)) is None


def test_0x05_boundary_matches_two_stage_share() -> None:
    # Two linear stages at equal durations: the slow stage's ideal share is
    # P·high/(start+high); with two stages largest-remainder rounding is nearest-integer
    # rounding (ties to the slow stage), so 3 pulses need a share ≥ 2.5:
    # start 1000, high 4 → P ≥ 2.5 · 1004 / 4 = 627.5.
    base = InitTable(C8, "linear", 1000, 4, 256)
    problem = init_stage_problem(base)
    assert problem is not None and problem[0] == 0x05
    need = int(problem[1].rsplit("≥ ", 1)[1])
    assert need == 628
    assert init_stage_problem(replace(base, accel_pulses=need)) is None
    assert init_stage_problem(replace(base, accel_pulses=need - 1)) is not None


def test_the_stage_budget_is_keyword_only() -> None:
    from profiles.ppmc312.init_model import init_stage_problem

    with pytest.raises(TypeError, match="positional argument"):
        init_stage_problem(None, 10)  # type: ignore[arg-type, misc]

"""profiles/pulses.py: the line deviation over pulse trains of any length (issue #20 item 13).

The reference is the plain one: every instant listed, every axis's count at each by
binary search, the distance to the line by projection (what the library did before
pulse trains). The stepped-over stretches must give the very same maximum; the bound,
where it is used, must never be below it.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles import alink, pulses
from profiles.alink.sync import pulse_times_s
from profiles.alink.sync import pulse_train as alink_train
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import Execution, simulate_move
from profiles.ppmc312.sync import pulse_train
from profiles.ppmc312.table import FreeCurveTable

CLOCKS = ("8MHz", "1MHz", "62.5kHz")


def plain_deviation(times: list[np.ndarray]) -> float:
    t = np.unique(np.concatenate([np.zeros(1), *times]))
    x = np.stack([np.searchsorted(ti, t, side="right") for ti in times], axis=1).astype(float)
    end = np.array([len(ti) for ti in times], dtype=float)
    u = end / np.linalg.norm(end)
    resid = x - np.outer(x @ u, u)
    return float(np.sqrt((resid * resid).sum(axis=1)).max())


def table(clock: str, rates: tuple[int, ...], counts: tuple[int, ...]) -> FreeCurveTable:
    return FreeCurveTable(Clock.internal(clock), rates, counts)


tables = st.integers(2, 4).flatmap(lambda k: st.builds(
    table, st.sampled_from(CLOCKS),
    st.lists(st.integers(20, 400), min_size=k, max_size=k, unique=True).map(
        lambda r: tuple(sorted(r))),
    st.lists(st.integers(2, 60), min_size=k, max_size=k).map(tuple)))


FAST = settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def runs(specs: list[tuple[FreeCurveTable, int]]) -> list[Execution]:
    return [simulate_move(t, n) for t, n in specs]


@FAST
@given(specs=st.lists(st.tuples(tables, st.integers(1, 3000)), min_size=2, max_size=3))
def test_pulse_trains_give_the_plain_deviation(specs: list[tuple[FreeCurveTable, int]]
                                               ) -> None:
    exes = runs(specs)
    for e in exes:  # the pieces hold the chip's very instants
        tr = pulse_train(e)
        assert np.array_equal(tr.times(1, e.pulses), e.pulse_times_s())
        assert np.array_equal(tr.emitted(e.pulse_times_s()), np.arange(1, e.pulses + 1))
    got, t, d = pulses.line_deviation([pulse_train(e) for e in exes])
    assert got == pytest.approx(plain_deviation([e.pulse_times_s() for e in exes]),
                                rel=1e-12, abs=1e-9)
    assert t[0] == 0 and len(t) == len(d) and d.max() == got


@settings(FAST, max_examples=6)
@given(specs=st.lists(st.tuples(tables, st.integers(20_000, 60_000)), min_size=2,
                      max_size=3))
@pytest.mark.slow  # 2–4 s: the quick suite's budget; CI runs it
def test_stepping_over_the_cruise_changes_nothing(specs: list[tuple[FreeCurveTable, int]],
                                                  ) -> None:
    """With small chunks the joint-period step runs on these moves; the maximum is the
    plain one (and the trace is shorter than the instants)."""
    exes = runs(specs)
    trains = [pulse_train(e) for e in exes]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(pulses, "CHUNK", 128)
        mp.setattr(pulses, "TRACE_MAX", 1000)
        stepped = pulses.line_deviation(trains)
    assert stepped[0] == pytest.approx(plain_deviation([e.pulse_times_s() for e in exes]),
                                       rel=1e-12, abs=1e-9)


def test_the_step_runs_and_the_largest_distance_is_inside_the_cruise() -> None:
    """Cruise rates 300 and 701 (ratio off the pulse ratio): the distance grows through the
    cruise and is largest near its end, after the stepped-over middle."""
    a = simulate_move(table("8MHz", (300, 400), (40, 40)), 200_000)
    b = simulate_move(table("8MHz", (701, 900), (40, 40)), 85_000)
    calls = []
    real = pulses._Merge.skip

    def spy(self: pulses._Merge) -> bool:
        calls.append(real(self))
        return calls[-1]

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(pulses, "CHUNK", 256)
        mp.setattr(pulses._Merge, "skip", spy)
        got, t, _ = pulses.line_deviation([pulse_train(a), pulse_train(b)])
    assert any(calls)
    assert got == pytest.approx(plain_deviation([a.pulse_times_s(), b.pulse_times_s()]),
                                rel=1e-12)
    assert len(t) < 200_000


def test_the_bound_is_never_below_the_exact_deviation() -> None:
    """A joint period longer than WINDOW_MAX: the middle is bounded from above, within a
    pulse or so of the truth."""
    a = simulate_move(table("8MHz", (311, 400), (40, 40)), 150_000)
    b = simulate_move(table("1MHz", (97, 150), (30, 30)), 90_000)
    exact = plain_deviation([a.pulse_times_s(), b.pulse_times_s()])
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(pulses, "CHUNK", 256)
        mp.setattr(pulses, "WINDOW_MAX", 8)
        bounded = pulses.line_deviation([pulse_train(a), pulse_train(b)])[0]
    assert exact <= bounded <= exact + math.sqrt(2)


def test_a_move_of_every_pulse_the_chip_counts_in_bounded_time() -> None:
    """0xFFFFFFFF pulses against 10⁹ (the axes schema's limit): no instant listed."""
    a = simulate_move(table("1MHz", (100, 200, 400), (300, 200, 100)), 0xFFFFFFFF)
    b = simulate_move(table("1MHz", (430, 800, 1600), (80, 60, 40)), 1_000_000_000)
    started = time.monotonic()
    got, t, _ = pulses.line_deviation([pulse_train(a), pulse_train(b)])
    assert time.monotonic() - started < 60  # a bound on the work, not a speed goal
    # the cruise speeds 10 000 and 2325.58 pps against the pulse ratio 0.232831: the
    # follower drifts ~ (1 − 0.23256/0.23283)·10⁹ pulses off the line by the end
    assert 1e5 < got < 1.5e6 and len(t) < 100_000


@pytest.mark.parametrize("n", [1, 2, 50, 3000, 40_000])
def test_alink_trains_hold_the_modelled_instants(n: int) -> None:
    s = alink.AlinkSettings(800, 20_000, 200)
    tr = alink_train(s, n)
    assert tr.count == n and np.array_equal(tr.times(1, n), pulse_times_s(s, n))
    cruise = [p for p in tr.pieces if p.period_s is not None]
    assert all(p.period_s == pytest.approx(1 / 20_000) for p in cruise)


def test_explicit_instants_are_a_train() -> None:
    a = np.array([0.1, 0.2, 0.3])
    b = np.array([0.15, 0.3])
    assert pulses.line_deviation([a, b])[0] == pytest.approx(plain_deviation([a, b]))


def test_the_lcm_of_periods_is_the_least_common_multiple() -> None:
    """lcm(3/2, 5/3) = 15 (3/2·10 = 5/3·9); of one period, itself; 2/3 and 4/9: 4/3."""
    from fractions import Fraction

    from profiles.pulses import _lcm

    assert _lcm([Fraction(3, 2), Fraction(5, 3)]) == Fraction(15)
    assert _lcm([Fraction(7, 4)]) == Fraction(7, 4)
    assert _lcm([Fraction(2, 3), Fraction(4, 9)]) == Fraction(4, 3)

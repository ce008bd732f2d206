"""profiles.ppmc312.chip_rules: every PPMC-312 chip rule, its code, its stage and its advice."""

from __future__ import annotations

import math
import re
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.findings import Finding
from profiles.ppmc312.chip_rules import check_table
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.init_model import init_stage_problem
from profiles.ppmc312.table import FreeCurveTable, InitTable, load_table
from tests.support.paths import ROOT

EXAMPLES = ROOT / "examples"


C8 = Clock.internal("8MHz")


def fc(rates: list[int], accel: list[int], decel: list[int] | None = None,
       clock: Clock = C8) -> FreeCurveTable:
    return FreeCurveTable(clock, tuple(rates), tuple(accel),
                          None if decel is None else tuple(decel))


def good(n: int = 10) -> FreeCurveTable:
    """A clean table: rates 400, 500, …, 100 pulses each (≥ 40 000 ticks a stage)."""
    return fc([400 + 100 * k for k in range(n)], [100] * n)


def rules(findings: list[Finding]) -> set[tuple[str, int | None, int | None]]:
    return {(f.rule, f.stage, f.chip_code) for f in findings}


def errors(findings: list[Finding]) -> list[Finding]:
    return [f for f in findings if f.severity == "error"]


def test_good_tables_have_no_findings() -> None:
    assert check_table(good()) == []
    assert check_table(load_table(EXAMPLES / "free-curve-nema17.json")) == []
    assert check_table(load_table(EXAMPLES / "init-linear.json")) == []


def test_bad_example_reports_each_planted_problem() -> None:
    found = rules(check_table(load_table(EXAMPLES / "free-curve-bad.json")))
    assert ("rate-min", 0, 0x18) in found
    assert ("pulses-min", 3, 0x19) in found
    assert ("stage-ticks-min", 1, None) in found
    assert ("rates-monotonic", 3, None) in found   # 380 after 400
    assert ("rates-monotonic", 7, None) in found   # 1200 twice


@pytest.mark.parametrize("n, bad", [(1, True), (2, False), (127, False), (128, True)])
def test_stage_count(n: int, bad: bool) -> None:
    t = fc([400 + 10 * k for k in range(n)], [100] * n)
    assert (("stage-count", None, 0x11) in rules(check_table(t))) == bad


def test_decel_stage_count_rule_and_warning() -> None:
    t = fc([400 + 100 * k for k in range(10)], [100] * 10, [100])
    found = check_table(t)
    assert ("stage-count", None, 0x11) in rules(found)
    t = fc([400 + 100 * k for k in range(10)], [100] * 10, [100] * 6)
    warn = [f for f in check_table(t) if f.rule == "decel-stage-count"]
    assert len(warn) == 1 and warn[0].severity == "warning"
    assert "6 fastest rates" in warn[0].message and "rates[0..5]" in warn[0].message


@pytest.mark.parametrize("rate", [0, 1])
def test_rate_at_most_one_is_0x18(rate: int) -> None:
    t = fc([rate, 500, 600], [300, 100, 100])
    f = [x for x in check_table(t) if x.rule == "rate-min"]
    assert len(f) == 1 and f[0].chip_code == 0x18 and f[0].stage == 0
    assert f"rates[0] = {rate}" in f[0].message and "raise it to ≥ 4" in f[0].message


@pytest.mark.parametrize("clock, rate, bad", [
    (C8, 3, True), (C8, 4, False),                      # 8 MHz / 4 = 2 Mpps exactly: allowed
    (Clock.internal("1MHz"), 2, False),                 # 500 kpps
    (Clock.extck(20e6), 9, True), (Clock.extck(20e6), 10, False),
])
def test_speed_never_above_2mpps(clock: Clock, rate: int, bad: bool) -> None:
    t = fc([rate, 500, 600], [300, 100, 100], clock=clock)
    found = [f for f in check_table(t) if f.rule == "speed-max"]
    assert bool(found) == bad
    if bad:
        need = math.ceil(clock.hz / 2e6)
        assert found[0].stage == 0 and f"raise it to ≥ {need}" in found[0].message


def test_pulse_count_at_most_one_is_0x19() -> None:
    t = fc([400, 500, 600], [100, 1, 100])
    f = [x for x in check_table(t) if x.rule == "pulses-min"]
    assert [(x.stage, x.chip_code) for x in f] == [(1, 0x19)]
    assert "accel_pulses[1] = 1" in f[0].message and "≥ 2" in f[0].message
    # Decel side too, with its own field name.
    t = fc([400, 500, 600], [100] * 3, [100, 100, 0])
    f = [x for x in check_table(t) if x.rule == "pulses-min"]
    assert [(x.stage, x.chip_code) for x in f] == [(2, 0x19)]
    assert "decel_pulses[2] = 0" in f[0].message


@pytest.mark.parametrize("pulses, rate, bad", [(2, 127, True), (2, 128, False),
                                               (3, 85, True), (3, 86, False)])
def test_stage_ticks_at_least_256(pulses: int, rate: int, bad: bool) -> None:
    t = fc([rate, 400, 500], [pulses, 100, 100])
    found = [f for f in check_table(t) if f.rule == "stage-ticks-min"]
    assert bool(found) == bad
    if bad:
        need = math.ceil(256 / rate)
        assert found[0].stage == 0
        assert f"{pulses * rate} ticks < 256" in found[0].message
        assert f"raise the count to ≥ {need}" in found[0].message
        # The advice is right: that count clears the rule.
        fixed = fc([rate, 400, 500], [need, 100, 100])
        assert not [f for f in check_table(fixed) if f.rule == "stage-ticks-min"]


def test_stage_pulse_field_and_totals_0x1a() -> None:
    limit = 0xFFFFF
    ok = fc([400, 500], [limit - 1000, 1000])
    assert errors(check_table(ok)) == []
    over = fc([400, 500], [limit - 1000, 1001])
    f = [x for x in check_table(over) if x.rule == "accel-total-max"]
    assert len(f) == 1 and f[0].chip_code == 0x1A and f[0].stage is None
    assert "remove 1 pulses" in f[0].message
    huge = fc([400, 500], [limit + 1, 100], [100, 100])
    found = rules(check_table(huge))
    assert ("pulses-field", 0, None) in found and ("accel-total-max", None, 0x1A) in found
    assert not any(r[0] == "decel-total-max" for r in found)
    dec = fc([400, 500], [100, 100], [limit, 1])
    assert ("decel-total-max", None, 0x1A) in rules(check_table(dec))


def test_rates_must_grow_fastest_to_slowest() -> None:
    t = fc([400, 500, 500, 450, 900], [100] * 5)
    f = [x for x in check_table(t) if x.rule == "rates-monotonic"]
    assert [(x.stage, x.severity) for x in f] == [(2, "warning"), (3, "warning")]
    assert "repeats" in f[0].message and "is faster than" in f[1].message


def test_short_stage_threshold_is_a_tenth_of_neighbour_mean() -> None:
    # Interior stage 2 (rate 1000): neighbours 200 × 500 and 100 × 1500 ticks → mean
    # 125 000; a tenth is 12 500 ticks = 12.5 pulses at rate 1000.
    def stage2(p: int) -> list[Finding]:
        t = fc([400, 500, 1000, 1500, 2000], [100, 200, p, 100, 100])
        return [f for f in check_table(t) if f.rule == "stage-short"]
    assert [f.stage for f in stage2(12)] == [2]
    assert "raise accel_pulses[2] to ≥ 13" in stage2(12)[0].message
    assert stage2(13) == []
    # The slowest end stage compares with its one neighbour: 10 × rate-600 vs 100 × 500.
    t = fc([400, 500, 600], [100, 100, 8])
    assert [f.stage for f in check_table(t) if f.rule == "stage-short"] == [2]
    t = fc([400, 500, 600], [100, 100, 9])
    assert [f.stage for f in check_table(t) if f.rule == "stage-short"] == []
    # The fastest stage runs on into the cruise at its own rate: never suspect.
    t = fc([400, 500, 600], [2, 100, 100])
    assert [f.stage for f in check_table(t) if f.rule == "stage-short"] == []


def test_stop_speed_warning_at_slowest_decel_stage() -> None:
    # 8 MHz / 128 = 62.5 kpps exactly: warn; 129: no warning.
    t = fc([100, 110, 128], [100] * 3)
    f = [x for x in check_table(t) if x.rule == "stop-speed-high"]
    assert [(x.stage, x.severity) for x in f] == [(2, "warning")]
    assert "≥ 129" in f[0].message
    assert not [x for x in check_table(fc([100, 110, 129], [100] * 3))
                if x.rule == "stop-speed-high"]
    # LE=1, 2 decel stages: the decel side stops at rates[1].
    t = fc([100, 110, 5000], [100] * 3, [100, 100])
    assert [x.stage for x in check_table(t) if x.rule == "stop-speed-high"] == [1]


def test_order_errors_first_then_stage() -> None:
    t = fc([1, 500, 500, 400, 700], [100, 1, 100, 100, 100], [100, 100])
    found = check_table(t)
    sev = [f.severity for f in found]
    assert sev == sorted(sev, key=lambda s: s != "error")
    err_stages = [f.stage for f in found if f.severity == "error"]
    assert err_stages == sorted(err_stages, key=lambda s: -1 if s is None else s)
    assert len(found) > 3


def test_messages_are_one_line_with_numbers() -> None:
    t = load_table(EXAMPLES / "free-curve-bad.json")
    for f in check_table(t):
        assert "\n" not in f.message and re.search(r"\d", f.message)
        assert re.fullmatch(r"[a-z]+(-[a-z]+)*", f.rule)


def test_check_table_refuses_other_objects() -> None:
    from profiles.errors import FormatError
    with pytest.raises(FormatError, match="FreeCurveTable or InitTable"):
        check_table("not a table")  # type: ignore[arg-type]


# An independent, plain-loop statement of the error rules, to cross-check the fast code.
def reference_errors(t: FreeCurveTable) -> set[tuple[str, int | None]]:
    out: set[tuple[str, int | None]] = set()
    sides = [("accel", t.accel_pulses)] + ([("decel", t.decel_pulses)] if t.decel_pulses
                                           is not None else [])
    for side, pulses in sides:
        if not 2 <= len(pulses) <= 127:
            out.add(("stage-count", None))
        if sum(pulses) > 0xFFFFF:
            out.add((f"{side}-total-max", None))
        for i, p in enumerate(pulses):
            r = t.rates[i]
            if p <= 1:
                out.add(("pulses-min", i))
            if p > 0xFFFFF:
                out.add(("pulses-field", i))
            if p > 1 and r > 1 and p * r < 256:
                out.add(("stage-ticks-min", i))
    for i, r in enumerate(t.rates):
        if r <= 1:
            out.add(("rate-min", i))
        elif t.clock.hz / r > 2e6:
            out.add(("speed-max", i))
    return out


@st.composite
def tables(draw: st.DrawFn) -> FreeCurveTable:
    n = draw(st.integers(1, 130))
    rates = draw(st.lists(st.integers(0, 0xFFFF), min_size=n, max_size=n))
    accel = draw(st.lists(st.integers(0, 2000), min_size=n, max_size=n))
    decel = draw(st.none() | st.lists(st.integers(0, 2000), min_size=1, max_size=n))
    if draw(st.booleans()):
        rates.sort()
    return fc(rates, accel, decel)


@pytest.mark.slow  # a reference comparison; CI runs it
@settings(max_examples=150, deadline=None)
@given(tables())
def test_errors_agree_with_plain_reference(t: FreeCurveTable) -> None:
    got = {(f.rule, f.stage) for f in check_table(t) if f.severity == "error"}
    assert got == reference_errors(t)


@pytest.mark.slow  # 2–4 s: the quick suite's budget; CI runs it
@settings(max_examples=100, deadline=None)
@given(st.integers(2, 127), st.integers(4, 2000), st.data())
def test_sorted_strict_rates_with_enough_pulses_have_no_errors(
        n: int, fastest: int, data: st.DataObject) -> None:
    rates = sorted(data.draw(st.sets(st.integers(fastest, 0xFFFF), min_size=n, max_size=n)))
    accel = [max(2, math.ceil(256 / r)) + data.draw(st.integers(0, 50)) for r in rates]
    t = fc(rates, accel)
    found = check_table(t)
    assert errors(found) == []
    assert not any(f.rule == "rates-monotonic" for f in found)


def init(**kw: object) -> InitTable:
    base = InitTable(C8, "linear", 10000, 400, 2000)
    return replace(base, **kw)  # type: ignore[arg-type]


def init_rules(t: InitTable) -> set[tuple[str, int | None]]:
    return {(f.rule, f.chip_code) for f in check_table(t)}


@pytest.mark.parametrize("kw", [dict(start_rate=0x10), dict(high_rate=1),
                                dict(high_rate=0xFFF0, start_rate=0xFFFF),
                                dict(stop_rate=0x10, decel_pulses=2000)])
def test_init_rate_ranges_0x01(kw: dict[str, int]) -> None:
    found = [f for f in check_table(init(**kw)) if f.rule == "rate-range"]
    assert len(found) == 1 and found[0].chip_code == 0x01
    name = next(iter(kw))
    assert found[0].message.startswith(name)


def test_init_start_or_stop_not_above_high_0x03() -> None:
    assert ("start-above-high", 0x03) in init_rules(init(start_rate=400))
    assert ("start-above-high", 0x03) in init_rules(init(start_rate=300))
    t = init(stop_rate=399, decel_pulses=2000)
    found = [f for f in check_table(t) if f.rule == "start-above-high"]
    assert len(found) == 1 and found[0].message.startswith("stop_rate = 399")
    assert "≥ 528" in found[0].message


@pytest.mark.parametrize("gap, bad", [(127, True), (128, False)])
def test_init_gap_of_the_slower_side_0x02(gap: int, bad: bool) -> None:
    t = init(start_rate=400 + gap)
    assert (("init-gap", 0x02) in init_rules(t)) == bad


@pytest.mark.parametrize(("start", "high", "advice"), [
    # both fixes in range
    (600, 500, "raise start_rate to ≥ 628 or lower high_rate to ≤ 472"),
    # high_rate cannot go 128 below a start rate of 100 (it is ≥ 2): one fix only
    (100, 50, "raise start_rate to ≥ 178"),
    (129, 60, "raise start_rate to ≥ 188"),
    (130, 60, "raise start_rate to ≥ 188 or lower high_rate to ≤ 2"),
    # start_rate cannot rise 128 above a high rate of 0xFFEF (it is ≤ 0xFFFF)
    (0xFFFF, 0xFFEF, "lower high_rate to ≤ 65407"),
    (0xFFFF, 0xFF80, "lower high_rate to ≤ 65407"),
    (65380, 65280, "raise start_rate to ≥ 65408 or lower high_rate to ≤ 65252"),
])
def test_init_gap_advice_stays_inside_the_fields(start: int, high: int, advice: str) -> None:
    found = [f for f in check_table(init(start_rate=start, high_rate=high))
             if f.rule == "init-gap"]
    assert len(found) == 1 and found[0].message.endswith(f"≤ 127: {advice}")


def test_init_gap_of_the_faster_side_is_0x04() -> None:
    t = init(stop_rate=400 + 100, decel_pulses=2000)   # start 10000 is far enough
    found = [f for f in check_table(t) if f.rule == "init-gap"]
    assert [(f.chip_code, f.message.split(" ")[0]) for f in found] == [(0x04, "stop_rate")]
    assert init_stage_problem(t) is not None and init_stage_problem(t)[0] == 0x04  # type: ignore[index]


def test_init_pulse_limits() -> None:
    assert ("init-pulses-field", None) in init_rules(init(accel_pulses=0x0F))
    assert ("init-pulses-field", None) in init_rules(init(accel_pulses=0x100000))
    assert ("init-pulses-min", None) in init_rules(init(accel_pulses=0xFF))
    assert ("init-pulses-min", None) not in init_rules(init(accel_pulses=0x100))
    assert ("init-pulses-min", None) in init_rules(init(stop_rate=9000, decel_pulses=0x80))


def test_init_speed_and_stop_speed() -> None:
    assert ("speed-max", None) in init_rules(init(high_rate=3, start_rate=0x200))
    assert ("speed-max", None) not in init_rules(init(high_rate=4, start_rate=0x200))
    warn = [f for f in check_table(init(high_rate=2, start_rate=0x80 + 2,
                                        clock=Clock.internal("1MHz")))
            if f.rule == "stop-speed-high"]
    assert warn == []   # 1 MHz / 130 = 7.7 kpps
    # At 8 MHz start ≥ high + 0x80 ≥ 130 keeps the stop below 62.5 kpps; a 20 MHz
    # external clock can reach it: 20 MHz / 300 = 66.7 kpps, fixed from rate 321.
    t = init(high_rate=10, start_rate=300, accel_pulses=5000, clock=Clock.extck(20e6))
    warn = [f for f in check_table(t) if f.rule == "stop-speed-high"]
    assert len(warn) == 1 and warn[0].severity == "warning" and "≥ 321" in warn[0].message
    assert not [f for f in check_table(replace(t, start_rate=321))
                if f.rule == "stop-speed-high"]


def test_init_built_stage_too_short_is_0x05_and_advice_fixes_it() -> None:
    t = init(start_rate=1000, high_rate=4, accel_pulses=256)
    found = [f for f in check_table(t) if f.rule == "init-stage-pulses"]
    assert len(found) == 1 and found[0].chip_code == 0x05
    need = int(re.search(r"≥ (\d+)", found[0].message).group(1))  # type: ignore[union-attr]
    assert need > 256
    assert not [f for f in check_table(replace(t, accel_pulses=need))
                if f.rule == "init-stage-pulses"]
    assert [f for f in check_table(replace(t, accel_pulses=need - 1))
            if f.rule == "init-stage-pulses"]


C1 = Clock.internal("1MHz")


C15 = Clock.internal("15.625kHz")


E, W = "error", "warning"


Pin = tuple[str, str, int | None, int | None]


def pinned(t: FreeCurveTable | InitTable) -> list[Pin]:
    return [(f.severity, f.rule, f.chip_code, f.stage) for f in check_table(t)]


def ramp(n: int, first: int = 400, step: int = 100) -> list[int]:
    return [first + step * k for k in range(n)]


FREE_CASES: list[tuple[str, FreeCurveTable, list[Pin]]] = [
    ("clean", fc(ramp(3), [100] * 3), []),
    # stage counts 2..127 per side [0x11]
    ("1 stage", fc([400], [100]), [(E, "stage-count", 0x11, None)]),
    ("2 stages", fc(ramp(2), [100] * 2), []),
    ("127 stages", fc(ramp(127, 400, 10), [100] * 127), []),
    ("128 stages", fc(ramp(128, 400, 10), [100] * 128), [(E, "stage-count", 0x11, None)]),
    ("decel 1 stage", fc(ramp(3), [100] * 3, [100]),
     [(E, "stage-count", 0x11, None), (W, "decel-stage-count", None, None)]),
    ("decel 2 stages", fc(ramp(3), [100] * 3, [100] * 2), [(W, "decel-stage-count", None, None)]),
    ("no decel stages, fast stop rate", fc([100, 120], [100, 100], []),
     [(E, "stage-count", 0x11, None), (W, "decel-stage-count", None, None)]),
    ("decel same count", fc(ramp(3), [100] * 3, [50] * 3), []),
    ("accel shorter", fc(ramp(3), [100] * 2, [100] * 3), [(W, "decel-stage-count", None, None)]),
    # rate ≤ 1 [0x18], at any clock (at 1 MHz rate 1 is 1 Mpps: legal speed, still 0x18)
    ("rate 1 at 8MHz", fc([1, 500, 600], [300, 100, 100]), [(E, "rate-min", 0x18, 0)]),
    ("rate 1 at 1MHz", fc([1, 500, 600], [300, 100, 100], clock=C1), [(E, "rate-min", 0x18, 0)]),
    ("rate 0 at 1MHz", fc([0, 500, 600], [300, 100, 100], clock=C1), [(E, "rate-min", 0x18, 0)]),
    ("rate 2 at 1MHz", fc([2, 500, 600], [300, 100, 100], clock=C1), []),
    ("rate 1 at stage 1", fc([400, 1, 600], [100, 300, 100]),
     [(E, "rate-min", 0x18, 1), (W, "rates-monotonic", None, 1), (W, "stage-short", None, 1)]),
    # speed ≤ 2 Mpps: at 8 MHz the fastest rate is 4
    ("rate 3 at 8MHz", fc([3, 500, 600], [100, 100, 100]), [(E, "speed-max", None, 0)]),
    ("rate 4 at 8MHz", fc([4, 500, 600], [100, 100, 100]), []),
    # pulses ≤ 1 [0x19]
    ("pulses 1", fc([400, 500, 600], [100, 1, 100]),
     [(E, "pulses-min", 0x19, 1), (W, "stage-short", None, 1)]),
    ("pulses 0 at stage 0", fc([400, 500, 600], [0, 100, 100]), [(E, "pulses-min", 0x19, 0)]),
    ("pulses 2", fc([400, 500, 600], [100, 2, 100]), [(W, "stage-short", None, 1)]),
    ("decel pulses 1", fc(ramp(3), [100] * 3, [100, 100, 1]),
     [(E, "pulses-min", 0x19, 2), (W, "stage-short", None, 2)]),
    # stage field ≤ 0xFFFFF (with it, the side total is over 0xFFFFF too [0x1A])
    ("pulses 0xFFFFF+1", fc([400, 500], [0x100000, 0x80000]),
     [(E, "accel-total-max", 0x1A, None), (E, "pulses-field", None, 0)]),
    ("decel pulses 0xFFFFF+1", fc([400, 500], [100, 100], [0x80000, 0x100000]),
     [(E, "decel-total-max", 0x1A, None), (E, "pulses-field", None, 1)]),
    ("pulses 0xFFFFF", fc([400, 500], [0xFFFFF, 2]),
     [(E, "accel-total-max", 0x1A, None), (W, "stage-short", None, 1)]),
    # side totals ≤ 0xFFFFF [0x1A]
    ("accel total 0xFFFFF", fc([400, 500], [0x80000, 0x7FFFF]), []),
    ("accel total 0x100000", fc([400, 500], [0x80000, 0x80000]),
     [(E, "accel-total-max", 0x1A, None)]),
    ("decel total 0xFFFFF", fc([400, 500], [100, 100], [0x80000, 0x7FFFF]), []),
    ("decel total 0x100000", fc([400, 500], [100, 100], [0x80000, 0x80000]),
     [(E, "decel-total-max", 0x1A, None)]),
    # pulses × rate ≥ 256 ticks
    ("255 ticks", fc([5, 400, 500], [51, 100, 100]), [(E, "stage-ticks-min", None, 0)]),
    ("256 ticks", fc([16, 400, 500], [16, 100, 100]), []),
    ("256 ticks beside 255", fc([5, 16, 400], [51, 16, 100]),
     [(E, "stage-ticks-min", None, 0), (W, "stage-short", None, 1)]),
    # (a count ≤ 1 or a rate ≤ 1 has its own rule: no tick finding on top)
    ("1 pulse at rate 5", fc([5, 400, 500], [1, 100, 100]), [(E, "pulses-min", 0x19, 0)]),
    ("rate 1 × 100 pulses", fc([1, 500, 600], [100, 100, 100]), [(E, "rate-min", 0x18, 0)]),
    ("rate 2 × 100 pulses at 1MHz", fc([2, 500, 600], [100, 100, 100], clock=C1),
     [(E, "stage-ticks-min", None, 0)]),
    ("decel 255 ticks", fc([5, 400, 500], [100, 100, 100], [51, 100, 100]),
     [(E, "stage-ticks-min", None, 0)]),
    # rates strictly growing fastest → slowest (stage 1 is checked too)
    ("repeat at stage 1", fc([400, 400, 500], [100] * 3), [(W, "rates-monotonic", None, 1)]),
    ("faster at stage 2", fc([400, 500, 450], [100] * 3), [(W, "rates-monotonic", None, 2)]),
    ("two repeats", fc([400, 400, 400], [100] * 3),
     [(W, "rates-monotonic", None, 1), (W, "rates-monotonic", None, 2)]),
    # a stage under 1/10 of its neighbours' mean (stage 0 exempt)
    ("middle exactly 1/10", fc([400, 500, 600, 700], [100, 100, 10, 100]), []),
    ("middle just under 1/10", fc([400, 500, 600, 700], [100, 100, 9, 100]),
     [(W, "stage-short", None, 2)]),
    # stage 1's one neighbour is stage 2 (stage 0 runs on into the cruise)
    ("stage 1 exactly 1/10 of stage 2", fc([400, 500, 600], [2000, 12, 100]), []),
    ("stage 1 under 1/10 of stage 2", fc([400, 500, 600], [2000, 11, 100]),
     [(W, "stage-short", None, 1)]),
    ("stage 1 of 3 under 1/10", fc([400, 500, 600], [100, 9, 100]), [(W, "stage-short", None, 1)]),
    ("last just over 1/10", fc([400, 500, 600], [100, 100, 9]), []),
    ("last under 1/10", fc([400, 500, 600], [100, 100, 8]), [(W, "stage-short", None, 2)]),
    ("stage 0 short is fine", fc([400, 500, 600], [2, 100, 100]), []),
    ("next stage 10x longer", fc([400, 500, 600], [100, 10, 10000]),
     [(W, "stage-short", None, 1)]),
    ("previous stage 10x longer", fc([400, 500, 600, 700], [125, 1000, 10, 10]),
     [(W, "stage-short", None, 2)]),
    ("decel short", fc([400, 500, 600], [100] * 3, [100, 9, 100]), [(W, "stage-short", None, 1)]),
    # slowest decel stage below 62.5 kpps: at 8 MHz rate ≥ 129
    ("stop at rate 128", fc([100, 128], [100, 100]), [(W, "stop-speed-high", None, 1)]),
    ("stop at rate 129", fc([100, 129], [100, 100]), []),
    ("LE=1 stop stage", fc([100, 128, 400], [100] * 3, [100, 100]),
     [(W, "decel-stage-count", None, None), (W, "stop-speed-high", None, 1)]),
    ("stop at 1MHz rate 16", fc([10, 16], [100, 100], clock=C1),
     [(W, "stop-speed-high", None, 1)]),
    ("stop at 1MHz rate 17", fc([10, 17], [100, 100], clock=C1), []),
    # at 1 MHz rate 2 is 500 kpps: legal beside a rate-1 stage
    ("rates 1, 2 at 1MHz", fc([1, 2, 600], [300, 200, 100], clock=C1),
     [(E, "rate-min", 0x18, 0), (W, "stage-short", None, 1)]),
    # order: errors first; table-wide before staged; by stage, whatever rule found it first
    ("order by stage across rules", fc([400, 500, 1, 700], [1, 100, 300, 100]),
     [(E, "pulses-min", 0x19, 0), (E, "rate-min", 0x18, 2), (W, "rates-monotonic", None, 2),
      (W, "stage-short", None, 2)]),
    ("order", fc([400, 1, 380, 500], [100, 300, 0, 100], [100]),
     [(E, "stage-count", 0x11, None), (E, "rate-min", 0x18, 1), (E, "pulses-min", 0x19, 2),
      (W, "decel-stage-count", None, None), (W, "rates-monotonic", None, 1),
      (W, "stage-short", None, 2)]),
]


@pytest.mark.parametrize("t, expected", [c[1:] for c in FREE_CASES],
                         ids=[c[0] for c in FREE_CASES])
def test_free_curve_rule_pinned(t: FreeCurveTable, expected: list[Pin]) -> None:
    assert pinned(t) == expected


def init_t(start: int = 1000, high: int = 100, accel: int = 0x1000, stop: int | None = None,
         decel: int | None = None, clock: Clock = C8, shape: str = "linear") -> InitTable:
    return InitTable(clock, shape, start, high, accel, stop, decel)  # type: ignore[arg-type]


INIT_CASES: list[tuple[str, InitTable, list[Pin]]] = [
    ("clean", init_t(), []),
    # start/stop 0x11..0xFFFF, high 2..0xFFEF [0x01]
    # (start 0x10 cannot be 128 above a legal high: the gap error comes with it)
    ("start 0x10", init_t(start=0x10, high=2, clock=C15),
     [(E, "rate-range", 0x01, None), (E, "init-gap", 0x02, None)]),
    ("start 0 (stop rate 0: no division by it)", init_t(start=0, high=2, clock=C15),
     [(E, "rate-range", 0x01, None), (E, "start-above-high", 0x03, None)]),
    ("start 0x11", init_t(start=0x11 + 0x80, high=0x11), []),
    ("stop 0x10", init_t(start=1000, high=2, stop=0x10, decel=0x1000, clock=C15),
     [(E, "rate-range", 0x01, None), (E, "init-gap", 0x04, None)]),
    ("high 1", init_t(start=1000, high=1, clock=C1), [(E, "rate-range", 0x01, None)]),
    ("high 2 at 1MHz", init_t(start=1000, high=2, clock=C1), []),
    ("high 0xFFEF", init_t(start=0xFFFF, high=0xFFEF - 0x70), []),
    ("high 0xFFF0", init_t(start=0xFFFF, high=0xFFF0),
     [(E, "rate-range", 0x01, None), (E, "init-gap", 0x02, None)]),
    # start (stop) ≤ high [0x03]
    ("start = high", init_t(start=500, high=500), [(E, "start-above-high", 0x03, None)]),
    ("stop = high", init_t(start=1000, high=500, stop=500, decel=0x1000),
     [(E, "start-above-high", 0x03, None)]),
    # slower end − high ≤ 127 [0x02]; the faster end's gap ≤ 127 [0x04]
    ("gap 127", init_t(start=627, high=500), [(E, "init-gap", 0x02, None)]),
    ("gap 128", init_t(start=628, high=500), []),
    ("faster end gap 127", init_t(start=1000, high=500, stop=627, decel=0x1000),
     [(E, "init-gap", 0x04, None)]),
    ("slower end gap 127", init_t(start=627, high=500, stop=600, decel=0x1000),
     [(E, "init-gap", 0x02, None), (E, "init-gap", 0x04, None)]),
    ("both gaps 128", init_t(start=628, high=500, stop=628, decel=0x1000), []),
    # accel/decel pulses: field 0x10..0xFFFFF, at least 0x100
    # (so few pulses cannot build the staircase either [0x05])
    ("pulses 0x0F", init_t(accel=0x0F),
     [(E, "init-pulses-field", None, None), (E, "init-stage-pulses", 0x05, None)]),
    ("pulses 0x10", init_t(accel=0x10),
     [(E, "init-pulses-min", None, None), (E, "init-stage-pulses", 0x05, None)]),
    ("pulses 0xFF", init_t(accel=0xFF), [(E, "init-pulses-min", None, None)]),
    ("decel pulses 0xFF", init_t(start=1000, high=100, stop=1000, decel=0xFF),
     [(E, "init-pulses-min", None, None)]),
    ("pulses 0xFFFFF", init_t(accel=0xFFFFF), []),
    ("pulses 0x100000", init_t(accel=0x100000), [(E, "init-pulses-field", None, None)]),
    # high speed ≤ 2 Mpps; stop speed below 62.5 kpps
    ("high rate 3 at 8MHz", init_t(start=1000, high=3), [(E, "speed-max", None, None)]),
    ("high rate 4 at 8MHz", init_t(start=1000, high=4), []),
    ("stop rate 128", init_t(start=1000, high=4, stop=128 + 0, decel=0x1000),
     [(E, "init-gap", 0x04, None), (W, "stop-speed-high", None, None)]),
    ("stop rate 129", init_t(start=1000, high=4, stop=129, decel=0x1000),
     [(E, "init-gap", 0x04, None)]),
    # (a stop rate ≤ 128 at 8 MHz is always within 127 of any legal high: 0x02 comes too)
    ("start rate 128 (LE=0)", init_t(start=128, high=4), [(E, "init-gap", 0x02, None),
                                                        (W, "stop-speed-high", None, None)]),
    ("start rate 129 (LE=0)", init_t(start=129, high=4), [(E, "init-gap", 0x02, None)]),
    ("stop 128, high 2", init_t(start=200, high=2, stop=128, decel=0x1000),
     [(E, "init-gap", 0x04, None), (E, "speed-max", None, None),
      (W, "stop-speed-high", None, None)]),
    # the built table has a stage ≤ 2 pulses [0x05]
    ("built stage too short", init_t(start=0xFFFF, high=2, accel=0x100, clock=C1),
     [(E, "init-stage-pulses", 0x05, None)]),
]


@pytest.mark.parametrize("t, expected", [c[1:] for c in INIT_CASES],
                         ids=[c[0] for c in INIT_CASES])
def test_init_rule_pinned(t: InitTable, expected: list[Pin]) -> None:
    assert pinned(t) == expected


def test_pulse_count_advice_is_2_at_slow_rates_and_256_ticks_at_fast_ones() -> None:
    (f,) = [x for x in check_table(fc([400, 500, 600], [100, 0, 1000])) if x.severity == "error"]
    assert f.message == "accel_pulses[1] = 0 is ≤ 1: raise it to ≥ 2"
    (f,) = [x for x in check_table(fc([16, 500, 600], [1, 100, 100]))]
    assert f.message == "accel_pulses[0] = 1 is ≤ 1: raise it to ≥ 16"


def test_advice_at_rate_0_and_rate_1() -> None:
    found = check_table(fc([0, 500, 600], [1, 100, 100]))
    assert [f.message for f in found if f.rule == "pulses-min"] == [
        "accel_pulses[0] = 1 is ≤ 1: raise it to ≥ 2"]
    # a short stage at rate 1: 300 ticks beside stage 2's 60 000 needs 6 000 pulses
    found = check_table(fc([400, 1, 600], [100, 300, 100]))
    (short,) = [f for f in found if f.rule == "stage-short"]
    assert "raise accel_pulses[1] to ≥ 6000 " in short.message


def test_rate_min_advice_at_slow_clocks_is_rate_2() -> None:
    (f,) = [x for x in check_table(fc([1, 500, 600], [300, 100, 100], clock=C1))]
    assert "raise it to ≥ 2 (≤ 2 Mpps at 1MHz)" in f.message
    (f,) = [x for x in check_table(fc([1, 500, 600], [300, 100, 100]))]
    assert "raise it to ≥ 4 (≤ 2 Mpps at 8MHz)" in f.message


@pytest.mark.parametrize("decel, says", [
    ((100, 100), "decel uses only the 2 fastest rates (rates[0..1]) and starts/stops at rate 500;"),
    ((100,), "decel uses only the 1 fastest rates (rates[0..0]) and starts/stops at rate 400;"),
    ((), "decel uses only the 0 fastest rates (rates[0..-1]); give"),
])
def test_decel_stage_count_message_names_the_end_rate(decel: tuple[int, ...], says: str) -> None:
    t = fc([400, 500, 600], [100] * 3, list(decel))
    (f,) = [x for x in check_table(t) if x.rule == "decel-stage-count"]
    assert says in f.message


def test_accel_side_shorter_message() -> None:
    t = fc([400, 500, 600], [100, 100], [100] * 3)
    (f,) = [x for x in check_table(t) if x.rule == "decel-stage-count"]
    assert "accel uses only the 2 fastest rates (rates[0..1]) and starts/stops at rate 500" \
        in f.message


@given(st.lists(st.integers(2, 3000), min_size=2, max_size=40), st.data())
@settings(max_examples=300, deadline=None)
def test_stage_short_is_exactly_the_rule_as_written(pulses: list[int],
                                                    data: st.DataObject) -> None:
    # The rule, spelled out one stage at a time in exact fractions (the check works in
    # numpy with an integer pre-filter): stage i ≥ 1 lasts under 1/10 of the mean of its
    # neighbours, stage 0 being no neighbour (stage 1 has stage 2 only, the last stage
    # the one before it). Pulse counts in small steps hit the 1/10 boundary exactly.
    from fractions import Fraction

    n = len(pulses)
    rates = sorted(data.draw(st.sets(st.integers(300, 3000), min_size=n, max_size=n)))
    ticks = [p * r for p, r in zip(pulses, rates, strict=True)]
    expected = []
    for i in range(1, n):
        neighbours = [ticks[j] for j in (i - 1, i + 1) if 1 <= j < n] if n > 2 else [ticks[0]]
        mean = Fraction(sum(neighbours), len(neighbours))
        if Fraction(ticks[i]) * 10 < mean:
            expected.append(i)
    found = [f for f in check_table(fc(rates, pulses)) if f.rule == "stage-short"]
    assert [f.stage for f in found] == expected
    for f in found:
        assert f.message.startswith(f"accel stage {f.stage} lasts {ticks[f.stage]} ticks")


def rules_pins(table: FreeCurveTable) -> list[tuple[str, str, int | None]]:
    return [(f.severity, f.rule, f.stage) for f in check_table(table)]


def test_a_stage_of_exactly_0xfffff_pulses_fits_its_field() -> None:
    # stage 1 holds one pulse too many; stage 0 exactly the most (and the side total is over)
    got = rules_pins(FreeCurveTable(C8, (100, 200), (0xFFFFF, 0x100000)))
    assert ("error", "pulses-field", 1) in got and ("error", "pulses-field", 0) not in got


def test_a_stop_rate_of_1_is_warned_about() -> None:
    # LE=1, one decel stage: it stops at rates[0] = 1, 8 Mpps (also a rate error)
    got = rules_pins(FreeCurveTable(C8, (1, 100), (5, 5), (5,)))
    assert ("warning", "stop-speed-high", 0) in got and ("error", "rate-min", 0) in got


def test_pulses_needed_at_a_rate_of_1_is_the_tick_minimum() -> None:
    # 1 pulse at rate 1: the count must reach 256 ticks / rate 1 = 256 pulses
    found = [f for f in check_table(FreeCurveTable(C8, (1, 100), (1, 5)))
             if f.rule == "pulses-min"]
    assert [f.stage for f in found] == [0]
    assert found[0].message == "accel_pulses[0] = 1 is ≤ 1: raise it to ≥ 256"


def test_a_stage_of_rate_0_is_short_and_needs_2_pulses() -> None:
    # stage 2 at rate 0 lasts 0 ticks against a mean of (2000 + 4000) / 2: the count that
    # would fix it cannot be computed from the rate, so the least count is named
    found = [f for f in check_table(FreeCurveTable(C8, (100, 200, 0, 400), (10, 10, 10, 10)))
             if f.rule == "stage-short"]
    assert [f.stage for f in found] == [2]
    assert found[0].message == ("accel stage 2 lasts 0 ticks, under 1/10 of its neighbours' "
                                "mean 3000 ticks: raise accel_pulses[2] to ≥ 2 or merge the "
                                "stage into a neighbour")


def test_init_rates_of_1_are_judged_for_speed() -> None:
    from profiles.ppmc312.table import InitTable

    # high_rate 1 runs at 8 Mpps; start_rate 1 stops there (LE=0: the start rate stops)
    got = [(f.rule, f.message.split(" = ")[0]) for f in check_table(
        InitTable(C8, "linear", 1, 1, 0x1000)) if f.rule in ("speed-max", "stop-speed-high")]
    assert got == [("speed-max", "high_rate"),
                   ("stop-speed-high", "start_rate (the stop rate, LE=0)")]
    le1 = InitTable(C8, "linear", 1000, 50, 0x1000, 100, 0x1000)  # stops at 80 kpps
    assert [f.message.split(" = ")[0] for f in check_table(le1)
            if f.rule == "stop-speed-high"] == ["stop_rate"]


def test_init_rates_of_0_are_range_errors_only() -> None:
    from profiles.ppmc312.table import InitTable

    # a rate of 0 has no speed to judge: the range rule names it, nothing divides by it
    assert [f.rule for f in check_table(InitTable(C8, "linear", 1000, 0, 0x1000))] ==\
        ["rate-range"]
    got = [f.rule for f in check_table(InitTable(C8, "linear", 0, 0, 0x1000))]
    assert "stop-speed-high" not in got and "speed-max" not in got and "rate-range" in got


def test_a_last_stage_of_0_ticks_is_short_against_its_one_neighbour() -> None:
    # 1 MHz, rates 100/200/300, accel 10/10/0: the last stage lasts 0 × 300 = 0 ticks, under
    # 1/10 of its only neighbour's 10 × 200 = 2000 ticks (the last stage has one neighbour,
    # the one before it); stage 1 lasts 2000 ticks against stage 2's 0: not short.
    found = [f for f in check_table(FreeCurveTable(Clock.internal("1MHz"), (100, 200, 300),
                                                   (10, 10, 0))) if f.rule == "stage-short"]
    assert [f.stage for f in found] == [2]
    assert found[0].message.startswith("accel stage 2 lasts 0 ticks, under 1/10 of its "
                                       "neighbours' mean 2000 ticks")

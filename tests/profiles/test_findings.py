"""Finding: immutable, compared by its values, its message written only when read."""

from __future__ import annotations

import pickle
from functools import partial

import pytest

from profiles.findings import Finding
from profiles.ppmc312.chip_rules import check_table
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.table import FreeCurveTable


class Writer:
    """A message writer that counts its calls."""

    def __init__(self, text: str) -> None:
        self.text, self.calls = text, 0

    def __call__(self) -> str:
        self.calls += 1
        return self.text


def test_a_lazy_message_is_written_once_and_only_when_read() -> None:
    writer = Writer("rates[2] is short")
    f = Finding("warning", "stage-short", writer, None, 2)
    assert writer.calls == 0
    assert f.rule == "stage-short" and f.stage == 2 and writer.calls == 0
    assert f.message == "rates[2] is short" and writer.calls == 1
    assert f.message == "rates[2] is short" and writer.calls == 1
    assert f.to_json()["message"] == "rates[2] is short" and writer.calls == 1


def test_lazy_and_plain_findings_with_the_same_values_are_equal() -> None:
    lazy = Finding("error", "rate-min", Writer("m"), 0x18, 3)
    plain = Finding("error", "rate-min", "m", 0x18, 3)
    assert lazy == plain and hash(lazy) == hash(plain)
    assert len({lazy, plain}) == 1
    for other in (Finding("error", "rate-min", "other", 0x18, 3),
                  Finding("warning", "rate-min", "m", 0x18, 3),
                  Finding("error", "rate-max", "m", 0x18, 3),
                  Finding("error", "rate-min", "m", 0x19, 3),
                  Finding("error", "rate-min", "m", 0x18, 4)):
        assert lazy != other
    assert lazy != ("error", "rate-min", "m", 0x18, 3)  # not a tuple
    assert "message='m'" in repr(lazy) and "chip_code=24" in repr(lazy)


def test_a_finding_is_immutable() -> None:
    f = Finding("warning", "x", "m")
    with pytest.raises(AttributeError, match="immutable"):
        f.rule = "y"  # type: ignore[misc]
    with pytest.raises(AttributeError, match="immutable"):
        del f.stage
    changed = f.with_message("n")
    assert (changed.message, f.message) == ("n", "m") and changed.rule == f.rule


def test_a_finding_pickles_with_its_message_written() -> None:
    # sweeps send findings between processes; a local function would not pickle
    f = Finding("warning", "stage-short", lambda: "written", None, 1)
    back = pickle.loads(pickle.dumps(f))
    assert back == f and back.message == "written"


def test_check_table_writes_no_message_until_one_is_read() -> None:
    # ten stages, every other one a hundredth of its neighbours: four short stages
    t = FreeCurveTable(Clock.internal("8MHz"), tuple(range(400, 1400, 100)),
                       (100, 1000, 1000, 10, 1000, 10, 1000, 10, 1000, 10))
    found = [f for f in check_table(t) if f.rule == "stage-short"]
    assert [f.stage for f in found] == [3, 5, 7, 9]
    assert all(isinstance(f._message, partial) for f in found)
    # stage 3: rate 700 × 10 = 7 000 ticks; neighbours 600 × 1000 and 800 × 1000, mean
    # 700 000, a tenth 70 000 ticks = 100 pulses at rate 700
    assert found[0].message == ("accel stage 3 lasts 7000 ticks, under 1/10 of its "
                                "neighbours' mean 700000 ticks: raise accel_pulses[3] to "
                                "≥ 100 or merge the stage into a neighbour")
    # the last stage has one neighbour: 1 300 × 10 vs 1 200 × 1000; a tenth is 120 000
    # ticks, ⌈120 000 / 1 300⌉ = 93 pulses
    assert "mean 1200000 ticks: raise accel_pulses[9] to ≥ 93" in found[3].message

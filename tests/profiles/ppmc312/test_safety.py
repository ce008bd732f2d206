"""profiles.ppmc312.safety: the PPMC-312's verdict on a table, which the one verdict
(`verify.safety.judge_safety`) hands its tables through the registry."""

from __future__ import annotations

import pytest

from profiles.errors import FieldRangeError, FormatError
from profiles.motor import load_motor
from profiles.ppmc312.init_model import as_free_curve
from profiles.ppmc312.safety import judge_table
from profiles.ppmc312.table import load_table
from tests.support.paths import ROOT
from verify.devices import safety_judge
from verify.safety import judge_safety

TABLE = ROOT / "examples" / "free-curve-nema17.json"
INIT = ROOT / "examples" / "init-linear.json"


def test_the_registry_hands_a_table_to_this_judge() -> None:
    assert safety_judge(load_table(TABLE)) is judge_table
    assert safety_judge(load_table(INIT)) is judge_table
    with pytest.raises(FormatError, match="no device judges a str"):
        safety_judge("a table")


def test_the_one_verdict_is_this_judge_s() -> None:
    motor = load_motor("nema17-1600")
    table = load_table(TABLE)
    mine = judge_table(table, motor, pulses=[200, 2000], commands=["82", "81"])
    theirs = judge_safety(table, motor, pulses=[200, 2000], commands=["82", "81"])
    assert mine.to_json() == theirs.to_json()
    assert [name for name, _ in mine.commands] == ["decel-stop"]


def test_an_init_table_is_judged_as_the_free_curve_it_becomes() -> None:
    motor = load_motor("nema17-1600")
    init = load_table(INIT)
    plain = judge_table(as_free_curve(init), motor, load_angle=False)
    assert judge_table(init, motor, load_angle=False).to_json() == plain.to_json()


def test_an_aim_past_the_peak_is_refused_before_any_work() -> None:
    with pytest.raises(FieldRangeError, match="load angle aim"):
        judge_table(load_table(TABLE), load_motor("nema17-1600"), aim_deg=91)

"""The command families a table's verdict reports (profiles/ppmc312/command_families.py): safe and
within the aim by the use the table always leaves, the envelope in JSON and a note, a
command-envelope finding when no use of a family is safe."""

from __future__ import annotations

import pytest

from profiles.motor import load_motor
from profiles.ppmc312.command_families import CODES, judge_family
from profiles.ppmc312.table import load_table
from tests.support.paths import ROOT

TABLE = load_table(ROOT / "examples" / "free-curve-nema17.json")


NEMA17 = load_motor(ROOT / "profiles" / "data" / "motor-nema17-1600.json")


HEAVY = load_motor(ROOT / "profiles" / "data" / "motor-nema23-heavy.json")


@pytest.mark.parametrize("name", list(CODES))
def test_a_table_the_motor_runs_leaves_every_family_a_safe_use(name: str) -> None:
    v = judge_family(name, TABLE, NEMA17, aim_deg=75.0)
    assert v.safe and v.within_aim and not v.findings()
    doc = v.to_json()
    assert (doc["command"], doc["code"], doc["safe"]) == (name, CODES[name], True)
    assert doc["worst_load_angle_deg"] >= 0 and doc["where"] and doc["box"] is None
    assert v.describe().startswith(v.describe().split(":")[0])


def test_the_notes_give_the_envelope_the_user_needs() -> None:
    stop = judge_family("stop", TABLE, NEMA17, aim_deg=75.0)
    assert "set the high-speed limit (05) to 685" in stop.describe()
    assert stop.to_json()["high_speed_limit_rate"] == 685
    constant = judge_family("constant", TABLE, NEMA17, aim_deg=75.0)
    assert "within the 75° aim at rate 1029 (7774.54 pps) and slower" in constant.describe()
    change = judge_family("change-speed", TABLE, NEMA17, aim_deg=75.0)
    assert "stops from 20000 pps at its old decel point (§8-8)" in change.describe()
    assert change.to_json()["faster_than_stop_rate"] is True


def test_a_motor_the_table_cannot_serve_gets_command_envelope_errors() -> None:
    found = {n: judge_family(n, TABLE, HEAVY, aim_deg=75.0) for n in CODES}
    assert not found["constant"].safe and not found["stop"].safe
    f = found["constant"].findings()
    assert [x.rule for x in f] == ["command-envelope"] and f[0].severity == "error"
    assert "none within the 75° aim, even at rate 10000" in f[0].message
    assert found["change-speed"].safe   # always a safe use: in a continuous run


def test_a_box_judges_every_corner_and_no_physics_judges_nothing() -> None:
    boxed = load_motor(ROOT / "examples" / "motor-nema17-tolerances.json")
    v = judge_family("constant", TABLE, boxed, aim_deg=75.0)
    assert v.box is not None and "over the tolerance box" in v.describe()
    assert v.to_json()["box"]["fastest_rate"] >= v.to_json()["fastest_rate"]
    off = judge_family("stop", TABLE, NEMA17, aim_deg=75.0, load_angle=False)
    assert off.safe and off.within_aim and "not judged" in off.describe()
    assert off.to_json()["safe"] is True

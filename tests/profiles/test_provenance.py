"""PlanProvenance (issue 32 item 4): every table `plan` writes says what it was planned for
(motor and hash, move lengths, aim, safety factor, cruise reserve, version, date); the
table format and its schema take it and round-trip it; `check` names the motor and warns
`motor-mismatch` when it judges with another."""

from __future__ import annotations

import json
import re
from pathlib import Path

import jsonschema
import pytest

from profiles.errors import FormatError
from profiles.motor import load_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.table import FreeCurveTable, InitTable, table_from_json
from profiles.provenance import FileRef, PlanProvenance, content_sha256
from tests.support.cli import run
from tests.support.paths import ROOT

SCHEMA = json.loads((ROOT / "profiles" / "data" / "table.schema.json").read_text("utf-8"))


NEMA17 = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


PROV = PlanProvenance(FileRef("nema17-1600", "ab" * 32), "0.1.0", "2025-01-31T12:00:00Z", (3200,),
                  None, 75.0, 0.6, "2x,10%")


@pytest.mark.parametrize("table", [
    FreeCurveTable(Clock.named("8MHz"), (400, 800), (10, 20), provenance=PROV),
    InitTable(Clock.named("8MHz"), "linear", 10000, 400, 2000, provenance=PROV),
])
def test_round_trip_and_schema(table: FreeCurveTable | InitTable) -> None:
    obj = table.to_json()
    jsonschema.validate(obj, SCHEMA)
    back = table_from_json(json.loads(json.dumps(obj)))
    assert back == table and back.provenance == PROV  # compared apart: not part of ==
    assert back.to_json() == obj
    # the same stages without provenance are the same table (a verdict is remembered by it)
    bare = table_from_json({k: v for k, v in obj.items() if k != "provenance"})
    assert bare == table and hash(bare) == hash(table) and bare.provenance is None


def test_a_mix_names_its_file_and_null_is_the_reference_move() -> None:
    prov = PlanProvenance(FileRef("m", "0" * 64), "0.1.0", "d", None, FileRef("mix.csv", "1" * 64))
    obj = prov.to_json()
    assert obj["pulses"] is None and obj["moves_file"] == {"name": "mix.csv", "sha256": "1" * 64}
    assert PlanProvenance.from_json(obj) == prov
    assert "the moves of mix.csv" in prov.describe()


@pytest.mark.parametrize("change, says", [
    ({"extra": 1}, "provenance: unknown key(s) 'extra'"),
    ({"motor": None}, "provenance.motor: expected"),
    ({"motor": {"name": "x", "sha256": "XYZ"}}, "provenance.motor.sha256: expected 64"),
    ({"pulses": [0]}, "provenance.pulses: expected null or a list"),
    ({"aim_deg": 120}, "provenance.aim_deg: expected null or a number 0..90"),
    ({"stepramp": 1}, "provenance.stepramp: expected a text"),
])
def test_a_bad_provenance_is_one_line_naming_its_key(change: dict[str, object],
                                                     says: str) -> None:
    obj = FreeCurveTable(Clock.named("8MHz"), (400, 800), (10, 20), provenance=PROV).to_json()
    good = obj["provenance"]
    with pytest.raises(FormatError, match="^" + re.escape(says)):
        table_from_json({**obj, "provenance": {**good, **change}})
    missing = {k: v for k, v in good.items() if k != "date"}
    with pytest.raises(FormatError, match=r"^provenance: missing key"):
        table_from_json({**obj, "provenance": missing})


def test_the_motor_hash_is_its_content_not_its_layout(tmp_path: Path) -> None:
    obj = json.loads(NEMA17.read_text("utf-8"))
    respaced = tmp_path / "m.json"
    respaced.write_text("\ufeff" + json.dumps(obj, indent=4), encoding="utf-8")
    same = content_sha256(load_motor(respaced).to_json())
    assert same == content_sha256(load_motor(NEMA17).to_json())
    respaced.write_text(json.dumps({**obj, "safety_factor": 0.5}), encoding="utf-8")
    assert content_sha256(load_motor(respaced).to_json()) != same


def test_plan_writes_it_and_check_names_the_motor(capsys: pytest.CaptureFixture[str],
                                                  tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    out = tmp_path / "t.json"
    code, _, err = run(capsys, "plan", "--motor", "nema17-1600", "--pulses", "3200", "-o",
                       str(out))
    assert code == 0, err
    obj = json.loads(out.read_text("utf-8"))
    jsonschema.validate(obj, SCHEMA)
    prov = obj["provenance"]
    assert prov["motor"] == {"name": "nema17-1600",
                             "sha256": content_sha256(load_motor(NEMA17).to_json())}
    assert prov["pulses"] == [3200] and prov["aim_deg"] == 75 and prov["safety_factor"] == 0.6
    assert prov["date"] == "2023-11-14T22:13:20Z" and prov["stepramp"]
    assert prov["cruise_reserve"] == "2x,10%"

    code, said, _ = run(capsys, "check", str(out), "--motor", str(NEMA17), "--no-physics")
    assert code == 0 and said.splitlines()[-1].endswith("(0 errors, 0 warnings)")
    assert f"{out}: note: planned for motor nema17-1600 (sha256 {prov['motor']['sha256'][:12]})" \
           ", a move of 3200 pulses, aim 75°, safety factor 0.6, cruise reserve 2x,10%; " \
           "stepramp " in said
    assert "motor-mismatch" not in said

    other = tmp_path / "changed.json"
    other.write_text(json.dumps({**json.loads(NEMA17.read_text("utf-8")),
                                 "inertia_kgm2": 7e-6}), encoding="utf-8")
    code, said, _ = run(capsys, "check", str(out), "--motor", str(other), "--no-physics",
                        "--pulses", "3200")
    assert f"{out}: warning [motor-mismatch]: planned for motor nema17-1600 (sha256 " in said
    assert "(1 error" not in said and "1 warning" in said.splitlines()[-1]


def test_the_commands_planned_for_round_trip_and_a_bad_list_names_its_key() -> None:
    prov = PlanProvenance(FileRef("m", "0" * 64), "0.1.0", "d", (3200,),
                          commands=("decel-stop", "accel"))
    table = FreeCurveTable(Clock.named("8MHz"), (400, 800), (10, 20), provenance=prov)
    obj = table.to_json()
    jsonschema.validate(obj, SCHEMA)
    assert obj["provenance"]["commands"] == ["decel-stop", "accel"]
    assert table_from_json(json.loads(json.dumps(obj))).provenance == prov
    assert "commands decel-stop,accel" in prov.describe()
    # planned for every command: the key is left out, as an older table has none
    assert "commands" not in PROV.to_json() and "commands" not in PROV.describe()
    for bad in ([], ["accel", ""], "82,81", [82]):
        with pytest.raises(FormatError, match=r"^provenance\.commands: expected null or a list"):
            table_from_json({**obj, "provenance": {**obj["provenance"], "commands": bad}})


def test_plan_records_its_commands(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "t.json"
    code, _, err = run(capsys, "plan", "--motor", "nema17-1600", "--pulses", "3200",
                       "--commands", "82,0x81", "-o", out)
    assert code == 0, err
    obj = json.loads(out.read_text("utf-8"))
    jsonschema.validate(obj, SCHEMA)
    assert obj["provenance"]["commands"] == ["decel-stop", "accel"]  # by name, registry order

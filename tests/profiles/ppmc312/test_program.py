"""profiles.ppmc312.program: program files (`stepramp.program/1`) and their schema."""

from __future__ import annotations

import json

from profiles.ppmc312.program import load_program
from tests.support.paths import ROOT

EXAMPLE = ROOT / "examples" / "program-home-and-jog.json"


def test_the_schema_accepts_the_example_and_refuses_what_the_reader_refuses() -> None:
    import jsonschema

    schema = json.loads((ROOT / "profiles" / "data" / "program.schema.json").read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    valid = jsonschema.Draft202012Validator(schema)
    assert valid.is_valid(json.loads(EXAMPLE.read_text()))
    load_program(EXAMPLE)
    good = {"format": "stepramp.program/1", "table": "t.json"}
    for commands in ([{"command": "jump"}], [{"command": "accel", "pulses": 5, "rate": 9}],
                     [{"command": "stop"}], [{"signal": "XL", "at": 1}],
                     [{"command": "change-speed", "rate": 0, "at": 4}]):
        assert not valid.is_valid({**good, "commands": commands}), commands
    for commands in ([{"command": "origin-search", "rate": 4000, "at": 300}],
                     [{"command": "continuous", "rate": 0}, {"signal": "FHL", "at": 1234}],
                     [{"command": "high-speed-limit", "rate": 700}, {"command": "step"}]):
        assert valid.is_valid({**good, "commands": commands}), commands

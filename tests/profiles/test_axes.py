"""profiles.axes: axes files (paths, defaults, one-line refusals) and their schema."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from profiles.axes import FORMAT, axes_from_json
from profiles.errors import FieldRangeError, FormatError, StepRampError
from profiles.motor import bundled_motor_paths, load_motor
from tests.support.paths import ROOT
from verify.devices import axes_entries, load_axes

SCHEMA = json.loads((ROOT / "profiles" / "data" / "axes.schema.json").read_text("utf-8"))


MOTORS = [load_motor(p) for p in bundled_motor_paths()]


NEMA17, NEMA23, PK566 = MOTORS


# --------------------------------------------------------------------------- axes file
def axes_doc(**over: object) -> dict:
    doc = {"format": FORMAT, "mode": "time",
           "axes": [{"name": "x", "motor": "m.json", "pulses": 1200},
                    {"name": "y", "motor": "m.json", "pulses": -700}]}
    doc.update(over)
    return doc


@pytest.fixture
def motor_dir(tmp_path: Path) -> Path:
    (tmp_path / "m.json").write_text(json.dumps(NEMA17.to_json()))
    return tmp_path


def test_axes_file_loads_with_paths_relative_to_it(motor_dir: Path) -> None:
    (motor_dir / "axes.json").write_text(json.dumps(axes_doc(device="ppmc312")))
    axes = load_axes(motor_dir / "axes.json")
    assert axes.mode == "time" and axes.device == "ppmc312"
    assert [a.name for a in axes.axes] == ["x", "y"]
    assert [a.pulses for a in axes.axes] == [1200, -700]
    assert axes.axes[1].ccw and axes.axes[1].distance == 700
    assert axes.axes[0].motor_path == motor_dir / "m.json"
    assert axes.axes[0].motor is not None and axes.axes[0].motor.name == NEMA17.name


def test_defaults_mode_time_device_ppmc312(motor_dir: Path) -> None:
    doc = axes_doc()
    del doc["mode"]
    axes = axes_from_json(doc, axes_entries(), motor_dir)
    assert (axes.mode, axes.device) == ("time", "ppmc312")


BAD = [
    ({"format": "stepramp.axes/2"}, "format"),
    ({"mode": "diagonal"}, "mode"),
    ({"device": "mc200"}, "device"),
    ({"axes": []}, "axes"),
    ({"extra": 1}, "unknown key"),
    ({"axes": [{"name": "x", "motor": "m.json", "pulses": 0}]}, "pulses"),
    ({"axes": [{"name": "x", "motor": "m.json", "pulses": 1.5}]}, "pulses"),
    ({"axes": [{"name": "x", "motor": "m.json", "pulses": 2**32}]}, "pulses"),
    ({"axes": [{"name": "1x", "motor": "m.json", "pulses": 10}]}, "name"),
    ({"axes": [{"name": "x", "pulses": 10}]}, "exactly one of motor"),
    ({"axes": [{"name": "x", "motor": "m.json", "table": "t.json", "pulses": 10}]},
     "exactly one of motor"),
    ({"axes": [{"name": "x", "motor": "m.json", "pulses": 10},
               {"name": "X", "motor": "m.json", "pulses": 10}]}, "used twice"),
    ({"axes": [{"name": "x", "motor": "m.json", "pulses": 10, "speed": 3}]}, "unknown key"),
    ({"axes": [{"name": "x", "motor": "", "pulses": 10}]}, "expected a file path"),
    ({"axes": [{"name": "x", "motor": 7, "pulses": 10}]}, "expected a file path"),
    ({"axes": [{"name": "x", "table": "", "pulses": 10}]}, "expected a file path"),
    ({"device": "alink", "axes": [{"name": n, "motor": "m.json", "pulses": 10}
                                  for n in "abc"]}, "axes"),
    ({"device": "alink", "axes": [{"name": "a", "motor": "m.json", "pulses": 2**27}]},
     "pulses"),
]


@pytest.mark.parametrize(("over", "word"), BAD)
def test_bad_axes_files_give_one_line_errors(motor_dir: Path, over: dict, word: str) -> None:
    with pytest.raises(StepRampError) as err:
        axes_from_json(axes_doc(**over), axes_entries(), motor_dir)
    assert word in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(("over", "word"), [b for b in BAD if b[1] != "used twice"])
def test_schema_refuses_what_the_loader_refuses(over: dict, word: str) -> None:
    import jsonschema
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(axes_doc(**over), SCHEMA)


def test_names_differing_only_in_case_pass_the_schema_and_the_loader_refuses_them(
        motor_dir: Path) -> None:
    # JSON Schema cannot state case-insensitive uniqueness (uniqueItems compares whole
    # items): the loader is the judge of that rule, and says so in one line.
    import jsonschema
    doc = axes_doc(axes=[{"name": "x", "motor": "m.json", "pulses": 10},
                         {"name": "X", "motor": "m.json", "pulses": 10}])
    jsonschema.validate(doc, SCHEMA)
    with pytest.raises(StepRampError, match="used twice"):
        axes_from_json(doc, axes_entries(), motor_dir)


def test_schema_accepts_the_examples() -> None:
    import jsonschema
    for path in sorted((ROOT / "examples").glob("axes-*.json")):
        doc = json.loads(path.read_text("utf-8"))
        jsonschema.validate(doc, SCHEMA)
        assert load_axes(path).axes


def test_missing_motor_file_names_the_axis(tmp_path: Path) -> None:
    (tmp_path / "axes.json").write_text(json.dumps(axes_doc()))
    with pytest.raises(FormatError, match=r"axes\[0\]\.motor: .*no such file"):
        load_axes(tmp_path / "axes.json")


def test_bad_pulses_for_the_chip_are_refused() -> None:
    with pytest.raises(FieldRangeError):
        axes_from_json(axes_doc(axes=[{"name": "x", "motor": "m.json", "pulses": -2**32}]),
                       axes_entries(), None, load_motors=False)

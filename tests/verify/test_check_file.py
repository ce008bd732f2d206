"""verify.check_file: one file judged as `stepramp check` does (library, no CLI)."""

from __future__ import annotations

from pathlib import Path

import pytest

from profiles.findings import Finding
from profiles.motor import load_motor
from tests.support.ascii_frames import by_hand, judge
from tests.support.paths import ROOT
from verify.check_file import check_file, dedupe

GOOD = ROOT / "examples" / "free-curve-nema17.json"


BAD = ROOT / "examples" / "free-curve-bad.json"


INIT = ROOT / "examples" / "init-linear.json"


MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


def test_good_and_bad_table_files() -> None:
    good = check_file(str(GOOD))
    assert good.ok and good.error is None and good.path == str(GOOD)
    bad = check_file(str(BAD))
    assert not bad.ok and bad.error is None
    assert {f.chip_code for f in bad.findings if f.severity == "error"} >= {0x18, 0x19}


def test_unusable_file_is_a_result_not_an_exception(tmp_path: Path) -> None:
    path = tmp_path / "x.json"
    path.write_text('{"format": "something/else"}')
    result = check_file(str(path))
    assert not result.ok and result.findings == [] and result.error


def test_motor_adds_stall_findings_only_when_given() -> None:
    motor = load_motor(MOTOR)
    without = check_file(str(INIT))
    with_motor = check_file(str(INIT), motor)
    rules = {f.rule for f in with_motor.findings} - {f.rule for f in without.findings}
    assert set(without.findings) <= set(with_motor.findings)
    # the stall module's rules are the only new ones
    import verify.criterion as stall

    source = Path(stall.__file__).read_text(encoding="utf-8")
    assert all(r in source or r.split("-", 1)[1] in source for r in rules)


def test_dedupe_keeps_first_of_equal_findings_in_order() -> None:
    a = Finding("error", "a", "m", 0x18, 0)
    b = Finding("warning", "b", "m")
    assert dedupe([a, b, Finding("error", "a", "m", 0x18, 0), b]) == [a, b]


def test_a_safe_table_says_its_worst_load_angle_as_a_note() -> None:
    """With a motor, a table within the aim has no load-angle finding, and its worst angle
    is told once, as a note (`stepramp check` prints it as "note: …"); without a motor,
    nothing is said of it."""
    result = check_file(str(GOOD), load_motor(MOTOR))
    assert result.ok and not any(f.rule.startswith("load-angle") for f in result.findings)
    said = [n for n in result.notes if n.startswith("worst load angle")]
    assert len(said) == 1 and "to the 90° peak" in said[0]
    without = check_file(str(GOOD))
    assert not any(n.startswith("worst load angle") for n in without.notes)


def test_check_file_defaults_are_check_options_defaults() -> None:
    """check_file is CheckOptions spelled as keywords: the same defaults (the load angle
    judged, seed 0 so a verdict is reproducible, resonance dwells warnings)."""
    import dataclasses
    import inspect

    from verify.check_options import CheckOptions

    fields = {f.name: f.default for f in dataclasses.fields(CheckOptions)}
    params = inspect.signature(check_file).parameters
    shared = set(fields) & set(params)
    assert shared >= {"physics", "samples", "seed", "strict", "pulses", "clock", "extck_hz"}
    assert {n: params[n].default for n in shared} == {n: fields[n] for n in shared}
    assert (fields["physics"], fields["seed"], fields["strict"]) == (True, 0, False)


# Every rule on a command of each family: (block hex, rule, chip code, severity)
RULES = [
    ("03 08 83 00 00 00 00 00 00 00", "move-pulses", 0x23, "error"),
    ("03 08 83 04 00 00 00 00 00 01", "move-trigger", 0x21, "error"),
    ("03 04 85 06 00 00", "move-trigger", 0x21, "error"),
    ("03 04 86 04 00 0A", "move-trigger", 0x21, "error"),
    ("03 04 86 00 00 09", "move-rate", 0x20, "error"),
    ("03 04 87 00 00 00", "move-rate", 0x20, "error"),
    ("03 04 10 00 00 01", "move-rate", 0x20, "error"),
    ("03 03 05 00 00", "move-rate", 0x20, "error"),
    ("03 08 82 00 00 01 00 00 00 05", "move-high-rate", 0x20, "error"),
    ("03 02 80 04", "move-position", None, "error"),
    ("03 08 88 06 00 02 00 00 00 09", "move-position", None, "error"),
    ("03 06 81 00 00 00 00 05", "move-position-ignored", None, "warning"),
    ("03 06 81 05 00 00 00 05", "move-position-ignored", None, "warning"),
    ("03 04 87 01 00 02", "move-trigger-ignored", None, "warning"),
    ("03 02 84 80", "move-mode-bits", None, "warning"),
    ("03 04 11 02 00 00", "move-mode-bits", None, "warning"),
    ("03 02 80 F8", "move-mode-bits", None, "warning"),
    ("03 03 80 00 00", "move-block", None, "error"),
    ("02 02 81 00", "move-block", None, "error"),
]


@pytest.mark.parametrize(("data", "rule", "code", "severity"), RULES)
def test_the_chips_parameter_errors_are_findings(tmp_path: Path, data: str, rule: str,
                                                 code: int | None, severity: str) -> None:
    result = judge(tmp_path, [bytes.fromhex(data)])
    found = [f for f in result.findings if f.rule == rule]
    assert len(found) == 1 and found[0].chip_code == code and found[0].severity == severity
    assert result.ok == (severity == "warning")
    assert not [f for f in result.findings if f.rule not in (rule, "upload-unchecked")]


@pytest.mark.parametrize(("payload", "rule", "code"), [
    ("84 0190 00000000", "move-pulses", 0x23),
    ("A5 0009", "move-rate", 0x20),
    ("89 0000", "move-rate", 0x20),
    ("47 0001", "move-rate", 0x20),
    ("83 0001 00000005", "move-high-rate", 0x20),
    ("8E 0002 00000009", "move-position", None),
    ("9D 0002 00", "move-block", None),
    ("82 00", "move-block", None),
])
def test_serial_frames_get_the_same_findings(tmp_path: Path, payload: str, rule: str,
                                             code: int | None) -> None:
    result = judge(tmp_path, [by_hand(4, payload)])
    assert [(f.rule, f.chip_code) for f in result.findings] == [(rule, code)]

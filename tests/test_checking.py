"""verify.check_file: one file judged as `stepramp check` does (library, no CLI)."""

from __future__ import annotations

import json
from pathlib import Path

from profiles.motor import load_motor
from profiles.ppmc312.formats import render
from profiles.ppmc312.table import load_table
from profiles.ppmc312.upload import encode_table
from tests.support.paths import ROOT
from verify.check_file import check_file, dedupe
from verify.devices.ppmc312 import load_checkable, looks_like_table_json
from verify.findings import Finding

GOOD = ROOT / "examples" / "free-curve-nema17.json"
BAD = ROOT / "examples" / "free-curve-bad.json"
INIT = ROOT / "examples" / "init-linear.json"
MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


def _hex() -> str:
    data = render(encode_table(load_table(GOOD)), "hex")
    return data if isinstance(data, str) else data.decode("ascii")


def test_good_and_bad_table_files() -> None:
    good = check_file(str(GOOD))
    assert good.ok and good.error is None and good.path == str(GOOD)
    bad = check_file(str(BAD))
    assert not bad.ok and bad.error is None
    assert {f.chip_code for f in bad.findings if f.severity == "error"} >= {0x18, 0x19}


def test_upload_file_is_decoded_and_judged(tmp_path: Path) -> None:
    path = tmp_path / "good.hex"
    path.write_text(_hex())
    table, findings = load_checkable(str(path))
    assert table == load_table(GOOD) and findings == []
    assert check_file(str(path)).ok


def test_upload_the_chip_refuses_is_one_finding_with_its_code(tmp_path: Path) -> None:
    lines = [line for line in _hex().splitlines() if not line.startswith("#")]
    first = lines[0].split()  # hand-edited, so without the CRC line (a warning, below)
    first[4] = "01"  # one stage: the chip answers parameter error 0x11
    path = tmp_path / "bad.hex"
    path.write_text(" ".join(first) + "\n" + "\n".join(lines[1:]) + "\n")
    table, findings = load_checkable(str(path))
    assert table is None
    assert [(f.rule, f.chip_code) for f in findings] == [("chip-rejects-upload", 0x11),
                                                         ("upload-unchecked", None)]
    result = check_file(str(path))
    assert not result.ok and result.error is None


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


def test_what_counts_as_a_table_file() -> None:
    assert looks_like_table_json(b'  {"format": "stepramp.table/1", "blocks": []}')
    assert looks_like_table_json(b'{"format": "wrong"}')  # reported as a bad table
    assert not looks_like_table_json(json.dumps({"blocks": ["02 00"]}).encode())
    assert not looks_like_table_json(b"02 00 01")


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


def test_every_front_end_draws_the_same_number_of_samples_by_default() -> None:
    """One default (verify.check_options.DEFAULT_SAMPLES) for the library's judges and the
    commands' --samples, and the guide says it."""
    import argparse
    import inspect
    import re

    from verify import cli
    from verify.check_options import DEFAULT_SAMPLES, CheckOptions
    from verify.cli._common import sample_count
    from verify.safety import judge_safety
    from verify.tolerance_box import judge_box

    for fn in (check_file, judge_safety, judge_box):
        assert inspect.signature(fn).parameters["samples"].default == DEFAULT_SAMPLES, fn
    assert CheckOptions().samples == DEFAULT_SAMPLES
    parser = cli.build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    def tolerance_samples(a: argparse.Action) -> bool:  # not simulate's --samples OUT.csv
        return a.dest == "samples" and a.type is sample_count

    with_samples = {name: next(a.default for a in sub._actions if tolerance_samples(a))
                    for name, sub in commands.choices.items()
                    if any(tolerance_samples(a) for a in sub._actions)}
    assert with_samples and set(with_samples.values()) == {DEFAULT_SAMPLES}, with_samples
    guide = (ROOT / "docs" / "guide.md").read_text(encoding="utf-8")
    said = re.search(r"`--samples N` \(default (\d+)\)", guide)
    assert said is not None and int(said.group(1)) == DEFAULT_SAMPLES == 1000


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

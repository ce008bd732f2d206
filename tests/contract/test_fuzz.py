"""Fuzzing in the suite: every reader and every command line, fed random and mutated
input in-process. A reader returns or raises a one-line StepRampError; a command exits
0/1 with the right verdict or 2 with one line on stderr, never a traceback or an
internal error, and leaves no output or temp file behind on failure. The generators
are tools/fuzz.py's (its longer campaign reports counts per command).

The fast part runs one seeded case of every light template (every command, a few
seconds); the hypothesis-driven campaign over every template, the planner-bound ones
included, is `slow`. Cases run in temporary folders that are also the working
directory: nothing lands beside the repository."""

from __future__ import annotations

import importlib.util
import random
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles import mc200
from profiles.alink.formats import parse as alink_parse
from profiles.errors import StepRampError
from profiles.mc200.formats import parse as mc200_parse
from profiles.motor import Motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.formats import parse_upload
from profiles.ppmc312.table import table_from_json
from profiles.ppmc312.upload import decode_table_read, decode_upload
from profiles.reading import parse_json
from tests.support.paths import ROOT

_spec = importlib.util.spec_from_file_location("stepramp_fuzz", ROOT / "tools" / "fuzz.py")


assert _spec is not None and _spec.loader is not None


fuzz = importlib.util.module_from_spec(_spec)


sys.modules["stepramp_fuzz"] = fuzz


_spec.loader.exec_module(fuzz)


FUZZ = settings(max_examples=40, deadline=None,
                suppress_health_check=[HealthCheck.too_slow,
                                       HealthCheck.function_scoped_fixture])


FEW = settings(FUZZ, max_examples=4)


SEEDS = fuzz.seeds()


ALL_FILE_COMMANDS = fuzz.FILE_COMMANDS + fuzz.HEAVY_FILE_COMMANDS


ALL_ARGV_TEMPLATES = fuzz.ARGV_TEMPLATES + fuzz.HEAVY_ARGV_TEMPLATES


def _one_line_or_value(read: Callable[[bytes], Any], data: bytes) -> None:
    try:
        read(data)
    except StepRampError as e:
        assert "\n" not in str(e) and str(e)


def _json_then(build: Callable[[Any], Any]) -> Callable[[bytes], Any]:
    return lambda data: build(parse_json(data, "fuzzed.json"))


READERS: dict[str, tuple[str, Callable[[bytes], Any]]] = {
    "table": ("table-free", _json_then(table_from_json)),
    "init table": ("table-init", _json_then(table_from_json)),
    "motor": ("motor", _json_then(Motor.from_json)),
    "upload hex": ("upload-hex", lambda d: decode_upload(parse_upload(d))),
    "upload bin": ("upload-bin", lambda d: decode_upload(parse_upload(d))),
    "upload json": ("upload-json", lambda d: decode_upload(parse_upload(d))),
    "table read": ("table-read", lambda d: decode_table_read(parse_upload(d),
                                                             clock=Clock.internal("8MHz"))),
    "mc200 hex": ("mc200-hex", lambda d: mc200.decode_stream(d.partition(b"#")[0], "host")),
    "mc200 bin": ("mc200-bin", lambda d: mc200.decode_stream(d, "driver")),
    "mc200 file": ("mc200-c", lambda d: mc200.read_stream(b"".join(mc200_parse(d).items))),
    "mc200 json": ("mc200-json", lambda d: mc200_parse(d)),
    "alink text": ("alink-text", lambda d: alink_parse(d)),
    "alink json": ("alink-json", lambda d: alink_parse(d)),
}


@pytest.mark.parametrize("name", READERS)
@FEW
@given(rnd=st.randoms(use_true_random=False))
def test_readers_return_or_raise_one_line(name: str, rnd: random.Random) -> None:
    kind, read = READERS[name]
    _one_line_or_value(read, fuzz.mutate(SEEDS[kind], rnd))


@pytest.mark.slow
@pytest.mark.parametrize("name", READERS)
@FUZZ
@given(rnd=st.randoms(use_true_random=False))
def test_readers_campaign(name: str, rnd: random.Random) -> None:
    kind, read = READERS[name]
    _one_line_or_value(read, fuzz.mutate(SEEDS[kind], rnd))


@pytest.mark.parametrize("name", ["table", "motor", "upload hex", "mc200 bin"])
@FEW
@given(data=st.binary(max_size=300))
def test_readers_on_random_bytes(name: str, data: bytes) -> None:
    _one_line_or_value(READERS[name][1], data)


def test_every_command_is_fuzzed() -> None:
    from verify.cli import COMMANDS

    assert set(COMMANDS) <= fuzz.covered_commands()
    light = {c[0].split()[0] for c in fuzz.FILE_COMMANDS} | {
        t[0].split()[0] for t in fuzz.ARGV_TEMPLATES}
    assert set(COMMANDS) <= light  # the fast part below runs every one


def _tree(root: Path) -> list[str]:
    return sorted(p.name for p in root.iterdir())


def test_every_light_template_once() -> None:
    """One seeded case of every light template: each command once or more, in seconds."""
    before = _tree(ROOT)
    problems = []
    with fuzz.case_folder() as folder:
        for i in range(len(fuzz.FILE_COMMANDS)):
            o = fuzz.file_case(random.Random(i), SEEDS, folder, i)
            problems += [(o.argv, o.problems, o.err)] if o.problems else []
        for i in range(len(fuzz.ARGV_TEMPLATES)):
            o = fuzz.argv_case(random.Random(i), folder, i)
            problems += [(o.argv, o.problems, o.err)] if o.problems else []
    assert problems == []
    assert _tree(ROOT) == before  # nothing written beside the repository


@pytest.mark.slow
@pytest.mark.parametrize("index", range(len(ALL_FILE_COMMANDS)),
                         ids=[f"{c[0]}-{c[1]}" for c in ALL_FILE_COMMANDS])
@settings(FUZZ, max_examples=8)
@given(rnd=st.randoms(use_true_random=False))
def test_commands_on_mutated_files(index: int, rnd: random.Random, tmp_path: Path,
                                   monkeypatch: pytest.MonkeyPatch) -> None:
    folder = Path(tempfile.mkdtemp(dir=tmp_path))
    monkeypatch.chdir(folder)
    outcome = fuzz.file_case(rnd, SEEDS, folder, index, commands=ALL_FILE_COMMANDS)
    assert outcome.problems == [], (outcome.argv, outcome.err)


@pytest.mark.slow
@pytest.mark.parametrize("index", range(len(ALL_ARGV_TEMPLATES)),
                         ids=[" ".join(t[1][:2]) for t in ALL_ARGV_TEMPLATES])
@settings(FUZZ, max_examples=6)
@given(rnd=st.randoms(use_true_random=False))
def test_command_lines(index: int, rnd: random.Random, tmp_path: Path,
                       monkeypatch: pytest.MonkeyPatch) -> None:
    folder = Path(tempfile.mkdtemp(dir=tmp_path))
    monkeypatch.chdir(folder)
    outcome = fuzz.argv_case(rnd, folder, index, templates=ALL_ARGV_TEMPLATES)
    assert outcome.problems == [], (outcome.argv, outcome.err)


def _run(*argv: str) -> tuple[int, str, str]:
    return fuzz.run_cli(list(argv))


@pytest.mark.parametrize("content, says", [
    ("[" * 1000 + "]" * 1000, "JSON nested more than the 64 levels"),
    ("1" * 4301, "has 4301 characters"),
    ('{"format": "stepramp.table/1", "rates": [NaN]}', "NaN is not a JSON number"),
])
def test_export_reproducers(tmp_path: Path, content: str, says: str) -> None:
    f = tmp_path / "d.json"
    f.write_text(content)
    code, _, err = _run("export", str(f), "-o", str(tmp_path / "out.hex"))
    assert code == 2 and err.count("\n") == 1 and says in err and err.startswith(
        "stepramp export: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.json"]


def test_huge_int_in_a_motor_file(tmp_path: Path) -> None:
    doc = (ROOT / "profiles" / "data" / "motor-nema17-1600.json").read_text()
    key = '"inertia_kgm2": '
    assert key in doc
    i = doc.index(key) + len(key)
    j = i + len(doc[i:].split(",")[0].split("}")[0])
    f = tmp_path / "m.json"
    f.write_text(doc[:i] + "1" + "0" * 309 + doc[j:])
    for argv in (["check", str(ROOT / "examples" / "free-curve-nema17.json"), "--motor", str(f)],
                 ["plan", "--motor", str(f)],
                 ["alink", "settings", "--motor", str(f)]):
        code, _, err = _run(*argv)
        assert code == 2 and err.count("\n") == 1 and "has 310 characters" in err, err


def test_mc200_stream_with_a_tiny_vmax() -> None:
    code, _, err = _run("mc200", "stream", "--vmax", "1e-9", "--amax", "200000", "--jmax",
                        "5000000", "--pulses", "3200", "--period-us", "1000")
    assert code == 2 and err.count("\n") == 1 and "internal error" not in err


def test_an_odd_file_name_on_a_strict_terminal(tmp_path: Path) -> None:
    import os
    import subprocess

    env = {**os.environ, "PYTHONIOENCODING": "utf-8:strict"}
    name = os.fsencode(tmp_path) + b"/missing\xff.json"
    r = subprocess.run([sys.executable, "-m", "verify.cli", "check", name], env=env,
                       capture_output=True, cwd=ROOT, timeout=120)
    assert r.returncode == 2
    assert b"Traceback" not in r.stderr and r.stderr.count(b"\n") == 1
    assert b"missing\\xff.json: no such file" in r.stderr
    assert b"missing\\xff.json" in r.stdout  # the report names it too, escaped


def test_motor_empty_string_is_not_no_motor() -> None:
    code, _, err = _run("check", str(ROOT / "examples" / "free-curve-nema17.json"), "--motor", "")
    assert code == 2 and "an empty file name" in err


def test_argparse_errors_are_one_line() -> None:
    for argv in (["check"], ["nonsense"], ["export", "x", "--format", "doc"], []):
        code, _, err = _run(*argv)
        assert code == 2 and err.count("\n") == 1 and err.startswith("stepramp"), err


def test_an_internal_error_is_one_line_exit_2_and_debug_shows_it(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from verify import chip_rules as checks

    def boom(*_: object) -> list[object]:
        raise ZeroDivisionError("planted")

    monkeypatch.setattr(checks, "check_table", boom)
    table = str(ROOT / "examples" / "free-curve-nema17.json")
    code, _, err = _run("export", table)
    assert code == 2 and err.count("\n") == 1
    assert err.startswith("stepramp export: internal error (ZeroDivisionError: planted) on ")
    assert "--debug" in err and "Traceback" not in err
    code, _, err = _run("export", table, "--debug")
    assert code == 2 and "Traceback" in err and "planted" in err


def test_table_read_falling_edge_round_trips(tmp_path: Path) -> None:
    from profiles.ppmc312.table import FreeCurveTable, dump_table, load_table
    from profiles.ppmc312.upload import encode_table_read_response

    table = FreeCurveTable(Clock.extck(1e6, "falling"), (400, 500), (100, 200))
    f = tmp_path / "read.hex"
    f.write_text("".join(b.hex(" ") + "\n" for b in encode_table_read_response(table)))
    out = tmp_path / "t.json"
    code, _, err = _run("decode", str(f), "--table-read", "--clock", "EXTCK", "--extck-hz",
                        "1e6", "--edge", "falling", "-o", str(out))
    assert code == 0, err
    assert load_table(out) == table and out.read_text() == dump_table(table)
    code, _, err = _run("decode", str(f), "--table-read", "--clock", "8MHz", "--edge", "falling")
    assert code == 2 and "--edge is for --table-read --clock EXTCK" in err


def test_simulate_outputs_all_or_none(tmp_path: Path) -> None:
    table = str(ROOT / "examples" / "free-curve-nema17.json")
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    code, _, err = _run("simulate", table, "--pulses", "10000001", "--csv", str(a),
                        "--pulse-times", str(b))
    assert code == 2 and "one CSV row per pulse" in err
    assert list(tmp_path.iterdir()) == []  # A is not left behind when B fails
    code, _, err = _run("simulate", table, "--pulses", "5000", "--csv", str(a), "--pulse-times",
                        str(b))
    assert code == 0 and a.exists() and len(b.read_text().splitlines()) == 5001


def test_mc200_decode_json_has_no_nan(tmp_path: Path) -> None:
    import json

    f = tmp_path / "nan.bin"  # a driver reply whose float32 current is NaN
    f.write_bytes(mc200.DriverPacket(current_a=float("nan")).encode())
    code, out, err = _run("mc200", "decode", str(f), "--direction", "driver", "--format", "json")
    assert code == 0, err
    assert "NaN" not in out
    assert json.loads(out)["packets"][0]["current_a"] is None

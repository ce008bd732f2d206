"""Bounded inputs: profiles/reading.py refuses what is not a small regular file, caps
JSON nesting and number size, and refuses NaN/Infinity; JSON outputs never carry NaN."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from profiles import reading
from profiles.errors import FormatError
from profiles.reading import (
    MAX_JSON_DEPTH,
    MAX_NUMBER_CHARS,
    display_path,
    json_depth,
    json_text,
    parse_json,
    read_bytes,
    read_json,
)
from tests.support.paths import ROOT


def _refused(path: str | Path, match: str) -> str:
    """read_bytes in a thread, so a reader that blocks fails the test instead of hanging it."""
    box: dict[str, BaseException | bytes] = {}

    def run() -> None:
        try:
            box["value"] = read_bytes(path)
        except BaseException as e:
            box["value"] = e

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(10)
    assert not t.is_alive(), f"read_bytes({path}) blocked"
    err = box["value"]
    assert isinstance(err, FormatError), err
    assert "\n" not in str(err)
    assert match in str(err), str(err)
    return str(err)


def test_a_regular_file_is_read(tmp_path: Path) -> None:
    f = tmp_path / "t.json"
    f.write_bytes(b'{"a": 1}')
    assert read_bytes(f) == b'{"a": 1}'
    assert read_json(f) == {"a": 1}


def test_missing_and_empty(tmp_path: Path) -> None:
    _refused(tmp_path / "nope.json", "no such file")
    (tmp_path / "e.json").write_bytes(b" \n")
    _refused(tmp_path / "e.json", "empty")


def _feed(fifo: Path, data: bytes) -> threading.Thread:
    """A writer for `fifo` (opening a FIFO blocks until both ends are open)."""
    def write() -> None:
        try:
            with open(fifo, "wb") as fh:
                fh.write(data)
        except BrokenPipeError:  # the reader stopped at its bound
            pass

    t = threading.Thread(target=write, daemon=True)
    t.start()
    return t


def test_a_fifo_is_read_like_stdin(tmp_path: Path) -> None:
    fifo = tmp_path / "f"
    os.mkfifo(fifo)
    writer = _feed(fifo, b'{"a": 1}')
    assert read_json(fifo) == {"a": 1}
    writer.join(10)


def test_a_fifo_has_the_same_bound_as_stdin(tmp_path: Path) -> None:
    fifo = tmp_path / "f"
    os.mkfifo(fifo)
    writer = _feed(fifo, b"x" * 11)
    with pytest.raises(FormatError, match="more than the 10 bytes an input may have"):
        read_bytes(fifo, limit=10)
    writer.join(10)
    writer = _feed(fifo, b"x" * 10)
    assert read_bytes(fifo, limit=10) == b"x" * 10
    writer.join(10)


def test_process_substitution_is_an_input(tmp_path: Path) -> None:
    """`stepramp check <(cat t.json)`: bash hands over /dev/fd/N, a pipe."""
    table = ROOT / "examples" / "free-curve-nema17.json"
    r = subprocess.run(["bash", "-c", f'"{sys.executable}" -m verify.cli check <(cat "{table}")'
                        f' && "{sys.executable}" -m verify.cli show <(cat "{table}")'],
                       capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "1 file checked: 1 ok" in r.stdout and "free-curve table, clock 8MHz" in r.stdout


def test_a_socket_is_refused(tmp_path: Path) -> None:
    import socket

    path = tmp_path / "s"
    with socket.socket(socket.AF_UNIX) as s:
        s.bind(str(path))
        _refused(path, "is a socket, not a file or a pipe")


def test_a_character_device_is_refused_not_read_forever() -> None:
    _refused("/dev/zero", "is a device, not a file or a pipe")


def test_a_directory_is_refused(tmp_path: Path) -> None:
    _refused(tmp_path, "is a directory")


def test_a_symlink_to_a_regular_file_is_followed(tmp_path: Path) -> None:
    (tmp_path / "real").write_bytes(b"[1]")
    (tmp_path / "link").symlink_to("real")
    assert read_bytes(tmp_path / "link") == b"[1]"


def test_a_symlink_to_a_device_is_refused(tmp_path: Path) -> None:
    (tmp_path / "zero").symlink_to("/dev/zero")
    _refused(tmp_path / "zero", "is a device")


def test_size_cap_at_the_boundary(tmp_path: Path) -> None:
    f = tmp_path / "big"
    f.write_bytes(b"x" * 10)
    assert read_bytes(f, limit=10) == b"x" * 10
    f.write_bytes(b"x" * 11)
    with pytest.raises(FormatError, match="11 bytes is more than the 10 bytes"):
        read_bytes(f, limit=10)


def test_the_default_cap_is_checked_before_reading(tmp_path: Path) -> None:
    f = tmp_path / "sparse"
    with open(f, "wb") as fh:  # a sparse 16 MiB + 1 file: refused from its size alone
        fh.truncate(reading.MAX_INPUT_BYTES + 1)
    _refused(f, f"more than the {reading.MAX_INPUT_BYTES} bytes")


class _Stdin:
    def __init__(self, data: bytes) -> None:
        self.buffer = io.BytesIO(data)


def test_dash_reads_stdin(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "stdin", _Stdin(b'{"x": 2}'))
    assert read_json("-") == {"x": 2}


def test_stdin_is_capped(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "stdin", _Stdin(b"y" * 6))
    assert read_bytes("-", limit=6) == b"y" * 6
    monkeypatch.setattr(sys, "stdin", _Stdin(b"y" * 7))
    with pytest.raises(FormatError, match="stdin: more than the 6 bytes"):
        read_bytes("-", limit=6)


def _nested(depth: int) -> bytes:
    return b"[" * depth + b"]" * depth


def test_depth_cap_at_the_boundary() -> None:
    assert json_depth(_nested(MAX_JSON_DEPTH)) == MAX_JSON_DEPTH
    parse_json(_nested(MAX_JSON_DEPTH), "d.json")
    with pytest.raises(FormatError, match=f"d.json: JSON nested more than the {MAX_JSON_DEPTH}"):
        parse_json(_nested(MAX_JSON_DEPTH + 1), "d.json")


def test_the_recursion_error_reproducer_is_one_line() -> None:
    with pytest.raises(FormatError, match="JSON nested more than the 64 levels"):
        parse_json(_nested(1000), "d.json")


def test_brackets_inside_strings_do_not_count() -> None:
    text = json.dumps({"s": "[[[[" * 100 + '\\"{{', "t": ["]"]}).encode()
    assert json_depth(text) == 2
    assert parse_json(text, "s.json")["t"] == ["]"]


@pytest.mark.parametrize("kind", ["int", "float"])
def test_number_size_cap_at_the_boundary(kind: str) -> None:
    def number(n: int) -> str:
        return "1" * n if kind == "int" else "1." + "0" * (n - 2)

    assert parse_json(f"[{number(MAX_NUMBER_CHARS)}]".encode(), "n.json")
    with pytest.raises(FormatError, match=f"has {MAX_NUMBER_CHARS + 1} characters"):
        parse_json(f"[{number(MAX_NUMBER_CHARS + 1)}]".encode(), "n.json")


def test_the_int_digits_reproducer_is_one_line() -> None:
    with pytest.raises(FormatError, match=r"n\.json: number 111111111111… has 4301 characters"):
        parse_json(b"1" * 4301, "n.json")


def test_the_overflowing_inertia_is_refused_at_reading() -> None:
    with pytest.raises(FormatError, match="has 310 characters"):
        parse_json(b'{"inertia_kgm2": 1' + b"0" * 309 + b"}", "m.json")


@pytest.mark.parametrize("word", ["NaN", "Infinity", "-Infinity"])
def test_nan_and_infinity_are_refused(word: str) -> None:
    with pytest.raises(FormatError, match=f"{word} is not a JSON number"):
        parse_json(f'{{"v": {word}}}'.encode(), "x.json")


@pytest.mark.parametrize("text", ["1e400", "-1e309"])
def test_a_float_that_overflows_is_refused(text: str) -> None:
    with pytest.raises(FormatError, match="not a finite double"):
        parse_json(f"[{text}]".encode(), "x.json")


def test_largest_finite_double_is_accepted() -> None:
    assert parse_json(b"[1.7976931348623157e308]", "x.json") == [1.7976931348623157e308]


def test_json_outputs_never_carry_nan() -> None:
    text = json_text({"a": float("nan"), "b": [float("inf"), -float("inf"), 1.5], "c": 2})
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text) == {"a": None, "b": [None, None, 1.5], "c": 2}


def test_display_path_escapes_undecodable_bytes() -> None:
    odd = os.fsdecode(b"missing\xff.json")
    shown = display_path(odd)
    assert shown == "missing\\xff.json"
    shown.encode("ascii")  # printable on the strictest terminal
    err = _refused(odd, "no such file")
    assert err.startswith("missing\\xff.json")


def test_display_path_survives_lone_surrogates() -> None:
    assert display_path("x\ud800y") == "x\\ud800y"


def test_an_empty_path_is_refused_by_name() -> None:
    with pytest.raises(FormatError, match="an empty file name"):
        read_bytes("")


def test_the_depth_scan_is_linear_on_unclosed_escaped_quotes() -> None:
    # `"\"\"\"…` with no closing quote made a one-regex scan quadratic (minutes at this
    # size; found by tools/fuzz.py). Run in a thread: a regression fails, never hangs.
    data = b'"' + b'\\"' * 400_000
    box: list[BaseException | None] = []

    def run() -> None:
        try:
            parse_json(data, "q.json")
        except BaseException as e:
            box.append(e)

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(60)
    assert not t.is_alive(), "the depth scan is not linear"
    assert isinstance(box[0], FormatError) and "not valid JSON" in str(box[0])


def test_depth_scan_stops_early() -> None:
    assert json_depth(b"[" * 1000, stop=65) == 65
    assert json_depth(b'["[[[", [{}]]') == 3
    assert json_depth(b'"unclosed [[[[') == 0


def test_json_that_is_not_utf8_says_so_and_where() -> None:
    """The words `plan --moves` uses for a CSV that is not text, with the first bad byte;
    no Python exception name in the line."""
    with pytest.raises(FormatError) as e:
        parse_json(b'{"a": "\xbe"}', "motor.json")
    assert str(e.value) == "motor.json: not a UTF-8 text file (byte 0xbe at offset 7)"


def test_the_guide_states_the_input_bounds_the_reader_keeps() -> None:
    """docs/guide.md, "Inputs": a file over 16 MiB, JSON nested more than 64 deep and a
    number of more than 40 characters are refused; the reader's constants say the same."""
    import re

    guide = (ROOT / "docs" / "guide.md").read_text("utf-8")
    inputs = " ".join(guide[guide.index("- **Inputs**"):guide.index("- **Outputs**")].split())
    said = re.search(r"a file over (\d+) MiB .* JSON nested more than (\d+) deep, a number "
                     r"of more than (\d+) characters", inputs)
    assert said is not None
    mib, depth, chars = (int(g) for g in said.groups())
    assert (mib * 1024 * 1024, depth, chars) == (reading.MAX_INPUT_BYTES,
                                                 reading.MAX_JSON_DEPTH, MAX_NUMBER_CHARS)

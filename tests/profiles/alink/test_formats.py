"""A-Link settings files: every format renders and parses back to the command words,
the settings come back from the commands, a changed file is reported as corrupted."""

from __future__ import annotations

import json
import zlib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from profiles import alink as A
from profiles.alink.formats import (
    FORMATS,
    commands_of_document,
    is_settings_file,
    parse,
    parse_c_set,
    payload_of,
    render,
    render_c_set,
    settings_of,
)
from profiles.errors import FormatError, StepRampError
from profiles.formats import Provenance, RenderOptions
from tests.support.file_checks import (
    assert_one_line_error,
    compile_and_run,
    flip_verdicts,
    needs_cc,
    parsed_in_any_format,
)

SETTINGS = settings(max_examples=80, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


ALL = ("text", "json", "hex", "c")


@st.composite
def valid_settings(draw: st.DrawFn) -> A.AlinkSettings:
    """Settings the unit runs unchanged, over every band of both multiplier tables."""
    max_pps = draw(st.sampled_from([0.0]) | st.floats(1, 100_000))
    high = draw(st.floats(1, max_pps or 100_000))
    start = draw(st.floats(1, high))
    accel = draw(st.floats(0.01, 1600))
    try:
        s = A.quantise_settings(start, high, accel, max_pps, s_curve=draw(st.booleans()),
                                triangle_avoidance=draw(st.booleans()))
    except StepRampError:
        assume(False)
        raise
    return s


@st.composite
def command_lists(draw: st.DrawFn) -> list[A.Command]:
    """The settings commands (addressed or not), or any commands (moves, reads…)."""
    if draw(st.booleans()):
        address = draw(st.none() | st.integers(1, 53))
        return A.settings_commands(draw(valid_settings()), slave_address=address,
                                   axis=draw(st.integers(0, 1)))
    writer = A.CommandWriter()
    return [writer.put(draw(st.sampled_from(list(A.Cmd))), draw(st.integers(0, A.FUNC_MAX)),
                       draw(st.integers(A.PARA_MIN, A.PARA_MAX)))
            for _ in range(draw(st.integers(1, 8)))]


@SETTINGS
@given(valid_settings(), st.none() | st.integers(1, 53), st.integers(0, 1))
def test_settings_come_back_from_their_commands(s: A.AlinkSettings, address: int | None,
                                                axis: int) -> None:
    commands = A.settings_commands(s, slave_address=address, axis=axis)
    assert A.settings_from_commands(commands) == s
    assert A.settings_from_commands([(c.cmd, c.func, c.para) for c in commands]) == s
    assert A.settings_from_commands(reversed(commands)) == s  # order does not matter


@SETTINGS
@given(command_lists(), st.sampled_from(ALL))
def test_every_format_round_trips(commands: list[A.Command], fmt: str) -> None:
    header = {"predicted_time_s": 0.125, "warnings": ["a warning"]}
    data = render(commands, fmt, RenderOptions(name="axis", header=header))
    parsed = parse(data)  # detected by content
    assert parsed.format == fmt and parsed.integrity == "verified"
    # JSON keeps the memory-map address; the other formats carry the words only
    want = commands if fmt == "json" else [
        A.Command(c.name, c.cmd, c.func, c.para, c.words, c.pair) for c in commands]
    assert parsed.items == want
    assert is_settings_file(data)


COMMANDS = A.settings_commands(A.quantise_settings(500, 10000, 20))


PAYLOAD = b"".join(w.to_bytes(2, "little") for c in COMMANDS for w in c.words)


CRC = f"{zlib.crc32(PAYLOAD):08X}"  # zlib's, independent of stepramp's


def test_payload_is_the_words_little_endian() -> None:
    assert payload_of(c.words for c in COMMANDS) == PAYLOAD
    assert PAYLOAD[:6] == bytes([0x15, 0x41, 0x00, 0x40, 0x00, 0x40])  # MAX_SPEED, pair 1


def test_files_carry_the_crc() -> None:
    assert render(COMMANDS, "hex").decode() == (
        "4115 4000 4000\n801D 8000 8005\nC113 C000 E710\n4112 4000 41F4\n8214 8000 87D0\n"
        f"# crc32 {CRC}: CRC-32 of the 15 command words above (16-bit little-endian, 30 "
        "bytes)\n")
    assert json.loads(render(COMMANDS, "json"))["crc32"] == CRC
    c = render(COMMANDS, "c", RenderOptions(name="x_axis")).decode()
    assert f"#define X_AXIS_CRC32 0x{CRC}UL" in c and "x_axis_words[X_AXIS_COMMAND_COUNT][3]" in c
    assert render(COMMANDS, "text").decode().endswith(f"# crc32 {CRC}: CRC-32 of the 15 "
                                                      "command words above (16-bit "
                                                      "little-endian, 30 bytes)\n")


def test_text_says_the_summary_and_c_rows_end_without_a_comma() -> None:
    """The text file's head: the multiplier line, then each summary number the planner
    gave (6 significant digits); the C rows: a comma between rows, none after the last."""
    text = render(COMMANDS, "text", RenderOptions(header={
        "predicted_time_s": 0.123456789, "ratio_to_optimum": 1.0417, "warnings": []}))
    lines = text.decode().splitlines()
    assert lines[0].startswith("multiplier ×5: start 500 pps, high 10000 pps")
    assert lines[1:3] == ["predicted_time_s: 0.123457", "ratio_to_optimum: 1.0417"]
    rows = [line for line in render(COMMANDS, "c").decode().splitlines()
            if line.startswith("    {0x")]
    assert len(rows) == len(COMMANDS)
    assert all("}," in r for r in rows[:-1])
    assert rows[-1].startswith("    {0x8214, 0x8000, 0x87D0}   /* UP_TIME")


def test_render_settings_keeps_the_document() -> None:
    s = A.quantise_settings(500, 12345, 3.35)
    doc = A.settings_document(s, A.settings_commands(s, slave_address=5),
                              summary={"predicted_time_s": 0.25, "shape": "trapezoid"},
                              warnings=["w"])
    assert json.loads(A.render_settings(doc, "json")) == {**doc, "crc32": json.loads(
        A.render_settings(doc, "json"))["crc32"]}
    assert commands_of_document(doc) == A.settings_commands(s, slave_address=5)


def test_settings_from_commands_refuses_what_is_not_settings() -> None:
    good = [(c.cmd, c.func, c.para) for c in COMMANDS]
    cases = [
        (good[:4], "lack UP_TIME"),
        (good + good[:1], "MAX_SPEED is given twice"),
        ([*good[:4], (A.Cmd.UP_TIME, 1, 2000)], "UP_TIME: func 1"),
        ([*good, (A.Cmd.MOVE_R, 28, 100)], "MOVE_R: not a settings command"),
        ([good[0], (A.Cmd.MODE, 0, 0x04), *good[2:]], "MODE: 0x4"),
        ([good[0], (A.Cmd.MODE, 0, 0x105), *good[2:]], "MODE: 0x105"),
        ([*good[:2], (A.Cmd.H_SPEED, 1, 10001), *good[3:]], "multiple"),
        ([(A.Cmd.MAX_SPEED, 1, 5000), *good[1:]], "high_pps"),
    ]
    for commands, words in cases:
        with pytest.raises(StepRampError, match=words):
            A.settings_from_commands(commands)


def test_settings_of_other_commands_is_none_and_text_lists_them_alone() -> None:
    writer = A.CommandWriter()
    moves = [writer.put(A.Cmd.MOVE_R, A.FUNC_MOVE, 1000), writer.put(A.Cmd.STOP, 0, 0)]
    assert settings_of(moves) is None
    text = render(moves, "text").decode()
    assert not text.startswith("multiplier") and text.splitlines()[0].startswith("MOVE_R")
    assert json.loads(render(moves, "json"))["warnings"] == []


# --- C --------------------------------------------------------------------------------------
MAIN_C = r"""
#include <stdio.h>
#include <string.h>
#include "x_axis.h"
#include "y_axis.h"
#include "y_axis.h"

/* CRC-32 of the words, 16-bit little-endian, in order (the array's bytes on this host). */
static uint32_t crc32_words(const uint16_t (*words)[3], size_t n) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; i++)
    for (size_t k = 0; k < 6; k++) {
      crc ^= (uint8_t)(words[i][k / 2] >> (8 * (k % 2)));
      for (int b = 0; b < 8; b++) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
  return ~crc;
}

int main(void) {
  if (crc32_words(x_axis_words, X_AXIS_COMMAND_COUNT) != X_AXIS_CRC32) return 3;
  if (crc32_words(y_axis_words, Y_AXIS_COMMAND_COUNT) != Y_AXIS_CRC32) return 4;
  for (size_t i = 0; i < Y_AXIS_COMMAND_COUNT; i++)
    printf("%04X %04X %04X\n", y_axis_words[i][0], y_axis_words[i][1], y_axis_words[i][2]);
  return 0;
}
"""


@needs_cc
def test_two_headers_compile_together_and_verify_their_crc(tmp_path: Path) -> None:
    other = A.settings_commands(A.quantise_settings(800, 40000, 2.5, 60000, s_curve=True),
                                slave_address=7, axis=1)
    prov = Provenance("stepramp alink settings '*/' --name x_axis", ())
    out = compile_and_run(tmp_path, {
        "x_axis.h": render(COMMANDS, "c", RenderOptions(name="x_axis", provenance=prov)),
        "y_axis.h": render(other, "c", RenderOptions(name="y_axis"))}, MAIN_C)
    assert out.returncode == 0, out.returncode  # 3/4: a CRC constant the C code disagrees with
    assert out.stdout.splitlines() == [" ".join(f"{w:04X}" for w in c.words) for c in other]


@needs_cc
def test_a_set_of_axes_compiles_reads_back_and_checks_each(tmp_path: Path) -> None:
    other = A.settings_commands(A.quantise_settings(800, 40000, 2.5, 60000, s_curve=True),
                                slave_address=7, axis=1)
    text = render_c_set([("x_axis", COMMANDS, "axis x"), ("y_axis", other, "axis y")],
                        RenderOptions(name="stepramp_sync"))
    parsed = parse_c_set(text)
    assert [c.words for c in parsed["x_axis"].items] == [c.words for c in COMMANDS]
    assert [c.words for c in parsed["y_axis"].items] == [c.words for c in other]
    assert {p.integrity for p in parsed.values()} == {"verified"}
    out = compile_and_run(tmp_path, {"axes.h": text}, MAIN_C.replace(
        '#include "x_axis.h"\n#include "y_axis.h"\n#include "y_axis.h"',
        '#include "axes.h"\n#include "axes.h"'))
    assert out.returncode == 0, out.returncode
    assert out.stdout.splitlines() == [" ".join(f"{w:04X}" for w in c.words) for c in other]
    word = f"0x{other[0].words[1]:04X}"
    changed = text.replace(f"{{0x{other[0].words[0]:04X}, {word}".encode(),
                           f"{{0x{other[0].words[0]:04X}, 0x{other[0].words[1] ^ 1:04X}"
                           .encode())
    assert changed != text
    with pytest.raises(StepRampError, match="Y_AXIS"):
        parse_c_set(changed)


# --- detection and errors ---------------------------------------------------------------------
def test_format_table() -> None:
    assert set(FORMATS.names) == set(ALL)
    with pytest.raises(FormatError, match="no commands"):
        render([], "hex")
    with pytest.raises(FormatError, match="format"):
        render(COMMANDS, "bin")


@pytest.mark.parametrize(("data", "words"), [
    (b"", "empty"),
    (b"4115 4000\n", "not an A-Link settings file|three 4-digit"),
    (b"4115 4000 8001\n", "line 1: pair codes differ"),
    (b"4199 4000 4000\n", "line 1: cmd: 0x99"),
    (b"4115 4000 4000\n# crc32 00000000\n", "corrupted: the crc32 comment says"),
    (b"MAX_SPEED  func  1 para        5  0x4115 0x4000 0x4000\n",
     "corrupted: line 1 says MAX_SPEED func 1 para 5, its words encode MAX_SPEED func 1 para 0"),
    (b"MAX_SPEED  func  1 para        0  0x4115 0x4000 0x4000\nhello\n",
     "line 2: neither a command row"),
    (b'{"commands": [{"words": ["0x4115", "0x4000"]}]}', "commands\\[0\\]: expected"),
    (b'{"commands": [{"words": ["0x4115", "0x4000", "x"]}]}', "words\\[2\\]"),
    (b'{"commands": [{"words": ["0x4115", "0x4000", "0x4000"]}], "start_pps": 5}',
     "corrupted: the document states settings"),
    (b'{"commands": [{"words": ["0x4115", "0x4000", "0x4000"]}], "crc32": "xyz"}',
     "corrupted: crc32"),
    (b"/* x */\nint a;\n", "NAME_words"),
    (b"static const uint16_t a_words[1][3] = {\n {0x4115, 0x4000},\n};\n", "2 values"),
    (b"static const uint16_t a_words[1][3] = {\n {0x4115, 0x4000, 0x14000},\n};\n",
     "not a 16-bit word"),
    (b"#define A_COMMAND_COUNT 2\nstatic const uint16_t a_words[1][3] = {\n"
     b" {0x4115, 0x4000, 0x4000},\n};\n", "corrupted: A_COMMAND_COUNT is 2"),
])
def test_parse_errors(data: bytes, words: str) -> None:
    assert_one_line_error(parse, data, words)


@SETTINGS
@given(st.binary(max_size=60))
def test_garbage_never_crashes_the_parsers(data: bytes) -> None:
    for items in parsed_in_any_format(parse, data, ALL):
        assert items
    is_settings_file(data)  # never raises


def test_hand_made_files_without_a_check_are_read_with_integrity_absent() -> None:
    for fmt in ALL:
        data = render(COMMANDS, fmt).decode()
        if fmt == "json":
            doc = json.loads(data)
            del doc["crc32"]
            data = json.dumps(doc)
        else:
            data = "\n".join(line for line in data.splitlines()
                             if "crc32" not in line and "_CRC32 0x" not in line)
        parsed = parse(data.encode())
        assert parsed.items == COMMANDS and parsed.integrity == "absent", fmt


# --- integrity --------------------------------------------------------------------------------
SAMPLE = [COMMANDS, A.settings_commands(A.quantise_settings(800, 40000, 2.5, 60000,
                                                            s_curve=True), slave_address=7)]


# The slowest formats to re-parse flip by flip run in CI only (-m slow).
@pytest.mark.parametrize("fmt", [pytest.param(f, marks=pytest.mark.slow) if f in ("c", "json")
                                 else f for f in ALL])
def test_every_single_bit_flip_is_caught(fmt: str) -> None:
    """Flip each bit of each file: refused or read back as the same command words;
    never as other commands."""
    caught, same = flip_verdicts(
        ((render(c, fmt, RenderOptions(name="axis")), [x.words for x in c]) for c in SAMPLE),
        lambda data: [x.words for x in parse(data).items])
    assert caught > same / 4  # text and C: most flips hit comments and names


def _doc() -> dict:
    s = A.quantise_settings(500, 12345, 3.35)
    cmds = A.settings_commands(s, slave_address=5)
    return A.settings_document(s, cmds, summary={"predicted_time_s": 0.25}, warnings=["w"])


def test_render_settings_hex_and_json_agree() -> None:
    doc = _doc()
    *hex_rows, check = A.render_settings(doc, "hex").splitlines()
    assert [[int(w, 16) for w in row.split()] for row in hex_rows] == [
        [int(w, 16) for w in c["words"]] for c in doc["commands"]]
    payload = b"".join(int(w, 16).to_bytes(2, "little") for c in doc["commands"]
                       for w in c["words"])
    crc = f"{zlib.crc32(payload):08X}"  # zlib's, independent of stepramp's
    assert check.startswith(f"# crc32 {crc}: ")
    assert json.loads(A.render_settings(doc, "json")) == {**doc, "crc32": crc}
    text = A.render_settings(doc, "text")
    assert "predicted_time_s: 0.25" in text and "warning: w" in text
    with pytest.raises(FormatError, match="format"):
        A.render_settings(doc, "xml")

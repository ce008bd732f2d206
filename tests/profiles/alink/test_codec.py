"""profiles.alink.codec: A-Link ALUM command words, responses, read-backs and the memory map
(manual §11), and settings read back from their commands."""

from __future__ import annotations

import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import alink as A
from profiles.errors import DecodeError, FieldRangeError, FormatError, StepRampError


def test_form_manual_example_and_erratum() -> None:
    # the manual prints form(MOVE_A, 28, 1000000) as 0006/06A0: those encode 100000
    cmd, p1, p2 = A.form(A.Cmd.MOVE_A, 28, 100000)
    assert (cmd, p1, p2) == (0x1C22, 0x0006, 0x06A0)
    assert A.form(A.Cmd.MOVE_A, 28, 1000000) == (0x1C22, 0x003D, 0x0240)
    assert (0x003D << 14) | 0x0240 == 1000000
    assert A.form(A.Cmd.LOGIC, 0, 0x14) == (0x001C, 0x0000, 0x0014)  # the LOGIC example
    assert A.form(A.Cmd.MOVE_R, 28, -1) == (0x1C21, 0x3FFF, 0x3FFF)


def test_form_refuses_bad_input() -> None:
    with pytest.raises(FieldRangeError, match="func"):
        A.form(A.Cmd.MOVE_A, 32, 0)
    with pytest.raises(FieldRangeError, match="para"):
        A.form(A.Cmd.MOVE_A, 28, 1 << 27)
    with pytest.raises(FieldRangeError, match="para"):
        A.form(A.Cmd.MOVE_A, 28, -(1 << 27) - 1)
    with pytest.raises(StepRampError, match="0x7D"):
        A.form(0x7D, 0, 0)  # ROUTINE_WRK: only in a sample #define
    with pytest.raises(StepRampError, match="0x86"):
        A.form(0x86, 0, 0)


@settings(max_examples=200, deadline=None)
@given(cmd=st.sampled_from(list(A.Cmd)), func=st.integers(0, 31),
       para=st.integers(-(1 << 27), (1 << 27) - 1), pairs=st.integers(1, 7))
def test_form_round_trip(cmd: A.Cmd, func: int, para: int, pairs: int) -> None:
    w = A.form(cmd, func, para)
    assert all(x >> 14 == 0 for x in w)  # no pair code before putcmd
    writer = A.CommandWriter()
    for _ in range(pairs):
        c = writer.put(cmd, func, para)
    assert A.parse_command(*c.words) == (cmd, func, para, c.pair)
    assert [x & 0x3FFF for x in c.words] == list(w)  # putcmd only adds bits 15–14


def test_pair_codes_cycle_from_one() -> None:
    writer = A.CommandWriter()
    pairs = [writer.put(A.Cmd.READ, 0, 0).pair for _ in range(7)]
    assert pairs == [1, 2, 3, 1, 2, 3, 1]
    assert [A.next_pair(p) for p in (0, 1, 2, 3)] == [1, 2, 3, 1]
    assert A.PairCode.NOOP.next() is A.PairCode.ONE and A.PairCode.THREE.next() == 1
    with pytest.raises(FieldRangeError, match="pair"):
        A.next_pair(4)
    words = list(A.CommandWriter().stream([(A.Cmd.LOGIC, 0, 0x14), (A.Cmd.MOVE_A, 28, 100000)]))
    assert words == [(0x401C, 0x4000, 0x4014), (0x9C22, 0x8006, 0x86A0)]


def test_parse_command_refuses_mixed_pairs_and_reserved_bit() -> None:
    with pytest.raises(FormatError, match="pair"):
        A.parse_command(0x401C, 0x8000, 0x4014)
    with pytest.raises(DecodeError, match="unexpected bits"):
        A.parse_command(0x201C, 0x0000, 0x0000)
    with pytest.raises(FieldRangeError, match="word"):
        A.parse_command(0x1_0000, 0, 0)


@pytest.mark.parametrize(("duplex", "axis", "word", "offset"), [
    ("full", 0, 0, 0), ("full", 0, 1, 2), ("full", 0, 2, 4),
    ("full", 1, 0, 6), ("full", 1, 1, 8), ("full", 1, 2, 10),
    ("half", 0, 0, 0), ("half", 0, 1, 1), ("half", 0, 2, 2),
    ("half", 1, 0, 3), ("half", 1, 1, 4), ("half", 1, 2, 5)])
def test_memory_map(duplex: A.Duplex, axis: int, word: int, offset: int) -> None:
    n = 7
    assert A.command_address(n, axis, duplex, word) == 0x080 + (n + offset) * 2
    assert A.status_address(n, axis, duplex, word) == 0x100 + (n + offset) * 2


def test_memory_map_ranges() -> None:
    assert A.command_address(1) == 0x082  # the first D0 word in table 9-2-1
    assert A.status_address(53, 1, "full", 2) == 0x100 + 63 * 2  # last DI word
    assert A.status_address(58, 1, "half", 2) == 0x100 + 63 * 2
    with pytest.raises(FieldRangeError, match="slave_address"):
        A.command_address(54, 0, "full")
    with pytest.raises(FieldRangeError, match="slave_address"):
        A.command_address(0)
    with pytest.raises(FieldRangeError, match="axis"):
        A.command_address(1, 2)
    with pytest.raises(FormatError, match="duplex"):
        A.command_address(1, 0, "simplex")  # type: ignore[arg-type]


def test_decode_response_status_bits_and_value() -> None:
    status = 0x0001 | (2 << 2) | (1 << 5) | (1 << 8) | (1 << 10) | (1 << 15)
    raw = (-5) & 0x0FFFFFFF
    r = A.decode_response(status, (2 << 14) | (raw >> 14), (2 << 14) | (raw & 0x3FFF),
                          expected_pair=2)
    assert r.valid and r.ack and r.value == -5
    assert r.driving and r.origin_set and r.plus_limit and r.abnormal_stop
    assert not (r.inhibit or r.minus_limit or r.eeprom_error or r.extended)
    nak = A.decode_response(0x0008, 0x8000, 0x8000, expected_pair=2)
    assert nak.valid and not nak.ack


def test_decode_response_names_the_pair_that_disagrees() -> None:
    r = A.decode_response(0x0008, 0x8000, 0x4000, expected_pair=2)
    assert not r.valid and r.mismatch is not None and r.mismatch.startswith("DATA2")
    r = A.decode_response(0x0004, 0x8000, 0x8000, expected_pair=2)
    assert r.mismatch is not None and r.mismatch.startswith("status")
    r = A.decode_response(0x0004, 0x8000, 0x4000)
    assert r.mismatch is not None and r.mismatch.startswith("DATA1")
    with pytest.raises(FieldRangeError, match="DATA1 word"):
        A.decode_response(0, -1, 0)


def test_decode_read_back() -> None:
    # H_SPEED_R answer: sub-command 3 echoed, parameter 0 = 1 (×1 pps), 12345 pps
    status = 1 | (3 << 2) | (1 << 4) | (3 << 6) | (1 << 11)
    r = A.decode_response(status, (3 << 14) | (12345 >> 14), (3 << 14) | (12345 & 0x3FFF),
                          expected_pair=3, read_back=True, expected_cmd=A.Cmd.H_SPEED_R)
    assert r.valid and r.value == 12345 and r.subcommand == 3 and r.param0 == 1
    # a read-back's status word has its own layout (extended, sub-command, parameter 0):
    # no drive flag is read from it, so none is claimed
    assert not any((r.driving, r.inhibit, r.origin_set, r.origin_detecting, r.plus_limit,
                    r.minus_limit, r.limit_latched, r.abnormal_stop, r.eeprom_error))
    wrong = A.decode_response(status, 0xC000, 0xC000, read_back=True,
                              expected_cmd=A.Cmd.L_SPEED_R)
    assert not wrong.valid and "sub-command" in (wrong.mismatch or "")
    assert A.decode_nak_cause(0b01010) == ["parameter value not valid",
                                           "self-start speed > high speed"]


_pair = st.integers(0, 3)


@settings(max_examples=200, deadline=None)
@given(pairs=st.tuples(_pair, _pair, _pair), value=st.integers(-(1 << 27), (1 << 27) - 1),
       flags=st.lists(st.booleans(), min_size=11, max_size=11),
       sub=st.integers(0, 15), p0=st.integers(0, 31), read_back=st.booleans())
def test_response_round_trip(pairs: tuple[int, int, int], value: int, flags: list[bool],
                             sub: int, p0: int, read_back: bool) -> None:
    if read_back:
        r = A.AlinkResponse(flags[0], pairs, value, False, read_back=True, extended=flags[1],
                            subcommand=sub, param0=p0)
    else:
        names = ("eeprom_error", "extended", "driving", "inhibit", "origin_set",
                 "origin_detecting", "plus_limit", "minus_limit", "limit_latched",
                 "abnormal_stop")
        r = A.AlinkResponse(flags[0], pairs, value, False,
                            **dict(zip(names, flags[1:], strict=True)))
    back = A.decode_response(*r.words(), read_back=read_back)
    assert back.valid == (len(set(pairs)) == 1)
    assert replace(back, valid=False, mismatch=None) == r
    assert back.words() == r.words()


# The command codes as the manual's §11 headings print them (SPEC §2 lists the same),
# written from the manual, not from Cmd.
MANUAL_CODES = {
    "LOGIC": 0x1C, "MODE": 0x1D, "L_SPEED": 0x12, "H_SPEED": 0x13, "UP_TIME": 0x14,
    "MAX_SPEED": 0x15, "SETTING": 0x17, "OL_SPEED": 0x18, "OH_SPEED": 0x19, "O_UPTIME": 0x1A,
    "MODE_SIG": 0x1E, "MOVE_R": 0x21, "MOVE_A": 0x22, "STOP": 0x2F, "HOME": 0x31,
    "P_SEARCH": 0x3C, "M_SEARCH": 0x3D, "P_ORG": 0x3E, "M_ORG": 0x3F, "READ_STAT": 0x45,
    "READ": 0x46, "OUT_M": 0x4C, "OUT_B": 0x4D, "OUT_S": 0x4E, "OUT_G": 0x4F,
    "CHANGE_SPD": 0x51, "LIMIT": 0x52, "DELAY": 0x58, "OFFSET": 0x5A, "RESET_POS": 0x5B,
    "CLEAR_EL": 0x5C,
    # §11-9, the read-backs (0x86 and 0x8B are not commands)
    "L_SPEED_R": 0x82, "H_SPEED_R": 0x83, "UP_TIME_R": 0x84, "MAX_SPEED_R": 0x85,
    "SETTING_R": 0x87, "OL_SPEED_R": 0x88, "OH_SPEED_R": 0x89, "O_UPTIME_R": 0x8A,
    "LOGIC_R": 0x8C, "MODE_R": 0x8D, "MODE_SIG_R": 0x8E,
}


def test_every_command_code_is_the_manuals() -> None:
    assert {c.name: int(c) for c in A.Cmd} == MANUAL_CODES


@pytest.mark.parametrize("axis", [-1, 2])
def test_an_axis_outside_the_units_two_is_refused_naming_them(axis: int) -> None:
    with pytest.raises(FieldRangeError,
                       match=rf"^axis: {axis} is outside the allowed range 0\.\.1"):
        A.command_address(1, axis)


def _doc() -> dict:
    s = A.quantise_settings(500, 12345, 3.35)
    cmds = A.settings_commands(s, slave_address=5)
    return A.settings_document(s, cmds, summary={"predicted_time_s": 0.25}, warnings=["w"])


def test_settings_document_fields() -> None:
    doc = _doc()
    assert (doc["start_pps"], doc["high_pps"], doc["up_time_para"]) == (500, 12345, 335)
    assert doc["accel_ms_per_kpps"] == 3.35 and doc["predicted_time_s"] == 0.25
    assert doc["warnings"] == ["w"]
    assert [c["name"] for c in doc["commands"]] == ["MAX_SPEED", "MODE", "H_SPEED", "L_SPEED",
                                                    "UP_TIME"]
    first = doc["commands"][0]
    assert first["address"] == f"0x{A.command_address(5):03X}"
    words = [int(w, 16) for w in first["words"]]
    assert A.parse_command(*words) == (A.Cmd.MAX_SPEED, 1, 0, 1)  # pair code 1 first


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_render_settings_c_compiles(tmp_path: Path) -> None:
    (tmp_path / "a.h").write_text(A.render_settings(_doc(), "c"))
    (tmp_path / "m.c").write_text('#include "a.h"\nint main(void) '
                                  "{ return (int)stepramp_alink_words[4][0] & 0; }\n")
    done = subprocess.run(["gcc", "-Wall", "-Wextra", "-Werror", "-c", "m.c", "-o", "m.o"],
                          cwd=tmp_path, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr

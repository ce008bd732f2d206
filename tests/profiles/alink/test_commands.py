"""Every A-Link ALUM command of manual §11 (`stepramp alink command`, `alink decode
--command`), the unit's Nak rules of §11–12 over command lists (`check`), and the homing
speeds (`alink homing`).

The words below are written by hand from §11-1's figure (CMD = P P * func(5) cmd(8),
PARAM1 = P P para bits 27–14, PARAM2 = P P para bits 13–0; pair code 1 is 0x4000 on every
word), not from the code."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import alink as A
from profiles.alink.commands import COMMANDS, Value, decode_command, encode_command
from profiles.errors import FieldRangeError, StepRampError

# (name, nn, value) → the words with pair code 1, from the figure by hand
BY_HAND: list[tuple[str, int, int, tuple[int, int, int]]] = [
    ("logic", 0, 0x14, (0x401C, 0x4000, 0x4014)),          # §11-1's LOGIC example
    ("mode", 0, 0x15, (0x401D, 0x4000, 0x4015)),
    ("l-speed", 1, 500, (0x4112, 0x4000, 0x41F4)),
    ("h-speed", 1, 10000, (0x4113, 0x4000, 0x6710)),
    ("up-time", 2, 2000, (0x4214, 0x4000, 0x47D0)),
    ("up-time", 1, 39320, (0x4114, 0x4002, 0x5998)),
    ("max-speed", 1, 100000, (0x4115, 0x4006, 0x46A0)),
    ("mode-sig", 0, 0x20, (0x401E, 0x4000, 0x4020)),
    ("ol-speed", 1, 200, (0x4118, 0x4000, 0x40C8)),
    ("oh-speed", 1, 800, (0x4119, 0x4000, 0x4320)),
    ("o-uptime", 2, 20, (0x421A, 0x4000, 0x4014)),
    ("o-uptime", 1, 4, (0x411A, 0x4000, 0x4004)),
    ("setting", 29, 1000, (0x5D17, 0x4000, 0x43E8)),
    ("setting", 30, -1, (0x5E17, 0x7FFF, 0x7FFF)),
    ("setting", 30, 134217727, (0x5E17, 0x5FFF, 0x7FFF)),
    ("move-r", 28, -1, (0x5C21, 0x7FFF, 0x7FFF)),
    ("move-a", 28, 100000, (0x5C22, 0x4006, 0x46A0)),       # §11-1's MOVE_A figure
    ("move-a", 28, -134217728, (0x5C22, 0x6000, 0x4000)),
    ("stop", 28, 0, (0x5C2F, 0x4000, 0x4000)),
    ("stop", 31, 0, (0x5F2F, 0x4000, 0x4000)),
    ("home", 1, 0, (0x4131, 0x4000, 0x4000)),
    ("home", 2, 0, (0x4231, 0x4000, 0x4000)),
    ("home", 3, 0, (0x4331, 0x4000, 0x4000)),
    ("home", 4, 0, (0x4431, 0x4000, 0x4000)),
    ("p-search", 28, 0, (0x5C3C, 0x4000, 0x4000)),
    ("p-search", 30, 0, (0x5E3C, 0x4000, 0x4000)),
    ("m-search", 28, 0, (0x5C3D, 0x4000, 0x4000)),
    ("m-search", 30, 0, (0x5E3D, 0x4000, 0x4000)),
    ("p-org", 28, 0, (0x5C3E, 0x4000, 0x4000)),
    ("p-org", 30, 0, (0x5E3E, 0x4000, 0x4000)),
    ("m-org", 28, 0, (0x5C3F, 0x4000, 0x4000)),
    ("m-org", 30, 0, (0x5E3F, 0x4000, 0x4000)),
    ("out-m", 28, 1, (0x5C4C, 0x4000, 0x4001)),
    ("out-b", 28, 0, (0x5C4D, 0x4000, 0x4000)),
    ("out-s", 28, 1, (0x5C4E, 0x4000, 0x4001)),
    ("out-g", 28, 8, (0x5C4F, 0x4000, 0x4008)),
    ("out-g", 31, 1, (0x5F4F, 0x4000, 0x4001)),
    ("read-stat", 0, 7, (0x4045, 0x4000, 0x4007)),
    ("read", 0, 0xA, (0x4046, 0x4000, 0x400A)),
    ("read", 3, 0, (0x4346, 0x4000, 0x4000)),
    ("change-speed", 1, 12000, (0x4151, 0x4000, 0x6EE0)),
    ("change-speed", 0, 150, (0x4051, 0x4000, 0x4096)),
    ("limit", 0, 0, (0x4052, 0x4000, 0x4000)),
    ("limit", 3, 5000, (0x4352, 0x4000, 0x5388)),
    ("clear-el", 0, 0, (0x405C, 0x4000, 0x4000)),
    ("delay", 0, 500, (0x4058, 0x4000, 0x41F4)),
    ("offset", 0, 1000, (0x405A, 0x4000, 0x43E8)),
    ("offset", 0, -1300, (0x405A, 0x7FFF, 0x7AEC)),         # §12-1 (3)'s example
    ("reset-pos", 0, 1000, (0x405B, 0x4000, 0x43E8)),
    ("logic-r", 0, 0, (0x408C, 0x4000, 0x4000)),
    ("mode-r", 0, 0, (0x408D, 0x4000, 0x4000)),
    ("l-speed-r", 0, 0, (0x4082, 0x4000, 0x4000)),
    ("h-speed-r", 0, 0, (0x4083, 0x4000, 0x4000)),
    ("up-time-r", 0, 0, (0x4084, 0x4000, 0x4000)),
    ("max-speed-r", 0, 0, (0x4085, 0x4000, 0x4000)),
    ("mode-sig-r", 0, 0, (0x408E, 0x4000, 0x4000)),
    ("ol-speed-r", 0, 0, (0x4088, 0x4000, 0x4000)),
    ("oh-speed-r", 0, 0, (0x4089, 0x4000, 0x4000)),
    ("o-uptime-r", 0, 0, (0x408A, 0x4000, 0x4000)),
    ("setting-r", 29, 0, (0x5D87, 0x4000, 0x4000)),
]


def test_every_command_and_form_of_section_11_is_written_by_hand() -> None:
    assert {(n, nn) for n, nn, _, _ in BY_HAND} == {
        (c.name, nn) for c in COMMANDS.values() for nn in c.forms}
    # the names are the manual's symbols, lower case with dashes (CHANGE_SPD: change-speed)
    assert {c.cmd.name for c in COMMANDS.values()} == {c.name for c in A.Cmd}
    assert all(c.name == c.cmd.name.lower().replace("_", "-")
               for c in COMMANDS.values() if c.cmd is not A.Cmd.CHANGE_SPD)


def _values(v: Value) -> st.SearchStrategy[int]:
    if v.bits:
        optional = [b for b in v.bits if b != 8]  # D8 is the factory check: not written
        return st.sets(st.sampled_from(optional)).map(
            lambda bits: v.fixed | sum(1 << b for b in bits))
    if v.choices:
        plain = [k for k in v.choices if k not in (0xF, 0x3FFF)]
        opened = [] if v.open_from is None else [st.integers(v.open_from, v.hi - 1)]
        return st.one_of(st.sampled_from(plain), *opened)
    if not v.takes:
        return st.just(0)
    return st.integers(v.lo, v.hi).filter(lambda x: x not in v.refused)


@st.composite
def _command(draw: Any) -> tuple[str, int, int, int]:
    name = draw(st.sampled_from(sorted(COMMANDS)))
    nn = draw(st.sampled_from(sorted(COMMANDS[name].forms)))
    value = draw(_values(COMMANDS[name].forms[nn].value))
    return name, nn, value, draw(st.integers(1, 3))


@settings(max_examples=300, deadline=None)
@given(_command())
def test_every_command_round_trips(case: tuple[str, int, int, int]) -> None:
    name, nn, value, pair = case
    c = encode_command(name, value if COMMANDS[name].forms[nn].value.takes else None, nn,
                       pair=pair)
    d = decode_command(*c.words)
    assert (d.command.name, d.nn, d.value, d.pair, d.problems) == (name, nn, value, pair, ())
    assert A.parse_command(*c.words) == (c.cmd, nn, c.para, pair)  # the one layout
    assert d.describe().startswith(f"{c.name} ({name}, §11")


@pytest.mark.parametrize(("words", "problem"), [
    ((0x4531, 0x4000, 0x4000), "nn 5 is not one §11 gives HOME (1, 2, 3, 4)"),
    ((0x5C4C, 0x4000, 0x4002), "2 is not one of 0 (off), 1 (on)"),
    ((0x5E17, 0x4000, 0x4000), "0: a soft limit is 1..134217727 (+) or -134217728..-1 (-)"),
    ((0x4131, 0x4000, 0x4001), "para 1: search CW, stop at the origin's CCW edge takes none"),
    ((0x401C, 0x4000, 0x4003), "0x3 sets bits outside the word's (0x3)"),
])
def test_decode_names_what_section_11_does_not_give(words: tuple[int, int, int],
                                                   problem: str) -> None:
    d = decode_command(*words)
    assert len(d.problems) == 1 and d.problems[0].startswith(problem)
    assert "NOT TAKEN: " + problem in d.describe()


def test_every_form_lists_its_values_for_help() -> None:
    with pytest.raises(FieldRangeError):
        encode_command("delay", -1)
    with pytest.raises(StepRampError, match="not an A-Link command"):
        encode_command("move_a", 1)
    for c in COMMANDS.values():
        for form in c.forms.values():
            assert form.value.shown and form.does

"""Every A-Link ALUM command of manual §11 (`stepramp alink command`, `alink decode
--command`), the unit's Nak rules of §11–12 over command lists (`check`), and the homing
speeds (`alink homing`).

The words below are written by hand from §11-1's figure (CMD = P P * func(5) cmd(8),
PARAM1 = P P para bits 27–14, PARAM2 = P P para bits 13–0; pair code 1 is 0x4000 on every
word), not from the code."""

from __future__ import annotations

import pytest
from hypothesis import given, settings

from profiles import alink as A
from profiles.alink.commands import COMMANDS, decode_command, encode_command
from profiles.errors import FieldRangeError, StepRampError
from tests.support.alink_figures import BY_HAND
from tests.support.strategies import alink_commands


def test_every_command_and_form_of_section_11_is_written_by_hand() -> None:
    assert {(n, nn) for n, nn, _, _ in BY_HAND} == {
        (c.name, nn) for c in COMMANDS.values() for nn in c.forms}
    # the names are the manual's symbols, lower case with dashes (CHANGE_SPD: change-speed)
    assert {c.cmd.name for c in COMMANDS.values()} == {c.name for c in A.Cmd}
    assert all(c.name == c.cmd.name.lower().replace("_", "-")
               for c in COMMANDS.values() if c.cmd is not A.Cmd.CHANGE_SPD)


@settings(max_examples=300, deadline=None)
@given(alink_commands())
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

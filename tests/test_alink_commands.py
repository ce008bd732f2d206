"""Every A-Link ALUM command of manual §11 (`stepramp alink command`, `alink decode
--command`), the unit's Nak rules of §11–12 over command lists (`check`), and the homing
speeds (`alink homing`).

The words below are written by hand from §11-1's figure (CMD = P P * func(5) cmd(8),
PARAM1 = P P para bits 27–14, PARAM2 = P P para bits 13–0; pair code 1 is 0x4000 on every
word), not from the code."""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import alink as A
from profiles.alink.commands import COMMANDS, Value, decode_command, encode_command
from profiles.errors import FieldRangeError, PlanError, StepRampError
from profiles.motor import load_motor
from verify import cli
from verify.devices.alink import command_findings

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


@pytest.mark.parametrize(("name", "nn", "value", "words"), BY_HAND)
def test_words_are_the_figures_and_decode_names_the_command(
        name: str, nn: int, value: int, words: tuple[int, int, int],
        capsys: pytest.CaptureFixture[str]) -> None:
    c = encode_command(name, value if COMMANDS[name].forms[nn].value.takes else None, nn)
    assert c.words == words and c.pair == 1
    d = decode_command(*words)
    assert (d.command.name, d.nn, d.value, d.pair, d.problems) == (name, nn, value, 1, ())
    # and through the CLI: `alink command` writes them, `alink decode --command` names them
    argv = ["alink", "command", name, "--nn", str(nn), "--format", "hex"]
    if COMMANDS[name].forms[nn].value.takes:
        argv += ["--value", str(value)]
    assert cli.main(argv) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == " ".join(f"{w:04X}" for w in words) and out[1].startswith("# crc32 ")
    assert cli.main(["alink", "decode", "--command", *(f"0x{w:04X}" for w in words),
                     "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert (doc["name"], doc["symbol"], doc["nn"], doc["value"], doc["problems"]) == \
        (name, COMMANDS[name].cmd.name, nn, value, [])


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


def _cli(argv: list[str]) -> Any:
    """`stepramp ARGV --format json`'s document (exit 0), in-process."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert cli.main([*argv, "--format", "json"]) == 0
    return json.loads(out.getvalue())


@settings(max_examples=100, deadline=None)
@given(_command())
def test_every_command_round_trips_through_the_cli(case: tuple[str, int, int, int]) -> None:
    """`alink command` writes the words, `alink decode --command` names them back."""
    name, nn, value, pair = case
    argv = ["alink", "command", name, "--nn", str(nn), "--pair", str(pair)]
    if COMMANDS[name].forms[nn].value.takes:
        argv += ["--value", str(value)]
    [row] = _cli(argv)["commands"]
    doc = _cli(["alink", "decode", "--command", *row["words"]])
    assert (doc["name"], doc["nn"], doc["value"], doc["pair"], doc["problems"]) == \
        (name, nn, value, pair, [])


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


@pytest.mark.parametrize(("argv", "line"), [
    (["l-speed", "--value", "0"],
     "--value (l-speed nn 1: speed): 0 is outside the allowed range 1..100000 (0x186A0)"),
    (["move-a", "--value", "0x8000000"],
     "--value (move-a nn 28: pulse): 134217728 (0x8000000) is outside the allowed range "
     "-134217728..134217727 (0x7FFFFFF)"),
    (["out-m", "--value", "2"], "--value (out-m nn 28: out): 2 is not one of 0 (off), 1 (on)"),
    (["home", "--nn", "5"], "--nn: 5 is not an nn of home (1: search CW, stop at the "
                            "origin's CCW edge; 2: …"),
    (["setting", "--nn", "30", "--value", "0"],
     "--value (setting nn 30: pulse): 0: a soft limit is 1..134217727 (+) or "
     "-134217728..-1 (-)"),
    (["change-speed", "--value", "100001"],
     "--value (change-speed nn 1: speed): 100001 (0x186A1) is outside the allowed range "
     "1..100000 (0x186A0)"),
    (["read-stat", "--value", "0x3FFF"], "--value (read-stat nn 0: type): READ_STAT type "
                                         "0x3FFF: the factory A-Link check: …"),
    (["stop", "--value", "3"], "--value: stop nn 28 takes no value (stop at once (the "
                               "position is not kept): its para is 0)"),
    (["move-a"], "--value: move-a nn 28 needs one: pulse, -134217728..134217727 pulses"),
    (["move-a", "--value", "1", "--pair", "4"], "--pair: 4 is outside the allowed range 1..3"),
    (["logic", "--value", "3"], "--value (logic nn 0: logic): 0x3 sets bits outside the "
                                "word's (0x3); it is a bit word: …"),
])
def test_bad_values_are_one_line_naming_the_flag_value_and_range(
        argv: list[str], line: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["alink", "command", *argv]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1
    err = err.removeprefix("stepramp alink: ").rstrip("\n")
    assert err.startswith(line.removesuffix("…")) if line.endswith("…") else err == line


def test_decode_refuses_answer_options_with_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["alink", "decode", "--command", "0x5C22", "0x4006", "0x46A0",
                     "--read-back"]) == 2
    assert capsys.readouterr().err == ("stepramp alink: --read-back: an answer's; a command's "
                                       "words carry their own pair code\n")
    assert cli.main(["alink", "decode", "--command", "0x5C22", "0x4006", "0x46A0"]) == 0
    assert capsys.readouterr().out == (
        "MOVE_A (move-a, §11-3 (2) absolute move) nn 28: move to pulse (absolute; needs the "
        "origin); pulse 100000 pulses, pair 1\n")
    assert cli.main(["alink", "decode", "--command", "0x7D00", "0", "0"]) == 2  # no command


def test_every_form_lists_its_values_for_help() -> None:
    with pytest.raises(FieldRangeError):
        encode_command("delay", -1)
    with pytest.raises(StepRampError, match="not an A-Link command"):
        encode_command("move_a", 1)
    for c in COMMANDS.values():
        for form in c.forms.values():
            assert form.value.shown and form.does


# --- the unit's Nak rules over command lists -----------------------------------------------------
def _list(*spec: tuple[Any, ...]) -> list[A.Command]:
    """Commands (name, value[, nn]), pair codes 1, 2, 3, 1, …, put word by word (what
    `encode_command` refuses to write included: a hand-made list may hold it)."""
    w = A.CommandWriter()
    out = []
    for s in spec:
        name, value, nn = (*s, None) if len(s) == 2 else s
        command = COMMANDS[name]
        out.append(w.put(command.cmd, command.default_nn if nn is None else nn, value))
    return out


def _rules(*spec: tuple[Any, ...]) -> list[tuple[str, str]]:
    return [(f.severity, f.rule) for f in command_findings(_list(*spec))]


WAIT = ("read-stat", 0)         # the host's status read: D5/D6 seen off
HOME = ("home", 0, 1)
SPEEDS = (("max-speed", 0), ("mode", 5), ("h-speed", 10000), ("l-speed", 500),
          ("up-time", 2000))


@pytest.mark.parametrize(("broken", "kept", "rule"), [
    # a value §11 does not give: Nak (parameter value not valid)
    ([(*HOME[:2], 5)], [HOME], ("error", "alink-range")),
    ([("out-m", 2)], [("out-m", 1)], ("error", "alink-range")),
    ([("setting", 0, 30)], [("setting", -5, 30)], ("error", "alink-range")),
    # D5 (driving) or D6 (inhibit) set: refused until the host has read them off
    ([("move-r", 10), ("move-r", 10)], [("move-r", 10), WAIT, ("move-r", 10)],
     ("error", "alink-busy")),
    ([("delay", 100), ("l-speed", 500)], [("delay", 100), WAIT, ("l-speed", 500)],
     ("error", "alink-busy")),
    ([("delay", 100), ("change-speed", 800)], [("delay", 100), ("stop", 0, 31)],
     ("error", "alink-busy")),
    ([("move-r", 10), ("clear-el", 0)], [("move-r", 10), ("out-m", 1), ("stop", 0)],
     ("error", "alink-busy")),
    # MOVE_A, OFFSET and a coordinate change need the origin (from power on)
    ([("move-a", 10)], [HOME, WAIT, ("move-a", 10)], ("error", "alink-origin")),
    ([("offset", 10)], [("reset-pos", 0), WAIT, ("offset", 10)], ("error", "alink-origin")),
    ([("setting", 10, 29)], [("p-org", 0, 28), WAIT, ("setting", 10, 29)],
     ("error", "alink-origin")),
    # a soft limit crossed once the origin is set
    ([HOME, WAIT, ("setting", 1000, 30), ("move-a", 1001)],
     [HOME, WAIT, ("setting", 1000, 30), ("move-a", 1000)], ("error", "alink-soft-limit")),
    ([HOME, WAIT, ("setting", -50, 30), ("move-r", -30), WAIT, ("move-r", -30)],
     [HOME, WAIT, ("setting", -50, 30), ("move-r", -30), WAIT, ("move-r", -20)],
     ("error", "alink-soft-limit")),
    # the speeds at a homing or drive command
    ([("ol-speed", 800), ("oh-speed", 200), HOME], [("ol-speed", 200), ("oh-speed", 800), HOME],
     ("error", "alink-nak")),
    ([("max-speed", 500), ("ol-speed", 200), ("oh-speed", 800), HOME],
     [("max-speed", 800), ("ol-speed", 200), ("oh-speed", 800), HOME], ("error", "alink-nak")),
    ([("max-speed", 5000), ("h-speed", 8000), ("move-r", 10)],
     [("max-speed", 8000), ("h-speed", 8000), ("move-r", 10)], ("error", "alink-nak")),
    ([("h-speed", 400), ("l-speed", 500), ("move-r", 10)],
     [("h-speed", 500), ("l-speed", 500), ("move-r", 10)], ("error", "alink-nak")),
    ([("ol-speed", 800), ("oh-speed", 200)], [("ol-speed", 200), ("oh-speed", 200)],
     ("error", "alink-nak")),  # no homing command: the settings the list leaves
    # CHANGE_SPD: never in an S-curve drive, never at or below the self-start speed
    ([("mode", 0x15), ("move-r", 10), ("change-speed", 2000)],
     [("mode", 0x05), ("move-r", 10), ("change-speed", 2000)], ("error", "alink-change-speed")),
    ([*SPEEDS, ("move-r", 10), ("change-speed", 500)],
     [*SPEEDS, ("move-r", 10), ("change-speed", 501)], ("error", "alink-change-speed")),
    ([*SPEEDS, ("move-r", 10), ("change-speed", 1, 0)],
     [*SPEEDS, ("move-r", 10), ("change-speed", 6, 0)], ("error", "alink-change-speed")),
    # … and above 2× the high speed (MAX_SPEED 0) or MAX_SPEED it runs at that cap
    ([*SPEEDS, ("move-r", 10), ("change-speed", 20001)],
     [*SPEEDS, ("move-r", 10), ("change-speed", 20000)], ("warning", "alink-corrected")),
    ([*SPEEDS, ("move-r", 10), ("change-speed", 201, 0)],
     [*SPEEDS, ("move-r", 10), ("change-speed", 200, 0)], ("warning", "alink-corrected")),
    ([("max-speed", 12000), ("h-speed", 10000), ("move-r", 10), ("change-speed", 12001)],
     [("max-speed", 12000), ("h-speed", 10000), ("move-r", 10), ("change-speed", 12000)],
     ("warning", "alink-corrected")),
    ([("change-speed", 2000)], [("move-r", 10), ("change-speed", 2000)],
     ("warning", "alink-change-speed-idle")),
    ([HOME, WAIT, ("setting", 1000, 30), ("offset", 100)],
     [HOME, WAIT, ("offset", 100), WAIT, ("setting", 900, 30)],
     ("warning", "alink-soft-limit-stale")),
    ([("read-stat", 0x3FFF)], [("read-stat", 7)], ("warning", "alink-factory")),
    ([("mode-sig", 0x100)], [("mode-sig", 0x40)], ("warning", "alink-factory")),
    ([("limit", 0, 3), WAIT, ("move-r", 10)], [("limit", 0, 3), WAIT, ("clear-el", 0),
                                               ("move-r", 10)], ("warning", "alink-clear-el")),
])
def test_each_nak_rule_breaks_and_holds(broken: list[tuple[Any, ...]],
                                        kept: list[tuple[Any, ...]],
                                        rule: tuple[str, str]) -> None:
    assert rule in _rules(*broken), _rules(*broken)
    assert rule not in _rules(*kept), _rules(*kept)


def test_the_messages_name_the_command_and_the_cause() -> None:
    messages = [f.message for f in command_findings(_list(
        ("move-a", 10), ("move-r", 5), ("ol-speed", 900), ("oh-speed", 400), HOME))]
    # MOVE_A is refused: it does not drive, so MOVE_R is taken and sets D5
    assert messages == [
        "command 0 (MOVE_A): the origin is not set (no HOME, P_ORG, M_ORG or RESET_POS before "
        "it since power on)",
        "command 2 (OL_SPEED): refused while D5 (driving) is set by MOVE_R: read the status "
        "(READ_STAT) until it is off first",
        "command 3 (OH_SPEED): refused while D5 (driving) is set by MOVE_R: read the status "
        "(READ_STAT) until it is off first",
        "command 4 (HOME): refused while D5 (driving) is set by MOVE_R: read the status "
        "(READ_STAT) until it is off first"]


def test_a_good_list_has_no_finding_and_its_answers_are_ack() -> None:
    commands = _list(*SPEEDS, ("ol-speed", 200), ("oh-speed", 800), ("o-uptime", 20), HOME,
                     WAIT, ("setting", 100000, 30), ("setting", -100, 30),
                     ("move-a", 50000), ("change-speed", 15000), WAIT, ("move-r", -50000),
                     WAIT, ("delay", 20), ("out-b", 1), WAIT, ("move-a", 0))
    assert command_findings(commands) == []
    run = A.run_commands(commands)
    assert all(a.ack for a in run.answers) and run.end == ()


# --- homing speeds -----------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["nema17-1600", "nema23-heavy", "pk566-5phase-half"])
def test_homing_speeds_stop_within_the_self_start_speed(name: str) -> None:
    motor = load_motor(name)
    plan = A.plan_homing(motor)
    h = plan.table
    cap = min(motor.start_pps, motor.jump_pps)
    assert 20 <= h.ol_pps <= h.oh_pps <= cap and h.oh_pps > cap - 20
    # run unchanged under every multiplier the unit can pick (speeds and para)
    for m, (lo, hi) in A.PARA_RANGE.items():
        if m <= 20:
            assert h.ol_pps % m == h.oh_pps % m == h.o_uptime_para % m == 0
            assert lo <= h.o_uptime_para <= hi and h.oh_pps // m <= A.STEPS_MAX
    assert "self-start" in plan.binds and plan.extras["model"] in plan.info
    commands = A.homing_commands(h)
    assert [c.name for c in commands] == ["OL_SPEED", "OH_SPEED", "O_UPTIME"]
    assert command_findings([*commands, encode_command("home", nn=1, pair=1)]) == []


def test_homing_under_max_speed_and_refused_without_a_safe_speed() -> None:
    motor = load_motor("nema17-1600")
    low = A.plan_homing(motor, max_pps=333)
    assert low.table.oh_pps == 320 and low.binds == "MAX_SPEED (333 pps)"
    slow = dataclasses.replace(motor, start_pps=39.0, max_jump_pps=None)
    with pytest.raises(PlanError, match=r"up to 39 pps, below 40 pps .*coarser microstep"):
        A.plan_homing(slow)


def test_alink_homing_writes_a_checked_file(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "home.json"
    assert cli.main(["alink", "homing", "--motor", "nema17-1600", "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["homing"]["oh_pps"] == 800 and doc["homing"]["ol_pps"] == 200
    assert [c["name"] for c in doc["commands"]] == ["OL_SPEED", "OH_SPEED", "O_UPTIME"]
    assert cli.main(["check", str(out)]) == 0
    assert cli.main(["alink", "read", str(out)]) == 0
    capsys.readouterr()
    assert cli.main(["alink", "homing", "--motor", "nema17-1600", "--max-pps", "-1"]) == 2
    assert capsys.readouterr().err.startswith("stepramp alink: --max-pps: -1.0 is outside")

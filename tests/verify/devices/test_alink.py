"""verify.devices.alink: the A-Link judge of command lists (NAK rules, messages)."""

from __future__ import annotations

from typing import Any

import pytest

from profiles import alink as A
from profiles.alink.commands import COMMANDS
from profiles.alink.model import quantise_settings
from profiles.motor import load_motor
from profiles.motor.catalogue import resolve
from verify.devices.alink import command_findings


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


def test_sync_axis_verdict_carries_the_ramps_verdict() -> None:
    """sync's report on an A-Link axis: the planner's rule and the one verdict's JSON."""
    from types import SimpleNamespace

    from verify.devices.alink import axis_verdict

    motor = load_motor(resolve("nema17-1600"))
    safe, facts = axis_verdict(SimpleNamespace(settings=quantise_settings(800, 20000, 5.0),
                                               motor=motor))
    assert safe and facts["stall_safe"] and facts["safety"]["moves"] == "every"
    fast, facts = axis_verdict(SimpleNamespace(settings=quantise_settings(2000, 40000, 0.1),
                                               motor=motor))
    assert not fast and not facts["safety"]["safe"]

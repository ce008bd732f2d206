"""The files of a synchronised A-Link move, through the device's format table with a
CRC-32 of the command words: per axis NAME.settings.json (the settings document of its
settings commands, with its pulses and duration) and NAME.commands.hex (every command:
settings, MODE_SIG with STA, MOVE_R); axes.h (each axis's words as NAME_words with its
CRC-32). `stepramp alink read` reads each back verified."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ...formats import Provenance, RenderOptions, c_name
from ...joint import SYNC_HEADER_FILE, SYNC_HEADER_NAME
from ..codec import FUNC_MOVE, Cmd, CommandWriter, command_address, settings_commands
from ..formats import FORMATS, render_c_set
from .plan import MODE_SIG_STA, AlinkSyncPlan

AXIS_SUFFIXES = (".settings.json", ".commands.hex")


def output_names(names: Sequence[str]) -> list[str]:
    """The names of every file `sync_files` writes for axes `names`."""
    return [n + suffix for n in names for suffix in AXIS_SUFFIXES] + [SYNC_HEADER_FILE]


def check_axis_names(names: Sequence[str]) -> None:
    """Refuse axis names that cannot prefix the symbols of axes.h (a C identifier that is
    no keyword), before any planning."""
    for n in names:
        c_name(n, "axis name")


def command_lists(plan: AlinkSyncPlan, *, slave_address: int | None = None
                  ) -> list[list[Any]]:
    """Per axis: its settings, MODE_SIG with STA (start with the unit's other axis on the
    simultaneous-start input), and the relative move — `Command`s with pair codes."""
    out = []
    for axis, a in enumerate(plan.axes):
        writer = CommandWriter(address=None if slave_address is None else
                               command_address(slave_address, axis))
        cmds = settings_commands(a.settings, writer=writer)
        cmds.append(writer.put(Cmd.MODE_SIG, 0, MODE_SIG_STA))
        cmds.append(writer.put(Cmd.MOVE_R, FUNC_MOVE, a.pulses))
        out.append(cmds)
    return out


def move_commands(plan: AlinkSyncPlan, *, slave_address: int | None = None
                  ) -> list[list[tuple[int, int, int]]]:
    """`command_lists` as each command's words (the sync report lists them)."""
    return [[c.words for c in cmds]
            for cmds in command_lists(plan, slave_address=slave_address)]


def sync_files(plan: AlinkSyncPlan, *, command: str | None = None) -> dict[str, bytes]:
    """Every file of `plan`, by name (see the module docstring). `command` is the command
    line, for axes.h's provenance."""
    check_axis_names([a.name for a in plan.axes])
    files: dict[str, bytes] = {}
    sets: list[tuple[str, Sequence[Any], str]] = []
    for a, cmds in zip(plan.axes, command_lists(plan), strict=True):
        settings = cmds[:-2]  # MODE_SIG and MOVE_R are the move, not the settings
        settings_file, commands_file = (a.name + s for s in AXIS_SUFFIXES)
        files[settings_file] = FORMATS.render(settings, "json", RenderOptions(
            header={"pulses": a.pulses, "duration_s": a.duration_s}))
        files[commands_file] = FORMATS.render(cmds, "hex")
        sets.append((a.name, cmds, f"axis {a.name}: {a.pulses} pulses, "
                                   f"{a.duration_s * 1e3:.6g} ms: settings, MODE_SIG (STA), "
                                   "MOVE_R"))
    files[SYNC_HEADER_FILE] = render_c_set(sets, RenderOptions(
        name=SYNC_HEADER_NAME,
        provenance=Provenance(command, (f"One synchronised move ({plan.mode} mode).",))))
    return files

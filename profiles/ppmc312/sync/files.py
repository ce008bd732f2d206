"""The files of a synchronised PPMC-312 move, each through the device's format table with
its check: per axis NAME.table.json, NAME.upload.hex and NAME.upload.ihex (the upload,
CRC-32 / record checksums) and NAME.move.hex (the move command with its trigger bits,
CRC-32); axes.h (every axis's blocks as NAME_… and its move command as NAME_move_…, each
with its CRC-32; `formats.parse_c_set` reads them back verified) and axes.json (the
tables as an axes file, for `stepramp simulate --axes`)."""

from __future__ import annotations

import json
from collections.abc import Sequence

from ...errors import FormatError
from ...formats import Provenance, RenderOptions, c_name
from ...joint import SYNC_HEADER_FILE, SYNC_HEADER_NAME
from ..formats import FORMATS, render_c_set
from ..table import DEVICE, dump_table
from ..upload import encode_table
from .moves import TRIGGER_EVENT1, SyncPlan, move_command

AXIS_SUFFIXES = (".table.json", ".upload.hex", ".upload.ihex", ".move.hex")
AXES_FILE = "axes.json"
MOVE_SUFFIX = "_move"      # an axis's move command in axes.h: NAME_move_…


def output_names(names: Sequence[str]) -> list[str]:
    """The names of every file `sync_files` writes for axes `names`."""
    return [n + suffix for n in names for suffix in AXIS_SUFFIXES] + [SYNC_HEADER_FILE,
                                                                       AXES_FILE]


def check_axis_names(names: Sequence[str]) -> None:
    """Refuse axis names that cannot prefix the symbols of axes.h, before any planning:
    a C identifier that is no keyword, and no axis named like another's move command (x
    and x_move would both declare X_MOVE_…; compared ignoring case, as the macros are
    upper case)."""
    taken = {n.lower() for n in names}
    for n in names:
        c_name(n, "axis name")
        if (n + MOVE_SUFFIX).lower() in taken:
            raise FormatError(f"axis {n}{MOVE_SUFFIX}: the C symbols of axis {n}'s move "
                              f"command are named {n}{MOVE_SUFFIX}_…; rename one of the axes")


def sync_files(plan: SyncPlan, *, command: str | None = None,
               trigger: int = TRIGGER_EVENT1) -> dict[str, bytes]:
    """Every file of `plan`, by name (see the module docstring). `command` is the command
    line, for axes.h's provenance."""
    check_axis_names([a.name for a in plan.axes])
    files: dict[str, bytes] = {}
    uploads: list[tuple[str, Sequence[bytes], str]] = []
    for a in plan.axes:
        blocks = encode_table(a.table)
        move = move_command(a, trigger)
        table, hex_file, ihex_file, move_file = (a.name + s for s in AXIS_SUFFIXES)
        files[table] = dump_table(a.table).encode()
        files[hex_file] = FORMATS.render(blocks, "text")
        files[ihex_file] = FORMATS.render(blocks, "ihex")
        files[move_file] = FORMATS.render([move], "text")
        uploads += [(a.name, blocks, f"axis {a.name}: {a.pulses} pulses, "
                                     f"{a.duration_s * 1e3:.6g} ms: its table upload"),
                    (a.name + MOVE_SUFFIX, [move], f"axis {a.name}: its move command (82), "
                                                   "held until the trigger")]
    files[SYNC_HEADER_FILE] = render_c_set(uploads, RenderOptions(
        name=SYNC_HEADER_NAME, provenance=Provenance(command, (
            f"One synchronised move ({plan.mode} mode). Per axis: write its blocks in order, "
            "then its move command; every chip starts when event input 1 goes low (TRG 01).",
        ))))
    # the same move as a set of tables: `stepramp simulate --axes DIR/axes.json`
    files[AXES_FILE] = (json.dumps(
        {"format": "stepramp.axes/1", "mode": plan.mode, "device": DEVICE,
         "axes": [{"name": a.name, "table": a.name + AXIS_SUFFIXES[0], "pulses": a.pulses}
                  for a in plan.axes]}, indent=1) + "\n").encode()
    return files

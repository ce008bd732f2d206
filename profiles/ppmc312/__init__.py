"""PPMC-312 pulse-controller LSI, split by role.

- `table`: free-curve and init tables (`FreeCurveTable`, `InitTable`, `load_table`);
- `planner`: the fastest stall-safe free curve (`plan_free_curve`), the
  best init table (`planner.init_planner.plan_init`) and the table following a reference;
- `upload`: tables and motion commands into the bytes the chip takes and back (the
  codec below); `motion` every motion command by name (`encode_command`); `ascii` the
  serial frames; `formats` the upload file formats (`render`, `parse`);
- `execution`: what the chip runs for a move (`simulate_move`); `init_model` the free
  curve an init table becomes (`expand_init`);
- `emulator` answers each block as the chip would (`accept_upload`); `answers` decodes
  what it answered; `program` reads command programs; `link` talks to a slave.

Frame layouts live once in `frames`. Every public name is importable from
`profiles.ppmc312` directly: the upload codec at once, the rest on first use (the
planners need numpy and numba, which reading and checking a table never does).
"""

from typing import TYPE_CHECKING

from ..lazy import lazy_exports
from .upload import (
    bus_writes,
    decode_free_curve,
    decode_init,
    decode_move,
    decode_table_read,
    decode_upload,
    encode_free_curve,
    encode_init,
    encode_move,
    encode_table,
    encode_table_read_response,
)

if TYPE_CHECKING:
    from .answers import decode_answer, decode_answers
    from .clock import Clock
    from .emulator import ChipEmulator, accept_upload
    from .execution import simulate_move
    from .formats import parse, parse_upload, render
    from .init_model import expand_init
    from .link import Link
    from .motion import decode_command, encode_command
    from .planner import plan_free_curve
    from .planner.init_planner import plan_init
    from .program import load_program
    from .table import FreeCurveTable, InitTable, Table, load_table

__getattr__ = lazy_exports(__name__, {
    "decode_answer": ".answers", "decode_answers": ".answers", "Clock": ".clock",
    "ChipEmulator": ".emulator", "accept_upload": ".emulator",
    "simulate_move": ".execution", "parse": ".formats", "parse_upload": ".formats",
    "render": ".formats",
    "expand_init": ".init_model", "plan_init": ".planner.init_planner", "Link": ".link",
    "decode_command": ".motion", "encode_command": ".motion",
    "plan_free_curve": ".planner", "load_program": ".program",
    "FreeCurveTable": ".table", "InitTable": ".table", "Table": ".table",
    "load_table": ".table",
})

__all__ = [
    "ChipEmulator",
    "Clock",
    "FreeCurveTable",
    "InitTable",
    "Link",
    "Table",
    "accept_upload",
    "bus_writes",
    "decode_answer",
    "decode_answers",
    "decode_command",
    "decode_free_curve",
    "decode_init",
    "decode_move",
    "decode_table_read",
    "decode_upload",
    "encode_command",
    "encode_free_curve",
    "encode_init",
    "encode_move",
    "encode_table",
    "encode_table_read_response",
    "expand_init",
    "load_program",
    "load_table",
    "parse",
    "parse_upload",
    "plan_free_curve",
    "plan_init",
    "render",
    "simulate_move",
]

"""stepramp.profiles: device models, tables, planners and codecs.

Data flows one way: motor → plan → table → check (``verify``) → bytes.
Heavy optional machinery (toppra, casadi, matplotlib) is imported lazily by
the modules that need it, never here.
"""

from typing import TYPE_CHECKING

from .errors import DecodeError, FieldRangeError, FormatError, StepRampError
from .lazy import lazy_exports
from .ppmc312.clock import Clock
from .ppmc312.table import FreeCurveTable, InitTable, Table, load_table, table_from_json

if TYPE_CHECKING:
    from .motor import Motor, load_motor
    from .ppmc312.formats import render
    from .ppmc312.planner import plan_free_curve
    from .ppmc312.planner.init_planner import plan_init
    from .ppmc312.upload import decode_upload, encode_table

# The front door: motor → plan → table → bytes in one import. The motor model and the
# planners need numpy (and numba), which reading and checking a table (`stepramp check`
# without `--motor`) never does, so they load on first use.
__getattr__ = lazy_exports(__name__, {
    "Motor": ".motor", "load_motor": ".motor",
    "plan_free_curve": ".ppmc312.planner", "plan_init": ".ppmc312.planner.init_planner",
    "encode_table": ".ppmc312.upload", "decode_upload": ".ppmc312.upload",
    "render": ".ppmc312.formats",
})

__all__ = [
    "Clock",
    "DecodeError",
    "FieldRangeError",
    "FormatError",
    "FreeCurveTable",
    "InitTable",
    "Motor",
    "StepRampError",
    "Table",
    "decode_upload",
    "encode_table",
    "load_motor",
    "load_table",
    "plan_free_curve",
    "plan_init",
    "render",
    "table_from_json",
]

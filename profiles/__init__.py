"""stepramp.profiles: device models, tables, planners and codecs.

Data flows one way: motor → plan → table → check (``verify``) → bytes.
Heavy optional machinery (toppra, casadi, matplotlib) is imported lazily by
the modules that need it, never here.
"""

from .errors import DecodeError, FieldRangeError, FormatError, StepRampError
from .motor import Motor, load_motor
from .ppmc312.clock import Clock
from .ppmc312.table import FreeCurveTable, InitTable, Table, load_table, table_from_json

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
    "load_motor",
    "load_table",
    "table_from_json",
]

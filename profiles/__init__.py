"""stepramp.profiles: device models, tables, planners and codecs.

Data flows one way: motor → plan → table → check (``verify``) → bytes.
Heavy optional machinery (toppra, casadi, matplotlib) is imported lazily by
the modules that need it, never here.
"""

from typing import TYPE_CHECKING, Any

from .errors import DecodeError, FieldRangeError, FormatError, StepRampError
from .ppmc312.clock import Clock
from .ppmc312.table import FreeCurveTable, InitTable, Table, load_table, table_from_json

if TYPE_CHECKING:
    from .motor import Motor, load_motor


def __getattr__(name: str) -> Any:
    """`Motor` and `load_motor` on first use: the motor model needs numpy, which reading
    and checking a table (`stepramp check` without `--motor`) never does."""
    if name in ("Motor", "load_motor"):
        from . import motor

        return getattr(motor, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

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

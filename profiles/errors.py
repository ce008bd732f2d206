"""The errors stepramp raises for input a user can fix.

Every one of them renders as a single line that says what is wrong and where;
the CLI prints that line and exits 2. Anything else escaping is a bug.
"""

from __future__ import annotations

import numbers


class StepRampError(Exception):
    """Base class: bad input, described in one line."""


class FormatError(StepRampError, ValueError):
    """A file or object that is not of the expected format (JSON, keys, types)."""


class FieldRangeError(StepRampError, ValueError):
    """A value that does not fit its field: names the field, the value and the range."""

    def __init__(self, field: str, value: object, lo: float | int, hi: float | int, *,
                 lo_excluded: bool = False) -> None:
        self.field = field
        self.value = value
        self.lo = lo
        self.hi = hi
        allowed = (f"above {_show(lo)} up to {_show(hi)}" if lo_excluded
                   else f"{_show(lo)}..{_show(hi)}")
        super().__init__(f"{field}: {_show(value)} is outside the allowed range {allowed}")


class DecodeError(StepRampError, ValueError):
    """Bytes that are not a valid frame/upload: names the block and byte offset."""

    def __init__(self, message: str, *, block: int | None = None, byte: int | None = None) -> None:
        self.block = block
        self.byte = byte
        where = []
        if block is not None:
            where.append(f"block {block}")
        if byte is not None:
            where.append(f"byte {byte}")
        prefix = (", ".join(where) + ": ") if where else ""
        super().__init__(prefix + message)


def require_int(name: str, value: object, lo: int, hi: int) -> int:
    """`value` as an int if it is a whole number (numpy's included, bool not) in lo..hi;
    else the FieldRangeError naming `name`, the value and the range."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not (
            lo <= int(value) <= hi):
        raise FieldRangeError(name, value, lo, hi)
    return int(value)


def _show(value: object) -> str:
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, int):
        return f"{value} (0x{value:X})" if value >= 0 and abs(value) > 9 else str(value)
    return repr(value) if isinstance(value, str) else str(value)

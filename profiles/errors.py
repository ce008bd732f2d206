"""The errors stepramp raises for input a user can fix, and the one number validator.

Every error renders as a single line that says what is wrong and where; the CLI
prints that line and exits 2. Anything else escaping is a bug. All of stepramp's
error classes live here, so a caller catches them without knowing which module
raised them.
"""

from __future__ import annotations

import numbers
from typing import Any

_INF = float("inf")


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
        super().__init__(f"{bounded(field)}: {_show(value)} is outside the allowed range "
                         f"{allowed}")


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


class CorruptedError(DecodeError):
    """A file whose own check (CRC-32, Intel HEX record checksum) does not match its
    content: the bytes changed after stepramp wrote them."""

    def __init__(self, message: str, *, block: int | None = None, byte: int | None = None) -> None:
        super().__init__(f"corrupted: {message}", block=block, byte=byte)


class UnsupportedError(StepRampError, ValueError):
    """A request the device cannot express at all (e.g. a free curve over serial)."""


class FieldChoiceError(FieldRangeError):
    """A field whose legal values are not one contiguous range (TRG with override)."""

    def __init__(self, field: str, value: object, allowed: tuple[int, ...]) -> None:
        super().__init__(field, value, min(allowed), max(allowed))
        shown = ", ".join(str(a) for a in allowed)
        self.args = (f"{bounded(field)}: {echo(value)} is not one of the allowed values "
                     f"{shown}",)


class MoveParameterError(FieldRangeError):
    """A move parameter the chip would refuse with parameter error `chip_code` (response F0)."""

    def __init__(self, field_name: str, value: object, lo: int, hi: int, chip_code: int) -> None:
        super().__init__(field_name, value, lo, hi)
        self.chip_code = chip_code
        self.args = (f"{self.args[0]} (the chip answers F0 {chip_code:02X})",)


class InitBuildError(StepRampError, ValueError):
    """The chip would refuse these init parameters with parameter-error `chip_code`."""

    def __init__(self, chip_code: int, reason: str) -> None:
        self.chip_code = chip_code
        self.reason = reason
        super().__init__(f"init table (chip code 0x{chip_code:02X}): {reason}")


class PlanError(StepRampError, ValueError):
    """A request no stall-safe, chip-legal table can satisfy."""


class InitPlanError(StepRampError, ValueError):
    """No stall-safe init table exists for this motor, clock and shape."""


class UnknownCommandError(StepRampError, ValueError):
    """A command code the A-Link ALUM manual does not define."""


class SyncError(StepRampError, ValueError):
    """Axes that cannot be synchronised as asked."""


class AlinkSyncError(StepRampError, ValueError):
    """A-Link axes that cannot be synchronised as asked."""


class ReferenceSolveError(StepRampError, RuntimeError):
    """A reference solver failed or gave a result outside its trust bracket."""


class ClusterError(StepRampError):
    """A sweep's workers failed it: no Dask scheduler answers (within the timeout), the
    cluster has no workers, a job was lost, or a local worker process died."""


# The serial link (profiles/ppmc312/link.py): one line each, naming slave, command, why.
class LinkError(StepRampError):
    """The serial link could not complete an exchange (one line: slave, what, why)."""


class LinkTimeout(LinkError):
    """No reply (or no whole reply) within the timeout, retries included."""


class GarbledReply(LinkError):
    """Replies arrived but none was valid (checksum, characters, length, address)."""


class UnknownReply(LinkError):
    """A valid frame whose meaning no table of the manual gives."""


class MotionRefused(FormatError):
    """A motion command the running motion does not take where it stands (the serial
    emulator's and a program's refusal; one line)."""


class ChipRefused(LinkError):
    """The chip answered a special reply refusing the command (`code`, e.g. 0x43)."""

    def __init__(self, message: str, code: int) -> None:
        super().__init__(message)
        self.code = code


# --- the number validator ----------------------------------------------------------------------
# bool is an int subclass, so `isinstance(True, int)` holds: every numeric field would take
# True as 1. One predicate excludes it, once, for every caller.

def is_number(value: object, *, integral: bool = False, finite: bool = False) -> bool:
    """True for a real number (numpy's included), never for bool; with `integral` only
    whole-number types (an integral float such as 3.0 is not one), with `finite` neither
    NaN nor ±inf (compared, never converted: a 400-digit int is finite, not an overflow)."""
    kind = numbers.Integral if integral else numbers.Real
    if isinstance(value, bool) or not isinstance(value, kind):
        return False
    v: Any = value
    return not finite or bool(v == v and -_INF < v < _INF)


def require_number(name: str, value: object, lo: float, hi: float, *, integral: bool = False,
                   lo_open: bool = False, hi_open: bool = False) -> float:
    """`value` unchanged if it is a number (see `is_number`) in lo..hi (bounds excluded when
    `lo_open`/`hi_open`; NaN never passes); else the FieldRangeError naming `name`, the value
    and the range."""
    if not is_number(value, integral=integral):
        raise FieldRangeError(name, value, lo, hi)
    v: Any = value  # a Real, checked above; compared as given (a huge int never overflows)
    above = v > lo if lo_open else v >= lo
    below = v < hi if hi_open else v <= hi
    if not (above and below):  # NaN fails both comparisons
        err = FieldRangeError(name, value, lo, hi, lo_excluded=lo_open)
        if hi_open:
            err.args = (f"{err.args[0]} ({_show(hi)} excluded)",)
        raise err
    return v


def require_int(name: str, value: object, lo: int, hi: int) -> int:
    """`value` as an int if it is a whole number (numpy's included, bool not) in lo..hi;
    else the FieldRangeError naming `name`, the value and the range."""
    return int(require_number(name, value, lo, hi, integral=True))


def _show(value: object) -> str:
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, int) and value.bit_length() <= 64:
        return f"{value} (0x{value:X})" if value >= 0 and abs(value) > 9 else str(value)
    return echo(value)


# --- echoing input in messages -------------------------------------------------------------
# An error line names the value it refuses, but a hostile input field can be a megabyte: every
# message that echoes input goes through `echo` (a value) or `bounded` (a text), so an error
# line stays a line.
ECHO_MAX_CHARS = 60
LINE_MAX_CHARS = 1000  # a whole message (paths and several echoed values included)


def echo(value: object, limit: int = ECHO_MAX_CHARS) -> str:
    """`value` as a message shows it (a string quoted, as repr does), cut to its first
    `limit` characters with "…" and the full length when longer. An integer too long to
    print (Python refuses ints of over 4300 digits) is described by its size."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 4000:
        return f"an integer of about {int(value.bit_length() * 0.30103)} digits"
    if isinstance(value, str):
        if len(value) <= limit:
            return repr(value)
        return f"{value[:limit]!r}… ({len(value)} characters)"
    try:
        text = repr(value) if isinstance(value, bytes | bytearray) else str(value)
    except ValueError:  # a container holding such an integer
        return f"a {type(value).__name__} too large to print"
    return bounded(text, limit)


def bounded(text: str, limit: int = LINE_MAX_CHARS) -> str:
    """`text` unchanged, or its first `limit` characters, "…" and its full length."""
    if len(text) <= limit:
        return text
    return f"{text[:limit]}… ({len(text)} characters)"


class OutputError(StepRampError, OSError):
    """An output file that cannot be written (verify/output.py): names OUT as the user
    wrote it, never a temp file, and the reason, in one line."""

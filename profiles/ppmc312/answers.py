"""Decoding (and encoding) every answer the PPMC-312 gives on the parallel bus.

`decode_answer(block)` reads one answer, header first as the manual draws it
(§5-7): its header, length byte and response code name the kind (answer_kinds), and
every value is checked against what the manual documents. `decode_answers(capture)`
splits answers read back to back by their length bytes. `encode_answer` is the exact
inverse. An `Answer` describes itself in lines a person reads (`describe`) and as
JSON (`to_json`); the serial mode's replies (replies.py) are `Answer`s too.

Anything that is not an answer of the manual is a `DecodeError` of one line naming
the byte: a header with bit 7, 6 or 2 set or RESP = 10, a length byte that disagrees
with the bytes, an unknown response code, a value no table of the manual gives.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..errors import DecodeError, FieldChoiceError, FormatError, echo
from ..fields import Array, Frame, SInt, UInt
from .answer_kinds import (
    BY_CODE,
    BY_KEY,
    CODE_FIELDS,
    COMMAND_NAMES,
    IMPOSSIBLE_RESP,
    ITEM_BLOCKS,
    KINDS,
    SOURCE_CODES,
    SOURCES,
    Flag,
    Kind,
)
from .frames import MAX_READ_LENGTH, block_bytes, check_length_byte

HEADER_BITS = ("cmr", "resp", "pal", "next")


@dataclass(frozen=True)
class Answer:
    """One decoded answer: its kind's `name` and `code` (None for a table-read item
    block, which has none), its `header` (parallel: cmr, source, pal, next; serial:
    type, address), its `fields` by name, and the bytes it was read from."""

    name: str
    code: int | None
    header: Mapping[str, int | str]
    fields: Mapping[str, Any]
    section: str
    raw: bytes
    kind: Kind = field(repr=False, compare=False)

    def describe(self) -> list[str]:
        """The answer in lines: its name, its header, then every field by name with what
        the manual says its value means."""
        return [f"{self.name}, manual {self.section}", "  " + self.header_line(),
                *("  " + line for line in field_lines(self.kind, self.fields))]

    def header_line(self) -> str:
        h = self.header
        if "type" in h:  # a serial reply: its control byte
            return f"control {self.raw[0]:02X}: {h['type']} reply from slave {h['address']}"
        return (f"header {self.raw[0]:02X}: CMR {h['cmr']} ("
                + ("a report the chip raises itself" if h["cmr"] else "the answer to a command")
                + f"), from the {h['source']}, PAL {h['pal']}, NEXT {h['next']} ("
                + ("the last block" if h["next"] else "more blocks follow") + ")")

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "key": self.kind.key, "code": self.code,
                "section": self.section, "bytes": self.raw.hex(" ").upper(),
                "header": dict(self.header), "fields": dict(self.fields),
                "meanings": meanings(self.kind, self.fields)}


# --- decoding -----------------------------------------------------------------------------
def decode_answer(data: bytes) -> Answer:
    """One parallel-bus answer, header first (`03 06 42 00 12 34 56 78`)."""
    data = block_bytes(data)
    _require_answer_header(data)
    check_length_byte(data, None, hi=MAX_READ_LENGTH)
    kind = _kind_of(data)
    _require_length(kind, data[1])
    values = decode_fields(kind, data)
    h = data[0]
    header: dict[str, int | str] = {"cmr": h >> 5 & 1, "source": SOURCES[h >> 3 & 3],
                                    "pal": h >> 1 & 1, "next": h & 1}
    for name in HEADER_BITS:
        values.pop(name, None)
    return Answer(kind.name, kind.code, header, values, kind.section, data, kind)


def decode_answers(capture: bytes) -> list[Answer]:
    """Answers read back to back (a capture), split by their length bytes; an error
    names the block (counted from 0) and its byte."""
    return decode_each(split_answers(capture), decode_answer)


def decode_each(blocks: Sequence[bytes], decode: Callable[[bytes], Answer]) -> list[Answer]:
    """`decode` of every block of a capture; an error is placed at its block (counted from
    0) and its byte within it."""
    out = []
    for index, block in enumerate(blocks):
        try:
            out.append(decode(block))
        except DecodeError as e:
            raise DecodeError(without_where(str(e)), block=index, byte=e.byte) from None
    return out


def split_answers(capture: bytes) -> list[bytes]:
    data = block_bytes(capture)
    if not data:
        raise DecodeError("no bytes: an answer is at least a header and a length byte")
    blocks: list[bytes] = []
    offset = 0
    while offset < len(data):
        if offset + 1 == len(data):
            raise DecodeError(f"header 0x{data[offset]:02X} with no length byte after it",
                              block=len(blocks), byte=0)
        end = offset + 2 + data[offset + 1]
        if end > len(data):
            raise DecodeError(f"length byte 0x{data[offset + 1]:02X} says {data[offset + 1]} "
                              f"bytes follow, only {len(data) - offset - 2} do",
                              block=len(blocks), byte=1)
        blocks.append(data[offset:end])
        offset = end
    return blocks


def decode_read_order(capture: bytes) -> list[Answer]:
    """Answers as the host reads them from DRR (§5-8: 「パラメータの下位から読み出します」,
    its example 78 56 34 12 00 42 06 03): each lowest parameter first and its header
    last, the reverse of the figures, one answer after another (a logic analyser's
    capture of the DRR reads). An error names the answer (counted from 0) and the byte
    as read."""
    out = []
    for index, block in enumerate(split_read_order(capture)):
        try:
            out.append(decode_answer(block[::-1]))
        except DecodeError as e:
            byte = None if e.byte is None else len(block) - 1 - e.byte
            raise DecodeError(without_where(str(e)), block=index, byte=byte) from None
    return out


def split_read_order(capture: bytes) -> list[bytes]:
    """A DRR capture's answers, each as read (header last). An answer ends with its length
    byte and its header, and the length byte says how many bytes were read before those
    two, so the capture splits from its end; what is left over is at its start (a capture
    that began inside an answer), and is named there."""
    data = block_bytes(capture)
    if not data:
        raise DecodeError("no bytes: an answer is at least a length byte and a header")
    blocks: list[bytes] = []
    end = len(data)
    while end:
        if end == 1:
            raise DecodeError(f"0x{data[0]:02X} with no length byte read before it (read from "
                              "DRR, an answer ends with its length byte and its header, "
                              "§5-8)", block=0, byte=0)
        length = data[end - 2]
        start = end - 2 - length
        if start < 0:
            raise DecodeError(f"length byte 0x{length:02X} says {length} bytes were read "
                              f"before it, only {end - 2} were", block=0, byte=end - 2)
        blocks.append(data[start:end])
        end = start
    return blocks[::-1]


def _require_answer_header(data: bytes) -> None:
    if len(data) < 2:
        raise DecodeError(f"an answer is at least a header and a length byte, got "
                          f"{len(data)} byte(s)", byte=len(data))
    h = data[0]
    shape = "0 0 CMR RESP(2) 0 PAL NEXT, §5-7.1"
    for bit in (7, 6, 2):
        if h >> bit & 1:
            raise DecodeError(f"header 0x{h:02X} has bit {bit} set: not an answer header "
                              f"({shape})", byte=0)
    if h >> 3 & 3 == IMPOSSIBLE_RESP:
        raise DecodeError(f"header 0x{h:02X} has RESP = 10, which §5-7.1 says cannot occur",
                          byte=0)


def _kind_of(data: bytes) -> Kind:
    """The kind the header and the response code (or a PAL=0 block's kind byte) name."""
    if not data[0] >> 1 & 1:  # PAL 0: a table-read item block, its kind byte first
        kind_byte = data[2] if len(data) > 2 else None
        kind = ITEM_BLOCKS.get(kind_byte) if kind_byte is not None else None
        if kind is None:
            shown = "none" if kind_byte is None else f"0x{kind_byte:02X}"
            raise DecodeError(f"a PAL=0 block (table read, §10-1) starts with its item kind "
                              f"01, 02 or 03, got {shown}", byte=2)
    else:
        if len(data) < 3:
            raise DecodeError("length byte 0x00: an answer with PAL 1 carries its response "
                              "code", byte=1)
        kinds = BY_CODE.get(data[2])
        if kinds is None:
            raise DecodeError(f"response code 0x{data[2]:02X} is no answer of the manual "
                              "(§7–§11)", byte=2)
        sized = [k for k in kinds if k.block.size in (None, len(data))]
        if not sized:
            want = " or ".join(f"0x{size - 2:02X}" for k in kinds
                               if (size := k.block.size) is not None)
            raise DecodeError(f"{kinds[0].name.split(',')[0]}: length byte 0x{data[1]:02X}, "
                              f"the manual's figure ({kinds[0].section}) gives {want}", byte=1)
        kind = sized[0]
    _require_drawn_header(kind, data[0])
    return kind


def _require_drawn_header(kind: Kind, header: int) -> None:
    for name, shift, width in (("cmr", 5, 1), ("resp", 3, 2), ("next", 0, 1)):
        want = kind.fixed_bit(name)
        got = header >> shift & ((1 << width) - 1)
        if want is not None and got != want:
            raise DecodeError(f"header 0x{header:02X} has {name.upper()} {got:0{width}b}, "
                              f"{kind.name}'s figure ({kind.section}) draws {want:0{width}b}",
                              byte=0)


def _require_length(kind: Kind, length: int) -> None:
    field = kind.block.fields[1]
    if isinstance(field, UInt) and not field.lo <= length <= field.max:
        raise DecodeError(f"{kind.name}: length byte 0x{length:02X}, the manual's figure "
                          f"({kind.section}) gives 0x{field.lo:02X}..0x{field.max:02X}",
                          byte=1)


def decode_fields(kind: Kind, data: bytes) -> dict[str, Any]:
    """`data` by `kind`'s frame, every documented value checked; errors name the kind."""
    try:
        values = kind.block.decode(data)
    except DecodeError as e:
        message = without_where(str(e))
        if not message.startswith(kind.name):
            message = f"{kind.name}: {message}"
        raise DecodeError(message, byte=e.byte) from None
    for name, texts in kind.choices.items():
        if values[name] not in texts:
            allowed = ", ".join(f"{v:02X}" for v in sorted(texts))
            raise DecodeError(f"{kind.name}: {label(kind, name)} 0x{values[name]:02X} is none "
                              f"of the manual's ({allowed}, {kind.section})",
                              byte=field_offset(kind.block, name))
    values.pop("length", None)
    return values


def field_offset(frame: Frame, name: str) -> int:
    offset = 0
    for f in frame.fields:
        if f.name == name:
            return offset
        offset += 0 if isinstance(f, Array) else f.size
    raise KeyError(name)


def without_where(message: str) -> str:
    """A DecodeError's message without its place."""
    # DecodeError prefixes "block N, byte M: "; a re-raise with its own place drops it.
    head, sep, tail = message.partition(": ")
    return tail if sep and head.startswith(("byte ", "block ")) else message


# --- encoding -------------------------------------------------------------------------------
def encode_answer(name_or_code: str | int, /, **fields: Any) -> bytes:
    """The bytes of one answer: `name_or_code` is a kind's key ("E0", "01 done", "41
    rates"), its name or its response code; `fields` as `decode_answer` gives them, with
    `source` ("bus", "event", "override"; default the bus, or what the figure fixes) and,
    for a table-read item block, `next`. The length byte is computed."""
    kind = kind_named(name_or_code, fields)
    values = dict(fields)
    source = values.pop("source", None)
    resp = kind.fixed_bit("resp")
    if source is not None:
        if source not in SOURCE_CODES or (resp is not None and SOURCE_CODES[source] != resp):
            allowed = [SOURCES[resp]] if resp is not None else list(SOURCE_CODES)
            raise FormatError(f"{kind.name}.source: {echo(source)} is not one of "
                              f"{', '.join(allowed)}")
        resp = SOURCE_CODES[source]
    values["resp"] = resp or 0
    unknown = set(values) - set(kind.field_names) - {"resp", "next"}
    if unknown:
        raise FormatError(f"{kind.name}: no field {echo(sorted(unknown)[0])} (its fields: "
                          f"{', '.join(kind.field_names) or 'none'})")
    require_choices(kind, values)
    if kind.block.size is None:
        values["length"] = frame_length(kind.block, values)
    return kind.block.encode(values)


def require_choices(kind: Kind, values: Mapping[str, Any]) -> None:
    for name, texts in kind.choices.items():
        if name in values and values[name] not in texts:
            raise FieldChoiceError(f"{kind.name}.{name}", values[name], tuple(texts))


def frame_length(frame: Frame, values: Mapping[str, Any]) -> int:
    """The length byte of a variable frame holding `values`: every byte after it."""
    size = 0
    for f in frame.fields[2:]:
        if isinstance(f, Array):
            items = values.get(f.name)
            size += f.item.size * (len(items) if isinstance(items, list | tuple) else 0)
        else:
            size += f.size
    return size


def kind_named(name_or_code: str | int, fields: Mapping[str, Any]) -> Kind:
    """The kind with this key or name; a code shared by several kinds (01) is told apart
    by the fields given."""
    if isinstance(name_or_code, str):
        kind = BY_KEY.get(name_or_code.upper()) or BY_KEY.get(name_or_code) or next(
            (k for k in KINDS if k.name == name_or_code), None)
        if kind is None:
            raise FormatError(f"answer {echo(name_or_code)}: no such answer (a key such as "
                              "E0, 82, 01 done, 41 rates, or its name)")
        return kind
    kinds = BY_CODE.get(name_or_code, ()) if isinstance(name_or_code, int) else ()
    if not kinds:
        raise FormatError(f"answer {echo(name_or_code)}: no answer has this response code")
    given = set(fields) - {"source", "next"}
    return next((k for k in kinds if set(k.field_names) == given), kinds[0])


# --- describing ---------------------------------------------------------------------------
def label(kind: Kind, name: str) -> str:
    return kind.labels.get(name, name.replace("_", " "))


def field_lines(kind: Kind, values: Mapping[str, Any]) -> list[str]:
    """One line per field: its label, its value and what the value means."""
    frame = kind.frame
    sizes = {f.name: f.size for f in frame.fields if isinstance(f, UInt | SInt)} \
        if frame is not None else {}
    return [f"{label(kind, name)} {_shown(kind, name, values[name], sizes.get(name, 1))}"
            for name in kind.field_names]


def _shown(kind: Kind, name: str, value: Any, size: int) -> str:
    if isinstance(value, list):
        if name in CODE_FIELDS:
            return ", ".join(_command(v) for v in value)
        if name == "parameters":
            return (f"({len(value)} bytes) " + " ".join(f"{v:02X}" for v in value)
                    if value else "none")
        return ", ".join(str(v) for v in value)
    if name in kind.choices:
        return f"{value:02X}: {kind.choices[name][value]}"
    if name in kind.flags:
        return f"{value:02X}: {flag_text(kind.flags[name], value)}"
    if name in CODE_FIELDS:
        return _command(value)
    return f"{value} (0x{value:0{2 * size}X})" if size > 1 or value > 9 else str(value)


def _command(code: int) -> str:
    return f"{code:02X} ({COMMAND_NAMES.get(code, 'no command code of the manual')})"


def flag_text(flags: tuple[Flag, ...], value: int) -> str:
    """The bits of `value` by name: those set, and those clear whose 0 has a meaning."""
    return ", ".join(flag_parts(flags, value)) or "none set"


def flag_parts(flags: tuple[Flag, ...], value: int) -> list[str]:
    parts = []
    for f in flags:
        bits = value >> f.shift & ((1 << f.width) - 1)
        if f.width > 1:
            parts.append(f"{f.name} {bits} ({f.on})")
        elif f.off is not None:
            parts.append(f"{f.name} {bits} ({f.on if bits else f.off})")
        elif bits:
            parts.append(f"{f.name} ({f.on})")
    return parts


def meanings(kind: Kind, values: Mapping[str, Any]) -> dict[str, Any]:
    """What the documented values mean, by field (for JSON)."""
    out: dict[str, Any] = {}
    for name in kind.field_names:
        value = values[name]
        if name in kind.choices:
            out[name] = kind.choices[name][value]
        elif name in kind.flags:
            out[name] = flag_parts(kind.flags[name], value)
        elif name in CODE_FIELDS:
            codes = value if isinstance(value, list) else [value]
            shown = [COMMAND_NAMES.get(c, "no command code of the manual") for c in codes]
            out[name] = shown if isinstance(value, list) else shown[0]
    return out

"""Declarative frame descriptions: one description serves encode and decode.

A `Frame` is an ordered tuple of fields. `Frame.encode(values)` turns a mapping
of field names to values into bytes, refusing any value that does not fit its
field (`FieldRangeError` names the field, value and range); `Frame.decode(data)`
is its exact inverse and raises `DecodeError` naming the byte offset of
whatever does not parse. Every codec in `profiles` (PPMC-312 blocks and ASCII
frames, A-Link command words, MC-200 packets) is written as frames.

Field kinds:
- `UInt` / `SInt`: integers of `size` bytes, big- or little-endian, with an
  optional narrower legal range.
- `F32`: IEEE-754 single.
- `Const`: fixed bytes (headers, codes); decode verifies them.
- `Reserved`: bytes written as `fill` and ignored on decode.
- `Bits`: an integer of `size` bytes split into named bit ranges (`Bit`),
  some of which may be constants.
- `Array`: the rest of the frame as a run of equal items (last field only).
- `Checksum`: computed over all preceding bytes by a function; decode checks it.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from .errors import DecodeError, FieldRangeError, FormatError

Order = Literal["big", "little"]


@dataclass(frozen=True)
class UInt:
    name: str
    size: int
    order: Order = "big"
    lo: int = 0
    hi: int | None = None

    @property
    def max(self) -> int:
        return (1 << (8 * self.size)) - 1 if self.hi is None else self.hi

    def check(self, value: Any, label: str | None = None) -> int:
        label = label or self.name
        if isinstance(value, bool) or not isinstance(value, int):
            raise FieldRangeError(label, value, self.lo, self.max)
        if not self.lo <= value <= self.max:
            raise FieldRangeError(label, value, self.lo, self.max)
        return value

    def pack(self, value: Any, label: str | None = None) -> bytes:
        return self.check(value, label).to_bytes(self.size, self.order)

    def unpack(self, data: bytes, offset: int) -> int:
        value = int.from_bytes(data[offset : offset + self.size], self.order)
        if not self.lo <= value <= self.max:
            raise DecodeError(
                f"{self.name} = {value} (0x{value:X}) is outside {self.lo}..{self.max}", byte=offset
            )
        return value


@dataclass(frozen=True)
class SInt:
    name: str
    size: int
    order: Order = "big"

    def pack(self, value: Any, label: str | None = None) -> bytes:
        lo, hi = -(1 << (8 * self.size - 1)), (1 << (8 * self.size - 1)) - 1
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise FieldRangeError(label or self.name, value, lo, hi)
        return value.to_bytes(self.size, self.order, signed=True)

    def unpack(self, data: bytes, offset: int) -> int:
        return int.from_bytes(data[offset : offset + self.size], self.order, signed=True)


@dataclass(frozen=True)
class F32:
    name: str
    order: Order = "little"
    size: int = 4

    def pack(self, value: Any, label: str | None = None) -> bytes:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise FieldRangeError(label or self.name, value, -3.4028235e38, 3.4028235e38)
        fmt = "<f" if self.order == "little" else ">f"
        try:
            return struct.pack(fmt, value)
        except OverflowError:
            raise FieldRangeError(label or self.name, value, -3.4028235e38, 3.4028235e38) from None

    def unpack(self, data: bytes, offset: int) -> float:
        fmt = "<f" if self.order == "little" else ">f"
        return struct.unpack_from(fmt, data, offset)[0]


@dataclass(frozen=True)
class Const:
    name: str
    value: bytes

    @property
    def size(self) -> int:
        return len(self.value)

    def unpack(self, data: bytes, offset: int) -> bytes:
        got = data[offset : offset + self.size]
        if got != self.value:
            raise DecodeError(f"{self.name} is {got.hex(' ').upper()}, expected "
                              f"{self.value.hex(' ').upper()}", byte=offset)
        return got


@dataclass(frozen=True)
class Reserved:
    size: int
    fill: int = 0
    name: str = "reserved"


@dataclass(frozen=True)
class Bit:
    """A bit range `[shift, shift + width)` of a `Bits` field; `const` fixes its value."""

    name: str
    shift: int
    width: int = 1
    const: int | None = None
    lo: int = 0
    hi: int | None = None

    @property
    def max(self) -> int:
        return (1 << self.width) - 1 if self.hi is None else self.hi


@dataclass(frozen=True)
class Bits:
    """An integer of `size` bytes made of named bit ranges; unnamed bits are zero."""

    name: str
    size: int
    parts: tuple[Bit, ...]
    order: Order = "big"
    strict: bool = True  # decode refuses set bits outside the parts

    def pack_int(self, values: Mapping[str, Any], label: str) -> int:
        word = 0
        for part in self.parts:
            if part.const is not None:
                value = part.const
            else:
                value = values.get(part.name, 0)
                if isinstance(value, bool):
                    value = int(value)
                if not isinstance(value, int) or not part.lo <= value <= part.max:
                    raise FieldRangeError(f"{label}.{part.name}", value, part.lo, part.max)
            word |= value << part.shift
        return word

    def unpack_int(self, word: int, offset: int) -> dict[str, int]:
        out: dict[str, int] = {}
        used = 0
        for part in self.parts:
            mask = (1 << part.width) - 1
            used |= mask << part.shift
            value = (word >> part.shift) & mask
            if part.const is not None:
                if value != part.const:
                    raise DecodeError(f"{self.name}.{part.name} is {value}, expected {part.const}",
                                      byte=offset)
                continue
            if not part.lo <= value <= part.max:
                raise DecodeError(f"{self.name}.{part.name} = {value} is outside "
                                  f"{part.lo}..{part.max}", byte=offset)
            out[part.name] = value
        if self.strict and word & ~used:
            raise DecodeError(f"{self.name} has unexpected bits set: 0x{word & ~used:X}",
                              byte=offset)
        return out


@dataclass(frozen=True)
class Array:
    """The remainder of the frame: a run of `item`s (as a list under `name`)."""

    name: str
    item: UInt
    min_items: int = 0
    max_items: int | None = None


@dataclass(frozen=True)
class Checksum:
    """`size` bytes computed by `func` over every byte before it."""

    name: str
    size: int
    func: Callable[[bytes], int]
    order: Order = "little"


FieldT = UInt | SInt | F32 | Const | Reserved | Bits | Array | Checksum


@dataclass(frozen=True)
class Frame:
    name: str
    fields: tuple[FieldT, ...]
    _fixed: int = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for f in self.fields[:-1]:
            if isinstance(f, Array):
                raise TypeError(f"{self.name}: an Array must be the last field")
        fixed = sum(f.size for f in self.fields if not isinstance(f, Array))
        object.__setattr__(self, "_fixed", fixed)

    @property
    def size(self) -> int | None:
        """Byte size, or None for a frame ending in an Array."""
        return None if isinstance(self.fields[-1], Array) else self._fixed

    def encode(self, values: Mapping[str, Any] | None = None, /, **kw: Any) -> bytes:
        vals = dict(values or {}, **kw)
        out = bytearray()
        for f in self.fields:
            label = f"{self.name}.{f.name}"
            if isinstance(f, Const):
                out += f.value
            elif isinstance(f, Reserved):
                out += bytes([f.fill]) * f.size
            elif isinstance(f, Bits):
                out += f.pack_int(vals, label).to_bytes(f.size, f.order)
            elif isinstance(f, Checksum):
                out += f.func(bytes(out)).to_bytes(f.size, f.order)
            elif isinstance(f, Array):
                items = _seq(vals, f.name, label)
                hi = f.max_items if f.max_items is not None else 1 << 30
                if not f.min_items <= len(items) <= hi:
                    raise FieldRangeError(f"{label} (item count)", len(items), f.min_items, hi)
                for i, item in enumerate(items):
                    out += f.item.pack(item, f"{label}[{i}]")
            else:
                if f.name not in vals:
                    raise FormatError(f"{label}: no value given")
                out += f.pack(vals[f.name], label)
        return bytes(out)

    def decode(self, data: bytes, *, block: int | None = None) -> dict[str, Any]:
        data = bytes(data)
        try:
            return self._decode(data)
        except DecodeError as e:
            if block is None:
                raise
            raise DecodeError(_strip_where(str(e)), block=block, byte=e.byte) from None

    def _decode(self, data: bytes) -> dict[str, Any]:
        size = self.size
        if size is not None and len(data) != size:
            raise DecodeError(f"{self.name} is {len(data)} bytes, expected {size}",
                              byte=min(len(data), size))
        if size is None and len(data) < self._fixed:
            raise DecodeError(f"{self.name} is {len(data)} bytes, needs at least {self._fixed}",
                              byte=len(data))
        out: dict[str, Any] = {}
        offset = 0
        for f in self.fields:
            if isinstance(f, Reserved):
                pass
            elif isinstance(f, Const):
                f.unpack(data, offset)
            elif isinstance(f, Bits):
                out.update(f.unpack_int(int.from_bytes(data[offset:offset + f.size], f.order),
                                        offset))
            elif isinstance(f, Checksum):
                want = f.func(data[:offset])
                got = int.from_bytes(data[offset:offset + f.size], f.order)
                if got != want:
                    raise DecodeError(f"{self.name}.{f.name} is 0x{got:0{2 * f.size}X}, "
                                      f"expected 0x{want:0{2 * f.size}X}", byte=offset)
            elif isinstance(f, Array):
                rest = len(data) - offset
                if rest % f.item.size:
                    raise DecodeError(f"{self.name}.{f.name}: {rest} bytes is not a whole number "
                                      f"of {f.item.size}-byte items", byte=offset + rest
                                      - rest % f.item.size)
                items = [f.item.unpack(data, offset + k) for k in range(0, rest, f.item.size)]
                hi = f.max_items if f.max_items is not None else 1 << 30
                if not f.min_items <= len(items) <= hi:
                    raise DecodeError(f"{self.name}.{f.name}: {len(items)} items, allowed "
                                      f"{f.min_items}..{hi}", byte=offset)
                out[f.name] = items
                offset = len(data)
                continue
            else:
                out[f.name] = f.unpack(data, offset)
            offset += f.size
        return out


def _seq(vals: Mapping[str, Any], name: str, label: str) -> Sequence[Any]:
    items = vals.get(name)
    if not isinstance(items, list | tuple):
        raise FieldRangeError(label, items, 0, 0)
    return items


def _strip_where(message: str) -> str:
    # DecodeError prefixes "byte N: "; the block-aware re-raise rebuilds it.
    head, sep, tail = message.partition(": ")
    return tail if sep and head.startswith(("byte ", "block ")) else message

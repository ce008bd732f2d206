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
    _layout: _Layout | None = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for f in self.fields[:-1]:
            if isinstance(f, Array):
                raise TypeError(f"{self.name}: an Array must be the last field")
        fixed = sum(f.size for f in self.fields if not isinstance(f, Array))
        object.__setattr__(self, "_fixed", fixed)
        object.__setattr__(self, "_layout", _compile(self))

    @property
    def size(self) -> int | None:
        """Byte size, or None for a frame ending in an Array."""
        return None if isinstance(self.fields[-1], Array) else self._fixed

    def encode(self, values: Mapping[str, Any] | None = None, /, **kw: Any) -> bytes:
        vals: Mapping[str, Any] = dict(values or {}, **kw) if kw else (values or {})
        layout = self._layout
        if layout is not None:
            try:
                return layout.encode(vals)
            except _Invalid:
                pass  # the interpreter below raises the precise, documented error
        return self._encode_slow(vals)

    def _encode_slow(self, vals: Mapping[str, Any]) -> bytes:
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

    # --- runs of items split over many frames (upload sections) ----------------------
    @property
    def item(self) -> UInt:
        """The item of the frame's trailing Array."""
        layout = self._layout
        if layout is not None and layout.array is not None:
            return layout.array.item
        last = self.fields[-1]
        if not isinstance(last, Array):
            raise TypeError(f"{self.name} has no Array")
        return last.item

    def pack_items(self, items: Sequence[Any]) -> bytes | None:
        """The items packed back to back as the trailing Array would pack them, or None
        when one does not fit (then `encode` per frame names it)."""
        try:
            return _pack_run(self.item, items)
        except _Invalid:
            return None

    def unpack_items(self, data: bytes) -> list[int] | None:
        """The items in `data` (the Array parts of several frames joined), or None when
        one is out of range (then `decode` per frame names it)."""
        if len(data) % self.item.size:
            return None
        try:
            return _unpack_run(self.item, data, 0)
        except _Invalid:
            return None

    def encode_fixed(self, values: Mapping[str, Any]) -> bytes:
        """The fields before the trailing Array: a prefix to put before packed items."""
        layout = self._layout
        if layout is None or layout.array is None or layout.checksum is not None:
            raise TypeError(f"{self.name}: no compiled prefix")
        return layout.encode_fixed(values)

    def decode_fixed(self, prefix: bytes) -> dict[str, Any] | None:
        """The fields before the trailing Array, from exactly those bytes; None when they
        do not decode (then `decode` of the whole frame says why)."""
        layout = self._layout
        if layout is None or layout.array is None or layout.checksum is not None:
            raise TypeError(f"{self.name}: no compiled prefix")
        if len(prefix) != layout.struct.size:
            return None
        try:
            return layout.decode_prefix(prefix)
        except _Invalid:
            return None

    def decode(self, data: bytes, *, block: int | None = None) -> dict[str, Any]:
        data = bytes(data)
        layout = self._layout
        if layout is not None:
            try:
                return layout.decode(data)
            except _Invalid:
                pass  # the interpreter below raises the precise, documented error
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


# --- compiled frames --------------------------------------------------------------
# A Frame is compiled once, when it is built: its fixed fields become one
# `struct.Struct` and a tuple of per-field steps, its Array one bulk packer.
# The compiled path handles valid values and well-formed bytes; on anything
# else it raises `_Invalid` and the interpreter above (`_encode_slow`,
# `_decode`) runs instead and raises the precise error. So the error messages
# have one source, and the fast path can only be faster, never different
# (tests/profiles/test_fields.py compares both paths on random input).

class _Invalid(Exception):
    """The compiled path met a value or byte it does not handle: use the interpreter."""


_INT_CODES = {1: "B", 2: "H", 4: "I", 8: "Q"}
_ENDIAN = {"big": ">", "little": "<"}
_INT_ONLY = frozenset((int,))

# Encode steps: (kind, field name, check lo, check hi / extra); decode steps the same.
(_E_CONST, _E_UINT, _E_UINT_BYTES, _E_SINT, _E_SINT_BYTES, _E_F32, _E_BITS, _E_BITS_BYTES,
 _E_INT_BYTES, _E_F32_BYTES) = range(10)


def _pack_run(item: UInt, items: Any) -> bytes:
    """`items` packed back to back as `item`s; `_Invalid` unless all are in range."""
    if not isinstance(items, list | tuple):
        raise _Invalid
    n = len(items)
    if not n:
        return b""
    if not _INT_ONLY.issuperset(map(type, items)):
        raise _Invalid
    size, end = item.size, _ENDIAN[item.order]
    code = _INT_CODES.get(size)
    if code is not None and item.lo == 0 and item.hi is None:
        try:  # struct refuses what does not fit the width
            return struct.pack(f"{end}{n}{code}", *items)
        except struct.error:
            raise _Invalid from None
    if size == 3 and item.lo == 0 and item.hi is None:
        # No 3-byte struct code: pack 4 bytes each (struct refuses negatives and values
        # above 32 bits), check the top bytes are zero, and drop them.
        try:
            wide = struct.pack(f"{end}{n}I", *items)
        except struct.error:
            raise _Invalid from None
        top = 0 if item.order == "big" else 3
        if wide[top::4].count(0) != n:
            raise _Invalid
        out = bytearray(3 * n)
        for k in range(3):
            out[k::3] = wide[k + 1 - top // 3::4]
        return bytes(out)
    if min(items) < item.lo or max(items) > item.max:
        raise _Invalid
    if code is not None:
        return struct.pack(f"{end}{n}{code}", *items)
    return b"".join(v.to_bytes(size, item.order) for v in items)


def _unpack_run(item: UInt, data: bytes, offset: int) -> list[int]:
    """Every `item` in `data[offset:]` (a whole number of them); `_Invalid` if one is out
    of range."""
    size, end = item.size, _ENDIAN[item.order]
    n = (len(data) - offset) // size
    code = _INT_CODES.get(size)
    if code is not None:
        values = list(struct.unpack_from(f"{end}{n}{code}", data, offset))
    elif size == 3:
        wide = bytearray(4 * n)
        skip = 1 if item.order == "big" else 0
        for k in range(3):
            wide[k + skip::4] = data[offset + k::3]
        values = list(struct.unpack(f"{end}{n}I", wide))
    else:
        values = [int.from_bytes(data[k:k + size], item.order)
                  for k in range(offset, len(data), size)]
    if values and (item.lo > 0 or item.hi is not None) and (
            min(values) < item.lo or max(values) > item.max):
        raise _Invalid
    return values


class _Layout:
    """The compiled form of one Frame."""

    def __init__(self, frame: Frame) -> None:
        fixed = [f for f in frame.fields if not isinstance(f, Array)]
        self.checksum: Checksum | None = None
        if fixed and isinstance(fixed[-1], Checksum):
            self.checksum = fixed[-1]
            fixed.pop()
        if any(isinstance(f, Checksum) for f in fixed):
            raise TypeError("a Checksum before other fields is not compiled")
        # One byte order for the struct: that of the multi-byte fields (a byte has none).
        orders = [f.order for f in fixed if isinstance(f, UInt | SInt | F32 | Bits) and f.size > 1]
        self.order: Order = orders[0] if orders else "big"
        codes: list[str] = []
        enc: list[tuple[int, str, Any, Any]] = []
        dec: list[tuple[int, str, Any, Any]] = []
        for f in fixed:
            same = f.size == 1 or getattr(f, "order", self.order) == self.order
            if isinstance(f, Reserved):
                codes.append(f"{f.size}x" if f.fill == 0 else f"{f.size}s")
                if f.fill:
                    enc.append((_E_CONST, f.name, bytes([f.fill]) * f.size, None))
                    dec.append((_E_CONST, f.name, None, None))  # ignored on decode
                continue
            if isinstance(f, Const):
                codes.append(f"{f.size}s")
                enc.append((_E_CONST, f.name, f.value, None))
                dec.append((_E_CONST, f.name, f.value, None))
            elif isinstance(f, UInt):
                code = _INT_CODES.get(f.size) if same else None
                codes.append(code or f"{f.size}s")
                if code:
                    enc.append((_E_UINT, f.name, f.lo, f.max))
                else:
                    enc.append((_E_INT_BYTES, f.name, None, (f.lo, f.max, f.size, f.order, False)))
                kind = _E_UINT if code else _E_UINT_BYTES
                narrow = f.lo > 0 or f.hi is not None
                dec.append((kind, f.name, (f.lo, f.max, f.order) if narrow else
                            (None, None, f.order), None))
            elif isinstance(f, SInt):
                code = _INT_CODES.get(f.size) if same else None
                codes.append(code.lower() if code else f"{f.size}s")
                lo, hi = -(1 << (8 * f.size - 1)), (1 << (8 * f.size - 1)) - 1
                kind = _E_SINT if code else _E_SINT_BYTES
                if code:
                    enc.append((_E_SINT, f.name, lo, hi))
                else:
                    enc.append((_E_INT_BYTES, f.name, None, (lo, hi, f.size, f.order, True)))
                dec.append((kind, f.name, f.order, None))
            elif isinstance(f, F32):
                if same:
                    codes.append("f")
                    enc.append((_E_F32, f.name, None, None))
                    dec.append((_E_F32, f.name, None, None))
                else:  # a float of the other byte order: its own 4-byte struct
                    codes.append("4s")
                    single = struct.Struct(_ENDIAN[f.order] + "f")
                    enc.append((_E_F32_BYTES, f.name, single, None))
                    dec.append((_E_F32_BYTES, f.name, single, None))
            elif isinstance(f, Bits):
                code = _INT_CODES.get(f.size) if same else None
                codes.append(code or f"{f.size}s")
                kind = _E_BITS if code else _E_BITS_BYTES
                enc.append((kind, f"{frame.name}.{f.name}", f, None))
                dec.append((kind, f.name, f, None))
            else:  # pragma: no cover - every field kind is listed above
                raise TypeError(f"field {f!r} is not compiled")
        self.struct = struct.Struct(_ENDIAN[self.order] + "".join(codes))
        self.enc = tuple(enc)
        self.dec = tuple(dec)
        last = frame.fields[-1]
        self.array: Array | None = last if isinstance(last, Array) else None
        self.size = frame.size
        self.fixed = self.struct.size + (self.checksum.size if self.checksum else 0)

    def encode(self, vals: Mapping[str, Any]) -> bytes:
        data = self.encode_fixed(vals)
        if self.checksum is not None:
            c = self.checksum
            data += c.func(data).to_bytes(c.size, c.order)
        if self.array is not None:
            arr = self.array
            items = vals.get(arr.name)
            if not isinstance(items, list | tuple):
                raise _Invalid
            hi = arr.max_items if arr.max_items is not None else 1 << 30
            if not arr.min_items <= len(items) <= hi:
                raise _Invalid
            data += _pack_run(arr.item, items)
        return data

    def encode_fixed(self, vals: Mapping[str, Any]) -> bytes:
        args: list[Any] = []
        append = args.append
        for kind, name, a, b in self.enc:
            if kind == _E_CONST:
                append(a)
            elif kind == _E_UINT or kind == _E_SINT:
                v = vals.get(name)
                if type(v) is not int or not a <= v <= b:
                    raise _Invalid
                append(v)
            elif kind == _E_BITS:
                append(a.pack_int(vals, name))  # raises the documented FieldRangeError itself
            elif kind == _E_F32:
                v = vals.get(name)
                if type(v) is not float and type(v) is not int:
                    raise _Invalid
                append(v)
            elif kind == _E_BITS_BYTES:
                append(a.pack_int(vals, name).to_bytes(a.size, a.order))
            elif kind == _E_F32_BYTES:
                v = vals.get(name)
                if type(v) is not float and type(v) is not int:
                    raise _Invalid
                try:
                    append(a.pack(v))
                except OverflowError:
                    raise _Invalid from None
            else:  # an integer without a struct code: b is (lo, hi, size, order, signed)
                v = vals.get(name)
                lo, hi, size, order, signed = b
                if type(v) is not int or not lo <= v <= hi:
                    raise _Invalid
                append(v.to_bytes(size, order, signed=signed))
        try:
            return self.struct.pack(*args)
        except (struct.error, OverflowError):
            raise _Invalid from None

    def decode(self, data: bytes) -> dict[str, Any]:
        n = len(data)
        if self.size is not None:
            if n != self.size:
                raise _Invalid
        elif n < self.fixed:
            raise _Invalid
        out = self.decode_prefix(data)
        offset = self.struct.size
        if self.checksum is not None:
            c = self.checksum
            if int.from_bytes(data[offset:offset + c.size], c.order) != c.func(data[:offset]):
                raise _Invalid
            offset += c.size
        arr = self.array
        if arr is not None:
            rest = n - offset
            if rest % arr.item.size:
                raise _Invalid
            count = rest // arr.item.size
            hi = arr.max_items if arr.max_items is not None else 1 << 30
            if not arr.min_items <= count <= hi:
                raise _Invalid
            out[arr.name] = _unpack_run(arr.item, data, offset)
        return out

    def decode_prefix(self, data: bytes) -> dict[str, Any]:
        raw = self.struct.unpack_from(data)
        out: dict[str, Any] = {}
        for (kind, name, a, _b), value in zip(self.dec, raw, strict=True):
            if kind == _E_CONST:
                if a is not None and value != a:
                    raise _Invalid
            elif kind == _E_UINT:
                if a[0] is not None and not a[0] <= value <= a[1]:
                    raise _Invalid
                out[name] = value
            elif kind == _E_UINT_BYTES:
                value = int.from_bytes(value, a[2])
                if a[0] is not None and not a[0] <= value <= a[1]:
                    raise _Invalid
                out[name] = value
            elif kind == _E_SINT or kind == _E_F32:
                out[name] = value
            elif kind == _E_SINT_BYTES:
                out[name] = int.from_bytes(value, a, signed=True)
            elif kind == _E_F32_BYTES:
                out[name] = a.unpack(value)[0]
            else:
                word = value if kind == _E_BITS else int.from_bytes(value, a.order)
                try:
                    out.update(a.unpack_int(word, 0))
                except DecodeError:
                    raise _Invalid from None
        return out


def _compile(frame: Frame) -> _Layout | None:
    try:
        return _Layout(frame)
    except TypeError:
        return None  # a layout the compiler does not know: the interpreter serves it

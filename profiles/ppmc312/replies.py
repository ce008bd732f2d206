"""Decoding the PPMC-312's replies in ASCII serial mode (manual §13, §15–19) as `Answer`s.

A reply is a control byte `1 0 type(2) address(4)` (80+a busy, 90+a ready, A0+a
data, B0+a special), its data as ASCII hex, and a checksum (ascii.py checks it). A
special reply carries its code; a data reply carries no code at all: what its bytes
mean depends on the command it answers (§17-6 inputs and §19-14's stop report are
both one byte after A0+a). `decode_reply(frame, reply_to=…)` says which command; without
it a reply is read as the poll's (the stop report for one data byte) or by its length
where only one command gives it, and a reply no reading fits is a `DecodeError`.

The data of a serial reply is laid out as the parallel answer's parameters (§18-1 is
§10-2's, §18-9 is §10-9's), so those payloads reuse the parallel kinds' fields; the
position reply is `ascii.POSITION_REPLY`, the link's and the emulator's, which matches
42's parameters field for field (a test holds them equal).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..errors import DecodeError, FormatError, echo
from ..fields import Frame
from .answer_kinds import BY_KEY, Kind
from .answers import Answer, decode_each, decode_fields, require_choices, without_where
from .ascii import (
    END_CODE_REPLY,
    END_CODES,
    ERROR_CODE_REPLY,
    ERROR_CODES,
    ERROR_COUNT_REPLY,
    POSITION_REPLY,
    SPECIAL_REPLIES,
    SPECIAL_REPLY,
    decode_frame,
    encode_frame,
)
from .frames import block_bytes


def _params_of(key: str, name: str) -> Frame:
    # The parallel answer's parameters (after header, length and code), as a payload.
    return Frame(name, BY_KEY[key].block.fields[3:])


def _kind(key: str, name: str, section: str, frame: Frame | None, **meaning: Any) -> Kind:
    return Kind(key, name, section, frame, None, **meaning)


# The serial reply kinds by key; each with the control types it comes with.
REPLY_KINDS: dict[str, tuple[Kind, tuple[str, ...]]] = {k.key: (k, types) for k, types in (
    (_kind("busy", "pulse output in progress (80+a)", "§19-2", None), ("busy",)),
    (_kind("ready", "ready (90+a): no pulse output, or the command accepted", "§19-1",
           None), ("ready",)),
    (_kind("stop report", "pulse output stopped (A0+a)", "§19-14", END_CODE_REPLY,
           choices={"end_code": END_CODES}), ("data",)),
    (_kind("end status", "end status read reply (A0+a)", "§18-6", END_CODE_REPLY,
           choices={"end_code": END_CODES}), ("data",)),
    # ascii.POSITION_REPLY, what the link reads and the emulator writes, is laid out as
    # 42's parameters (counter, position unsigned): one description for all three.
    (_kind("position", "position read reply (A0+a)", "§18-1", POSITION_REPLY,
           choices=BY_KEY["42"].choices), ("data",)),
    (_kind("inputs", "general input reply (A0+a)", "§17-6",
           _params_of("25", "serial general input reply"), flags=BY_KEY["25"].flags),
     ("data",)),
    (_kind("terminals", "control terminal read reply (A0+a)", "§17-8",
           _params_of("27", "serial control terminal reply"), flags=BY_KEY["27"].flags),
     ("data",)),
    (_kind("status", "status read reply (A0+a)", "§18-9",
           _params_of("4D", "serial status reply"), flags=BY_KEY["4D"].flags), ("data",)),
    (_kind("version", "version read reply (90+a)", "§18-4",
           _params_of("40", "serial version reply")), ("ready",)),
    # §18-10/18-11 print the ready control byte on these data replies: either is read.
    (_kind("error code", "error code read reply (90+a)", "§18-10", ERROR_CODE_REPLY,
           choices={"error_code": ERROR_CODES}), ("ready", "data")),
    (_kind("error count", "error count read reply (90+a)", "§18-11", ERROR_COUNT_REPLY),
     ("ready", "data")),
    (_kind("special", "special reply (B0+a)", "§19", SPECIAL_REPLY,
           choices={"code": SPECIAL_REPLIES}), ("special",)),
)}

# The command a reply answers → the replies it may get. Every command may be refused
# with a special reply (§19); a poll gets busy, ready, the stop report or a report.
_REFUSED = ("special",)
REPLY_TO: dict[str, tuple[str, ...]] = {
    "poll": ("busy", "ready", "stop report", *_REFUSED),
    "command": ("ready", *_REFUSED),
    "position": ("position", *_REFUSED),
    "end-status": ("end status", *_REFUSED),
    "inputs": ("inputs", *_REFUSED),
    "terminals": ("terminals", *_REFUSED),
    "status": ("status", *_REFUSED),
    "version": ("version", *_REFUSED),
    "error-code": ("error code", *_REFUSED),
    "error-count": ("error count", *_REFUSED),
}
# Without `reply_to`: the poll's reading, then each length only one command gives.
GUESSED = ("busy", "ready", "stop report", "position", "terminals", "status", "error count",
           "special")


def decode_reply(frame: bytes, *, reply_to: str | None = None) -> Answer:
    """One slave reply (control byte, ASCII hex, checksum) as an `Answer`; `reply_to`
    names the command it answers (a `REPLY_TO` key)."""
    data = block_bytes(frame)
    if data and data[0] & 0xC0 != 0x80:
        raise DecodeError(f"0x{data[0]:02X} is no control byte (1 0 type(2) address(4), "
                          "§13-2)", byte=0)
    parsed = decode_frame(data, from_slave=True)
    kind = _reply_kind(parsed.kind, len(parsed.payload), reply_to)
    values: dict[str, Any] = {}
    if kind.frame is not None:
        try:
            values = decode_fields(kind, parsed.payload)
        except DecodeError as e:
            # payload byte k is sent as the characters at frame offsets 1 + 2k, 2 + 2k
            where = None if e.byte is None else 1 + 2 * e.byte
            raise DecodeError(without_where(str(e)), byte=where) from None
    code = values["code"] if kind.key == "special" else None
    header: dict[str, int | str] = {"type": parsed.kind, "address": parsed.address}
    return Answer(kind.name, code, header, values, kind.section, data, kind)


def decode_replies(capture: bytes, *, reply_to: str | None = None) -> list[Answer]:
    """Replies back to back, each starting at its control byte (the only bytes with bit 7
    set: the rest is ASCII); an error names the reply (counted from 0)."""
    return decode_each(split_replies(capture), lambda f: decode_reply(f, reply_to=reply_to))


def split_replies(capture: bytes) -> list[bytes]:
    data = block_bytes(capture)
    if not data:
        raise DecodeError("no bytes: a reply is at least a control byte and a checksum")
    if not data[0] & 0x80:
        raise DecodeError(f"0x{data[0]:02X} is no control byte (bit 7 clear): a capture of "
                          "replies starts with one", byte=0)
    starts = [k for k, b in enumerate(data) if b & 0x80]
    return [data[a:b] for a, b in zip(starts, [*starts[1:], len(data)], strict=True)]


def _reply_kind(kind: str, size: int, reply_to: str | None) -> Kind:
    if reply_to is not None and reply_to not in REPLY_TO:
        raise FormatError(f"reply_to: {echo(reply_to)} is not one of {', '.join(REPLY_TO)}")
    keys = REPLY_TO[reply_to] if reply_to is not None else GUESSED
    fits = [k for k in keys if kind in REPLY_KINDS[k][1]
            and _payload_size(REPLY_KINDS[k][0]) == size]
    if fits:
        return REPLY_KINDS[fits[0]][0]
    if reply_to is None and kind == "ready" and size == 1:
        raise DecodeError("a ready reply with one data byte answers version read (§18-4) or "
                          "error code read (§18-10): say which (reply to version or "
                          "error-code)", byte=1)
    to = f"an answer to {reply_to}" if reply_to else "a reply of §13–19"
    raise DecodeError(f"a {kind} reply with {size} data byte(s) is not {to}", byte=1)


def _payload_size(kind: Kind) -> int:
    return 0 if kind.frame is None else kind.frame.size or 0


def encode_reply(key: str, address: int, /, **fields: Any) -> bytes:
    """A reply frame of kind `key` (a `REPLY_KINDS` key) from slave `address`; the error
    code and count come with the ready byte the manual prints."""
    if key not in REPLY_KINDS:
        raise FormatError(f"reply {echo(key)}: no such reply (one of {', '.join(REPLY_KINDS)})")
    kind, types = REPLY_KINDS[key]
    require_choices(kind, fields)
    payload = b"" if kind.frame is None else kind.frame.encode(_only(kind, fields))
    return encode_frame(types[0], address, payload)


def _only(kind: Kind, fields: Mapping[str, Any]) -> Mapping[str, Any]:
    unknown = set(fields) - set(kind.field_names)
    if unknown:
        raise FormatError(f"{kind.name}: no field {echo(sorted(unknown)[0])} (its fields: "
                          f"{', '.join(kind.field_names) or 'none'})")
    return fields

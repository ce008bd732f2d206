"""PPMC-312 motion commands: every command that starts, changes or stops pulse output
(manual §8-1…§8-11 and the high-speed limit, §7-6), as parallel blocks and as the ASCII
frames of §16 (§15-5 for 05), each described once as a `profiles.fields.Frame`.

`COMMANDS` is the one registry: a command's name (`stop`, `decel-stop`, `accel`, …) gives
its code, its parallel frames, its serial frames by how it starts, what parameters it
takes and the rates its figure allows. The CLI (`stepramp move --command NAME`) and
`stepramp check` (profiles/ppmc312/command_rules.py) look commands up there, never in if-chains.

Parameters, the same for every command (each command takes some of them):
- `rate`: a rate divisor (82's is its high-rate override; 0 = the table's high rate where
  the manual allows it: `Rate.zero`);
- `pulses`: the pulses to output (82, 83), 1..0xFFFFFFFF;
- `ccw`: DIR = 1; `index`: IDX = 1 (origin search and return: /ORG and /INDEX together);
- `override_at`: OV = 1 with a position trigger (TRG 00): the command waits in the
  override buffer until the position counter reaches it (80, 81, 87, 88 only: the others'
  figures refuse TRG 00/10, §11-6's 0x21);
- `on`: OV = 1 with an event trigger: `"evt1"` (TRG 01, イベント入力1) or `"evt2"`
  (TRG 11, イベント入力2); the serial forms call the same inputs イベント入力0 and 1 (the
  pins /EVT0 and /EVT1).

`encode_command` refuses what the figure's ranges exclude (FieldRangeError naming field,
value and range); `decode_command` is its exact inverse and refuses, naming the byte,
whatever `encode_command` would not write. `stepramp check` reads the bytes without those
refusals (`read_fields`) and reports what the chip would refuse as findings with its
codes. The readings the figures leave open are in docs/manual-notes.md.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..errors import DecodeError, FieldRangeError, FormatError, UnsupportedError, echo, require_int
from ..fields import Bit, Bits, Const, Frame, UInt
from .ascii import MAX_ADDRESS, SERIAL_MOVE, SERIAL_STOP, decode_frame, encode_frame
from .frames import HDR_CODE_EXEC, MOVE, block_bytes

RATE_MAX = 0xFFFF
EVENTS = {"evt1": 0b01, "evt2": 0b11}   # TRG of an event-triggered override
POSITION_TRIGGERS = (0b00, 0b10)        # both read 「パルス位置がオーバーライド位置に達した時」
TRG_POSITION = 0b00                     # the one stepramp writes
# How a command starts: at once, at a position (override), or on an event input.
NOW, AT = "now", "at"
STARTS = (NOW, AT, *EVENTS)
PARAMS = ("rate", "pulses", "ccw", "index", "override_at", "on")


@dataclass(frozen=True)
class Rate:
    """The rates a command's figure allows: `lo`..0xFFFF, and 0 (the table's high rate)
    when `zero`. Which rates of that range the chip takes depends on the table it holds
    (0x20 otherwise): `table` says how, or is empty when no table bounds it (05)."""

    lo: int
    zero: bool
    table: str = "within the rates of the table it holds"

    def allows(self, rate: int) -> bool:
        return (rate == 0 and self.zero) or self.lo <= rate <= RATE_MAX

    def error(self, field: str, rate: object) -> FieldRangeError:
        err = FieldRangeError(field, rate, self.lo, RATE_MAX)
        if self.zero:
            err.args = (f"{err.args[0]}, or 0 (the table's high rate)",)
        return err

    @property
    def shown(self) -> str:
        return (f"{'0 or ' if self.zero else ''}{self.lo}..{RATE_MAX} "
                f"(0x{self.lo:X}..0x{RATE_MAX:X})")


@dataclass(frozen=True)
class Command:
    """One motion command: its name, code, frames and parameters."""

    name: str                      # as `stepramp move --command` takes it
    code: int                      # the parallel command code
    title: str                     # what the manual calls it, in English
    section: str                   # the parallel figure (§8-x, §7-6)
    serial_section: str            # the serial figure (§16-x, §15-5)
    takes: frozenset[str]          # which of PARAMS it takes
    block: Frame                   # the parallel block (no override position)
    serial: Mapping[str, Frame]    # the ASCII payload by how it starts (NOW, AT, evt1, evt2)
    positioned: Frame | None = None  # the parallel block with the override position
    rate: Rate | None = None
    rate_field: str = "rate"       # 82's frames call it high_rate

    @property
    def label(self) -> str:
        return f"{self.name} ({self.code:02X})"

    @property
    def forms(self) -> tuple[Frame, ...]:
        """The parallel blocks, without the override position first."""
        return (self.block,) if self.positioned is None else (self.block, self.positioned)

    @property
    def needs(self) -> tuple[str, ...]:
        """The parameters without a default: pulses, and a rate that cannot be 0."""
        out = ("pulses",) if "pulses" in self.takes else ()
        return out + (("rate",) if self.rate is not None and not self.rate.zero else ())


# --- the frames ---------------------------------------------------------------------
def _head(length: int, code: int) -> tuple[Const, Const, Const]:
    return (Const("header", bytes([HDR_CODE_EXEC])), Const("length", bytes([length])),
            Const("code", bytes([code])))


_OV_TRG = (Bit("ov", 2), Bit("trg", 0, 2))   # mode `x x x x x OV TRG(2)` (§8-1)
_DIR = Bit("dir", 6)                        # `× DIR × …` (§8-3)
_IDX = Bit("idx", 0)                        # `× DIR × × × × × IDX` (§8-10)


def _rate() -> UInt:
    return UInt("rate", 2)


def _position(lo: int = 0) -> UInt:
    # 80/81 print 「設定範囲は 0x0~0xffffffff」, 87/88 「0xa~0xffffffff」
    return UInt("position", 4, lo=lo)


def _scode(code: int) -> Const:
    return Const("code", bytes([code]))


def _sbits(low: int, width: int, *parts: Bit) -> Bits:
    # a serial code `1 0 DIR [IDX] low…`: the direction (and IDX) ride in the code (§16)
    return Bits("code", 1, (Bit("b7", 7, const=1), Bit("b6", 6, const=0), Bit("dir", 5),
                            *parts, Bit("low", 0, width, const=low)))


def _stop(code: int, title: str, serial: tuple[int, int, int, int],
          rate: bool = False, position_lo: int = 0) -> tuple[Frame, Frame, dict[str, Frame]]:
    """80, 81, 87, 88: a short block (OV = 0, or an event), a long one with the override
    position, and four serial codes (at once, at a position, event input 0, 1)."""
    params: tuple[UInt, ...] = (_rate(),) if rate else ()
    n = 2 + 2 * len(params)
    block = Frame(title, (*_head(n, code), Bits("mode", 1, _OV_TRG), *params))
    long = Frame(f"{title} at a position", (*_head(n + 4, code), Bits("mode", 1, _OV_TRG),
                                            *params, _position(position_lo)))
    now, at, evt1, evt2 = serial
    forms = {NOW: Frame(f"serial {title}", (_scode(now), *params)),
             AT: Frame(f"serial {title} at a position", (_scode(at), *params,
                                                          _position(position_lo))),
             "evt1": Frame(f"serial {title} on event input 0", (_scode(evt1), *params)),
             "evt2": Frame(f"serial {title} on event input 1", (_scode(evt2), *params))}
    return block, long, forms


STOP, STOP_AT, _SERIAL_STOPS = _stop(0x80, "immediate stop", (0x80, 0x8B, 0x9B, 0xBB))
SERIAL_STOPS = {**_SERIAL_STOPS, NOW: SERIAL_STOP}  # §16-1's 80: the link's own frame
DECEL_STOP, DECEL_STOP_AT, SERIAL_DECEL_STOPS = _stop(0x81, "decelerate stop",
                                                      (0x81, 0x8C, 0x9C, 0xBC))
CHANGE_SPEED, CHANGE_SPEED_AT, SERIAL_CHANGE_SPEEDS = _stop(
    0x87, "speed change by acceleration", (0x89, 0x8E, 0x9E, 0xBE), rate=True,
    position_lo=0xA)
SET_SPEED, SET_SPEED_AT, SERIAL_SET_SPEEDS = _stop(
    0x88, "immediate speed change", (0x88, 0x8D, 0x9D, 0xBD), rate=True, position_lo=0xA)

# §8-4's figure is not in the text: 82's layout, with §16-4's rate then count.
CONSTANT = Frame("constant-speed move", (
    *_head(0x08, 0x83), Bits("mode", 1, (_DIR, *_OV_TRG)), _rate(), UInt("pulses", 4, lo=1)))
SERIAL_CONSTANT = Frame("serial constant-speed move", (
    _sbits(0b00100, 5), _rate(), UInt("pulses", 4, lo=1)))
STEP = Frame("single step", (*_head(0x02, 0x84), Bits("mode", 1, (_DIR,))))
SERIAL_STEP = Frame("serial single step", (_sbits(0b00010, 5),))
CONTINUOUS = Frame("continuous high speed", (
    *_head(0x04, 0x85), Bits("mode", 1, (_DIR, *_OV_TRG)), _rate()))
SERIAL_CONTINUOUS = Frame("serial continuous high speed", (_sbits(0b00110, 5), _rate()))
CONTINUOUS_CONSTANT = Frame("continuous constant speed", (
    *_head(0x04, 0x86), Bits("mode", 1, (_DIR, *_OV_TRG)), _rate()))
SERIAL_CONTINUOUS_CONSTANT = Frame("serial continuous constant speed", (
    _sbits(0b00101, 5), _rate()))
ORIGIN_SEARCH = Frame("constant-speed origin search", (
    *_head(0x04, 0x10), Bits("mode", 1, (_DIR, _IDX)), _rate()))
SERIAL_ORIGIN_SEARCH = Frame("serial constant-speed origin search", (
    _sbits(0b0111, 4, Bit("idx", 4)), _rate()))
# §8-11's figure is not in the text either: §8-10's layout (the same IDX and DIR).
ORIGIN_RETURN = Frame("high-speed origin return", (
    *_head(0x04, 0x11), Bits("mode", 1, (_DIR, _IDX)), _rate()))
SERIAL_ORIGIN_RETURN = Frame("serial high-speed origin return", (  # REV 1.3's code
    _sbits(0b1010, 4, Bit("idx", 4)), _rate()))
HIGH_SPEED_LIMIT = Frame("high-speed limit setting", (*_head(0x03, 0x05), _rate()))
SERIAL_HIGH_SPEED_LIMIT = Frame("serial high-speed limit setting", (_scode(0x47), _rate()))

_STOPS = frozenset({"override_at", "on"})
_RUNS = frozenset({"rate", "ccw", "on"})
COMMANDS: dict[str, Command] = {c.name: c for c in (
    Command("stop", 0x80, "immediate stop", "§8-1", "§16-1", _STOPS, STOP, SERIAL_STOPS,
            STOP_AT),
    Command("decel-stop", 0x81, "decelerate stop", "§8-2", "§16-2", _STOPS, DECEL_STOP,
            SERIAL_DECEL_STOPS, DECEL_STOP_AT),
    Command("accel", 0x82, "accel/decel move", "§8-3", "§16-3", _RUNS | {"pulses"}, MOVE,
            {NOW: SERIAL_MOVE}, rate=Rate(2, zero=True), rate_field="high_rate"),
    Command("constant", 0x83, "constant-speed move", "§8-4", "§16-4", _RUNS | {"pulses"},
            CONSTANT, {NOW: SERIAL_CONSTANT}, rate=Rate(2, zero=True)),
    Command("step", 0x84, "single step", "§8-5", "§16-5", frozenset({"ccw"}), STEP,
            {NOW: SERIAL_STEP}),
    Command("continuous", 0x85, "continuous high speed", "§8-6", "§16-6", _RUNS,
            CONTINUOUS, {NOW: SERIAL_CONTINUOUS}, rate=Rate(2, zero=True)),
    Command("continuous-constant", 0x86, "continuous constant speed", "§8-7", "§16-7", _RUNS,
            CONTINUOUS_CONSTANT, {NOW: SERIAL_CONTINUOUS_CONSTANT},
            rate=Rate(0xA, zero=True)),
    Command("change-speed", 0x87, "speed change by acceleration", "§8-8", "§16-8",
            _STOPS | {"rate"}, CHANGE_SPEED, SERIAL_CHANGE_SPEEDS, CHANGE_SPEED_AT,
            rate=Rate(2, zero=False)),
    Command("set-speed", 0x88, "immediate speed change", "§8-9", "§16-9", _STOPS | {"rate"},
            SET_SPEED, SERIAL_SET_SPEEDS, SET_SPEED_AT, rate=Rate(2, zero=False)),
    Command("origin-search", 0x10, "constant-speed origin search", "§8-10", "§16-10",
            frozenset({"rate", "ccw", "index"}), ORIGIN_SEARCH, {NOW: SERIAL_ORIGIN_SEARCH},
            rate=Rate(2, zero=False, table="between the table's high rate and the faster of "
                                           "its start and stop rates")),
    Command("origin-return", 0x11, "high-speed origin return", "§8-11", "§16-11",
            frozenset({"rate", "ccw", "index"}), ORIGIN_RETURN, {NOW: SERIAL_ORIGIN_RETURN},
            rate=Rate(2, zero=True)),
    Command("high-speed-limit", 0x05, "high-speed limit setting", "§7-6", "§15-5",
            frozenset({"rate"}), HIGH_SPEED_LIMIT, {NOW: SERIAL_HIGH_SPEED_LIMIT},
            rate=Rate(2, zero=False, table="")),
)}
DEFAULT = "accel"
BY_CODE: dict[int, Command] = {c.code: c for c in COMMANDS.values()}


def _first_bytes(frame: Frame) -> list[int]:
    """Every first byte `frame` decodes (a serial code, with its DIR and IDX bits)."""
    first = frame.fields[0]
    if isinstance(first, Const):
        return [first.value[0]]
    assert isinstance(first, Bits)
    out = []
    for value in range(256):
        try:
            first.unpack_int(value, 0)
        except DecodeError:
            continue
        out.append(value)
    return out


SERIAL_BY_CODE: dict[int, tuple[Command, str]] = {
    code: (c, start) for c in COMMANDS.values() for start, frame in c.serial.items()
    for code in _first_bytes(frame)}


def command_named(name: object) -> Command:
    if not isinstance(name, str) or name not in COMMANDS:
        raise FormatError(f"command: {echo(name)} is not one of {', '.join(COMMANDS)}")
    return COMMANDS[name]


# --- encode -------------------------------------------------------------------------
def encode_command(name: str, *, to: str = "parallel", address: int = 0,
                   **params: Any) -> bytes:
    """The parallel block (or, `to="ascii"`, the ASCII frame to slave `address`) of the
    motion command `name` with `params` (see the module docstring)."""
    command = command_named(name)
    if to not in ("parallel", "ascii"):
        raise FormatError(f"to: {echo(to)} is not 'parallel' or 'ascii'")
    values, start = _values(command, params)
    if to == "parallel":
        if start in EVENTS or start == NOW:
            return command.block.encode(values)
        assert command.positioned is not None  # _values allows AT for these only
        return command.positioned.encode(values)
    address = require_int("address", address, 0, MAX_ADDRESS)
    frame = command.serial.get(start)
    if frame is None:
        raise UnsupportedError(f"{command.label} has no serial form started by "
                               f"{_start_text(start)} ({command.serial_section}: no OV/TRG); "
                               "the parallel bus only")
    return encode_frame("command", address, frame.encode(values))


def _values(command: Command, params: Mapping[str, Any]) -> tuple[dict[str, Any], str]:
    """The frames' field values for `params`, and how the command starts."""
    unknown = [p for p in params if p not in command.takes]
    if unknown:
        raise FormatError(f"{command.label} takes no {unknown[0]} (it takes "
                          f"{', '.join(sorted(command.takes)) or 'no parameter'})")
    missing = [p for p in command.needs if params.get(p) is None]
    if missing:
        raise FormatError(f"{command.label} needs {missing[0]}")
    at, on = params.get("override_at"), params.get("on")
    if at is not None and on is not None:
        raise FormatError(f"{command.label}: give override_at or on, not both")
    if on is not None and on not in EVENTS:
        raise FormatError(f"on: {echo(on)} is not one of {', '.join(EVENTS)}")
    values: dict[str, Any] = {"dir": int(bool(params.get("ccw", False))),
                              "idx": int(bool(params.get("index", False))),
                              "ov": int(at is not None or on is not None),
                              "trg": TRG_POSITION if on is None else EVENTS[on]}
    if at is not None:
        values["position"] = at
    if "pulses" in command.takes:
        values["pulses"] = params["pulses"]
    if command.rate is not None:
        rate = params.get("rate")
        rate = 0 if rate is None else rate
        if isinstance(rate, bool) or not isinstance(rate, int) or not command.rate.allows(rate):
            raise command.rate.error("rate", rate)
        values[command.rate_field] = rate
    return values, (AT if at is not None else on or NOW)


def _start_text(start: str) -> str:
    return {NOW: "at once", AT: "a position (override_at)"}.get(
        start, f"an event ({start})")


# --- decode -------------------------------------------------------------------------
def decode_command(data: bytes) -> dict[str, Any]:
    """The command and parameters of one parallel block or ASCII frame (then with its
    `address`): `{"command": name, **params}`, every parameter the command takes
    (`override_at` and `on` None when it starts at once), so that
    `encode_command(d.pop("command"), **d)` (with `to="ascii"` for a frame) gives the
    bytes back. Anything `encode_command` would not write is a `DecodeError`."""
    data = block_bytes(data)
    if data[:1] and data[0] & 0x80:
        return _decode_serial(data)
    command, frame = parallel_form(data)
    if command is None:
        raise DecodeError(_not_motion(data), byte=min(len(data), 2))
    if data[0] != HDR_CODE_EXEC:
        raise DecodeError(f"{command.label}: header {data[0]:02X}; a motion command is one "
                          "block that executes (header 03)", byte=0)
    if frame is None:
        sizes = " or ".join(f"{length_byte(f):02X}" for f in command.forms)
        raise DecodeError(f"{command.label}: {len(data)} bytes with length byte "
                          f"{data[1]:02X}; its blocks have length {sizes}", byte=1)
    fields = frame.decode(data)
    out = _params(command, fields, _offset(frame, command.rate_field))
    if "on" not in command.takes:
        return out
    ov, trg = fields["ov"], fields["trg"]
    if frame is command.positioned:
        if not ov or trg not in POSITION_TRIGGERS:
            raise DecodeError(f"{command.label}: an override position with OV {ov}, TRG "
                              f"{trg:02b}: the position is read with OV = 1, TRG 00 or 10 "
                              "only", byte=3)
        out["override_at"] = fields["position"]
    elif ov and trg in POSITION_TRIGGERS:
        why = ("its block with the position has length "
               f"{length_byte(command.positioned):02X}" if command.positioned is not None
               else "this command cannot be position-triggered (§11-6: 0x21)")
        raise DecodeError(f"{command.label}: TRG {trg:02b} with override (OV = 1) but no "
                          f"position: {why}", byte=3)
    elif ov:
        out["on"] = next(k for k, v in EVENTS.items() if v == trg)
    elif trg:
        raise DecodeError(f"{command.label}: TRG {trg:02b} without override (OV = 0): "
                          "the chip ignores it and stepramp writes 00", byte=3)
    return out


def _offset(frame: Frame, name: str) -> int:
    """Where field `name` starts in `frame` (its size when it has none)."""
    offset = 0
    for f in frame.fields:
        if f.name == name:
            break
        offset += f.size if isinstance(f, UInt | Const | Bits) else 0
    return offset


def _params(command: Command, fields: Mapping[str, Any], offset: int) -> dict[str, Any]:
    """The parameters in decoded `fields`; a rate the figure refuses is a DecodeError at
    `offset`, where the rate sits (in its block, or its frame's characters)."""
    out: dict[str, Any] = {"command": command.name}
    if "ccw" in command.takes:
        out["ccw"] = bool(fields["dir"])
    if "index" in command.takes:
        out["index"] = bool(fields["idx"])
    if command.rate is not None:
        rate = fields[command.rate_field]
        if not command.rate.allows(rate):
            raise DecodeError(f"{command.label}: rate {rate} is outside "
                              f"{command.rate.shown}", byte=offset)
        out["rate"] = rate
    if "pulses" in command.takes:
        out["pulses"] = fields["pulses"]
    if "override_at" in command.takes:
        out["override_at"] = None
    if "on" in command.takes:
        out["on"] = None
    return out


def _decode_serial(data: bytes) -> dict[str, Any]:
    parsed = decode_frame(data)
    if parsed.kind != "command" or not parsed.payload:
        raise DecodeError(f"a {parsed.kind} frame without a command code, not a command "
                          "(0x90 + address)", byte=0)
    found = serial_form(parsed.payload)
    if found is None:
        raise DecodeError(f"serial code 0x{parsed.payload[0]:02X} is not a motion command",
                          byte=1)
    command, start = found
    frame = command.serial[start]
    try:
        fields = frame.decode(parsed.payload)
    except DecodeError as e:  # payload byte k is sent as the characters at 1 + 2k
        where = None if e.byte is None else 1 + 2 * e.byte
        raise DecodeError(f"{frame.name}: {str(e).partition(': ')[2] or e}",
                          byte=where) from None
    out = {"address": parsed.address,
           **_params(command, fields, 1 + 2 * _offset(frame, command.rate_field))}
    if start == AT:
        out["override_at"] = fields["position"]
    elif start in EVENTS:
        out["on"] = start
    return out


def length_byte(frame: Frame) -> int:
    """The length byte of a parallel motion block (its second field, a constant)."""
    field = frame.fields[1]
    assert isinstance(field, Const) and field.name == "length"
    return field.value[0]


def _not_motion(data: bytes) -> str:
    if len(data) < 3:
        return f"block is {len(data)} byte(s): no command code"
    codes = ", ".join(f"{c:02X}" for c in BY_CODE)
    return (f"header {data[0]:02X}, code {data[2]:02X}: not a motion command block "
            f"(header 03; codes {codes})")


# --- reading what the chip would refuse (profiles/ppmc312/command_rules.py) ---------------------
def parallel_form(block: bytes) -> tuple[Command | None, Frame | None]:
    """The motion command a parallel block names (header 02/03 and its code), and the
    form of it the block's size and length byte fit (None: none does)."""
    if len(block) < 3 or block[0] not in (0x02, HDR_CODE_EXEC):
        return None, None
    command = BY_CODE.get(block[2])
    if command is None:
        return None, None
    if block[0] != HDR_CODE_EXEC:
        return command, None
    return command, next((f for f in command.forms
                          if f.size == len(block) and block[1] == len(block) - 2), None)


def serial_form(payload: bytes) -> tuple[Command, str] | None:
    """The motion command and start an ASCII payload's code names."""
    return SERIAL_BY_CODE.get(payload[0]) if payload else None


_RELAXED: dict[int, Frame] = {}


def read_fields(frame: Frame, data: bytes) -> dict[str, Any]:
    """`data` decoded as `frame`'s wire carries it: every value its bytes hold (no range,
    the × bits ignored); the caller has checked the size and code."""
    relaxed = _RELAXED.get(id(frame))
    if relaxed is None:
        relaxed = _RELAXED[id(frame)] = Frame(frame.name, tuple(_wide(f) for f in frame.fields))
    return relaxed.decode(data)


def _wide(f: Any) -> Any:
    if isinstance(f, UInt):
        return dataclasses.replace(f, lo=0, hi=None)
    if isinstance(f, Bits):
        return dataclasses.replace(f, strict=False, parts=tuple(
            dataclasses.replace(p, const=None) for p in f.parts))
    return f


def ignored_bits(frame: Frame, value: int, name: str = "mode") -> int:
    """The bits of field `name` (a byte) that the figure marks ×: set in `value`."""
    used = 0
    for f in frame.fields:
        if isinstance(f, Bits) and f.name == name:
            for p in f.parts:
                used |= ((1 << p.width) - 1) << p.shift
    return value & ~used & 0xFF


def field_range(frame: Frame, name: str) -> tuple[int, int]:
    """The range a UInt field of `frame` allows."""
    f = next(f for f in frame.fields if isinstance(f, UInt) and f.name == name)
    return f.lo, f.max


__all__ = [
    "COMMANDS",
    "DEFAULT",
    "EVENTS",
    "PARAMS",
    "Command",
    "Rate",
    "command_named",
    "decode_command",
    "encode_command",
    "field_range",
    "ignored_bits",
    "length_byte",
    "parallel_form",
    "read_fields",
    "serial_form",
]

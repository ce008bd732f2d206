"""PPMC-312 ASCII serial mode (manual §12–19, SPEC §1.7).

Frame = control byte (raw) | command code and parameters as ASCII hex |
checksum as two ASCII hex characters. The control byte is
`1 0 type(2) address(4)`. The checksum is the 8-bit sum of the control byte
and every ASCII data character, inverted, bit 7 cleared — computed over the
characters as sent, so the case of the hex digits matters.

Serial command codes differ from the parallel ones: the binary content of
each serial command is described once as a `Frame` below.
"""

from __future__ import annotations

import string
from dataclasses import dataclass
from typing import Any

from ..errors import DecodeError, FormatError, UnsupportedError, echo, require_int
from ..fields import Bit, Bits, Const, Frame, UInt
from .clock import EXTCK_FALLING, Clock
from .frames import block_bytes
from .table import InitTable

# type field (bits 5-4) by direction; data/special only ever come from a slave.
MASTER_KINDS = {"poll": 0, "command": 1}
SLAVE_KINDS = {"busy": 0, "ready": 1, "data": 2, "special": 3}
KINDS = {**MASTER_KINDS, **SLAVE_KINDS}
MAX_ADDRESS = 15

CONTROL = Frame("ASCII control byte", (
    Bits("control", 1, (Bit("one", 7, const=1), Bit("zero", 6, const=0), Bit("type", 4, 2),
                        Bit("address", 0, 4))),
))

# §15-1 serial init: `0000 FO CLK` (the code is the high nibble), start rate,
# high rate, common accel/decel pulses. The CLK table lists 000..110 only.
SERIAL_INIT = Frame("serial init", (
    Bits("mode", 1, (Bit("code", 4, 4, const=0), Bit("fo", 3), Bit("clk", 0, 3, hi=6))),
    UInt("start_rate", 2), UInt("high_rate", 2), UInt("accel_pulses", 3),
))
# §16-3 serial accel/decel move: `1 0 DIR 0 0011`, high rate, pulses.
SERIAL_MOVE = Frame("serial accel/decel move", (
    Bits("code", 1, (Bit("b7", 7, const=1), Bit("b6", 6, const=0), Bit("dir", 5),
                     Bit("low", 0, 5, const=0b00011))),
    UInt("high_rate", 2), UInt("pulses", 4, lo=1),
))

# §19 special replies (B0+a) carry one code byte.
SPECIAL_REPLIES: dict[int, str] = {
    0x23: "held execution started (/RUN)",
    0x42: "parameter error",
    0x43: "state error",
    0x44: "limit error",
    0x46: "alarm",
    0x47: "command error",
    # §15-2/15-3/15-4, §18-7, §19: state reports and other refusals.
    0x20: "interlock released",
    0x21: "override command executed",
    0x22: "event command executed",
    0x24: "encoder range entered",
    0x25: "in-position range entered",
    0x26: "encoder range left",
    0x27: "in-position range left",
    0x28: "general input changed",
    0x48: "event registration failed",
    0x49: "override aborted",
    0x4A: "event aborted",
}

_HEX = set(string.hexdigits.encode())


@dataclass(frozen=True)
class AsciiFrame:
    kind: str
    address: int
    payload: bytes

    @property
    def control(self) -> int:
        return control_byte(self.kind, self.address)


def control_byte(kind: str, address: int) -> int:
    if kind not in KINDS:
        raise FormatError(f"ASCII frame kind: {echo(kind)} is not one of {', '.join(KINDS)}")
    address = require_int("address", address, 0, MAX_ADDRESS)
    return CONTROL.encode(type=KINDS[kind], address=address)[0]


def checksum(control: int, chars: bytes) -> int:
    """8-bit sum of the control byte and the ASCII data characters, inverted, bit 7 cleared."""
    return ~(control + sum(chars)) & 0x7F


def encode_frame(kind: str, address: int, payload: bytes) -> bytes:
    control = control_byte(kind, address)
    chars = bytes(payload).hex().upper().encode("ascii")
    return bytes([control]) + chars + f"{checksum(control, chars):02X}".encode("ascii")


def decode_frame(frame: bytes, *, from_slave: bool = False) -> AsciiFrame:
    """Parse one ASCII frame; `from_slave` names types 00/01 busy/ready, not poll/command."""
    data = block_bytes(frame)
    if len(data) < 3:
        raise DecodeError(f"ASCII frame is {len(data)} byte(s); it needs a control byte and a "
                          "2-character checksum", byte=len(data))
    fields = CONTROL.decode(data[:1])
    chars, sent = data[1:-2], data[-2:]
    if len(chars) % 2:
        raise DecodeError(f"{len(chars)} data characters: not whole bytes (two hex characters "
                          "a byte)", byte=len(data) - 2)
    for offset, ch in enumerate(data[1:], start=1):
        if ch not in _HEX:
            raise DecodeError(f"0x{ch:02X} is not an ASCII hex character", byte=offset)
    want = checksum(data[0], chars)
    got = int(sent.decode("ascii"), 16)
    if got != want:
        raise DecodeError(f"checksum mismatch: expected {want:02X}, got {got:02X}",
                          byte=len(data) - 2)
    names = SLAVE_KINDS if from_slave or fields["type"] >= 2 else MASTER_KINDS
    kind = next(k for k, v in names.items() if v == fields["type"])
    return AsciiFrame(kind, fields["address"], bytes.fromhex(chars.decode("ascii")))


# --- serial commands ------------------------------------------------------------
def encode_serial_init(table: InitTable, address: int) -> bytes:
    """The §15-1 init command frame; LE=1 and EXTCK-falling tables have no serial form."""
    if table.separate:
        raise UnsupportedError("the serial init command has one start rate and one accel/decel "
                               "pulse count: a table with a separate stop rate / decel pulses "
                               "(LE=1) has no serial form; use the parallel bus")
    if table.clock.code == EXTCK_FALLING:
        raise UnsupportedError("the serial init command cannot select the EXTCK falling edge "
                               "(its CLK table stops at 110, rising edge)")
    payload = SERIAL_INIT.encode(fo=int(table.shape == "s_curve"), clk=table.clock.code,
                                 start_rate=table.start_rate, high_rate=table.high_rate,
                                 accel_pulses=table.accel_pulses)
    return encode_frame("command", address, payload)


def decode_serial_init(frame: bytes, *, extck_hz: float | None = None) -> InitTable:
    parsed = _command(frame)
    fields = _decode_payload(SERIAL_INIT, parsed.payload)
    return InitTable(Clock.from_code(fields["clk"], extck_hz),
                     "s_curve" if fields["fo"] else "linear", fields["start_rate"],
                     fields["high_rate"], fields["accel_pulses"])


def encode_serial_move(address: int, pulses: int, *, ccw: bool = False,
                       high_rate: int = 0) -> bytes:
    """The §16-3 accel/decel move frame (high_rate 0 = the table's)."""
    payload = SERIAL_MOVE.encode(dir=int(bool(ccw)), high_rate=high_rate, pulses=pulses)
    return encode_frame("command", address, payload)


def decode_serial_move(frame: bytes) -> dict[str, Any]:
    parsed = _command(frame)
    fields = _decode_payload(SERIAL_MOVE, parsed.payload)
    return {"address": parsed.address, "ccw": bool(fields["dir"]),
            "high_rate": fields["high_rate"], "pulses": fields["pulses"]}


def describe_reply(frame: bytes) -> str:
    """One line for a slave's reply frame (ready, busy, data or special)."""
    parsed = decode_frame(frame, from_slave=True)
    if parsed.kind == "special":
        if len(parsed.payload) != 1:
            raise DecodeError(f"a special reply carries one code byte, got "
                              f"{len(parsed.payload)}", byte=1)
        code = parsed.payload[0]
        text = SPECIAL_REPLIES.get(code, "unknown special reply")
        return f"slave {parsed.address}: {text} (0x{code:02X})"
    if parsed.kind == "data":
        return f"slave {parsed.address}: data {parsed.payload.hex(' ').upper()}"
    return f"slave {parsed.address}: {parsed.kind}"


def _command(frame: bytes) -> AsciiFrame:
    parsed = decode_frame(frame)
    if parsed.kind != "command":
        raise DecodeError(f"control byte 0x{parsed.control:02X} is a {parsed.kind} frame, "
                          "not a command (0x90 + address)", byte=0)
    if not parsed.payload:
        raise DecodeError("the command frame carries no command code", byte=1)
    return parsed


def _decode_payload(frame: Frame, payload: bytes) -> dict[str, Any]:
    # Payload byte k is sent as the characters at frame offsets 1 + 2k, 2 + 2k.
    try:
        return frame.decode(payload)
    except DecodeError as e:
        where = None if e.byte is None else 1 + 2 * e.byte
        raise DecodeError(f"{frame.name}: " + _strip_byte(str(e)), byte=where) from None


def _strip_byte(message: str) -> str:
    head, sep, tail = message.partition(": ")
    return tail if sep and head.startswith("byte ") else message


# --- the other serial commands and their replies (link master, serial chip) -------
# Each §16–18 command the link sends, and each data reply it reads, described once.
SERIAL_STOP = Frame("serial immediate stop", (Const("code", b"\x80"),))              # §16-1
SERIAL_POSITION_READ = Frame("serial position read", (                                # §18-1
    Bits("code", 1, (Bit("high", 6, 2, const=0b01), Bit("encoder", 5),
                     Bit("low", 0, 5, const=0b00010))),
))
SERIAL_POSITION_SET = Frame("serial position set", (                                  # §18-2
    Bits("code", 1, (Bit("high", 6, 2, const=0b01), Bit("encoder", 5),
                     Bit("low", 0, 5, const=0b00011))),
    UInt("position", 4),  # 0…0xFFFFFFFF (§10-3 「設定範囲は 0x0~0xffffffff」)
))
SERIAL_END_STATUS_READ = Frame("serial end status read", (Const("code", b"\x40"),))   # §18-6
SERIAL_ERROR_CODE_READ = Frame("serial error code read", (Const("code", b"\x41"),))   # §18-10
SERIAL_ERROR_COUNT_READ = Frame("serial error count read", (Const("code", b"\x4C"),))  # §18-11

# Replies. The position is the 32-bit counter, 0…0xFFFFFFFF (§2-1.6, §10-3): CCW counts
# down and wraps from 0 to 0xFFFFFFFF. Laid out as the parallel answer 42's parameters
# (§18-1 is §10-2's): `counter` 00 pulse, 01 encoder; the reader checks it (replies.py
# names any other value as none of the manual's, the link refuses all but 00).
POSITION_REPLY = Frame("position reply", (UInt("counter", 1), UInt("position", 4)))
POSITION_MODULUS = 1 << 32  # the counter's 32 bits: positions are taken modulo it
END_CODE_REPLY = Frame("end code reply", (UInt("end_code", 1),))       # §18-6, §19-14
ERROR_CODE_REPLY = Frame("error code reply", (UInt("error_code", 1),))  # §18-10
ERROR_COUNT_REPLY = Frame("error count reply", (UInt("error_count", 2),))  # §18-11
SPECIAL_REPLY = Frame("special reply", (UInt("code", 1),))              # §19 (B0 + a)

# §18-6 / §19-14: why pulse output stopped.
END_CODES: dict[int, str] = {
    0x31: "stopped by the alarm input",
    0x32: "stopped at the origin input",
    0x33: "stopped by a limit",
    0x34: "decelerated to a stop by the high-speed limit",
    0x36: "stopped by the decelerate-stop command",
    0x37: "stopped by the immediate-stop command",
    0x38: "normal stop at the commanded position",
    0x39: "stopped at once (stop rate = start rate: no deceleration possible)",
}
# §18-10: the error code register.
ERROR_CODES: dict[int, str] = {
    0x00: "no error",
    0x42: "parameter error",
    0x43: "state error",
    0x44: "limit error",
    0x47: "undefined command",
    0x48: "size error",
    0x49: "registration failed",
}

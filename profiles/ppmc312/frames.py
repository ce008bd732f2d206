"""PPMC-312 parallel-bus blocks, each described once as a `profiles.fields.Frame`.

The same description encodes and decodes. Frames here describe the *wire*:
a field accepts every value its bytes can carry (a rate of 1, a stage count
of 200 …); what breaks a chip rule is the emulator's and `verify`'s business,
so a bad table still round-trips and gets its chip error code.

Block = header | length | [code] | parameters (SPEC §1.5, manual §5-5):
the length byte counts every byte after itself, so a block is `2 + length`
bytes and at most 32 on the bus.

Block size: REV 1.3 of the manual (§5-5) limits a block to the code and parameters
[0]–[12], i.e. 14 bytes after the length byte (a parameter-only block the same); the
§24 change list shows REV 1.1 allowed [0]–[28] (30 bytes). §11-6's error 0x15 (a
length byte ≥ 31) still stands, so 15–30 is a size only older chips are documented
to take. stepramp writes REV 1.3 blocks (every revision accepts them); the frames
still carry up to 30, so an older file decodes and `check` names §5-5 instead of
failing to read it.
"""

from __future__ import annotations

from typing import Any

from ..errors import DecodeError
from ..fields import Array, Bit, Bits, Const, Frame, UInt

# Command headers (manual §5-5.1).
HDR_CODE_MORE = 0x02
HDR_CODE_EXEC = 0x03

MAX_BLOCK_BYTES = 32  # WAR = 0x20 − size must not go negative
MAX_BLOCK_DATA = MAX_BLOCK_BYTES - 2  # header and length byte: REV 1.1's [0]–[28] + code
REV13_BLOCK_DATA = 14  # REV 1.3 §5-5: the code slot and parameters [0]–[12]
REFUSED_LENGTH = 31  # error 0x15 / response F6: a length byte ≥ 31 is refused

CODE_INIT = 0x00
CODE_FREE_CURVE = 0x01
CODE_TABLE_READ = 0x41
CODE_ACCEL_MOVE = 0x82

RESP_PARAM_ERROR = 0xF0
RESP_STATE_ERROR = 0xF1
RESP_SIZE_ERROR = 0xF6

# Free-curve per-block status (manual §7-2).
STATUS_RATES, STATUS_ACCEL, STATUS_DECEL, STATUS_DONE = 0x00, 0x01, 0x02, 0x0F

RATE_SIZE = 2
PULSES_SIZE = 3


def _clk() -> Bit:
    return Bit("clk", 0, 3)


# --- init command (code 00), manual §7-1 -----------------------------------------
INIT_COMMON = Frame("init (LE=0)", (
    Const("header", bytes([HDR_CODE_EXEC])), Const("length", b"\x09"),
    Const("code", bytes([CODE_INIT])),
    Bits("mode", 1, (Bit("le", 4, const=0), Bit("fo", 3), _clk())),
    UInt("start_rate", 2), UInt("high_rate", 2), UInt("accel_pulses", 3),
))
INIT_SEPARATE = Frame("init (LE=1)", (
    Const("header", bytes([HDR_CODE_EXEC])), Const("length", b"\x0e"),
    Const("code", bytes([CODE_INIT])),
    Bits("mode", 1, (Bit("le", 4, const=1), Bit("fo", 3), _clk())),
    UInt("start_rate", 2), UInt("stop_rate", 2), UInt("high_rate", 2),
    UInt("accel_pulses", 3), UInt("decel_pulses", 3),
))

# --- free-curve command block (code 01), manual §7-2 -----------------------------
# A stage count of 0 cannot be uploaded at all (there would be no last block to
# execute), so the wire field starts at 1; 2..127 is the chip's rule (error 11).
FC_COMMAND_COMMON = Frame("free-curve command (LE=0)", (
    Const("header", bytes([HDR_CODE_MORE])), Const("length", b"\x03"),
    Const("code", bytes([CODE_FREE_CURVE])),
    Bits("mode", 1, (Bit("le", 4, const=0), _clk())),
    UInt("accel_stages", 1, lo=1),
))
FC_COMMAND_SEPARATE = Frame("free-curve command (LE=1)", (
    Const("header", bytes([HDR_CODE_MORE])), Const("length", b"\x04"),
    Const("code", bytes([CODE_FREE_CURVE])),
    Bits("mode", 1, (Bit("le", 4, const=1), _clk())),
    UInt("accel_stages", 1, lo=1), UInt("decel_stages", 1, lo=1),
))


def _param_block(name: str, item: UInt) -> Frame:
    # header 00 (more follows) / 01 (last: execute); length = data bytes.
    return Frame(name, (
        Bits("header", 1, (Bit("last", 0),)),
        UInt("length", 1, lo=1, hi=MAX_BLOCK_DATA),
        Array("items", item, min_items=1),
    ))


RATE_BLOCK = _param_block("rate block", UInt("rate", RATE_SIZE))
ACCEL_BLOCK = _param_block("accel pulse block", UInt("accel_pulses", PULSES_SIZE))
DECEL_BLOCK = _param_block("decel pulse block", UInt("decel_pulses", PULSES_SIZE))

# --- accel/decel move (code 82), manual §8-3 --------------------------------------
MOVE = Frame("accel/decel move", (
    Const("header", bytes([HDR_CODE_EXEC])), Const("length", b"\x08"),
    Const("code", bytes([CODE_ACCEL_MOVE])),
    Bits("mode", 1, (Bit("dir", 6), Bit("ov", 2), Bit("trg", 0, 2))),
    UInt("high_rate", 2), UInt("pulses", 4, lo=1),
))
# TRG 00 and 10 are "設定不可（パラメータ異常）" when OV=1 (ignored when OV=0).
OVERRIDE_TRIGGERS = (1, 3)

# --- responses (manual §5-7.1 header: 0 0 CMR RESP(2) 0 PAL NEXT) ----------------
RESPONSE_HEADER = Bits("header", 1, (Bit("cmr", 5), Bit("resp", 3, 2), Bit("pal", 1),
                                     Bit("next", 0)))
ANSWER = bytes([0x03])  # CMR 0 (answers a command), RESP 00 (bus), PAL 1, NEXT 1

FC_PROGRESS = Frame("free-curve response (in progress)", (
    Const("header", ANSWER), Const("length", b"\x03"), Const("code", bytes([CODE_FREE_CURVE])),
    UInt("status", 1, hi=STATUS_DECEL), UInt("remaining", 1),
))
FC_DONE = Frame("free-curve response (done)", (
    Const("header", ANSWER), Const("length", b"\x08"), Const("code", bytes([CODE_FREE_CURVE])),
    Const("status", bytes([STATUS_DONE])), UInt("accel_total", 3), UInt("decel_total", 3),
))
INIT_DONE = Frame("init response", (
    Const("header", ANSWER), Const("length", b"\x01"), Const("code", bytes([CODE_INIT])),
))
# F0 + error status + the command code it refers to (manual §11-6).
PARAM_ERROR = Frame("parameter-error response", (
    Const("header", ANSWER), Const("length", b"\x03"), Const("code", bytes([RESP_PARAM_ERROR])),
    UInt("error", 1), UInt("command", 1),
))
# F1 + status + state bits (RUN ALM FIX ACC NOR INI) + command code (manual §11-7).
STATE_ERROR = Frame("state-error response", (
    Const("header", ANSWER), Const("length", b"\x04"), Const("code", bytes([RESP_STATE_ERROR])),
    UInt("status", 1, hi=2), UInt("state", 1, hi=0x3F), UInt("command", 1),
))
# F6 + the refused length byte (manual §11-5).
SIZE_ERROR = Frame("size-error response", (
    Const("header", ANSWER), Const("length", b"\x02"), Const("code", bytes([RESP_SIZE_ERROR])),
    UInt("length_written", 1, lo=REFUSED_LENGTH),
))
ALARM = Frame("alarm response", (Const("header", b"\x23"), Const("length", b"\x02"),
                                 Const("code", b"\xf4"), UInt("status", 1, hi=3)))

# --- table read (code 41), manual §10-1 -------------------------------------------
TABLE_READ_COMMAND = Frame("table read", (
    Const("header", bytes([HDR_CODE_EXEC])), Const("length", b"\x01"),
    Const("code", bytes([CODE_TABLE_READ])),
))
TABLE_READ_FIRST = Frame("table-read response (first block)", (
    Const("header", b"\x02"),  # PAL 1, NEXT 0: items follow
    Const("length", b"\x0a"), Const("code", bytes([CODE_TABLE_READ])),
    UInt("rate_stages", 1), UInt("accel_stages", 1), UInt("decel_stages", 1),
    UInt("accel_total", 3), UInt("decel_total", 3),
))
ITEM_KIND_RATES, ITEM_KIND_ACCEL, ITEM_KIND_DECEL = 0x01, 0x02, 0x03
# The largest read block: RAR gives 0x40 − size, so a block is at most 64 bytes.
MAX_READ_LENGTH = 0x40 - 2


def _item_block(name: str, kind: int, item: UInt) -> Frame:
    # PAL 0 (no response code): the manual's figure shows a kind byte 01/02/03
    # where the code would be; NEXT marks the last block of the whole answer.
    return Frame(name, (
        Bits("header", 1, (Bit("next", 0),)),
        UInt("length", 1, lo=1 + item.size, hi=MAX_READ_LENGTH),
        Const("kind", bytes([kind])),
        Array("items", item, min_items=1),
    ))


READ_RATES = _item_block("table-read rate block", ITEM_KIND_RATES, UInt("rate", RATE_SIZE))
READ_ACCEL = _item_block("table-read accel block", ITEM_KIND_ACCEL,
                         UInt("accel_pulses", PULSES_SIZE))
READ_DECEL = _item_block("table-read decel block", ITEM_KIND_DECEL,
                         UInt("decel_pulses", PULSES_SIZE))
# Items per read block: the manual's PAL=0 block carries parameters [0]..[13]
# (14 bytes after the length): the kind byte and 13 data bytes.
READ_DATA_BYTES = 13

# Chip parameter-error texts (manual §11-6), for one-line messages.
PARAM_ERRORS: dict[int, str] = {
    0x00: "init: wrong data length",
    0x01: "init: a rate is out of range",  # 「パルスレートのデータが範囲外です」: rates only
    0x02: "init: the slower of start/stop rate is within 127 of the high rate",
    0x03: "init: start or stop rate is not above the high rate",
    0x04: "init: start/stop too close to the high rate, no table can be built",
    0x05: "init: the built table has a stage of ≤ 2 pulses",
    0x10: "free curve: bad command header",
    0x11: "free curve: stage count outside 2..127",
    0x15: "free curve: a length byte of 31 or more",
    0x16: "free curve: more data than the section being written needs",
    0x17: "free curve: bad parameter-block header",
    0x18: "free curve: a stage rate ≤ 1",
    0x19: "free curve: a stage pulse count ≤ 1",
    0x1A: "free curve: accel or decel pulse total above 0xFFFFF",
    0x20: "move: a pulse rate outside the table's range",
    0x21: "override: a position trigger on a command that cannot start at a position",
    0x23: "move: a wrong pulse count",
    0x24: "event read: no event registered under that number",
    0x25: "event setting: a wrong length byte",
    0x26: "in-position setting: a range of 0",
    0x27: "encoder setting: a range of 0",
}


def block_bytes(block: Any, index: int | None = None) -> bytes:
    """`block` as bytes, refusing anything that is not a byte string."""
    if isinstance(block, bytes | bytearray | memoryview):
        return bytes(block)
    raise DecodeError(f"expected a block of bytes, got {type(block).__name__}", block=index)


def block_list(blocks: Any) -> list[bytes]:
    """A list of blocks, each a byte string (a bare bytes object is refused: ambiguous)."""
    if isinstance(blocks, bytes | bytearray | memoryview | str) or not isinstance(
            blocks, list | tuple):
        raise DecodeError(f"expected a list of blocks, got {type(blocks).__name__}")
    if _BYTES_ONLY.issuperset(map(type, blocks)):
        return list(blocks)
    return [block_bytes(b, i) for i, b in enumerate(blocks)]


_BYTES_ONLY = frozenset((bytes,))


def check_length_byte(block: bytes, index: int | None, *, hi: int = MAX_BLOCK_DATA) -> int:
    """The length byte, checked against the bytes actually in the block."""
    if len(block) < 2:
        raise DecodeError(f"block is {len(block)} byte(s): no length byte", block=index,
                          byte=len(block))
    length = block[1]
    if length > hi:
        raise DecodeError(f"length byte 0x{length:02X} is above the limit 0x{hi:02X}",
                          block=index, byte=1)
    if len(block) != 2 + length:
        raise DecodeError(f"length byte says {length} bytes follow but the block carries "
                          f"{len(block) - 2}", block=index, byte=1)
    return length

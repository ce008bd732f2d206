"""PPMC-312 uploads: tables ⇄ parallel blocks / ASCII frames, and the bus writes.

Free-curve upload (manual §7-2): a command block `02 len 01 mode accel
[decel]`, then parameter-only blocks `00|01 len data…` carrying, in order,
the stage rates (2 bytes each), the accel pulse counts (3 bytes) and, with
LE=1, the decel pulse counts (3 bytes), all fastest stage first. Entries are
never split across blocks, a block never mixes two sections, and the last
block's header is 01 (execute). There is one rate entry per stage of the
longer side; each side uses the fastest stages it counts.

The codec is about the wire: it refuses only what the bytes cannot carry.
Chip rules (2..127 stages, rates ≥ 2 …) are checked by the emulator and
`verify`, with the chip's error codes.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from ..errors import (
    DecodeError,
    FieldChoiceError,
    FieldRangeError,
    FormatError,
    UnsupportedError,
    echo,
    require_int,
)
from ..fields import Frame
from . import ascii as serial
from .clock import Clock
from .frames import (
    ACCEL_BLOCK,
    CODE_FREE_CURVE,
    CODE_INIT,
    DECEL_BLOCK,
    FC_COMMAND_COMMON,
    FC_COMMAND_SEPARATE,
    HDR_CODE_EXEC,
    HDR_CODE_MORE,
    INIT_COMMON,
    INIT_SEPARATE,
    ITEM_KIND_ACCEL,
    ITEM_KIND_DECEL,
    ITEM_KIND_RATES,
    MAX_BLOCK_BYTES,
    MAX_BLOCK_DATA,
    MAX_READ_LENGTH,
    MOVE,
    OVERRIDE_TRIGGERS,
    PULSES_SIZE,
    RATE_BLOCK,
    READ_ACCEL,
    READ_DATA_BYTES,
    READ_DECEL,
    READ_RATES,
    REV13_BLOCK_DATA,
    TABLE_READ_FIRST,
    block_bytes,
    block_list,
    check_length_byte,
)
from .table import FreeCurveTable, InitTable, Table

MIN_MAX_DATA = PULSES_SIZE  # a block must hold at least one 3-byte pulse count


# --- free curve -----------------------------------------------------------------
def _sections(table: FreeCurveTable) -> list[tuple[str, Frame, tuple[int, ...]]]:
    out = [("rate", RATE_BLOCK, table.rates), ("accel", ACCEL_BLOCK, table.accel_pulses)]
    if table.decel_pulses is not None:
        out.append(("decel", DECEL_BLOCK, table.decel_pulses))
    return out


def encode_free_curve(table: FreeCurveTable, *, max_data: int = REV13_BLOCK_DATA
                      ) -> list[bytes]:
    """Command block then parameter blocks of at most `max_data` data bytes each (default
    REV 1.3's 14; 3..30)."""
    if not isinstance(table, FreeCurveTable):
        raise FormatError(f"encode_free_curve needs a free-curve table, got "
                          f"{type(table).__name__}")
    max_data = require_int("max_data", max_data, MIN_MAX_DATA, MAX_BLOCK_DATA)
    mode = {"clk": table.clock.code}
    if table.separate:
        command = FC_COMMAND_SEPARATE.encode(mode, accel_stages=len(table.accel_pulses),
                                             decel_stages=len(table.decel))
    else:
        command = FC_COMMAND_COMMON.encode(mode, accel_stages=len(table.accel_pulses))
    fast = _encode_sections(table, max_data)
    if fast is not None:
        return [command, *fast]
    # A value the wire cannot carry: encode block by block for the error naming it.
    chunks: list[tuple[Frame, tuple[int, ...]]] = []
    for _name, frame, items in _sections(table):
        per_block = max_data // frame.item.size
        chunks += [(frame, items[i:i + per_block]) for i in range(0, len(items), per_block)]
    blocks = [command]
    for k, (frame, items) in enumerate(chunks):
        blocks.append(frame.encode(last=int(k == len(chunks) - 1),
                                   length=len(items) * frame.item.size, items=list(items)))
    return blocks


def _encode_sections(table: FreeCurveTable, max_data: int) -> list[bytes] | None:
    """The parameter blocks, each section's items packed at once and cut into blocks
    (the frames' own packers and prefixes); None if an item does not fit its field."""
    out: list[bytes] = []
    last_frame = RATE_BLOCK
    for _name, frame, items in _sections(table):
        data = frame.pack_items(items)
        if data is None:
            return None
        step = max_data // frame.item.size * frame.item.size
        whole = len(data) - len(data) % step
        head = _prefix(frame, 0, step)
        out += [head + data[i:i + step] for i in range(0, whole, step)]
        if whole < len(data):
            out.append(_prefix(frame, 0, len(data) - whole) + data[whole:])
        last_frame = frame
    if out:  # the last block executes: header 01
        n = len(_prefix(last_frame, 0, 1))
        out[-1] = _prefix(last_frame, 1, len(out[-1]) - n) + out[-1][n:]
    return out


# Encoded block prefixes (header, length) and decoded ones, per frame: few distinct
# values, so each is built by its frame once.
_PREFIXES: dict[tuple[int, int, int], bytes] = {}
_READ_PREFIXES: dict[int, dict[bytes, dict[str, Any] | None]] = {}


def _prefix(frame: Frame, last: int, length: int) -> bytes:
    key = (id(frame), last, length)
    prefix = _PREFIXES.get(key)
    if prefix is None:
        prefix = _PREFIXES[key] = frame.encode_fixed({"last": last, "length": length})
    return prefix


def decode_free_curve(blocks: Sequence[bytes], *, extck_hz: float | None = None) -> FreeCurveTable:
    """The table a free-curve upload carries; anything else is a `DecodeError`."""
    blocks = block_list(blocks)
    if not blocks:
        raise DecodeError("empty upload: no blocks")
    command = blocks[0]
    if len(command) < 2:
        raise DecodeError(f"the command block is {len(command)} byte(s)", block=0,
                          byte=len(command))
    frames = {0x03: FC_COMMAND_COMMON, 0x04: FC_COMMAND_SEPARATE}
    if command[1] not in frames:
        raise DecodeError(f"length byte 0x{command[1]:02X}: a free-curve command block has "
                          "03 (LE=0) or 04 (LE=1)", block=0, byte=1)
    head = frames[command[1]].decode(command, block=0)
    clock = Clock.from_code(head["clk"], extck_hz)
    accel_n = head["accel_stages"]
    decel_n = head.get("decel_stages")
    due = [("rate", RATE_BLOCK, max(accel_n, decel_n or 0)), ("accel", ACCEL_BLOCK, accel_n)]
    if decel_n is not None:
        due.append(("decel", DECEL_BLOCK, decel_n))
    fast = _decode_sections(blocks, due)
    if fast is not None:
        return FreeCurveTable.from_wire(clock, fast[0], fast[1],
                                        fast[2] if decel_n is not None else None)
    # Something is wrong: walk the blocks one by one for the error that names it.
    got: dict[str, list[int]] = {name: [] for name, _f, _n in due}
    section = 0
    for index in range(1, len(blocks)):
        block = blocks[index]
        if section == len(due):
            raise DecodeError("data after the last block (the table was already complete)",
                              block=index, byte=0)
        name, frame, count = due[section]
        _param_header(block, index)
        length = check_length_byte(block, index)
        if length == 0:
            raise DecodeError("a parameter block with no data", block=index, byte=1)
        size = frame.item.size
        if length % size:
            raise DecodeError(f"{length} data bytes is not a whole number of {size}-byte "
                              f"{name} entries: an entry is split across blocks",
                              block=index, byte=2 + length - length % size)
        remaining = count - len(got[name])
        if length // size > remaining:
            raise DecodeError(f"{length // size} {name} entries, but only {remaining} more are "
                              "due (a block never mixes sections)", block=index,
                              byte=2 + remaining * size)
        fields = frame.decode(block, block=index)
        got[name] += fields["items"]
        while section < len(due) and len(got[due[section][0]]) == due[section][2]:
            section += 1
        complete = section == len(due)
        if fields["last"] and not complete:
            missing = due[section][2] - len(got[due[section][0]])
            raise DecodeError(f"header 01 (last block) but {missing} {due[section][0]} "
                              "entries are still missing", block=index, byte=0)
        if complete and not fields["last"]:
            raise DecodeError("this block completes the table but its header is 00 (more "
                              "follows), expected 01", block=index, byte=0)
    if section < len(due):
        name, _frame, count = due[section]
        raise DecodeError(f"the upload ends with {count - len(got[name])} {name} entries "
                          "missing (no last block with header 01)", block=len(blocks), byte=0)
    return FreeCurveTable(clock, tuple(got["rate"]), tuple(got["accel"]),
                          tuple(got["decel"]) if decel_n is not None else None)


def _decode_sections(blocks: list[bytes], due: list[tuple[str, Frame, int]]
                     ) -> tuple[tuple[int, ...], ...] | None:
    """Every section's entries from well-formed parameter blocks (each block's header and
    length read by its frame, each section's entries unpacked at once), or None if
    anything is out of place."""
    out: list[tuple[int, ...]] = []
    index, n_blocks = 1, len(blocks)
    for number, (_name, frame, count) in enumerate(due):
        size = frame.item.size
        known = _READ_PREFIXES.setdefault(id(frame), {})
        n = len(_prefix(frame, 0, 1))
        need = count * size
        parts = []
        while need > 0:
            if index >= n_blocks:
                return None
            block = blocks[index]
            head = block[:n]
            fixed = known.get(head)
            if fixed is None:
                fixed = frame.decode_fixed(head)
                if fixed is None:
                    return None
                known[head] = fixed
            length = fixed["length"]
            if len(block) != n + length or length % size or length > need:
                return None
            need -= length
            if fixed["last"] != (need == 0 and number == len(due) - 1):
                return None
            parts.append(block[n:])
            index += 1
        items = frame.unpack_items(b"".join(parts))
        if items is None:
            return None
        out.append(tuple(items))
    if index != n_blocks:
        return None
    return tuple(out)


def _param_header(block: bytes, index: int) -> None:
    if not block:
        raise DecodeError("empty block", block=index, byte=0)
    if block[0] not in (0x00, 0x01):
        raise DecodeError(f"header 0x{block[0]:02X}: a parameter block has 00 (more follows) "
                          "or 01 (last)", block=index, byte=0)


# --- init -------------------------------------------------------------------------
def encode_init(table: InitTable) -> bytes:
    if not isinstance(table, InitTable):
        raise FormatError(f"encode_init needs an init table, got {type(table).__name__}")
    values: dict[str, Any] = {"fo": int(table.shape == "s_curve"), "clk": table.clock.code,
                              "start_rate": table.start_rate, "high_rate": table.high_rate,
                              "accel_pulses": table.accel_pulses}
    if table.separate:
        return INIT_SEPARATE.encode(values, stop_rate=table.stop_rate,
                                    decel_pulses=table.decel_pulses)
    return INIT_COMMON.encode(values)


def decode_init(block: bytes, *, extck_hz: float | None = None) -> InitTable:
    data = block_bytes(block)
    if len(data) < 2:
        raise DecodeError(f"the init block is {len(data)} byte(s)", byte=len(data))
    frames = {0x09: INIT_COMMON, 0x0E: INIT_SEPARATE}
    if data[1] not in frames:
        raise DecodeError(f"length byte 0x{data[1]:02X}: an init block has 09 (LE=0) or "
                          "0E (LE=1)", byte=1)
    f = frames[data[1]].decode(data)
    return InitTable(Clock.from_code(f["clk"], extck_hz), "s_curve" if f["fo"] else "linear",
                     f["start_rate"], f["high_rate"], f["accel_pulses"], f.get("stop_rate"),
                     f.get("decel_pulses"))


# --- accel/decel move --------------------------------------------------------------
def encode_move(pulses: int, *, ccw: bool = False, high_rate: int = 0, override: bool = False,
                trigger: int = 0) -> bytes:
    """Command 82: `03 08 82 mode rate_hi rate_lo p3 p2 p1 p0` (high_rate 0 = the table's)."""
    if override and trigger not in OVERRIDE_TRIGGERS:
        raise FieldChoiceError("trigger (with override)", trigger, OVERRIDE_TRIGGERS)
    return MOVE.encode(dir=int(bool(ccw)), ov=int(bool(override)), trg=trigger,
                       high_rate=high_rate, pulses=pulses)


def decode_move(block: bytes) -> dict[str, Any]:
    f = MOVE.decode(block_bytes(block))
    if f["ov"] and f["trg"] not in OVERRIDE_TRIGGERS:
        raise DecodeError(f"TRG {f['trg']:02b} with override: the manual allows 01 or 11 only",
                          byte=3)
    return {"pulses": f["pulses"], "ccw": bool(f["dir"]), "high_rate": f["high_rate"],
            "override": bool(f["ov"]), "trigger": f["trg"]}


# --- tables in general ------------------------------------------------------------
def encode_table(table: Table, *, to: str = "parallel", address: int = 0,
                 max_data: int = REV13_BLOCK_DATA) -> list[bytes]:
    """Blocks for the parallel bus, or one ASCII command frame (init tables only)."""
    if to not in ("parallel", "ascii"):
        raise FormatError(f"to: {echo(to)} is not 'parallel' or 'ascii'")
    if isinstance(table, FreeCurveTable):
        if to == "ascii":
            raise UnsupportedError("the free-curve command has no serial (ASCII) form; upload "
                                   "a free-curve table over the parallel bus")
        return encode_free_curve(table, max_data=max_data)
    if isinstance(table, InitTable):
        if to == "ascii":
            return [serial.encode_serial_init(table, address)]
        return [encode_init(table)]
    raise FormatError(f"not a PPMC-312 table: {type(table).__name__}")


def decode_upload(blocks: Sequence[bytes], *, extck_hz: float | None = None) -> Table:
    """A parallel free-curve upload, a parallel init block or an ASCII init frame."""
    blocks = block_list(blocks)
    if not blocks:
        raise DecodeError("empty upload: no blocks")
    first = blocks[0]
    if not first:
        raise DecodeError("empty block", block=0, byte=0)
    if first[0] & 0x80:
        if len(blocks) > 1:
            raise DecodeError("an ASCII init upload is one frame; more follow", block=1,
                              byte=0)
        return _with_block(lambda: serial.decode_serial_init(first, extck_hz=extck_hz))
    if len(first) < 3:
        raise DecodeError(f"block is {len(first)} byte(s): no command code", block=0,
                          byte=len(first))
    code = first[2]
    if first[0] == HDR_CODE_MORE and code == CODE_FREE_CURVE:
        return decode_free_curve(blocks, extck_hz=extck_hz)
    if first[0] == HDR_CODE_EXEC and code == CODE_INIT:
        if len(blocks) > 1:
            raise DecodeError("an init upload is one block; more follow", block=1, byte=0)
        return _with_block(lambda: decode_init(first, extck_hz=extck_hz))
    raise DecodeError(f"header {first[0]:02X} with command code {code:02X} is not a table "
                      "upload (02 …01 free curve or 03 …00 init expected)", block=0, byte=0)


def _with_block(decode: Callable[[], InitTable]) -> InitTable:
    try:
        return decode()
    except DecodeError as e:
        message = str(e).partition(": ")[2] if e.byte is not None else str(e)
        raise DecodeError(message, block=0, byte=e.byte) from None


# --- table read (41) ----------------------------------------------------------------
def encode_table_read_response(table: FreeCurveTable) -> list[bytes]:
    """The chip's answer to table read (41) for a free-curve table."""
    if not isinstance(table, FreeCurveTable):
        raise UnsupportedError("table read: only a free-curve table's stages are known; an "
                               "init table's stages come from the chip's undocumented builder")
    # LE=0 reads back with a decel stage count of 0 and no decel blocks, so the
    # reader can tell a common table from two equal lists; the decel total is
    # what the chip runs (the accel counts).
    first = TABLE_READ_FIRST.encode(
        rate_stages=len(table.rates), accel_stages=len(table.accel_pulses),
        decel_stages=0 if table.decel_pulses is None else len(table.decel_pulses),
        accel_total=table.accel_total, decel_total=table.decel_total)
    parts: list[tuple[Frame, tuple[int, ...]]] = [(READ_RATES, table.rates),
                                                  (READ_ACCEL, table.accel_pulses)]
    if table.decel_pulses is not None:
        parts.append((READ_DECEL, table.decel_pulses))
    chunks: list[tuple[Frame, tuple[int, ...], int]] = []
    for frame, items in parts:
        size = frame.item.size
        per = READ_DATA_BYTES // size
        chunks += [(frame, items[i:i + per], size) for i in range(0, len(items), per)]
    out = [first]
    for k, (frame, items, size) in enumerate(chunks):
        out.append(frame.encode(next=int(k == len(chunks) - 1), length=1 + len(items) * size,
                                items=list(items)))
    return out


def decode_table_read(blocks: Sequence[bytes], *, clock: Clock) -> FreeCurveTable:
    """The free-curve table in a table-read (41) answer; totals are cross-checked."""
    blocks = block_list(blocks)
    if not blocks:
        raise DecodeError("empty table-read answer: no blocks")
    head = TABLE_READ_FIRST.decode(blocks[0], block=0)
    accel_n, decel_n = head["accel_stages"], head["decel_stages"]
    rate_n = max(accel_n, decel_n)
    if head["rate_stages"] != rate_n:
        raise DecodeError(f"{head['rate_stages']} rate stages, expected {rate_n} (one per stage "
                          "of the longer side)", block=0, byte=3)
    if accel_n == 0:
        raise DecodeError("accel stage count 0: a table has at least one stage", block=0,
                          byte=4)
    due = [("rate", READ_RATES, ITEM_KIND_RATES, rate_n),
           ("accel", READ_ACCEL, ITEM_KIND_ACCEL, accel_n)]
    if decel_n:
        due.append(("decel", READ_DECEL, ITEM_KIND_DECEL, decel_n))
    got: dict[str, list[int]] = {d[0]: [] for d in due}
    section = 0
    for index in range(1, len(blocks)):
        block = blocks[index]
        if section == len(due):
            raise DecodeError("data after the last block", block=index, byte=0)
        name, frame, kind, count = due[section]
        check_length_byte(block, index, hi=MAX_READ_LENGTH)
        if len(block) >= 3 and block[0] in (0, 1) and block[2] != kind:
            raise DecodeError(f"item kind 0x{block[2]:02X}, expected 0x{kind:02X} ({name} "
                              "entries)", block=index, byte=2)
        fields = frame.decode(block, block=index)
        remaining = count - len(got[name])
        if len(fields["items"]) > remaining:
            raise DecodeError(f"{len(fields['items'])} {name} entries, only {remaining} more "
                              "are due", block=index, byte=3)
        got[name] += fields["items"]
        while section < len(due) and len(got[due[section][0]]) == due[section][3]:
            section += 1
        if fields["next"] != (section == len(due)):
            raise DecodeError("NEXT bit " + ("set before the last block" if fields["next"]
                                             else "missing on the last block"),
                              block=index, byte=0)
    if section < len(due):
        raise DecodeError(f"the answer ends with {due[section][0]} entries missing",
                          block=len(blocks), byte=0)
    table = FreeCurveTable(clock, tuple(got["rate"]), tuple(got["accel"]),
                           tuple(got["decel"]) if decel_n else None)
    for side, total, offset in (("accel", table.accel_total, 6),
                                ("decel", table.decel_total, 9)):
        if head[f"{side}_total"] != total:
            raise DecodeError(f"{side} total {head[side + '_total']} but the stages sum to "
                              f"{total}", block=0, byte=offset)
    return table


# --- bus writes ----------------------------------------------------------------------
def bus_writes(block: bytes) -> list[tuple[str, int]]:
    """Host register writes for one block (manual §5-6): WCR, WAR, then DWR last byte first."""
    data = block_bytes(block)
    if not 1 <= len(data) <= MAX_BLOCK_BYTES:
        raise FieldRangeError("block size (bytes)", len(data), 1, MAX_BLOCK_BYTES)
    if data[0] & 0x80:
        raise UnsupportedError("an ASCII frame goes over the serial line, not the parallel bus")
    return ([("WCR", 0x20), ("WAR", 0x20 - len(data))]
            + [("DWR", b) for b in reversed(data)])


__all__ = [
    "bus_writes",
    "decode_free_curve",
    "decode_init",
    "decode_move",
    "decode_table_read",
    "decode_upload",
    "encode_free_curve",
    "encode_init",
    "encode_move",
    "encode_table",
    "encode_table_read_response",
]

"""A PPMC-312 acceptance emulator for table uploads (init 00, free curve 01).

`ChipEmulator.feed(block)` answers one parallel-bus block the way the chip
does: the free-curve per-block status (00/01/02 + stages still to send, 0F +
totals when done), `03 01 00` for a good init, or an error response — F0 +
parameter-error code, F1 (a header out of sequence), F6 (a length byte ≥ 31).
The chip sees a block's size from WAR, so the emulator compares the length
byte with the bytes written.

When each rule is checked (our reading; see docs/manual-notes.md):
per block, as the data arrives — length (15), header (10/17), section fit
(16), rate ≤ 1 (18), pulses ≤ 1 (19), running total > 0xFFFFF (1A) — and the
stage counts (11) on the command block. Init errors 04/05 need the chip's
table builder and are left to `verify`.

The answer handshake (manual §7-2 「各ブロック書込毎にレスポンスが報告されます」): the
chip answers every block, and a host compares each answer with the one expected
before it writes the next block. `expected_answers(blocks)` is that list for a
table upload the chip accepts (what every upload file carries, `formats`);
`chip_answers(blocks)` the answer to every block of any table upload, refusals
included (what a file's answers are checked against).

The alarm state (manual §5-4, §11-9, 表 2-1 「異常発生 … ほとんどの命令を受け付け
られません」): `raise_alarm(status)` puts the chip in it (the bus emulator,
`profiles.ppmc312.bus`, does when an answer overwrites an unread one: F4 01); an
upload in progress is dropped, and until `reset()` every block is refused
unexecuted with a state error, F1 status 00 and the ALM state bit (what 表 2-2's ×
means for every command in 異常発生).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from ..errors import DecodeError
from .clock import Clock
from .frames import (
    CODE_FREE_CURVE,
    CODE_INIT,
    FC_DONE,
    FC_PROGRESS,
    HDR_CODE_EXEC,
    HDR_CODE_MORE,
    INIT_COMMON,
    INIT_DONE,
    INIT_SEPARATE,
    MAX_BLOCK_BYTES,
    PARAM_ERROR,
    PARAM_ERRORS,
    PULSES_SIZE,
    RATE_SIZE,
    REFUSED_LENGTH,
    RESP_PARAM_ERROR,
    RESP_SIZE_ERROR,
    RESP_STATE_ERROR,
    SIZE_ERROR,
    STATE_ERROR,
    STATUS_ACCEL,
    STATUS_DECEL,
    STATUS_RATES,
    block_bytes,
    block_list,
)
from .init_model import init_parameter_problem
from .limits import SIDE_TOTAL_MAX, STAGE_PULSES_MIN, STAGES_MAX, STAGES_MIN
from .table import InitTable

STATE_INI, STATE_NOR = 0x01, 0x02  # F1 state bits: INI initial, NOR normal (a table)
STATE_ALM = 0x10  # F1 state bit: ALM, the alarm state (manual §11-7)
ALARM_DOUBLE_WRITE = 0x01  # F4 status: 命令の多重書込み (an unread command answer overwritten)


@dataclass
class UploadVerdict:
    ok: bool
    responses: list[bytes]
    error_code: int | None = None  # the F0 parameter-error status (or F1 status / F6 length)
    block: int | None = None  # the block that drew the error
    accel_total: int | None = None
    decel_total: int | None = None
    message: str = ""
    response_code: int | None = None  # F0, F1 or F6 when refused


@dataclass
class _Upload:
    separate: bool
    counts: list[int]  # rates, accel, [decel]
    got: list[int] = field(default_factory=lambda: [0, 0, 0])
    totals: list[int] = field(default_factory=lambda: [0, 0])
    section: int = 0


class _Refused(Exception):
    def __init__(self, response: bytes, message: str, *, keeps_table: bool = False) -> None:
        super().__init__(message)
        self.response = response
        self.keeps_table = keeps_table


class ChipEmulator:
    """Feed blocks in order; each call returns the chip's response block."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Power-on state: no table, nothing half-uploaded."""
        self.table_kind: str | None = None
        self.accel_total: int | None = None
        self.decel_total: int | None = None
        self._upload: _Upload | None = None
        self.last_message = ""
        self.alarm: int | None = None  # the F4 status while in the alarm state

    def raise_alarm(self, status: int) -> None:
        """Enter the alarm state (F4 `status`, manual §11-9): pulse output stops, an
        upload in progress is dropped; every block is refused until `reset()`."""
        self.alarm = status
        self._upload = None
        self.last_message = f"alarm F4 {status:02X}"

    @property
    def busy(self) -> bool:
        """A free-curve upload has started and still expects data."""
        return self._upload is not None

    def feed(self, block: bytes) -> bytes:
        data = block_bytes(block)
        if not data:
            raise DecodeError("empty block: nothing was written")
        if len(data) > MAX_BLOCK_BYTES:
            raise DecodeError(f"block is {len(data)} bytes; the bus takes at most "
                              f"{MAX_BLOCK_BYTES} (WAR = 0x20 − size)", byte=MAX_BLOCK_BYTES)
        if self.alarm is not None:
            command = data[2] if data[0] in (HDR_CODE_MORE, HDR_CODE_EXEC) and len(data) > 2 \
                else 0
            self.last_message = (f"state error: the chip is in the alarm state (F4 "
                                 f"{self.alarm:02X}) and executes no block until a reset")
            return self._state_error(0, command)
        try:
            if self._upload is not None:
                return self._param_block(data)
            return self._command_block(data)
        except _Refused as refused:
            # A refused table-setting command leaves the chip without a table
            # (manual §7-1: the old table is destroyed, back to the initial state);
            # state and size errors change no state (manual §11-5, §11-7).
            if not refused.keeps_table:
                self.table_kind = None
                self.accel_total = self.decel_total = None
            self._upload = None
            self.last_message = str(refused)
            return refused.response

    # --- command blocks ---------------------------------------------------------
    def _command_block(self, data: bytes) -> bytes:
        if data[0] not in (HDR_CODE_MORE, HDR_CODE_EXEC) or len(data) < 3:
            command = data[2] if len(data) >= 3 else 0
            raise _Refused(self._state_error(1, command),
                           f"state error: header 0x{data[0]:02X} / {len(data)} byte(s) where "
                           "a command block (02/03 len code …) was expected", keeps_table=True)
        length, code = data[1], data[2]
        if code not in (CODE_INIT, CODE_FREE_CURVE):
            raise DecodeError(f"command code 0x{code:02X} is not modelled (the emulator "
                              "models table setup: 00 init, 01 free curve)", byte=2)
        if length >= REFUSED_LENGTH:
            if code == CODE_FREE_CURVE:
                raise self._param(0x15, code, f"length byte 0x{length:02X}")
            raise _Refused(SIZE_ERROR.encode(length_written=length),
                           f"size error: length byte 0x{length:02X} ≥ 31", keeps_table=True)
        if code == CODE_INIT:
            return self._init(data)
        return self._free_curve_command(data)

    def _init(self, data: bytes) -> bytes:
        separate = bool(data[3] & 0x10) if len(data) > 3 else False
        want = INIT_SEPARATE.size if separate else INIT_COMMON.size
        if data[0] != HDR_CODE_EXEC or len(data) != want or data[1] != len(data) - 2:
            raise self._param(0x00, CODE_INIT, f"{len(data)}-byte init block, header "
                              f"0x{data[0]:02X}, length byte 0x{data[1]:02X} (LE={int(separate)}"
                              f" needs one {want}-byte 03 block)")
        # The chip ignores the x bits of the mode byte: clear them before parsing.
        clean = data[:3] + bytes([data[3] & 0x1F]) + data[4:]
        f = (INIT_SEPARATE if separate else INIT_COMMON).decode(clean)
        # The rate rules (codes 01–04) live in one place, shared with profiles.ppmc312.chip_rules.
        # Pulse counts outside 0x10..0xFFFFF have no documented code: the emulator
        # does not invent one, and verify reports them (init-pulses-field).
        # (The clock does not enter the rate rules; EXTCK's frequency is not in the bytes.)
        table = InitTable(Clock.internal("8MHz"), "linear", f["start_rate"], f["high_rate"],
                          f["accel_pulses"], f.get("stop_rate"), f.get("decel_pulses"))
        problem = init_parameter_problem(table)
        if problem is not None:
            raise self._param(problem[0], CODE_INIT, problem[1])
        self.table_kind = "init"
        self.accel_total = self.decel_total = None  # the chip's builder decides the stages
        self.last_message = "init accepted"
        return INIT_DONE.encode()

    def _free_curve_command(self, data: bytes) -> bytes:
        separate = bool(data[3] & 0x10) if len(data) > 3 else False
        want_length = 4 if separate else 3
        if data[0] != HDR_CODE_MORE or data[1] != want_length or len(data) != 2 + want_length:
            raise self._param(0x10, CODE_FREE_CURVE,
                              f"command block {data.hex(' ').upper()} (expected 02 "
                              f"{want_length:02X} 01 mode … for LE={int(separate)})")
        accel_n = data[4]
        decel_n = data[5] if separate else accel_n
        for side, n in (("accel", accel_n), ("decel", decel_n)):
            if not STAGES_MIN <= n <= STAGES_MAX:
                raise self._param(0x11, CODE_FREE_CURVE, f"{side} stage count {n}")
        counts = [max(accel_n, decel_n), accel_n] + ([decel_n] if separate else [])
        self._upload = _Upload(separate, counts)
        self.table_kind = None
        return FC_PROGRESS.encode(status=STATUS_RATES, remaining=counts[0])

    # --- parameter blocks ---------------------------------------------------------
    def _param_block(self, data: bytes) -> bytes:
        up = self._upload
        assert up is not None
        if len(data) >= 2 and data[1] >= REFUSED_LENGTH:
            raise self._param(0x15, CODE_FREE_CURVE, f"length byte 0x{data[1]:02X}")
        if data[0] not in (0x00, 0x01) or len(data) < 2 or data[1] != len(data) - 2:
            raise self._param(0x17, CODE_FREE_CURVE, f"parameter block header "
                              f"{data[:2].hex(' ').upper()} for {len(data)} bytes written")
        payload = data[2:]
        sizes = [RATE_SIZE, PULSES_SIZE, PULSES_SIZE]
        if payload:
            section = up.section
            size = sizes[section]
            left = up.counts[section] - up.got[section]
            if len(payload) % size or len(payload) // size > left:
                raise self._param(0x16, CODE_FREE_CURVE,
                                  f"{len(payload)} data bytes for {left} {_NAMES[section]} "
                                  f"entries of {size} bytes still due")
            for k in range(0, len(payload), size):
                value = int.from_bytes(payload[k:k + size], "big")
                stage = up.got[section] + k // size
                if section == 0 and value <= 1:
                    raise self._param(0x18, CODE_FREE_CURVE, f"rate {value} at stage {stage}")
                if section > 0:
                    if value < STAGE_PULSES_MIN:
                        raise self._param(0x19, CODE_FREE_CURVE, f"{_NAMES[section]} pulses "
                                          f"{value} at stage {stage}")
                    up.totals[section - 1] += value
                    if up.totals[section - 1] > SIDE_TOTAL_MAX:
                        raise self._param(0x1A, CODE_FREE_CURVE,
                                          f"{_NAMES[section]} total passes 0xFFFFF at stage "
                                          f"{stage}")
            up.got[section] += len(payload) // size
            while up.section < len(up.counts) and up.got[up.section] == up.counts[up.section]:
                up.section += 1
        complete = up.section == len(up.counts)
        if complete != (data[0] == 0x01):
            raise self._param(0x17, CODE_FREE_CURVE,
                              "header 01 (execute) before all data" if data[0]
                              else "header 00 on the block that completes the table")
        if not complete:
            return FC_PROGRESS.encode(status=(STATUS_RATES, STATUS_ACCEL, STATUS_DECEL)[
                up.section], remaining=up.counts[up.section] - up.got[up.section])
        self._upload = None
        accel_total = up.totals[0]
        # LE=0: the decel side runs the accel counts, so its total is the same.
        decel_total = up.totals[1] if up.separate else accel_total
        self.table_kind = "free_curve"
        self.accel_total, self.decel_total = accel_total, decel_total
        self.last_message = (f"free curve accepted: accel total {accel_total}, decel total "
                             f"{decel_total}")
        return FC_DONE.encode(accel_total=accel_total, decel_total=decel_total)

    # --- responses -----------------------------------------------------------------
    def _param(self, code: int, command: int, detail: str) -> _Refused:
        return _Refused(PARAM_ERROR.encode(error=code, command=command),
                        f"parameter error 0x{code:02X} ({PARAM_ERRORS[code]}): {detail}")

    def _state_error(self, status: int, command: int) -> bytes:
        state = (STATE_NOR if self.table_kind else STATE_INI) | (
            STATE_ALM if self.alarm is not None else 0)
        return STATE_ERROR.encode(status=status, state=state, command=command)


_NAMES = ("rate", "accel", "decel")


def accept_upload(blocks: Sequence[bytes], emulator: ChipEmulator | None = None) -> UploadVerdict:
    """Feed a whole upload from power-on; stop at the first refusal."""
    chip = emulator if emulator is not None else ChipEmulator()
    chip.reset()
    items = block_list(blocks)
    if not items:
        return UploadVerdict(False, [], message="empty upload: nothing was sent")
    responses: list[bytes] = []
    for index, block in enumerate(items):
        try:
            response = chip.feed(block)
        except DecodeError as e:
            message = str(e).partition(": ")[2] if e.byte is not None else str(e)
            raise DecodeError(message, block=index, byte=e.byte) from None
        responses.append(response)
        kind = response[2]
        if kind in (RESP_PARAM_ERROR, RESP_STATE_ERROR, RESP_SIZE_ERROR):
            code = response[3]
            return UploadVerdict(False, responses, code, index, message=f"block {index}: "
                           f"{chip.last_message}", response_code=kind)
    if chip.busy:
        return UploadVerdict(False, responses, None, len(items),
                       message="the upload ends before the last block (header 01): the chip "
                               "is still waiting for data")
    return UploadVerdict(True, responses, None, None, chip.accel_total, chip.decel_total,
                   chip.last_message)


def is_table_upload(blocks: Sequence[bytes]) -> bool:
    """Parallel blocks starting with a table-setting command (02/03 … 00 init or 01 free
    curve): what the emulator answers. Moves, table-read captures and ASCII frames are not."""
    items = block_list(blocks)
    return bool(items) and len(items[0]) > 2 and items[0][0] in (HDR_CODE_MORE, HDR_CODE_EXEC) \
        and items[0][2] in (CODE_INIT, CODE_FREE_CURVE)


def chip_answers(blocks: Sequence[bytes]) -> list[bytes] | None:
    """The chip's answer to every block of a table upload, from power-on, each read before
    the next block is written, refusals included (after a refusal the chip answers what
    follows as it would: a parameter block out of sequence draws F1); None when the blocks
    are not a table upload the emulator models (`is_table_upload`, or a later block with
    a command it does not model)."""
    if not is_table_upload(blocks):
        return None
    chip = ChipEmulator()
    try:
        return [chip.feed(block) for block in block_list(blocks)]
    except DecodeError:
        return None


def expected_answers(blocks: Sequence[bytes]) -> list[bytes] | None:
    """The answer a host expects to each block of a table upload the chip accepts, header
    first as the blocks (manual §7-2: progress `03 03 01 status remaining`, `03 08 01 0F`
    and the totals after the last block; `03 01 00` for an init block); None for anything
    else (a move, a table-read capture, ASCII frames, an upload the chip refuses)."""
    if not is_table_upload(blocks):
        return None
    try:
        verdict = accept_upload(blocks)
    except DecodeError:
        return None
    return verdict.responses if verdict.ok else None

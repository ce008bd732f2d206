"""Chip rules for the PPMC-312 commands stepramp writes besides table uploads: the
accel/decel move (82) as a parallel block (manual §8-3) or an ASCII frame (§16-3).

The bytes are read field by field, without the codec's own range checks, so a value the
chip refuses is a finding with the chip's parameter-error code (§11-6), never unusable
input:
- 0x23 "動作パルス数が間違ってます": a move of 0 pulses (the field is 1..0xFFFFFFFF);
- 0x20 "パルスレートの設定が範囲外です": a high-rate override of 1 (every table's rates are
  ≥ 2, and the override must lie within the table's rates: which table the chip holds
  is not in the file, so only what no table allows is an error here);
- TRG 00 or 10 with OV = 1: "設定不可（パラメータ異常）" (a parameter error; the manual
  names no code for it);
- TRG set with OV = 0: ignored by the chip ("通常は 00 を設定してください": a warning), and
  the bits the manual marks × (mode bits 7, 5, 4, 3): ignored (a warning);
- a block whose header, length byte or size is not the move's `03 08 82 …` (10 bytes).
"""

from __future__ import annotations

from profiles.errors import DecodeError

from .findings import Finding

MOVE_CODE = 0x82
MOVE_BLOCK = bytes([0x03, 0x08, MOVE_CODE])   # header (execute), length 8, code
SERIAL_MOVE_CODES = (0x83, 0xA3)              # `1 0 DIR 0 0011`: CW, CCW
IGNORED_MODE_BITS = 0b1011_1000               # × in the manual's mode byte (bits 7, 5, 4, 3)


def is_move_block(block: bytes) -> bool:
    """Whether a parallel block is an accel/decel move command (code 82)."""
    return len(block) >= 3 and block[2] == MOVE_CODE and block[0] in (0x02, 0x03)


def move_block_findings(block: bytes, index: int) -> list[Finding]:
    """The chip's rules for one parallel move block (see the module docstring)."""
    where = f"block {index}: move (82)"
    if block[:3] != MOVE_BLOCK or len(block) != 2 + block[1]:
        return [Finding("error", "move-block",
                        f"{where}: {block.hex(' ').upper()} is not the 10-byte `03 08 82 mode "
                        "rate(2) pulses(4)`: the chip refuses it (header 03 executes, the "
                        "length byte counts the code and 7 parameters)")]
    mode, high_rate, pulses = block[3], int.from_bytes(block[4:6], "big"), \
        int.from_bytes(block[6:10], "big")
    out = _pulses_and_rate(where, pulses, high_rate)
    ov, trg = bool(mode & 0x04), mode & 0x03
    if ov and trg in (0b00, 0b10):
        out.append(Finding("error", "move-trigger",
                           f"{where}: TRG {trg:02b} with override (OV = 1) is not allowed "
                           "(設定不可, a parameter error): TRG 01 (event input 1) or 11 "
                           "(event input 2)"))
    elif not ov and trg:
        out.append(Finding("warning", "move-trigger-ignored",
                           f"{where}: TRG {trg:02b} without override (OV = 0): the chip "
                           "ignores it (the manual asks for 00); set OV to wait for the "
                           "event input"))
    if mode & IGNORED_MODE_BITS:
        out.append(Finding("warning", "move-mode-bits",
                           f"{where}: mode byte 0x{mode:02X} sets bits the chip ignores "
                           f"(0x{mode & IGNORED_MODE_BITS:02X}; stepramp writes 0)"))
    return out


def serial_move_findings(payload: bytes, index: int) -> list[Finding]:
    """The chip's rules for one ASCII move frame's payload (code, high rate, pulses)."""
    where = f"frame {index}: move"
    if len(payload) != 7:
        return [Finding("error", "move-block",
                        f"{where}: {len(payload)} payload bytes, the serial move has 7 "
                        "(code, high rate (2), pulses (4)): the slave refuses it")]
    return _pulses_and_rate(where, int.from_bytes(payload[3:7], "big"),
                            int.from_bytes(payload[1:3], "big"))


def _pulses_and_rate(where: str, pulses: int, high_rate: int) -> list[Finding]:
    out = []
    if pulses == 0:
        out.append(Finding("error", "move-pulses",
                           f"{where}: 0 pulses: a move runs 1..0xFFFFFFFF pulses", 0x23))
    if high_rate == 1:
        out.append(Finding("error", "move-high-rate",
                           f"{where}: high-rate override 1: no table has a rate ≤ 1 (0 runs "
                           "the table's own top, else a rate within the table's)", 0x20))
    return out


def describe_move(pulses: int, ccw: bool, high_rate: int, start: str) -> str:
    """One line: what a move command asks of the chip."""
    rate = "the table's top rate" if high_rate == 0 else f"high-rate override {high_rate}"
    return f"move: {pulses} pulses {'CCW' if ccw else 'CW'} at {rate}, {start}"


def move_notes(blocks: list[bytes]) -> list[str]:
    """What each well-formed parallel move asks, and what a move file cannot say by
    itself: an override rate must lie within the table the chip holds (0x20 otherwise),
    which the file does not carry."""
    moves = [b for b in blocks if b[:3] == MOVE_BLOCK and len(b) == 10]
    out = []
    for b in moves:
        ov, trg = bool(b[3] & 0x04), b[3] & 0x03
        start = ("at once" if not ov else
                 f"held until event input {1 if trg == 1 else 2} goes low (OV, TRG {trg:02b})"
                 if trg in (0b01, 0b11) else f"with override but TRG {trg:02b} (refused)")
        out.append(describe_move(int.from_bytes(b[6:10], "big"), bool(b[3] & 0x40),
                                 int.from_bytes(b[4:6], "big"), start))
    rates = sorted({int.from_bytes(b[4:6], "big") for b in moves} - {0, 1})
    if rates:
        out.append(f"high-rate override {', '.join(map(str, rates))}: the chip refuses it "
                   "(0x20) unless it lies within the rates of the table it holds; check "
                   "that table")
    return out


def serial_move_notes(payloads: list[bytes]) -> list[str]:
    """What each well-formed ASCII move frame asks."""
    return [describe_move(int.from_bytes(p[3:7], "big"), p[0] == SERIAL_MOVE_CODES[1],
                          int.from_bytes(p[1:3], "big"), "at once (serial: no override)")
            for p in payloads if len(p) == 7]


def frame_payload(frame: bytes, index: int) -> bytes:
    """An ASCII command frame's payload (the control byte and checksum checked)."""
    from profiles.ppmc312.ascii import decode_frame

    try:
        parsed = decode_frame(frame)
    except DecodeError as e:
        raise DecodeError(f"frame {index}: {e}") from None
    if parsed.kind != "command" or not parsed.payload:
        raise DecodeError(f"frame {index}: a {parsed.kind} frame, not a command")
    return parsed.payload

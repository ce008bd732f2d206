"""Chip rules for the PPMC-312 commands stepramp writes besides table uploads: every motion
command (stop 80 … high-speed origin return 11, the high-speed limit 05; manual §8, §7-6)
as a parallel block or an ASCII frame (§16, §15-5), looked up in the one registry
(`profiles.ppmc312.motion.COMMANDS`).

The bytes are read field by field without the codec's own range checks
(`motion.read_fields`), so a value the chip refuses is a finding with the chip's
parameter-error code (§11-6), never unusable input:
- 0x23 「動作パルス数が間違ってます」: a move of 0 pulses (82, 83: 1..0xFFFFFFFF);
- 0x20 「パルスレートの設定が範囲外です」: a rate no table allows (1; 0 where the manual does
  not make 0 the table's high rate; below 0xA on 86, whose figure prints 0xa~0xffff).
  Whether any other rate lies within the rates of the table the chip holds is not in the
  file: a note says what it depends on, never a guess;
- 0x21 「オーバーライドでパルス位置指定できない命令を使用した」: TRG 00 or 10 (a position
  trigger) with OV = 1 on a command whose figure has no position (82, 83, 85, 86: there
  「設定不可（パラメータ異常）」);
- an override position the figure refuses (below 0xA on 87/88), or a position trigger on
  80/81/87/88 whose block carries no position: errors without a code (§11-6 names none);
- TRG set with OV = 0, a position the chip does not use, the bits the figures mark ×:
  ignored by the chip (warnings);
- a block whose header, length byte or size is none of the command's forms.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from profiles.errors import DecodeError
from profiles.findings import Finding

if TYPE_CHECKING:
    from profiles.fields import Frame
    from profiles.ppmc312.motion import Command


def is_move_block(block: bytes) -> bool:
    """Whether a parallel block is a motion command (header 02/03 and a motion code)."""
    from profiles.ppmc312.motion import parallel_form

    return parallel_form(block)[0] is not None


def is_serial_move(payload: bytes) -> bool:
    """Whether an ASCII command frame's payload is a motion command (by its code)."""
    from profiles.ppmc312.motion import serial_form

    return serial_form(payload) is not None


def layout(frame: Frame) -> str:
    """A frame's bytes as the figures draw them: `03 06 80 mode position(4)`."""
    from profiles.fields import Array, Const

    words = []
    for f in frame.fields:
        if isinstance(f, Const):
            words.append(f.value.hex(" ").upper())
        elif not isinstance(f, Array):
            words.append(f.name if f.size == 1 else f"{f.name}({f.size})")
    return " ".join(words)


def move_block_findings(block: bytes, index: int) -> list[Finding]:
    """The chip's rules for one parallel motion block (see the module docstring)."""
    from profiles.ppmc312.motion import parallel_form, read_fields

    command, frame = parallel_form(block)
    assert command is not None
    where = f"block {index}: {command.label}"
    if frame is None:
        forms = " or ".join(f"`{layout(f)}`" for f in command.forms)
        return [Finding("error", "move-block",
                        f"{where}: {block.hex(' ').upper()} is not {forms} ({command.section}): "
                        "the chip refuses it (header 03 executes, the length byte counts the "
                        "code and the parameters)")]
    fields = read_fields(frame, block)
    out = _value_findings(command, fields, where)
    if "ov" in fields:
        out += _trigger_findings(command, frame, fields, where)
    if "mode" in {f.name for f in frame.fields}:
        out += _mode_findings(frame, block[3], where)
    return out


def serial_move_findings(payload: bytes, index: int) -> list[Finding]:
    """The chip's rules for one ASCII motion frame's payload (code and parameters)."""
    from profiles.ppmc312.motion import read_fields, serial_form

    found = serial_form(payload)
    assert found is not None
    command, start = found
    frame = command.serial[start]
    where = f"frame {index}: {command.label}"
    if len(payload) != frame.size:
        return [Finding("error", "move-block",
                        f"{where}: {len(payload)} payload bytes, its serial form "
                        f"{payload[0]:02X} has {frame.size} (`{layout(frame)}`, "
                        f"{command.serial_section}): the slave refuses it")]
    fields = read_fields(frame, payload)
    out = _value_findings(command, fields, where)
    if "position" in fields:
        out += _position_findings(command, frame, fields["position"], where)
    return out


def _value_findings(command: Command, fields: dict[str, Any], where: str) -> list[Finding]:
    out = []
    if fields.get("pulses") == 0:
        out.append(Finding("error", "move-pulses",
                           f"{where}: 0 pulses: a move runs 1..0xFFFFFFFF pulses", 0x23))
    rate = command.rate
    if rate is None or rate.allows(fields[command.rate_field]):
        return out
    value = fields[command.rate_field]
    why = ("no table has a rate ≤ 1" if value == 1 else
           f"{command.section} gives 0 no meaning here (it is not the table's high rate)"
           if value == 0 else f"{command.section} prints 設定範囲は 0x{rate.lo:x}~0xffff")
    if command.rate_field == "high_rate":
        out.append(Finding("error", "move-high-rate",
                           f"{where}: high-rate override {value}: {why} (0 runs the table's "
                           "own top, else a rate within the table's)", 0x20))
    else:
        out.append(Finding("error", "move-rate",
                           f"{where}: rate {value}: {why}; the figure allows {rate.shown}, "
                           "within the table's rates", 0x20))
    return out


def _trigger_findings(command: Command, frame: Frame, fields: dict[str, Any],
                      where: str) -> list[Finding]:
    from profiles.ppmc312.motion import POSITION_TRIGGERS

    ov, trg = fields["ov"], fields["trg"]
    if ov and trg in POSITION_TRIGGERS:
        if command.positioned is None:
            return [Finding("error", "move-trigger",
                            f"{where}: TRG {trg:02b} with override (OV = 1): this command "
                            "cannot be position-triggered (設定不可（パラメータ異常）; §11-6 "
                            "0x21); TRG 01 (event input 1) or 11 (event input 2)", 0x21)]
        if frame is not command.positioned:
            return [Finding("error", "move-position",
                            f"{where}: a position trigger (OV = 1, TRG {trg:02b}) but no "
                            f"position: the block that carries it is `{layout(command.positioned)}`"
                            f" ({command.section})")]
        return _position_findings(command, frame, fields["position"], where)
    out = []
    if frame is command.positioned:
        out.append(Finding("warning", "move-position-ignored",
                           f"{where}: override position {fields['position']} with OV {ov}, "
                           f"TRG {trg:02b}: the chip triggers on it only with OV = 1, TRG 00 "
                           "or 10 (this block acts at once or on its event)"))
    if not ov and trg:
        out.append(Finding("warning", "move-trigger-ignored",
                           f"{where}: TRG {trg:02b} without override (OV = 0): the chip "
                           "ignores it (the manual asks for 00); set OV to wait for the "
                           "event input"))
    return out


def _position_findings(command: Command, frame: Frame, position: int,
                       where: str) -> list[Finding]:
    from profiles.ppmc312.motion import field_range

    lo, _hi = field_range(frame, "position")
    if position >= lo:
        return []
    return [Finding("error", "move-position",
                    f"{where}: override position {position}: {command.section} prints "
                    f"設定範囲は 0x{lo:x}~0xffffffff (§11-6 names no code for it)")]


def _mode_findings(frame: Frame, mode: int, where: str) -> list[Finding]:
    from profiles.ppmc312.motion import ignored_bits

    extra = ignored_bits(frame, mode)
    if not extra:
        return []
    return [Finding("warning", "move-mode-bits",
                    f"{where}: mode byte 0x{mode:02X} sets bits the chip ignores "
                    f"(0x{extra:02X}; stepramp writes 0)")]


# --- notes: what each command asks, and what the file alone cannot say ----------------
def describe_move(pulses: int, ccw: bool, high_rate: int, start: str) -> str:
    """One line: what an accel/decel move (82) asks of the chip."""
    rate = "the table's top rate" if high_rate == 0 else f"high-rate override {high_rate}"
    return f"move: {pulses} pulses {'CCW' if ccw else 'CW'} at {rate}, {start}"


def _describe(command: Command, fields: dict[str, Any], start: str) -> str:
    if command.rate_field == "high_rate":
        return describe_move(fields["pulses"], bool(fields["dir"]), fields["high_rate"], start)
    words = [f"{fields['pulses']} pulses"] if "pulses" in fields else []
    if "ccw" in command.takes:
        words.append("CCW" if fields["dir"] else "CW")
    if "index" in command.takes:
        words.append("on /ORG and /INDEX" if fields["idx"] else "on /ORG")
    if command.rate is not None:
        rate = fields[command.rate_field]
        words.append("at the table's high rate" if rate == 0 and command.rate.zero
                     else f"at rate {rate}")
    if "on" in command.takes:
        return f"{command.label}: {' '.join(words)}{', ' if words else ''}{start}"
    return f"{command.label}: {' '.join(words)}"


def _start(command: Command, fields: dict[str, Any]) -> str:
    from profiles.ppmc312.motion import POSITION_TRIGGERS

    ov, trg = fields.get("ov", 0), fields.get("trg", 0)
    if not ov:
        return "at once"
    if trg in POSITION_TRIGGERS and "position" in fields:
        return (f"when the position counter reaches {fields['position']} (OV, TRG "
                f"{trg:02b})")
    if trg in (0b01, 0b11):
        return f"held until event input {1 if trg == 1 else 2} goes low (OV, TRG {trg:02b})"
    missing = " and no position" if command.positioned is not None else ""
    return f"with override but TRG {trg:02b}{missing} (refused)"


def move_notes(blocks: list[bytes]) -> list[str]:
    """What each well-formed parallel motion block asks, and what a command file cannot
    say by itself: whether a rate lies within the table the chip holds (0x20 otherwise)."""
    from profiles.ppmc312.motion import parallel_form, read_fields

    out = []
    rates: dict[str, set[int]] = {}
    for block in blocks:
        command, frame = parallel_form(block)
        if command is None or frame is None:
            continue
        fields = read_fields(frame, block)
        out.append(_describe(command, fields, _start(command, fields)))
        _collect_rate(command, fields, rates)
    return out + _rate_notes(rates)


def serial_move_notes(payloads: list[bytes]) -> list[str]:
    """What each well-formed ASCII motion frame asks."""
    from profiles.ppmc312.motion import AT, EVENTS, read_fields, serial_form

    out = []
    rates: dict[str, set[int]] = {}
    for payload in payloads:
        found = serial_form(payload)
        if found is None or len(payload) != found[0].serial[found[1]].size:
            continue
        command, start = found
        fields = read_fields(command.serial[start], payload)
        how = ("at once (serial: no override)" if command.rate_field == "high_rate"
               else f"when the position counter reaches {fields['position']}" if start == AT
               else f"held until event input {list(EVENTS).index(start) + 1} goes low"
               if start in EVENTS else "at once")
        out.append(_describe(command, fields, how))
        _collect_rate(command, fields, rates)
    return out + _rate_notes(rates)


def _collect_rate(command: Command, fields: dict[str, Any], rates: dict[str, set[int]]
                  ) -> None:
    rate = command.rate
    if rate is not None and rate.table and rate.allows(value := fields[command.rate_field]) \
            and value != 0:
        rates.setdefault(command.name, set()).add(value)


def _rate_notes(rates: dict[str, set[int]]) -> list[str]:
    from profiles.ppmc312.motion import COMMANDS

    out = []
    for name, values in rates.items():
        command = COMMANDS[name]
        assert command.rate is not None
        shown = ", ".join(map(str, sorted(values)))
        what = (f"high-rate override {shown}" if command.rate_field == "high_rate"
                else f"{command.label} rate {shown}")
        out.append(f"{what}: the chip refuses it (0x20) unless it lies "
                   f"{command.rate.table}; check that table")
    return out


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

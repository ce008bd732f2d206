"""`stepramp check` for the MC-200 stream and A-Link settings files: which device a
file is for, its own check, and the device's rules a CI gate wants.

PPMC-312 tables and uploads keep priority (verify/check_file.py asks here first only
because these files have shapes a PPMC-312 file never has: see
`profiles.mc200.formats.is_stream_file` and `profiles.alink.formats.is_settings_file`).

- MC-200: the file's CRC-32 (`mc200-corrupted` / `mc200-unchecked`), every packet's
  own check (`mc200-packet`), and the driver's reading of the sequence
  (`profiles.mc200.model.read_stream`): the servo turns on, no SPI error, the mode
  switch, commands that move with the servo off, reversals of a move, and a stream
  that ends holding one target.
- A-Link: the file's CRC-32 (`alink-corrupted` / `alink-unchecked`), pair codes that
  change from command to command, and the settings the unit would refuse (Nak) or
  silently correct (`profiles.alink.unit_applies`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Literal

from profiles.errors import CorruptedError, StepRampError

from .findings import Finding

if TYPE_CHECKING:
    from profiles.alink import Command
    from profiles.mc200.model import StreamReading

Device = Literal["mc200", "alink"]


def device_of(raw: bytes) -> Device | None:
    """The device an MC-200 stream or A-Link settings file is for; None for anything
    else (PPMC-312 tables and uploads, and what is no file of any device)."""
    if b"stepramp.table/1" in raw[:4096]:
        return None  # a table file: the device modules are not even imported (cold start)
    from profiles.alink.formats import is_settings_file
    from profiles.mc200.formats import is_stream_file

    if is_stream_file(raw):
        return "mc200"
    if is_settings_file(raw):
        return "alink"
    return None


def check_device_file(raw: bytes, path: str) -> tuple[Device, list[Finding]] | None:
    """The device and the findings for an MC-200 or A-Link file; None for other files.
    A file whose own check fails has that one finding (its content cannot be trusted
    for more); a file that cannot be read raises StepRampError (unusable input)."""
    device = device_of(raw)
    if device is None:
        return None
    return device, (mc200_findings(raw, path) if device == "mc200" else
                    alink_findings(raw, path))


def _integrity(prefix: str, fmt: str, integrity: str, detail: str) -> list[Finding]:
    return ([] if integrity == "verified" else
            [Finding("warning", f"{prefix}-unchecked", f"{fmt} file: {detail}")])


# --- MC-200 -----------------------------------------------------------------------------------
def mc200_findings(raw: bytes, path: str) -> list[Finding]:
    from profiles.mc200.formats import parse, payload_of_parsed
    from profiles.mc200.model import read_stream

    try:
        parsed = parse(raw, path)
    except CorruptedError as e:  # a verdict on the file, not unusable input
        return [Finding("error", "mc200-corrupted", str(e))]
    out = _integrity("mc200", parsed.format, parsed.integrity, parsed.detail)
    return out + stream_findings(read_stream(payload_of_parsed(parsed)))


def stream_findings(r: StreamReading) -> list[Finding]:
    """The driver rules on a `StreamReading`."""
    from profiles.mc200 import HOLD_PACKETS_MIN as HOLD_TARGET_MIN

    out: list[Finding] = []
    if r.bad_count:
        shown = "; ".join(f"packet {i}: {why}" for i, why in r.bad_packets)
        out.append(Finding("error", "mc200-packet",
                           f"{r.bad_count} packet(s) fail their own check (checksum, bits that "
                           f"must be 0), read as lost by the driver: {shown}"))
    if len(r.driver_ids) > 1:
        out.append(Finding("warning", "mc200-driver-ids",
                           f"packets for drivers {', '.join(map(str, r.driver_ids))}: each "
                           "driver reads only its own"))
    if r.servo_on_at is None:
        out.append(Finding("error", "mc200-servo",
                           "the servo never turns on (3 consecutive packets with the servo "
                           "bit): the motor never moves"))
    for at, cause in r.spi_errors:
        out.append(Finding("error", "mc200-spi-error",
                           f"packet {at}: the driver raises the SPI error ({cause}); it ignores "
                           "every command until a packet with the reset bit"
                           + (f" ({r.ignored} packets ignored in all)" if r.ignored else "")))
    if not r.mode_switches:
        out.append(Finding("warning", "mc200-mode-switch",
                           "the stream never switches the control mode: its positions count "
                           "on the driver being in position mode already"))
    if r.moved_while_off is not None:
        out.append(Finding("warning", "mc200-servo-off",
                           f"packet {r.moved_while_off}: a position command moves the target "
                           "while the servo is off (the motor jumps when it turns on)"))
    if r.reversal_count:
        shown = "; ".join(f"packet {at}: {a} → {b} → {c}" for at, a, b, c in r.reversals)
        out.append(Finding("warning", "mc200-position-reversal",
                           f"the commanded position turns back {r.reversal_count} time(s) "
                           f"({shown}); a planned move is monotone, and bit 7 of byte 3 or 5 "
                           "flipped (±128, ±8388608 pulses) passes the packet checksum"))
    if r.hold < HOLD_TARGET_MIN:
        st = r.state
        why = ("the servo is off at the end" if not st.servo_on else
               "the SPI error stands at the end" if st.spi_error else
               "the driver is not in position mode at the end" if st.mode != 1 else
               f"the last {r.hold} packet(s) hold position {r.target}" if r.target is not None
               else "no position command is applied")
        out.append(Finding("error", "mc200-hold",
                           f"the stream does not end holding one target for ≥ "
                           f"{HOLD_TARGET_MIN} packets: {why}"))
    return out


# --- A-Link -----------------------------------------------------------------------------------
def alink_findings(raw: bytes, path: str) -> list[Finding]:
    from profiles.alink.formats import parse

    try:
        parsed = parse(raw, path)
    except CorruptedError as e:
        return [Finding("error", "alink-corrupted", str(e))]
    out = _integrity("alink", parsed.format, parsed.integrity, parsed.detail)
    return out + command_findings(parsed.items)


def command_findings(commands: Sequence[Command]) -> list[Finding]:
    """The unit's rules on a list of `Command`s: pair codes, then the settings they leave."""
    from profiles.alink import FUNC_ACCEL_PARA, FUNC_SPEED_PPS, Cmd

    out: list[Finding] = []
    previous = None
    for k, c in enumerate(commands):
        if c.pair == 0:
            out.append(Finding("error", "alink-pair-code",
                               f"command {k} ({c.name}): pair code 0 is the no-op: the unit "
                               "does not run it"))
        elif c.pair == previous:
            out.append(Finding("error", "alink-pair-code",
                               f"command {k} ({c.name}): pair code {c.pair} again: the sender "
                               "must change it for every command (manual 10-4 (3)); the unit "
                               "cannot tell this one from the one before"))
        previous = c.pair
    last: dict[int, Command] = {}
    for c in commands:
        last[c.cmd] = c
    settings = (Cmd.MAX_SPEED, Cmd.MODE, Cmd.H_SPEED, Cmd.L_SPEED, Cmd.UP_TIME)
    present = [Cmd(k).name for k in settings if k in last]
    if not present:
        return out
    missing = [Cmd(k).name for k in settings if k not in last]
    if missing:
        out.append(Finding("warning", "alink-incomplete",
                           f"the file sets {', '.join(present)} but not {', '.join(missing)}: "
                           "the unit keeps what it holds, which the file cannot show"))
    for k in (Cmd.MAX_SPEED, Cmd.H_SPEED, Cmd.L_SPEED):
        if k in last and last[k].func != FUNC_SPEED_PPS:
            out.append(Finding("warning", "alink-func",
                               f"{Cmd(k).name} func {last[k].func}: stepramp models func "
                               f"{FUNC_SPEED_PPS} only (×1 pps)"))
    if Cmd.MODE in last:
        mode = last[Cmd.MODE].para
        if mode & 0x5 != 0x5:
            out.append(Finding("error", "alink-mode",
                               f"MODE 0x{mode:X}: D0 and D2 are fixed at 1 (manual 11-2 (2))"))
    if Cmd.UP_TIME in last and last[Cmd.UP_TIME].func == 1:
        out.append(Finding("warning", "alink-func",
                           "UP_TIME func 1: the legacy axis-chip rate, whose conversion to "
                           "pps/s the manual lacks (stepramp writes func 2, 0.01 ms per 1000 "
                           "pps)"))
    if Cmd.UP_TIME in last and last[Cmd.UP_TIME].func not in (1, FUNC_ACCEL_PARA):
        out.append(Finding("error", "alink-range",
                           f"UP_TIME func {last[Cmd.UP_TIME].func}: nn is 1 (rate) or 2 (0.01 "
                           "ms per 1000 pps)"))
        return out
    if {Cmd.L_SPEED, Cmd.H_SPEED, Cmd.UP_TIME} <= set(last):
        out += _unit_findings(last)
    return out


def _unit_findings(last: dict[int, Command]) -> list[Finding]:
    """What the unit makes of the speeds and ramp: Nak, range, silent corrections."""
    from profiles.alink import Cmd, unit_applies

    max_pps = last[Cmd.MAX_SPEED].para if Cmd.MAX_SPEED in last else 0
    try:
        run = unit_applies(last[Cmd.L_SPEED].para, last[Cmd.H_SPEED].para,
                           last[Cmd.UP_TIME].para, max_pps=max_pps,
                           nn=last[Cmd.UP_TIME].func)
    except StepRampError as e:
        return [Finding("error", "alink-range", f"the unit answers Nak (parameter value not "
                                                f"valid): {e}")]
    out = []
    if run.nak:
        out.append(Finding("error", "alink-nak", f"the unit answers a drive command with Nak: "
                                                 f"{run.nak}"))
    out += [Finding("warning", "alink-corrected", f"the unit silently changes it: {note}")
            for note in run.corrections]
    return out

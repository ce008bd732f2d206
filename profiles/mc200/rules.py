"""The MC-200 driver's rules on a stream it reads (`model.read_stream` → `StreamReading`),
as findings: packets that fail their own check, several driver ids, a servo that never
turns on, the SPI error, no mode switch, commands that move with the servo off, reversals
of a move, and a stream that does not end holding one command. `stepramp check`'s judge
(verify/devices/mc200.py) adds the file's own CRC-32 and reads the stream."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..findings import Finding

if TYPE_CHECKING:
    from .model import StreamReading


def stream_findings(r: StreamReading) -> list[Finding]:
    """The driver rules on a `StreamReading`."""

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
                           f"packet {r.moved_while_off}: a {_kind(r, r.moved_while_off)} "
                           "command changes while the servo is off (the motor jumps when it "
                           "turns on)"))
    if r.reversal_count:
        shown = "; ".join(f"packet {at}: {a} → {b} → {c}" for at, a, b, c in r.reversals)
        out.append(Finding("warning", "mc200-position-reversal",
                           f"the commanded position turns back {r.reversal_count} time(s) "
                           f"({shown}); a planned move is monotone, and bit 7 of byte 3 or 5 "
                           "flipped (±128, ±8388608 pulses) passes the packet checksum"))
    return out + _hold_findings(r)


def _kind(r: StreamReading, packet: int) -> str:
    """The control mode a command of packet `packet` was read in, by name."""
    import numpy as np

    from . import MODES

    at = r.commands.at
    k = int(np.searchsorted(at, packet))
    return MODES[int(r.commands.mode[k]) - 1] if k < len(at) and at[k] == packet else "position"


def _hold_findings(r: StreamReading) -> list[Finding]:
    """The stream's end: one command held ≥ 5 packets (servo on, no SPI error, its mode),
    and in velocity mode that command 0 (a velocity held is a motor still turning)."""
    from . import HOLD_PACKETS_MIN as HOLD_TARGET_MIN
    from . import MODES, UNITS

    st = r.state
    mode = MODES[st.mode - 1]
    if r.hold >= HOLD_TARGET_MIN:
        if mode == "velocity" and r.target != 0:
            return [Finding("error", "mc200-hold",
                            f"the stream ends commanding velocity {r.target:g} "
                            f"{UNITS['velocity']}, not 0: the motor keeps turning")]
        return []
    applied = len(r.commands) and r.commands.mode[-1] == st.mode
    why = ("the servo is off at the end" if not st.servo_on else
           "the SPI error stands at the end" if st.spi_error else
           f"the last {r.hold} packet(s) hold {mode} {r.target} {UNITS[mode]}" if applied
           else f"no {mode} command is applied after the switch to {mode} mode")
    return [Finding("error", "mc200-hold",
                    f"the stream does not end holding one command for ≥ "
                    f"{HOLD_TARGET_MIN} packets: {why}")]


__all__ = ["stream_findings"]
